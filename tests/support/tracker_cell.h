// A robot controller's capture tests (acquisition/ur_capture_test.cc, kuka_capture_test.cc):
// a virtual robot of simulation/virtual_robots.h (hidden geometric and joint-angle errors)
// measured by one virtual laser tracker (LT1 at the origin, emScon on loopback TCP, fast),
// its stations file, a plan near the robot's home, and what a session stored, checked against
// the truth.
#pragma once

#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "acquisition/plan.h"
#include "acquisition/session.h"
#include "calibration/model.h"
#include "db/database.h"
#include "io/lab_file.h"
#include "simulation/emscon_simulator.h"
#include "simulation/virtual_lab.h"
#include "simulation/virtual_robots.h"
#include "test_support.h"

namespace armsig::testing {

struct TrackerCell {
  // The virtual robot `robot` on the model file `model_file` (from the source tree), seed 7;
  // `dir`'s stations.yaml; `configurations` within ±0.3 rad of home on every joint. The
  // tracker finds its reflector only within `acquire_radius_mm` of its beam (0: always).
  TrackerCell(const std::string& robot, const std::string& model_file, const TempDir& dir,
              int configurations, double acquire_radius_mm = 0.0);

  calibration::RobotModel model;
  simulation::VirtualRobot truth;
  std::unique_ptr<simulation::VirtualLab> lab;
  std::unique_ptr<simulation::EmsconSimulator> tracker;
  acquisition::Plan plan;
};

// A session's measured configurations, in plan order: their plan index, joints, the
// controller's time stamp and how many attempts they took.
struct StoredPose {
  int seq = 0;
  Eigen::VectorXd joints;
  std::optional<double> controller_time_s;
  int attempts = 0;
};
std::vector<StoredPose> StoredPoses(db::Database& db, int64_t session);

// Every stored configuration (`count` of them) at its planned joints within
// `joint_tolerance_rad` (where the controller put the arm), its point where the true robot is
// at those joints (its joint errors included), within the tracker's noise.
void ExpectStoredAsPlanned(db::Database& db, int64_t session, size_t count, const TrackerCell& cell,
                           double joint_tolerance_rad);

// Captures `session` of the lab `lab`; `event` (the operator, the network) happens once `done`
// configurations are stored and the session is not waiting on the controller.
acquisition::CaptureSummary CaptureWithEvent(db::Database& db, const io::LabConfig& lab,
                                             int64_t session, int done,
                                             const std::function<void()>& event);

}  // namespace armsig::testing
