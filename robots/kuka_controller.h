// A KUKA KR C4 / KR C5 controller through a variable server on TCP 7000 (KukaVarProxy or the
// C3 Bridge Interface: robots/kuka_codec.h says why this interface and what it implies
// for the cell's network), with armsig's KRL program ARMSIG.src running for the moves
// (controllers/kuka, docs/how-to/kuka.md).
//
// Joints: $AXIS_ACT (A1 … An, deg; KUKA's own joint zero and signs, which the model file
// follows, models/kr16_2.yaml), taken only while the arm stands: $ROB_STOPPED is read before
// and after it, and a reading with either FALSE is refused (kMoving, never a reading).
// $AXIS_ACT is the position the controller holds the axes at; after an exact stop it lies
// within the axes' positioning window of the encoders' own value.
//
// A move: the controller must be in AUT or EXT, with no EMERGENCY STOP and no stopping
// message, its robot interpreter running (#P_ACTIVE) and ARMSIG's contract version the
// driver's. The driver writes ARMSIG_TARGET, ARMSIG_VEL, ARMSIG_ACC, then ARMSIG_CMD = the
// next number, and polls: ARMSIG_BUSY must take the number within accept_timeout (else the
// program does not run: kNotRunning naming what runs instead), ARMSIG_DONE ends the move
// with ARMSIG_RESULT. The controller's states, as the framework's ControllerError kinds
// (instruments/device.h):
//   EMERGENCY STOP ($ALARM_STOP FALSE)                         kEmergencyStop
//   a stopping message ($STOPMESS: the gate opened in AUT/EXT,
//     a safety stop 1/2), or ARMSIG stopped (#P_STOP): KUKA's
//     protective stop, waited out until the operator restarts  kProtectiveStop
//   T1 or T2 ($MODE_OP): no moves from the network              kNotRemote
//   no program, another one, or ARMSIG not started             kNotRunning
//   ARMSIG's globals missing or another contract version        kVersionRefused
//   a reading while $ROB_STOPPED is FALSE                      kArmMoving
//   ARMSIG refused the target, or the move did not end          kMoveRefused
//   the variable server did not answer by the deadline          kConnectionLost
// The move resumes on the controller once the operator clears a stop and restarts ARMSIG;
// MoveTo with the same target then waits for that same command instead of sending another.
// A command the program reports not executed (it started after the command was written)
// is sent again once.
//
// Every variable exchange is retried with the RetryPolicy (a lost connection reconnects, a
// late answer is recognised by its tag and skipped, a stream out of frame is reconnected) and
// bounded by the device call's deadline; an interrupt (Ctrl-C) ends any wait at once.
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "instruments/device.h"
#include "robots/kuka_codec.h"
#include "instruments/packet_transport.h"

namespace armsig::robots {

struct KukaOptions {
  int axes = 6;                   // A1 … A<axes> are the model's joints
  int velocity_percent = 20;      // ARMSIG_VEL: PTP velocity, % of each axis's maximum
  int acceleration_percent = 20;  // ARMSIG_ACC
  instruments::Millis poll{20};                // how often a move's progress is read
  instruments::Millis accept_timeout{2000};    // ARMSIG takes a command within this (it waits in WAIT FOR)
  instruments::Millis move_timeout{180000};    // a move (at 1 % of a big robot's speed: minutes) ends by then
};

// What the controller's state variables say.
struct KukaState {
  std::string mode;              // $MODE_OP: T1 T2 AUT EX
  std::string program_state;     // $PRO_STATE1: P_FREE P_RESET P_ACTIVE P_STOP P_END
  std::string program_name;      // $PRO_NAME1[], e.g. "/R1/ARMSIG.src"
  bool emergency_stop = false;   // NOT $ALARM_STOP
  bool stop_message = false;     // $STOPMESS
  bool operator_safety = true;   // $USER_SAF (FALSE: the cell's gate is open)
  bool drives_on = false;        // $PERI_RDY
  bool robot_stopped = true;     // $ROB_STOPPED
  int contract_version = 0;      // ARMSIG_VERSION
  bool Automatic() const { return mode == "AUT" || mode == "EX"; }
  bool ProgramIsArmsig() const;  // $PRO_NAME1[]'s module is ARMSIG
};

// Copies a program's files (its .src and .dat) into the controller's program folder:
// KRC:\R1\Program as the lab's PC mounts the controller's share (a KR C4 shares it over SMB
// when the lab sets it up). InstrumentError naming the file and the folder when it fails.
void CopyToProgramFolder(const std::vector<std::string>& files, const std::string& folder);

// The arm's type in a kinematic model's name, as armsig compares it with the lab's robot
// model: "#KR16_2 C4 FLR" → "KR16_2" (the first word without '#').
std::string KukaArmOf(const std::string& trafo_name);

class KukaController : public instruments::RobotController {
 public:
  KukaController(std::unique_ptr<instruments::PacketTransport> transport, bool can_move,
                 instruments::RetryPolicy policy = {}, KukaOptions options = {});

  const std::string& name() const override { return name_; }
  Eigen::VectorXd ReadJointsRad() override;
  bool CanMove() const override { return can_move_; }
  void MoveTo(const Eigen::VectorXd& joints_rad) override;
  void SetInterrupt(const std::atomic<bool>* flag) override { transport_->SetInterrupt(flag); }
  // A reading is three variable exchanges (milliseconds): cheap enough for the session to
  // read the joints again after the instruments and keep a configuration only when the arm
  // stood still in between (no time stamp: the controller gives none).
  bool StreamsJoints() const override { return true; }

  // $TRAFONAME[] (the arm: its first word), $KR_SERIALNO, $RCV_INFO[].
  std::optional<instruments::ControllerIdentity> Identify() override;
  // Throws the ControllerError a move would meet now.
  void CheckReady() override;
  KukaState State();
  // $POS_ACT: the TCP in the active $BASE by the controller's own kinematics (x, y, z mm;
  // A, B, C deg).
  Eigen::Matrix<double, 6, 1> ReadPoseAct();

  // One variable read / write, with the retries above (for `instrument probe` and tests).
  std::string Read(const std::string& variable);
  void Write(const std::string& variable, const std::string& value);

  // A KRL program run as a lab runs one (instruments/kuka_programs.cc; the submit
  // interpreter's part controllers/kuka/ARMSIG_SPS.sub): its .src and .dat already in the
  // controller's program folder (CopyToProgramFolder), ARMSIG_RUN_NAME[] written, then
  // ARMSIG_RUN_CMD = the next run's number, which is returned.
  int64_t RunProgram(const std::string& name);
  // Whether run `n` still runs; once it ended, nothing when it reached its END, else the
  // ControllerError of how it ended (not in AUT or EXT: kNotRemote; not selected, or stopped
  // before its END: kNotRunning, naming the program).
  bool ProgramRunning(int64_t n, const std::string& name);

  struct Statistics {
    int exchanges = 0, retries = 0, reconnects = 0, stale_answers = 0, bad_frames = 0,
        moves = 0, resumed_moves = 0, resent_moves = 0, move_polls = 0;
  };
  const Statistics& statistics() const { return stats_; }

 private:
  instruments::Deadline CallDeadline() const { return instruments::Clock::now() + policy_.timeout; }
  kuka::Response Exchange(kuka::MessageType type, const std::string& variable,
                          const std::string& value, instruments::Deadline deadline);
  kuka::Response ExchangeOnce(const kuka::Request& request, instruments::Deadline deadline);
  std::string ReadBy(const std::string& variable, instruments::Deadline deadline);
  void WriteBy(const std::string& variable, const std::string& value, instruments::Deadline deadline);
  int64_t ReadInt(const std::string& variable, instruments::Deadline deadline);
  bool ReadBool(const std::string& variable, instruments::Deadline deadline);
  KukaState StateBy(instruments::Deadline deadline);
  // The error of a state no move may start in (or continue through), its message
  // prefixed by `during` when given.
  std::optional<instruments::ControllerError> NotReady(const KukaState& s, const std::string& during = "") const;
  instruments::ControllerError Error(instruments::ControllerError::Kind kind, const std::string& what,
                        const std::string& action) const;
  [[noreturn]] void ThrowStopped(instruments::Deadline deadline, const char* during);
  // Waits for command `n` to be taken and done; returns its ARMSIG_RESULT.
  int WaitFor(int64_t n, instruments::Deadline move_deadline);

  std::unique_ptr<instruments::PacketTransport> transport_;
  bool can_move_;
  instruments::RetryPolicy policy_;
  KukaOptions options_;
  std::string name_;
  uint16_t next_tag_ = 1;
  Statistics stats_;
};

}  // namespace armsig::robots
