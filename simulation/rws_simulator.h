// A virtual ABB robot controller behind Robot Web Services: an IRC5 (RobotWare 6, RWS 1.0:
// HTTP, Digest authentication, XHTML or ?json=1) or an OmniCore (RobotWare 7, RWS 2.0: HTTPS
// with a self-signed certificate made at start, Basic authentication, hal+json), serving
// the resources armsig's driver uses (robots/rws_codec.h names them) with Boost.Beast
// on its own thread, answering through the same codec as the driver.
//
// Followed: ABB, "Application Manual - Robot Web Services", 3HAC050973-001 Revision M (RWS
// 1.0), and ABB's OmniCore App SDK 1.5.0 RWS library (RWS 2.0 paths and media types); the
// return codes as RobotWare 6.16 / 7.21 give them (robots/rws_codec.h). Where ABB does
// not say, it chooses and says so: the jointtarget resource is written with two decimals
// (the manual states no precision; armsig must not depend on it), the realm is
// "validusers@robapi.abb", the session cookies are -http-session- and ABBCX.
//
// Its RAPID task runs the module armsig ships (controllers/abb/ArmsigServer.mod, compiled
// in; simulation/rapid_module.h reads its declarations): the task's data are exactly the
// module's, with its initial values, and the task does what the module's armsig_serve
// does — waits for armsig_cmd ≠ armsig_done, moves (MoveAbsJ, fine), records CJointT into
// armsig_joints, sets armsig_done; a start from main drops a pending request. RAPID num
// values are single-precision floats, as on the controller.
//
// A lab's own programs reach the task as on the real controller (simulation/rws_programs.h):
// a module uploaded to $HOME, loaded into the task with mastership while RAPID stands, the
// program pointer set to one of its routines; execution started then runs that routine's
// motions with the controller's inverse kinematics on its nominal model (the lab's model)
// until its end, and resetpp gives the task back to the shipped module's main. Users and
// sessions: simulation/rws_sessions.h.
//
// Moves take the time the real arm would take (times time_scale), on the arm every virtual
// controller shares (simulation/virtual_arm.h): a synchronised joint move whose leading joint
// (the largest turn) runs at the speed and acceleration that keep every axis within its
// maximum times the velocity override (armsig_speed %), an axis reaching its maximum in
// accel_time_s. Defaults: the IRB 4600-40/2.55's axis speeds 175, 175, 175, 250, 250,
// 360 °/s and working ranges ±180, +150/−90, +75/−180, ±400, +120/−125, ±400° as ABB's data
// sheet gives them (and ROS-Industrial's abb_irb4600_support, irb4600_40_255_macro.xacro,
// copies them). The acceleration time (0.25 s at full speed) is this simulator's
// assumption. A target outside a working range stops the program (event 50050, as the
// controller's motion planner does); the arm does not move.
//
// The cell and the operator (thread-safe, from the test or the demo): a guard stop (the
// safety run chain opening: ABB's protective stop) or an emergency stop brakes a move along
// its path, switches the motors off and stops the program; the operator resets the stop,
// switches the motors on and starts the program again (continue: the move is finished; from
// main: it is dropped). The operating mode can be turned to manual (the program stops, the
// motors go off). The network can be cut and restored (every connection closed, new ones
// refused; sessions survive, as on a controller whose cable was pulled). Another client can
// request a move, or something can turn a joint behind the module's back, for the driver's
// still-checks. Generic faults (simulation/simulator.h): kVanish (the connection closed as a
// request arrives), kDropReply (no answer), kErrorCode (HTTP 500 with that return code),
// kNoiseBytes (bytes that are no HTTP, then closed), kTruncateReply (half a reply, then
// closed).
#pragma once

#include <Eigen/Core>
#include <array>
#include <atomic>
#include <chrono>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "robots/rws_codec.h"
#include "simulation/rapid_module.h"
#include "simulation/simulator.h"
#include "simulation/virtual_lab.h"

namespace armsig::simulation {

struct RwsSimulatorOptions {
  robots::rws::Version version = robots::rws::Version::kRws2;
  std::string user = "Default User";
  std::string password = "robotics";  // ABB's factory default
  // What the controller says it is.
  std::string model = "IRB 4600-40/2.55";
  std::string serial_high = "4600", serial_low = "501234";
  std::string controller_name = "armsig-virtual", controller_id = "14-21985";
  std::string robotware;  // "" : 6.15.03.00 (RWS 1.0) or 7.16.0.0 (RWS 2.0)
  std::string task = "T_ROB1", mechunit = "ROB_1";
  // The module in the task; empty: no module loaded (every symbol unknown).
  std::string module_text = std::string(ShippedAbbModule());
  double time_scale = 1.0;                   // multiplies every move and latency
  std::chrono::milliseconds latency{2};      // each answer
  std::array<double, 6> max_speed_deg_s{175, 175, 175, 250, 250, 360};
  double accel_time_s = 0.25;                // to reach an axis' maximum speed
  std::array<std::pair<double, double>, 6> limits_deg{
      {{-180, 180}, {-90, 150}, {-180, 75}, {-400, 400}, {-125, 120}, {-400, 400}}};
  // Where the arm stands at start (degrees); the program runs in AUTO, motors on.
  std::array<double, 6> start_deg{0, 0, 0, 0, 30, 0};
  bool running = true;
};

class RwsSimulator : public Simulator {
 public:
  // Listens on `host`:`port` (0: any free port). The lab's robot is moved by the task.
  RwsSimulator(VirtualLab& lab, RwsSimulatorOptions options = {},
               std::string host = "127.0.0.1", unsigned short port = 0);
  ~RwsSimulator() override;
  RwsSimulator(const RwsSimulator&) = delete;
  RwsSimulator& operator=(const RwsSimulator&) = delete;

  void Start() override;  // throws std::runtime_error when the address cannot be bound
  void Stop() override;
  const std::string& path() const override { return address_; }  // HOST:PORT
  unsigned short port() const { return port_; }
  void InjectOnce(FaultSpec fault) override;
  void InjectAlways(FaultSpec fault) override;
  void ClearFaults() override;
  int requests() const override { return requests_.load(); }
  int64_t flood_bytes() const override { return 0; }

  // RWS 2.0: the certificate made at start (PEM) and its SHA-256 fingerprint.
  const std::string& certificate_pem() const { return certificate_pem_; }
  const std::string& certificate_sha256() const { return fingerprint_; }

  // The cell and the operator.
  void GuardStop();
  void EmergencyStop();
  void ResetStop();  // the stop cleared and acknowledged: motors off
  void SetMotors(bool on);
  void SetMode(robots::rws::OperationMode mode);
  // Starts the program (continue where it stopped; or from main). Refused (false) unless the
  // motors are on.
  bool StartProgram(bool from_main = false);
  void StopProgram();
  // Reset, motors on, continue: what the operator does after a stop.
  void Recover();
  void CutNetwork();      // every connection closed, new ones refused
  void RestoreNetwork();  // listening again on the same port
  // Another client asks the module for a move (writes target and armsig_cmd).
  void RequestMoveElsewhere(const Eigen::VectorXd& joints_deg);
  // Something turns `joint` (0-based) without the module (another program, a jog) at
  // `deg_per_s` until the module's next move.
  void TurnBehindModule(int joint, double deg_per_s);
  // The same `delay_s` after the module's next move has ended, for `for_s` of physical time
  // (a program started on the pendant once the arm stood).
  void TurnAfterNextMove(int joint, double deg_per_s, double delay_s, double for_s);
  // Another client holds the RAPID write access (mastership).
  void HoldMastershipElsewhere(bool held);
  // The next move the task makes is stopped after `fraction` of its time (as if the test
  // pressed the button then): deterministic, whatever the machine's load.
  enum class CellStop { kGuardStop, kEmergencyStop, kProgramStop };
  void StopDuringNextMove(CellStop stop, double fraction);

  struct Snapshot {
    robots::rws::ControllerState controller;
    robots::rws::OperationMode mode;
    bool running = false;
    bool moving = false;
    Eigen::VectorXd joints_deg;
    double cmd = 0, done = 0, error = 0;
    int moves = 0;        // moves finished
    int logins = 0;       // sessions opened by authentication
    int refused_logins = 0;
    int connections = 0;  // accepted
    int routines_run = 0;  // routines of loaded modules started (simulation/rws_programs.h)
    std::string program_pointer;  // "main", or MODULE/routine
  };
  Snapshot snapshot() const;
  // A RAPID datum's value text (the module's declaration), "" when unknown.
  std::string Symbol(const std::string& name) const;
  // Every request line seen ("POST /rw/…"), bodies excluded.
  std::vector<std::string> request_log() const;

  struct Impl;  // the controller's state and the server (rws_simulator.cc)

 private:
  std::unique_ptr<Impl> impl_;
  std::string address_;
  unsigned short port_ = 0;
  std::string certificate_pem_, fingerprint_;
  std::atomic<int> requests_{0};
};

}  // namespace armsig::simulation
