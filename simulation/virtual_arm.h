// A robot arm as its controller moves it, in physical time: where its joints are (what the
// encoders read), how fast they turn, whether a move runs, and what stops it. It keeps the
// virtual lab's robot where the arm is, so that the instruments measure the arm as it moves.
// Protocol-free: the UR, KUKA and ABB simulators each drive one and put its state in their
// own words. Thread-safe (the protocol's io thread moves it, a test injects its faults).
#pragma once

#include <deque>
#include <memory>

#include <Eigen/Core>
#include <mutex>
#include <optional>

#include "simulation/joint_motion.h"
#include "simulation/virtual_lab.h"

namespace armsig::simulation {

class VirtualArm {
 public:
  VirtualArm(VirtualLab& lab, PhysicalClock clock, Eigen::VectorXd home_rad);

  enum class Stop { kNone, kProtective, kEmergency };
  struct State {
    double t = 0.0;         // physical seconds since the controller started
    Eigen::VectorXd q, qd;  // encoder angles (rad) and speeds (rad/s)
    Eigen::VectorXd target;  // where the running move goes (q when none)
    bool moving = false;     // a move runs (not yet arrived, not stopped)
    double move_start = 0.0;  // when the running move began (physical s), with `moving`
    Stop stop = Stop::kNone;
    bool powered = true;     // false after an emergency stop until powered on again
  };
  // The state now; the lab's robot follows it.
  State Now();
  // Where the controller's moves had the joints at physical time `t` (now or in the recent
  // past: the last 256 moves are kept), and how fast they turned: what an instrument that
  // samples on its own clock (a tracker's continuous mode, RTDE's period) saw then. Side-
  // effect free. Leaves out drifts (another program's motion) and a stop's braking before
  // the running move.
  struct Motion {
    Eigen::VectorXd q, qd;
  };
  Motion At(double t) const;
  const PhysicalClock& clock() const { return clock_; }

  // Starts a joint move from where the arm is; false (nothing moves) while it is stopped or
  // not powered. A move replaces the one running.
  bool MoveJ(const Eigen::VectorXd& target_rad, double a_rad_s2, double v_rad_s);

  // A move along a path the controller computed (a linear TCP move by its own inverse
  // kinematics, simulation/path_motion.h): the joints every `dt_s` of physical time from now,
  // linearly interpolated between. Replaces a move running; false while stopped or not
  // powered. A stop during it holds the arm where it is (no braking modelled).
  bool MovePath(std::vector<Eigen::VectorXd> joints_rad, double dt_s);

  // Stops: the arm brakes along its path (a protective stop at the move's own deceleration,
  // at least 2 rad/s²; an emergency stop at 10 rad/s², and the arm is powered off).
  void ProtectiveStop();
  void EmergencyStop();
  // A protective stop `fraction` of the way through the next move (a collision).
  void ProtectiveStopDuringNextMove(double fraction);
  // Clears a protective stop; returns the physical seconds since it happened (0: none).
  double ClearProtectiveStop();
  double SecondsSinceStop();
  // The emergency stop button released: still powered off until PowerOn.
  void ReleaseEmergencyStop();
  bool emergency_pressed() const;
  // Powered on and brakes released (the pendant's ON then START); false while the
  // emergency stop is pressed.
  bool PowerOn();

  // Something other than the controller's moves turns `joint` at `speed_rad_s` (another
  // program, the pendant, freedrive) until StopDrifting or the controller's next move.
  void Drift(int joint, double speed_rad_s);
  void StopDrifting();
  // The same `delay_s` after the next move has ended, for `for_s` (a program started on the
  // pendant once the arm stood: what a reading taken then must not keep).
  void DriftAfterNextMove(int joint, double speed_rad_s, double delay_s, double for_s);

  int moves() const;
  int stops() const;
  double moving_s() const;  // physical time spent in moves so far

 private:
  State StateAt(double t);  // under the lock
  void Halt(double t, double deceleration, Stop why);

  VirtualLab& lab_;
  PhysicalClock clock_;
  mutable std::mutex mutex_;
  Eigen::VectorXd rest_;  // where the arm stands when no move runs
  std::optional<JointMove> move_;
  double move_start_ = 0.0;
  std::optional<double> stop_fraction_;  // of the next move
  std::optional<double> stop_at_;        // physical time of the planned stop of this move
  std::optional<double> halt_at_;        // braking since (move time), at halt_deceleration_
  double halt_deceleration_ = 2.0;
  Stop stop_ = Stop::kNone;
  double stopped_at_ = 0.0;
  bool emergency_pressed_ = false, powered_ = true;
  std::optional<int> drift_joint_;
  double drift_speed_ = 0.0, drift_since_ = 0.0;
  std::optional<double> drift_until_;
  Eigen::VectorXd drift_offset_;  // where drifts took the joints since the last move began
  struct PendingDrift {
    int joint;
    double speed, delay, duration;
  };
  std::optional<PendingDrift> pending_drift_;
  void EndDrift(double t);  // under the lock
  Eigen::VectorXd pushed_;  // the joints last given to the lab
  struct SampledPath {
    double start = 0.0, dt = 0.0;
    std::vector<Eigen::VectorXd> q;
    double duration() const { return dt * static_cast<double>(q.size() - 1); }
    Motion At(double tau) const;  // clamped to [0, duration]
  };
  std::optional<SampledPath> path_;  // a path move running
  struct PastMove {
    double start = 0.0, end = 0.0;  // physical time; `end` before the move's own when cut short
    JointMove move;
    std::shared_ptr<const SampledPath> path;  // a path move instead of `move`
  };
  std::deque<PastMove> past_;  // the latest last
  void Remember(double start, double end, const JointMove& move);  // under the lock
  int moves_ = 0, stops_ = 0;
  double moving_s_ = 0.0;
};

}  // namespace armsig::simulation
