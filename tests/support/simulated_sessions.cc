#include "support/simulated_sessions.h"

#include <algorithm>
#include <random>
#include <vector>

#include "calibration/synthetic.h"
#include "db/store.h"
#include "test_support.h"

namespace armsig::testing {

namespace {
constexpr double kNoiseMm = 0.01;
}  // namespace

// One session of `count` configurations of the true robot, stored like a capture.
void AddSession(db::Database& db, const Eigen::VectorXd& truth, int count, unsigned seed,
                double blunder_fraction, const std::string& lab_yaml, const std::string& robot_name,
                const Eigen::Isometry3d& world_from_base, int stride) {
  const auto model = Puma();
  std::mt19937 rng(seed);
  const auto design = calibration::LabTestConfigurations(model, rng);
  std::vector<Eigen::VectorXd> configurations;
  for (size_t k = 0; k < design.size(); k += static_cast<size_t>(std::max(stride, 1)))
    configurations.push_back(design[k]);
  const auto poses =
      calibration::SimulatePoses(model, world_from_base, truth, configurations, kNoiseMm, rng);
  db::WriteTransaction tx(db);
  const int64_t robot =
      db::EnsureRobot(db, robot_name, "puma760", ReadText(SourcePath("models/puma760.yaml")));
  const int64_t session = db::CreateSession(db, robot, lab_yaml, "", db::SessionState::kCompleted, "simulated");
  std::uniform_real_distribution<double> u(0, 1);
  for (int i = 0; i < count && i < static_cast<int>(poses.size()); ++i) {
    const int64_t pose =
        db::InsertPose(db, session, i, poses[i].id, poses[i].joints_rad, "measured", 1);
    Eigen::Vector3d x = poses[i].target_in_world;
    if (u(rng) < blunder_fraction) x += Eigen::Vector3d(3.0, -2.0, 1.5);  // a bad measurement
    db::PointRow point;
    point.pose_id = pose;
    point.point = "target";
    point.position_mm = x;
    point.covariance_mm2 = Eigen::Matrix3d::Constant(NAN);  // not known
    point.rays = 3;
    db::InsertPoint(db, session, point);
  }
  tx.commit();
}

Eigen::Isometry3d NightFrame(unsigned seed) {
  std::mt19937 rng(seed * 7919u + 17u);
  std::uniform_real_distribution<double> offset(-400.0, 400.0), angle(-0.5, 0.5);
  Eigen::Isometry3d frame = Eigen::Isometry3d::Identity();
  frame.linear() = (Eigen::AngleAxisd(angle(rng), Eigen::Vector3d::UnitZ()) *
                    Eigen::AngleAxisd(0.05 * angle(rng), Eigen::Vector3d::UnitX()))
                       .toRotationMatrix();
  frame.translation() = Eigen::Vector3d(offset(rng), offset(rng), 0.1 * offset(rng));
  return frame;
}

int ActiveVersion(const std::string& path) {
  db::Database db(path, db::OpenMode::kMustExist);
  return static_cast<int>(db.connection().QueryInt(
      "SELECT coalesce(max(version), 0) FROM calibrations WHERE active = 1"));
}

int Versions(const std::string& path) {
  db::Database db(path, db::OpenMode::kMustExist);
  return static_cast<int>(db.connection().QueryInt("SELECT count(*) FROM calibrations"));
}

}  // namespace armsig::testing
