// What every virtual instrument offers (start and stop, where a driver finds it) and the
// faults it can be told to commit: noise bytes, dropped or truncated replies, wrong
// transaction ids, bad or missing CRC, busy / error / warning return codes, a port that
// disappears and comes back, floods (bytes, an endless line, unrelated lines, all without
// pause), another command's reply, readings out of range or in wrong units. A fault
// applies to the next request (InjectOnce) or to every request (InjectAlways).
// The simulators: simulation/geocom_simulator.h, gsi_online_simulator.h, val_simulator.h,
// counter_simulator.h (on pseudo-terminals, simulation/line_simulator.h) and
// emscon_simulator.h (a laser tracker over TCP), kuka_simulator.h (a KUKA controller's variable
// server over TCP).
#pragma once

#include <chrono>
#include <cstdint>
#include <deque>
#include <mutex>
#include <optional>
#include <string>

namespace armsig::simulation {

enum class Fault {
  kNone,
  kNoiseBytes,     // garbage bytes (and a garbage line) before the reply
  kDropReply,      // no reply at all
  kTruncateReply,  // the reply cut in half (and no terminator)
  kWrongTrid,      // GeoCOM: the reply carries another transaction id
  kBadCrc,         // GeoCOM: the reply's CRC is wrong
  kBusy,           // GeoCOM 13 SYSBUSY / GSI @W, once
  kErrorCode,      // the given code (GeoCOM rc, GSI @E, VAL error message)
  kWarningCode,    // GeoCOM: the given warning code with valid data (1283/1284/1285)
  kNoCrc,          // GeoCOM: the reply without its CRC field although the request had one
  kFloodBytes,     // instead of the reply: binary garbage (CR and LF among it), without pause
  kEndlessLine,    // instead of the reply: printable bytes without pause, never a line end
  kFloodLines,     // instead of the reply: lines of the protocol, none of them the reply
                   // asked for (GeoCOM other transaction ids, GSI other words, VAL text
                   // rows without a prompt, counter other registers), without pause
  kOtherReply,     // the reply to another command (GeoCOM: same transaction id, another
                   // RPC's values; GSI: another word; VAL: a move's reply to WHERE;
                   // counter: another register)
  kOutOfRange,     // a reading no instrument can give: GeoCOM angles in degrees, GSI a
                   // negative zenith angle, VAL a joint at 1000°, counter a count at 2^31-1
  kWrongUnit,      // GSI: Hz and V words with a length unit
  kVanish,         // the port vanishes as the request arrives (the peer closes the pty)
  kStopShort,      // VAL: a move acknowledged as usual, but the arm stops 2° short on joint 2
                   // (a safety fence, a limit, someone holding the pendant's hold button)
  // Laser tracker (emScon) faults:
  kWrongCommandId,     // every reply echoes another command's id (a measurement: no result)
  kBeamBreak,          // StartMeasurement: accepted, then an error for it (NoDistanceSet)
  kReflectorNotFound,  // StartMeasurement / FindReflector: MeasurementStatusNotReady
  kStatusBetween,      // status changes and an unsolicited error before the reply and between
                       // the reply and the result; the reply's header and body in two writes
  kStatusInside,       // a status-change packet written between the reply's 8 header bytes and
                       // the rest of it (a corrupted stream)
  // Binary length-prefixed protocols (a KUKA variable server):
  kMalformed,  // an answer whose inner length field runs past its frame
};

struct FaultSpec {
  Fault fault = Fault::kNone;
  int code = 0;
};

// The faults a simulator applies: queued ones to the next requests, then one to every
// request. Thread-safe (the test thread injects, the io thread takes).
class FaultQueue {
 public:
  void Once(FaultSpec fault);
  void Always(FaultSpec fault);
  void Clear();
  FaultSpec Next();  // Fault::kNone when there is none

 private:
  std::mutex mutex_;
  std::deque<FaultSpec> once_;
  std::optional<FaultSpec> always_;
};

struct SimulatorOptions {
  double time_scale = 1.0;  // multiplies every latency (0.1 = ten times faster)
  std::chrono::milliseconds angle_latency{40};
  std::chrono::milliseconds distance_latency{150};
  std::chrono::milliseconds motion_latency{800};
};

// What every virtual instrument offers: start and stop, where a driver finds it, and
// fault injection.
class Simulator {
 public:
  virtual ~Simulator() = default;
  virtual void Start() = 0;
  virtual void Stop() = 0;
  // Where a driver finds it: the pty's path, or HOST:PORT for a TCP simulator.
  virtual const std::string& path() const = 0;
  virtual void InjectOnce(FaultSpec fault) = 0;  // applies to the next request
  virtual void InjectAlways(
      FaultSpec fault) = 0;        // applies to every request (after the queued ones)
  virtual void ClearFaults() = 0;  // and stops a flood
  virtual int requests() const = 0;
  virtual int64_t flood_bytes() const = 0;  // written by floods so far
};

}  // namespace armsig::simulation
