// A virtual KUKA KR C4 / KR C5 controller as armsig's driver meets it: a variable server on
// TCP (Boost.Asio, its own thread) speaking KukaVarProxy's protocol as the C3 Bridge
// Interface's "Application Protocol Specification", version 1 revision 5 (24 March 2022),
// §3.1–3.5.2 documents it, and as KukaVarProxy's source (github.com/ImtsSrl/KUKAVARPROXY,
// src/basMain.bas at commit 2745373) answers: an unknown variable reads as an empty value
// with success 1, "PING" reads "PONG", a write's answer echoes the value. Behind it, the KRL
// system variables of "System Variables, KSS 8.1, 8.2, 8.3, 8.4" (KUKA, V2, 26.09.2016)
// armsig reads, the globals of the shipped controllers/kuka/config_globals.dat (parsed from
// that very file, embedded at build time, so the simulator declares exactly what a
// controller set up from the file declares), and ARMSIG.src's contract (contract 1) run as
// its interpreter would:
//
//  - a new ARMSIG_CMD is taken (ARMSIG_BUSY) within one interpreter cycle while the robot
//    interpreter runs ARMSIG (#P_ACTIVE); a target beyond the software limits or a velocity
//    outside 1 to 100 % is refused (ARMSIG_RESULT 1, 2) without a motion; otherwise a
//    synchronous PTP: every axis moves with ARMSIG_VEL % of its maximum velocity and
//    ARMSIG_ACC % of its maximum acceleration on a trapezoidal profile, all axes on the
//    slowest one's time (time_scale multiplies it); ARMSIG_DONE once the robot stands at the
//    target; $ROB_STOPPED is FALSE meanwhile, $AXIS_ACT follows the profile;
//  - ARMSIG started from its first line (after SelectProgram / ResetProgram) sets
//    ARMSIG_VERSION and answers a command written before it ran with result 3;
//  - a halted move (an EMERGENCY STOP, a safety stop from the cell's gate in AUT/EXT, the
//    STOP key, a mode change, the drives switched off) stands where it halted and goes on to
//    its target when the program is started again.
//
// Programs of the lab's own: with a program folder (KRC:\R1\Program, a directory), the
// submit interpreter's runner of controllers/kuka/ARMSIG_SPS.sub selects and starts one when
// ARMSIG_RUN_CMD changes, and runs its motions with the controller's inverse kinematics on its
// nominal model (simulation/kuka_programs.cc says how, and what it refuses).
//
// The arm is a simulation::VirtualArm (physical time, scaled; the lab's robot follows it):
// ARMSIG's PTP is its joint move, with the speed and acceleration that give the leading
// axis's profile; an EMERGENCY STOP brakes it and cuts the drives, a safety stop or the STOP
// key brakes it along its path. The robot's joint angles are the encoders': the lab computes
// the true position with its hidden errors. REALs are 32-bit floats on the controller:
// $AXIS_ACT shows a float's 9 significant digits.
//
// Faults (FaultSpec, once or on every request): kVanish (the connection closes as the
// request arrives), kDropReply (no answer), kNoiseBytes (garbage bytes before the answer:
// the stream's framing breaks), kTruncateReply (half the answer, then nothing), kWrongTrid
// (first an answer with another tag, then the right one), kOtherReply (the right tag
// with another variable's value), kErrorCode (success 0), kOutOfRange ($AXIS_ACT with A1 at
// 1000°), kMalformed (an answer whose value length runs past its frame), kFloodBytes
// (binary garbage without pause), kFloodLines (well-formed answers with other tags without
// pause).
#pragma once

#include <Eigen/Core>
#include <atomic>
// clang-format off
#include <utility>  // first: Boost 1.74 Asio uses std::exchange without including it (C++20)
#include <boost/asio.hpp>
// clang-format on
#include <chrono>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "robots/kuka_codec.h"
#include "programs/controller.h"
#include "programs/krl.h"
#include "simulation/program_runner.h"
#include "simulation/simulator.h"
#include "simulation/tcp_peer.h"
#include "simulation/virtual_arm.h"
#include "simulation/virtual_lab.h"

namespace armsig::simulation {

struct KukaSimulatorOptions {
  double time_scale = 1.0;                   // wall seconds per physical second (≥ 0.001)
  std::chrono::microseconds latency{2000};   // per variable exchange (KukaVarProxy: a few ms)
  std::string robot_name = "KR16-LAB";       // $ROBNAME[]
  Eigen::VectorXd home_rad;                   // where the arm stands at start (empty: the lab's)
  std::string trafo_name = "#KR16_2 C4 FLR";  // $TRAFONAME[]
  int serial = 501234;                        // $KR_SERIALNO
  std::string software = "KS V8.3.38";        // $RCV_INFO[]
  // Per axis at 100 % (deg/s, deg/s²); empty: a KR 16-2's (156, 156, 156, 330, 330, 615 °/s,
  // reached in 0.4 s).
  std::vector<double> max_velocity_deg_s, max_acceleration_deg_s2;
  // $SOFTN_END / $SOFTP_END per axis; empty: the lab model's joint limits, else ±350°.
  std::vector<std::pair<double, double>> software_limits_deg;
  std::string mode = "AUT";       // $MODE_OP at start
  bool program_running = true;    // ARMSIG selected and started at start
  // The program folder KRC:\R1\Program (the share a lab's PC copies programs into): a
  // directory; empty, none (a run is never selected).
  std::string program_folder;
  // TOOL_DATA and BASE_DATA of the controller's $CONFIG.DAT, for the programs it runs.
  programs::KrlControllerData config;
};

class KukaSimulator : public Simulator {
 public:
  // Listens on `host`:`port` (0: any free port; path() names the one taken).
  KukaSimulator(VirtualLab& lab, std::string host = "127.0.0.1", unsigned short port = 0,
                KukaSimulatorOptions options = {});
  ~KukaSimulator() override;
  KukaSimulator(const KukaSimulator&) = delete;
  KukaSimulator& operator=(const KukaSimulator&) = delete;

  void Start() override;  // throws std::runtime_error when the address cannot be bound
  void Stop() override;
  const std::string& path() const override { return address_; }
  unsigned short port() const { return port_; }
  void InjectOnce(FaultSpec fault) override { faults_.Once(fault); }
  void InjectAlways(FaultSpec fault) override { faults_.Always(fault); }
  void ClearFaults() override;
  int requests() const override { return requests_.load(); }
  int64_t flood_bytes() const override { return flood_bytes_.load(); }
  int connections() const { return connections_.load(); }

  // The cell, as the operator or its safety circuit changes it.
  void PressEmergencyStop();
  void ReleaseEmergencyStop();
  void OpenSafetyGate();   // operator safety: in AUT/EXT a safety stop with a stopping message
  void CloseSafetyGate();
  void Acknowledge();      // clears the stopping message once its causes are gone
  // The Start key (AUT) or $EXT_START, the drives switched on first: a halted move goes on.
  void StartProgram();
  void StopProgram();      // the STOP key: the move halts, no message
  // The drives switched off (the smartPAD's drives key, $DRIVES_OFF from the PLC): the arm
  // brakes along its path and the program stops; $PERI_RDY FALSE until StartProgram.
  void SwitchDrivesOff();
  void SetMode(const std::string& mode);        // T1 T2 AUT EX; a change stops the program
  void SelectProgram(const std::string& name);  // #P_RESET: started, it runs from its first line
  // Closes every client connection now; while unreachable, new connections are closed as
  // soon as they are accepted (the controller's network gone and back).
  void DropConnections();
  void SetReachable(bool reachable);
  // Another client's command, as armsig would write it (tests of a reading during a move).
  void CommandMove(const Eigen::VectorXd& target_deg, int velocity_percent);

  struct Snapshot {
    Eigen::VectorXd joints_deg;
    bool moving = false, halted = false;
    int64_t cmd = 0, busy = 0, done = 0, result = 0, version = 0;
    int moves = 0, refused = 0, halts = 0;
    int runs = 0;  // programs the runner selected and started
    std::string last_run_refusal;  // why the last run was not selected, as the smartPAD says
    std::string mode, program_state, program;
    double last_move_seconds = 0.0;  // the last move's planned duration (physical)
  };
  Snapshot snapshot() const;
  // The planned duration of a synchronous PTP between two joint vectors (deg), physical.
  double MoveSeconds(const Eigen::VectorXd& from_deg, const Eigen::VectorXd& to_deg,
                     int velocity_percent, int acceleration_percent) const;
  VirtualArm& arm() { return *arm_; }

 private:
  struct Connection;
  using Step = TcpPeer::Step;
  struct Global {
    std::string type, text;
  };
  struct MovePlan {
    double seconds = 0.0, ramp = 0.0;  // the leading axis's duration and its ramps (physical)
  };
  // ARMSIG's command under way: its PTP runs on the arm (`issued`), or was halted by a stop
  // and goes on when the program is started again.
  struct Command {
    int64_t number = 0;
    Eigen::VectorXd target_rad;
    int velocity = 0, acceleration = 0;
    bool issued = false;
  };

  void StartAccept();
  void StartRead(std::shared_ptr<Connection> c);
  void OnFrame(const std::shared_ptr<Connection>& c, const std::string& frame);
  void Flood(std::shared_ptr<Connection> c, bool frames, int64_t k, uint64_t generation);
  void Tick();  // the interpreter cycle: Advance() every 12 ms

  // Under mutex_: the controller's state now.
  void Advance();
  void TakeCommand();
  MovePlan Plan(const Eigen::VectorXd& from_deg, const Eigen::VectorXd& to_deg,
                int velocity_percent, int acceleration_percent) const;
  void Issue();  // the command's PTP from where the arm stands
  // A synchronous PTP to `target_rad` from where the arm stands (Plan's profile); false when
  // the arm does not move (no turn, or it is stopped).
  bool Ptp(const Eigen::VectorXd& target_rad, int velocity_percent, int acceleration_percent);
  // The program runner of the submit interpreter (ARMSIG_SPS.sub; kuka_programs.cc): a new
  // run selected and started, the running program's next step, its end reported.
  void AdvanceRunner();
  std::optional<std::string> SelectRun(const std::string& name);  // why not, or nullopt
  void EndRun(int result);
  // A halt: an EMERGENCY STOP, a safety stop (the arm stays stopped until acknowledged), or
  // the STOP key and a mode change (it brakes and stands).
  enum class HaltKind { kEmergency, kSafety, kStopKey };
  void Halt(HaltKind kind);
  std::optional<std::string> ReadVariable(const std::string& name, bool out_of_range);
  bool WriteVariable(const std::string& name, const std::string& value);
  int64_t GlobalInt(const std::string& name) const;
  void SetGlobal(const std::string& name, int64_t value);
  bool Automatic() const { return mode_ == "AUT" || mode_ == "EX"; }

  VirtualLab& lab_;
  std::string host_;
  unsigned short port_;
  std::string address_;
  KukaSimulatorOptions options_;
  int axes_;
  std::vector<double> vmax_, amax_;
  std::vector<std::pair<double, double>> limits_;

  boost::asio::io_context io_;
  std::unique_ptr<boost::asio::ip::tcp::acceptor> acceptor_;
  std::vector<std::weak_ptr<Connection>> clients_;  // io thread only
  std::unique_ptr<boost::asio::steady_timer> tick_;
  std::thread thread_;
  std::optional<boost::asio::executor_work_guard<boost::asio::io_context::executor_type>> work_;

  mutable std::mutex mutex_;  // the controller's state below
  FaultQueue faults_;
  std::map<std::string, Global> globals_;
  std::unique_ptr<VirtualArm> arm_;
  VirtualArm::State arm_state_;  // as of the last Advance
  Eigen::VectorXd joints_deg_;   // six axes, the robot's first
  std::optional<Command> command_;
  std::string mode_;
  std::string program_ = "ARMSIG";
  std::string program_state_ = "P_ACTIVE";
  bool fresh_start_ = true;  // ARMSIG runs its first lines on the next cycle
  bool alarm_stop_ = true, stop_message_ = false, user_saf_ = true, drives_on_ = true;
  int moves_ = 0, refused_ = 0, halts_ = 0, runs_ = 0;
  programs::ControllerModel controller_;  // its nominal model: the IK its programs run on
  std::optional<ProgramPlayer> run_;      // the program the runner started
  std::string last_run_refusal_;          // why the last run was not selected (the smartPAD's message)
  double last_move_seconds_ = 0.0;
  std::atomic<bool> reachable_{true};

  std::atomic<int> requests_{0}, connections_{0};
  std::atomic<int64_t> flood_bytes_{0};
  std::atomic<uint64_t> flood_generation_{0};
};

}  // namespace armsig::simulation
