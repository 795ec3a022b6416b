// How a controller moves the arm's joints, as functions of physical time; pure (no clock,
// no thread), so that every virtual controller (UR, KUKA, ABB) and a later program
// interpreter share it.
//   - PhysicalClock: the simulators' time, physical seconds, optionally scaled: a scale of
//     0.1 runs ten times faster than the wall clock (every latency times 0.1).
//   - JointMove: a joint move with synchronised joints, the leading one (the largest turn)
//     on a trapezoidal speed profile — URScript's movej (robots::ur::MoveJDuration):
//     accelerate at a to v, cruise, brake at a; the others scaled to start and end with it.
//     A stop brakes along the same path (Braked).
#pragma once

#include <Eigen/Core>
#include <chrono>

namespace armsig::simulation {

class PhysicalClock {
 public:
  // `time_scale` > 0: wall seconds per physical second (below 1e-3 it is taken as 1e-3).
  explicit PhysicalClock(double time_scale = 1.0);
  // Physical seconds since the clock was made.
  double Now() const;
  double time_scale() const { return scale_; }
  // The wall time `physical_s` takes.
  std::chrono::steady_clock::duration Wall(double physical_s) const;

 private:
  double scale_;
  std::chrono::steady_clock::time_point start_;
};

class JointMove {
 public:
  JointMove(Eigen::VectorXd from, Eigen::VectorXd to, double a_rad_s2, double v_rad_s);
  double duration_s() const { return duration_; }
  const Eigen::VectorXd& from() const { return from_; }
  const Eigen::VectorXd& to() const { return to_; }

  // The leading joint's distance covered and its speed `t` seconds into the move.
  struct PathPoint {
    double s = 0.0, ds = 0.0;
  };
  PathPoint Path(double t) const;
  // The joints at a distance `s` of the leading joint along the path, and their speeds when
  // the leading joint turns at `ds`.
  Eigen::VectorXd PositionAlong(double s) const;
  Eigen::VectorXd VelocityAlong(double ds) const;
  Eigen::VectorXd PositionAt(double t) const { return PositionAlong(Path(t).s); }
  Eigen::VectorXd VelocityAt(double t) const { return VelocityAlong(Path(t).ds); }

  // A stop `t_stop` into the move, braking along the path at `deceleration` (rad/s² of the
  // leading joint): where the path is `t` seconds into the move (t ≥ t_stop), and when the arm
  // stands again.
  PathPoint Braked(double t_stop, double deceleration, double t) const;
  double BrakedUntil(double t_stop, double deceleration) const;

 private:
  Eigen::VectorXd from_, to_, direction_;  // direction_: (to − from) / distance
  double distance_ = 0.0, a_ = 1.0, v_ = 1.0, ramp_ = 0.0, peak_ = 0.0, duration_ = 0.0;
};

}  // namespace armsig::simulation
