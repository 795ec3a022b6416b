#include "support/tracker_cell.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <random>

#include "db/store.h"
#include "io/model_yaml.h"
#include "io/network_files.h"
#include "workflows/capture.h"

namespace armsig::testing {

using namespace std::chrono_literals;

TrackerCell::TrackerCell(const std::string& robot, const std::string& model_file,
                         const TempDir& dir, int configurations, double acquire_radius_mm) {
  model = io::LoadRobotModel(SourcePath(model_file));
  truth = simulation::MakeVirtualRobot(robot, model, 7);
  lab =
      std::make_unique<simulation::VirtualLab>(model, truth.true_params, truth.world_from_base, 3);
  lab->SetJointErrors(truth.joint_errors);
  simulation::VirtualStation lt1;
  lt1.pose.id = "LT1";
  lab->AddStation(lt1);
  simulation::EmsconSimulatorOptions t;
  t.command_latency = 1ms;
  t.motion_latency = 2ms;
  t.initialize_latency = 2ms;
  t.acquire_radius_mm = acquire_radius_mm;
  t.seed = 11;
  // An AT9xx-class tracker: it also measures continuously, on a clock 42.1 ms and −8 ppm off
  // the controller's (measuring on the move; stationary readings carry no time).
  t.continuous_modes = true;
  t.clock_offset_s = 0.0421;
  t.clock_drift_ppm = -8.0;
  tracker = std::make_unique<simulation::EmsconSimulator>(*lab, 0, "127.0.0.1", 0, t);
  tracker->Start();
  std::vector<reduction::Station> stations(1);
  stations[0].pose = lt1.pose;
  WriteText(dir.File("stations.yaml"), io::FormatStationsYaml(stations, "truth"));
  // Near where the arm stands: moves of a few tenths of a radian.
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> around(-0.3, 0.3);
  for (int k = 0; k < configurations; ++k) {
    Eigen::VectorXd q = truth.home_rad;
    for (int j = 0; j < q.size(); ++j) q(j) += around(rng);
    plan.push_back({"C" + std::to_string(k + 1), q});
  }
}

std::vector<StoredPose> StoredPoses(db::Database& db, int64_t session) {
  auto q = db.connection().Prepare(
      "SELECT seq, joints_json, controller_time_s, attempts FROM poses WHERE session_id = ? "
      "AND status = 'measured' ORDER BY seq");
  q->Bind(1, session);
  std::vector<StoredPose> out;
  while (q->Step()) {
    const auto j = nlohmann::json::parse(q->Text(1));
    Eigen::VectorXd joints(static_cast<Eigen::Index>(j.size()));
    for (size_t k = 0; k < j.size(); ++k) joints(static_cast<Eigen::Index>(k)) = j[k].get<double>();
    out.push_back({static_cast<int>(q->Int(0)), joints, q->OptionalDouble(2),
                   static_cast<int>(q->Int(3))});
  }
  return out;
}

void ExpectStoredAsPlanned(db::Database& db, int64_t session, size_t count, const TrackerCell& cell,
                           double joint_tolerance_rad) {
  const auto stored = StoredPoses(db, session);
  ASSERT_EQ(stored.size(), count);
  const auto poses = db::LoadSessionPoses(db, session);
  ASSERT_EQ(poses.size(), count);
  calibration::Kinematics kin(cell.model);
  for (size_t k = 0; k < count; ++k) {
    EXPECT_LE((stored[k].joints - cell.plan[stored[k].seq].joints_rad).cwiseAbs().maxCoeff(),
              joint_tolerance_rad)
        << "configuration " << stored[k].seq;
    const Eigen::VectorXd q = cell.truth.joint_errors.TrueAngles(poses[k].joints_rad);
    const Eigen::Vector3d truth =
        kin.Position(cell.truth.world_from_base, cell.truth.true_params, q.data());
    EXPECT_LT((poses[k].target_in_world - truth).norm(), 0.15) << "configuration " << k;
  }
}

acquisition::CaptureSummary CaptureWithEvent(db::Database& db, const io::LabConfig& lab,
                                             int64_t session, int done,
                                             const std::function<void()>& event) {
  acquisition::CaptureOptions options;
  options.progress = [&](const acquisition::Progress& p) {
    if (p.done == done && p.waiting.empty()) event();
  };
  return workflows::CaptureInto(db, lab, session, options);
}

}  // namespace armsig::testing
