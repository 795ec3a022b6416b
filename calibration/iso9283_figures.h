// The performance figures of ISO 9283 from attained poses, pure computation:
//   pose accuracy      AP = |x̄ − x_c| with APx = x̄ − x_c, APy, APz (x̄ the barycentre of
//                      the n attained positions); orientation APa = ā − a_c, APb, APc;
//   pose repeatability RP = l̄ + 3 S_l, l_j = |x_j − x̄|, S_l = √(Σ(l_j − l̄)² / (n − 1));
//                      orientation RPa = ±3 S_a, S_a = √(Σ(a_j − ā)² / (n − 1));
//   distance accuracy  AD = D̄ − D_c, D_j = |x_Aj − x_Bj| of the same cycle, D_c = |c_A − c_B|;
//   distance repeatability RD = ±3 S_D, S_D on n − 1;
//   multi-directional pose accuracy variation vAP = the largest distance between the
//                      barycentres of the approach directions (vAPa… likewise per angle).
// Orientation angles (a, b, c) are compared component by component, as the standard does,
// each difference taken on (−π, π] around the command (or, without one, the first sample).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <optional>
#include <string>
#include <vector>

namespace armsig::calibration::iso9283 {

// One attained pose of a test point.
struct Sample {
  int cycle = 0;
  int approach = 0;  // 0: the one approach; 1…3: the multi-directional test's directions
  Eigen::Vector3d position_mm = Eigen::Vector3d::Zero();
  std::optional<Eigen::Vector3d> orientation_rad;  // a, b, c, when the instrument measures it
};

struct PointData {
  std::string name;
  Eigen::Vector3d commanded_mm = Eigen::Vector3d::Zero();
  std::optional<Eigen::Vector3d> commanded_orientation_rad;
  std::vector<Sample> samples;
};

struct PointFigures {
  std::string name;
  int n = 0;
  Eigen::Vector3d commanded_mm = Eigen::Vector3d::Zero();
  Eigen::Vector3d barycentre_mm = Eigen::Vector3d::Zero();
  Eigen::Vector3d ap_xyz_mm = Eigen::Vector3d::Zero();  // APx, APy, APz
  double ap_mm = 0.0;
  // n ≥ 2: l̄, S_l (on n − 1) and RP; NaN for one sample.
  double mean_l_mm = NAN, s_l_mm = NAN, rp_mm = NAN;
  std::vector<double> l_mm;  // |x_j − x̄| per sample, in sample order
  // Orientation, when every sample carries one: S_a… and RPa… = 3 S (n ≥ 2); APa… when
  // the command carries one too.
  std::optional<Eigen::Vector3d> ap_abc_rad, s_abc_rad, rp_abc_rad;
  // Two or more approach directions: vAP and (with orientation) vAPa, vAPb, vAPc.
  std::optional<double> vap_mm;
  std::optional<Eigen::Vector3d> vap_abc_rad;
  int approaches = 0;
};

// Throws std::invalid_argument for a point without samples.
PointFigures EvaluatePoint(const PointData& point);

// RP = l̄ + 3 S_l of a set of positions (n ≥ 2; NaN otherwise).
double PoseRepeatability(const std::vector<Eigen::Vector3d>& positions_mm);

struct DistanceFigures {
  std::string from, to;
  int n = 0;                         // cycles in which both points were attained
  double commanded_mm = 0.0;         // D_c
  double mean_mm = 0.0;              // D̄
  double ad_mm = 0.0;                // D̄ − D_c
  double s_d_mm = NAN, rd_mm = NAN;  // n ≥ 2
  std::vector<double> d_mm;          // D_j per cycle
};
// Pairs the samples of `a` and `b` by (cycle, approach); nullopt when no cycle has both.
std::optional<DistanceFigures> EvaluateDistance(const PointData& a, const PointData& b);

// A percentile bootstrap interval of RP: `resamples` resamples of the positions with
// replacement, each one's RP; the (1 − level)/2 and (1 + level)/2 quantiles. A cheap and
// honest statement of how well 30 cycles fix RP (the standard gives none). Deterministic
// for a seed; nullopt for fewer than 3 positions.
struct Interval {
  double lo = NAN, hi = NAN;
  double level = 0.95;
  int resamples = 0;
};
std::optional<Interval> BootstrapRpInterval(const std::vector<Eigen::Vector3d>& positions_mm,
                                            int resamples = 2000, double level = 0.95,
                                            unsigned seed = 1);

// Orientation as a, b, c (rad): rotations about the fixed x, y and z axes, in that order,
// R = Rz(c)·Ry(b)·Rx(a).
Eigen::Matrix3d RotationFromAbc(const Eigen::Vector3d& abc_rad);
Eigen::Vector3d AbcFromRotation(const Eigen::Matrix3d& rotation);

// The rigid best fit (Umeyama, no scale) that maps attained positions (the measuring
// frame) onto commanded ones (the robot frame), one point per test point (its
// barycentre), equal weights, and its residuals.
struct Alignment {
  Eigen::Isometry3d commanded_from_attained = Eigen::Isometry3d::Identity();
  std::vector<double> residual_mm;  // per point, |T·attained − commanded|
  double rms_mm = 0.0;
};
// nullopt for fewer than three points, or points on one line.
std::optional<Alignment> AlignRigidly(const std::vector<Eigen::Vector3d>& attained_mm,
                                      const std::vector<Eigen::Vector3d>& commanded_mm);
// Every sample of `point` (position and orientation) through `commanded_from_attained`.
void TransformSamples(PointData& point, const Eigen::Isometry3d& commanded_from_attained);

}  // namespace armsig::calibration::iso9283
