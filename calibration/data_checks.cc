#include "calibration/data_checks.h"

#include <cmath>
#include <numbers>
#include <set>

#include "calibration/estimation.h"

namespace armsig::calibration {

namespace {

// The nominal model's rms distance after the best rigid base; nullopt when the poses cannot
// place it.
std::optional<double> NominalRms(const RobotModel& model, const std::vector<MeasuredPose>& poses) {
  const auto base = AlignBase(model, poses);
  if (!base) return std::nullopt;
  double sum = 0.0;
  for (const auto& r :
       Residuals(model, *base, Eigen::VectorXd::Zero(model.num_parameters()), poses))
    sum += r.squaredNorm();
  const double rms = std::sqrt(sum / static_cast<double>(poses.size()));
  if (!std::isfinite(rms)) return std::nullopt;
  return rms;
}

struct Reading {
  double joint_factor, length_factor;
  const char* words;
};

}  // namespace

PoseModelCheck CheckPosesAgainstModel(const RobotModel& model,
                                      const std::vector<MeasuredPose>& poses,
                                      double max_rms_mm) {
  PoseModelCheck check;
  RobotModel bare = model;
  bare.nongeometric.clear();
  bare.term_support.clear();
  bare.base.reset();  // the measuring frame is the data's own
  const auto rms = NominalRms(bare, poses);
  if (!rms) return check;
  check.checked = true;
  check.rms_mm = *rms;
  check.fits = *rms <= max_rms_mm;
  if (check.fits) return check;
  constexpr double kDeg = std::numbers::pi / 180.0;
  static const Reading kReadings[] = {
      {1.0 / kDeg, 1.0, "the joint values are radians, not degrees"},
      {kDeg, 1.0, "the joint values are degrees, not radians"},
      {1.0, 1000.0, "the positions are metres, not millimetres"},
      {1.0, 25.4, "the positions are inches, not millimetres"},
      {1.0, 0.001, "the positions are micrometres, not millimetres"},
      {1.0 / kDeg, 1000.0, "the joint values are radians, not degrees, and the positions metres"},
      {kDeg, 1000.0, "the joint values are degrees, not radians, and the positions metres"},
  };
  double best = check.rms_mm;
  for (const Reading& r : kReadings) {
    std::vector<MeasuredPose> read = poses;
    for (auto& p : read) {
      p.joints_rad *= r.joint_factor;
      p.target_in_world *= r.length_factor;
    }
    const auto alt = NominalRms(bare, read);
    if (!alt || *alt > max_rms_mm || *alt >= best) continue;
    best = *alt;
    check.reading = r.words;
    check.reading_rms_mm = *alt;
  }
  return check;
}

int DistinctConfigurations(const std::vector<MeasuredPose>& poses) {
  std::set<std::vector<long long>> seen;
  for (const auto& p : poses) {
    std::vector<long long> key;
    for (int i = 0; i < p.joints_rad.size(); ++i) key.push_back(std::llround(p.joints_rad(i) * 1e6));
    seen.insert(std::move(key));
  }
  return static_cast<int>(seen.size());
}

}  // namespace armsig::calibration
