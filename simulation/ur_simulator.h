// A virtual Universal Robots controller (CB3 3.x or e-Series 5.x) on loopback TCP, written
// from Universal Robots' public documents — the same ones as the driver's codec
// (robots/ur_codec.h): "Real-Time Data Exchange (RTDE) Guide" (support article 22229,
// protocol version 2), the "Client Interface" document and its Excel of packet layouts
// (primary and secondary interfaces), "Dashboard Server CB-Series" and "Dashboard Server
// e-Series". Four Boost.Asio acceptors on one io thread:
//   - RTDE: protocol version request (1 and 2 accepted, 2 refusable), URControl version,
//     output setup (the guide's names and types; NOT_FOUND for an unknown name or one told to
//     be missing; a frequency above 125 Hz on a CB3 or 500 Hz on an e-Series is refused),
//     start and pause; data packages at the recipe's frequency in physical time, their time
//     stamps in whole periods of it, drift-free — at most one per 0.2 ms of wall time, so a
//     time scale that would send them faster sends every k-th (stamps k periods apart);
//   - primary and secondary interfaces: the version message on connect, then the robot state
//     at 10 Hz (robot mode data, joint data, KinematicsInfo); script lines taken on both,
//     each `movej([…], a=…, v=…)` moving the arm (simulation/joint_motion.h: a trapezoid on
//     the leading joint, in physical time), each `movel([…], a=…, v=…)` moving the flange on
//     a straight line to the pose of those joints (simulation/path_motion.h: the controller's
//     inverse every 4 ms on a trapezoid of the path speed), each `movec([via…], [to…], …)`
//     on the arc through the via joints' position; any other line answered with a runtime exception
//     message; on an e-Series in local control a script is not run;
//   - a whole program sent on either ("def name():" … its "end"; "sec name():" a secondary
//     program, which may not move the arm), as the "Client Interface" document and the
//     URScript manual describe it: the controller takes the lines up to the program's own
//     end, compiles it (programs/urscript.h: a program it cannot read is answered with a
//     runtime exception message naming line and column, and not run) and runs it in place of
//     any program running. Its motions (movej, movel, movep, movec, with literals, waypoints
//     and variables, set_tcp) in the order written, each Cartesian target through the
//     controller's inverse kinematics on ITS kinematics (the KinematicsInfo below,
//     programs/controller.h, the solution nearest the joints it stands at or a waypoint's
//     q) — simulation/program_runner.h — and its `sleep(t)` calls, where the arm stands still
//     for t physical seconds. Not simulated: the program's control flow (a loop runs once, a
//     branch's motions all run), a motion's path between targets (every motion moves as a
//     movej at its default a = 1.4 rad/s², v = 1.05 rad/s: only where it stops is checked)
//     and blending (every target is reached and stopped at, as with r = 0);
//   - the dashboard server: PolyscopeVersion, robotmode, safetymode, safetystatus (e-Series
//     5.4+), is in remote control (5.6+), get robot model / get serial number (CB3 3.12+,
//     e-Series 5.6+), close safety popup, unlock protective stop (5 s after the stop at the
//     earliest, as on the real controller), power on, brake release, running, programState,
//     quit; anything else "Could not understand: '…'".
// The arm (simulation/virtual_arm.h) keeps the virtual lab's robot where it is, so a virtual
// tracker measures it as it moves. Faults are injected as a lab meets them (below).
#pragma once

#include <Eigen/Core>
#include <atomic>
// clang-format off
#include <utility>  // first: Boost 1.74 Asio uses std::exchange without including it (C++20)
#include <boost/asio.hpp>
// clang-format on
#include <chrono>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include "robots/ur_codec.h"
#include "programs/controller.h"
#include "simulation/program_runner.h"
#include "simulation/virtual_arm.h"
#include "simulation/virtual_lab.h"

namespace armsig::simulation {

struct UrSimulatorOptions {
  bool e_series = true;
  // PolyScope's version (CB3: 3.15.7.106331; e-Series: 5.11.1.108318) and its build date.
  robots::ur::SoftwareVersion software{5, 11, 1, 108318};
  std::string build_date = "Nov 03 2021";
  std::string model = "UR10";
  std::string serial = "20183010001";
  bool remote_control = true;  // e-Series: local control takes no program from the network
  instruments::ControllerKinematics kinematics;  // the controller's own (factory) DH table
  Eigen::VectorXd home_rad = Eigen::VectorXd::Zero(6);
  double time_scale = 1.0;  // wall seconds per physical second
  std::string host = "127.0.0.1";
  // 0: any free port (ports() names those taken).
  unsigned short rtde_port = 0, primary_port = 0, secondary_port = 0, dashboard_port = 0;
};

// The CB3 options: software 3.15.7, RTDE at 125 Hz, no remote control.
UrSimulatorOptions Cb3Options(UrSimulatorOptions options = {});

// The controller's own model from its kinematics (KinematicsInfo, mm and rad): what its
// inverse kinematics runs a program's Cartesian targets on.
programs::ControllerModel UrControllerModel(const instruments::ControllerKinematics& kinematics);

class UrSimulator {
 public:
  UrSimulator(VirtualLab& lab, UrSimulatorOptions options);
  ~UrSimulator();
  UrSimulator(const UrSimulator&) = delete;
  UrSimulator& operator=(const UrSimulator&) = delete;

  void Start();  // throws std::runtime_error when a port cannot be bound
  void Stop();
  const std::string& host() const { return options_.host; }
  struct Ports {
    unsigned short rtde = 0, primary = 0, secondary = 0, dashboard = 0;
  };
  const Ports& ports() const { return ports_; }

  // --- Faults, as a lab meets them --------------------------------------------------------
  // The arm stops itself `fraction` of the way through its next move (a collision).
  void ProtectiveStopDuringNextMove(double fraction = 0.5);
  // The operator unlocks the protective stop on the pendant.
  void UnlockProtectiveStopOnPendant();
  void PressEmergencyStop();
  void ReleaseEmergencyStop();
  // The pendant's ON and START after an emergency stop: powered, brakes released.
  void PowerOnFromPendant();
  void SetRemoteControl(bool remote);
  // RTDE protocol version 2 refused (an older controller's software).
  void RefuseRtdeVersion2(bool refuse);
  // RTDE output `name` answered NOT_FOUND (a software that lacks it).
  void HideRtdeOutput(const std::string& name);
  // Every connection closes now; new ones are refused (closed at once) for `down_for` of
  // wall time (a cable pulled and plugged in again, a controller rebooting its network).
  void DropConnections(std::chrono::milliseconds down_for);
  // Something else turns `joint` at `speed_rad_s` (another program, freedrive) until
  // StopMoving.
  void KeepMoving(int joint, double speed_rad_s);
  void StopMoving();
  // `delay_s` after the next move has ended, something turns `joint` for `for_s` (physical).
  void MoveAfterNextMove(int joint, double speed_rad_s, double delay_s, double for_s);
  // The controller's own calibration changes (UR's calibration run again on the pendant).
  void SetKinematics(const instruments::ControllerKinematics& kinematics);

  // --- What it did ----------------------------------------------------------------------
  VirtualArm& arm() { return *arm_; }
  int moves() const { return arm_->moves(); }
  int rtde_packages() const { return rtde_packages_.load(); }
  // Periods left out because the simulator sampled late (a loaded machine); never on a real
  // controller's own clock, but counted so a test can tell them from lost packages.
  int rtde_skipped() const { return rtde_skipped_.load(); }
  int connections() const { return connections_.load(); }
  int scripts() const { return scripts_.load(); }
  int programs_started() const { return programs_started_.load(); }
  int programs_finished() const { return programs_finished_.load(); }
  double frequency_hz() const;  // of the last RTDE recipe set up (0: none)
  // Every how many periods of an RTDE recipe at `frequency_hz` a package is sent at
  // `time_scale` (1 unless the wall could not keep up: at most one per 0.2 ms of wall time).
  static int Thinning(double frequency_hz, double time_scale);
  // The KinematicsInfo it sends (checksums computed from the table).
  robots::ur::primary::KinematicsInfo kinematics_info() const;

 private:
  enum class Port { kRtde, kPrimary, kSecondary, kDashboard };
  struct Connection;
  using ConnectionPtr = std::shared_ptr<Connection>;
  void Listen(Port port, unsigned short wanted);
  void Accept(Port port);
  void Read(ConnectionPtr c);
  void Queue(const ConnectionPtr& c, std::string bytes, bool droppable = false);
  void Pump(ConnectionPtr c);
  void Close(const ConnectionPtr& c);
  void OnRtde(const ConnectionPtr& c, const std::string& frame);
  void StreamTick(ConnectionPtr c);
  void StateTick(ConnectionPtr c);
  void PhysicsTick();
  void OnScript(const ConnectionPtr& c, const std::string& line);
  void MoveLinear(const ConnectionPtr& c, const robots::ur::MoveCommand& move);
  void StartProgram(const ConnectionPtr& c, const std::string& text);
  void ProgramTick();  // io thread: the running program's next step once the arm is ready
  std::string Dashboard(const ConnectionPtr& c, const std::string& command);
  std::vector<double> OutputValue(const std::string& name, const VirtualArm::State& s) const;
  int RobotMode(const VirtualArm::State& s) const;
  int SafetyMode(const VirtualArm::State& s) const;
  uint64_t Microseconds() const;
  std::chrono::steady_clock::duration Wall(double physical_s) const;

  VirtualLab& lab_;
  UrSimulatorOptions options_;
  std::unique_ptr<VirtualArm> arm_;
  boost::asio::io_context io_;
  std::unique_ptr<boost::asio::ip::tcp::acceptor> acceptors_[4];
  std::optional<boost::asio::executor_work_guard<boost::asio::io_context::executor_type>> work_;
  std::unique_ptr<boost::asio::steady_timer> physics_;
  std::thread thread_;
  // Plans a linear move (the controller's inverse along the line) beside the io thread, which
  // keeps streaming meanwhile; the arm stands until the plan starts it.
  std::thread planner_;
  Ports ports_;
  std::set<ConnectionPtr> live_;  // io thread only
  std::optional<ProgramPlayer> program_;  // io thread only

  mutable std::mutex mutex_;  // what the test thread changes
  bool remote_ = true;
  bool refuse_v2_ = false;
  std::set<std::string> hidden_outputs_;
  instruments::ControllerKinematics kinematics_;
  std::chrono::steady_clock::time_point down_until_{};
  double frequency_hz_ = 0.0;

  std::atomic<int> rtde_packages_{0}, rtde_skipped_{0}, connections_{0}, scripts_{0},
      programs_started_{0}, programs_finished_{0};
};

}  // namespace armsig::simulation
