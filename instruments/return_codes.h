// The return codes armsig acts on by value, in GeoCOM's code space (Leica GeoCOM
// Reference Manual, TPS1200+ v1.50, "Return codes": the GRC_* numbers). Every driver's
// InstrumentError carries a code of this space (instruments/device.h); transport
// failures are the GeoCOM client codes (GRC_COM_*). geocom::CodeName knows more codes.
#pragma once

namespace armsig::instruments::grc {

inline constexpr int kOk = 0;                            // GRC_OK
inline constexpr int kIvParam = 2;                       // GRC_IVPARAM
inline constexpr int kSysBusy = 13;                      // GRC_SYSBUSY
inline constexpr int kEdmBusy = 786;                     // GRC_EDM_BUSY
inline constexpr int kTmcNoFullCorrection = 1283;        // GRC_TMC_NO_FULL_CORRECTION
inline constexpr int kTmcAccuracyGuarantee = 1284;       // GRC_TMC_ACCURACY_GUARANTEE
inline constexpr int kTmcAngleOk = 1285;                 // GRC_TMC_ANGLE_OK
inline constexpr int kTmcAngleNoFullCorrection = 1288;   // GRC_TMC_ANGLE_NO_FULL_CORRECTION
inline constexpr int kTmcAngleAccuracyGuarantee = 1289;  // GRC_TMC_ANGLE_ACCURACY_GUARANTEE
inline constexpr int kTmcDistError = 1292;               // GRC_TMC_DIST_ERROR
inline constexpr int kTmcBusy = 1293;                    // GRC_TMC_BUSY
inline constexpr int kMotBusy = 1793;                    // GRC_MOT_BUSY
inline constexpr int kComCantDecode = 3074;              // GRC_COM_CANT_DECODE
inline constexpr int kComTimedOut = 3077;                // GRC_COM_TIMEDOUT
inline constexpr int kComCantDecodeReq = 3080;           // GRC_COM_CANT_DECODE_REQ
inline constexpr int kComProcUnavail = 3081;             // GRC_COM_PROC_UNAVAIL
inline constexpr int kComFailed = 3085;                  // GRC_COM_FAILED
inline constexpr int kComTrIdMismatch = 3093;            // GRC_COM_TR_ID_MISMATCH
inline constexpr int kComOverrun = 3100;                 // GRC_COM_OVERRUN
inline constexpr int kComSrvrRxChecksumError = 3101;     // GRC_COM_SRVR_RX_CHECKSUM_ERROR
inline constexpr int kComClntRxChecksumError = 3102;     // GRC_COM_CLNT_RX_CHECKSUM_ERROR
inline constexpr int kComConsReq = 3107;                 // GRC_COM_CONS_REQ
inline constexpr int kComSrvrIsSleeping = 3108;          // GRC_COM_SRVR_IS_SLEEPING
inline constexpr int kComNoChecksum = 3110;              // GRC_COM_NO_CHECKSUM

}  // namespace armsig::instruments::grc
