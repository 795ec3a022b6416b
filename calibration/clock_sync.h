// Measuring on the move: a laser tracker's continuous points paired with a controller's joint
// stream at the tracker's own time stamps. The two clocks never agree: the tracker's time is
//   t_tracker = offset + (1 + drift) · t_controller
// with an offset (different boots, milliseconds to hours) and a drift (quartz, tens of ppm).
// Neither is assumed: both are estimated from the data themselves.
//   1. CoarseClock: the lag that best lines up the tracker's measured speed with the speed the
//      model gives the joint stream (cross-correlation of the two speed profiles on a grid;
//      speeds are blind to the frames and barely touched by the model's errors), around a
//      first guess (e.g. the arrival times of the two streams at the computer).
//   2. RefineClock: Gauss-Newton on offset and drift together with the rigid frame between the
//      robot's base and the tracker: each point's residual moves along the target's velocity
//      as the clock changes (∂x/∂t = J(q) q̇), so the fit is the one a least-squares
//      adjustment of a time offset does (1 ms at 250 mm/s is 0.25 mm). The robot model's errors
//      bias it unless the model is calibrated, so a session refines it again with the model it
//      fitted (acquisition/on_the_move.h) until both settle.
//   3. PairStreams: each tracker point with the joints at its own instant on the controller's
//      clock (cubic Hermite interpolation between the packages around it, exact for a constant
//      acceleration), left out and counted when the joint stream has a gap there, the arm
//      accelerates beyond a bound (a real arm bends under its own inertia, which a static
//      model does not know), or the clock's uncertainty moves the point more than a bound; the
//      rest carry the synchronisation's share of their error (speed × σ_t) for their weights.
// Pure computation (no I/O); the model through calibration::Kinematics.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <optional>
#include <vector>

#include "calibration/model.h"

namespace armsig::calibration {

// A controller's joint stream (UR RTDE: actual_q, actual_qd), in time order.
struct JointStream {
  std::vector<double> t_s;  // the controller's clock
  std::vector<Eigen::VectorXd> q_rad, qd_rad_s;
  size_t size() const { return t_s.size(); }
};

// A tracker's continuous points in its own frame (mm), in time order.
struct PointStream {
  std::vector<double> t_s;  // the tracker's clock
  std::vector<Eigen::Vector3d> point_mm;
  size_t size() const { return t_s.size(); }
};

// t_tracker = offset_s + (1 + drift) · t_controller. Estimated as the controller time of a
// tracker time t, a + b (t − reference_s); the covariance is of (a, b), so SigmaAt is the σ
// of the controller time given to a tracker time, offset and drift together.
struct ClockMap {
  double offset_s = 0.0;
  double drift = 0.0;  // dimensionless (1e-6 = 1 ppm)
  // Of (a, b) above; zero for an unestimated map.
  Eigen::Matrix2d covariance = Eigen::Matrix2d::Zero();
  double reference_s = 0.0;  // a tracker time inside the data
  double sigma0_mm = 0.0;    // the refinement's RMS residual per coordinate
  int iterations = 0;

  double ControllerTime(double tracker_s) const { return (tracker_s - offset_s) / (1.0 + drift); }
  double TrackerTime(double controller_s) const { return offset_s + (1.0 + drift) * controller_s; }
  // σ of ControllerTime(tracker_s), s.
  double SigmaAt(double tracker_s) const;
};

struct ClockOptions {
  double grid_s = 0.005;      // CoarseClock's speed profiles
  double max_lag_s = 10.0;    // searched either side of the first guess
  int max_iterations = 30;    // RefineClock
  // RefineClock uses the points whose target moves at least this fast (slower ones tell
  // nothing of the clock and weigh on the frame alone) and is not accelerating beyond the
  // pairing's bound.
  double min_speed_mm_s = 20.0;
  double max_acceleration_rad_s2 = 0.3;
  // The largest gap between two joint packages a point may fall in.
  double max_gap_s = 0.05;
};

// The lag around `guess` (its offset; drift taken as zero) that lines up the speed profiles;
// nullopt when the streams do not overlap long enough (two seconds of motion) to tell.
std::optional<ClockMap> CoarseClock(const RobotModel& model, const Eigen::VectorXd& params,
                                    const JointStream& joints, const PointStream& points,
                                    const ClockMap& guess, const ClockOptions& options = {});

// Offset, drift and the frame (`world_from_base`, updated) by least squares with the model's
// `params` held; throws std::invalid_argument when fewer than 20 moving points pair.
ClockMap RefineClock(const RobotModel& model, const Eigen::VectorXd& params,
                     const JointStream& joints, const PointStream& points, const ClockMap& start,
                     Eigen::Isometry3d& world_from_base, const ClockOptions& options = {});

struct PairedPoint {
  size_t index = 0;  // in the point stream
  double tracker_time_s = 0.0, controller_time_s = 0.0;
  Eigen::VectorXd q_rad;
  Eigen::Vector3d point_mm = Eigen::Vector3d::Zero();
  double speed_mm_s = 0.0;           // the target's, by the model
  double acceleration_rad_s2 = 0.0;  // the fastest-accelerating joint's
  double sync_sigma_mm = 0.0;        // speed × σ_t
};

struct PairingOptions {
  double max_acceleration_rad_s2 = 0.3;
  double max_gap_s = 0.05;
  // A point whose clock uncertainty alone moves it further than this is left out.
  double max_sync_sigma_mm = 0.05;
};

struct Pairing {
  std::vector<PairedPoint> points;
  int outside = 0;       // before the first or after the last joint package
  int gaps = 0;          // in a gap of the joint stream
  int accelerating = 0;  // beyond the acceleration bound
  int uncertain = 0;     // beyond the synchronisation bound
};

// `params` and `world_from_base` give each point's speed (for its σ).
Pairing PairStreams(const RobotModel& model, const Eigen::VectorXd& params,
                    const Eigen::Isometry3d& world_from_base, const JointStream& joints,
                    const PointStream& points, const ClockMap& clock,
                    const PairingOptions& options = {});

// The joints and their speeds at controller time t by cubic Hermite interpolation (exact
// for a constant acceleration), and the largest joint acceleration over the bracket and its
// neighbours; nullopt
// outside the stream or in a gap longer than `max_gap_s`.
struct JointState {
  Eigen::VectorXd q_rad, qd_rad_s;
  double acceleration_rad_s2 = 0.0;
};
std::optional<JointState> JointsAt(const JointStream& joints, double t_s, double max_gap_s);

}  // namespace armsig::calibration
