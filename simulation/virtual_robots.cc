#include "simulation/virtual_robots.h"

#include <cmath>
#include <random>
#include <stdexcept>

#include "calibration/synthetic.h"
#include "core/units.h"

namespace armsig::simulation {

namespace {

// Universal Robots' nominal UR10 DH table (m, rad), as models/ur10.yaml has it in mm and deg.
constexpr double kUr10A[6] = {0, -0.612, -0.5723, 0, 0, 0};
constexpr double kUr10D[6] = {0.1273, 0, 0, 0.163941, 0.1157, 0.0922};
constexpr double kUr10Alpha[6] = {kPi / 2, 0, 0, kPi / 2, -kPi / 2, 0};

VirtualRobot Ur10(const calibration::RobotModel& model, unsigned seed) {
  VirtualRobot r;
  r.name = "ur10";
  r.description = "a Universal Robots UR10";
  r.model = model;
  std::mt19937 rng(seed);
  // Geometric errors of an arm as built: σ 0.3 mm and 0.3 mrad per parameter (the real UR10
  // of the IPA data misses by 5 mm nominal); the non-geometric terms at zero (the truth's
  // own joint errors are the periodic ones below, not the model's terms).
  r.true_params = calibration::RandomParameters(r.model, 0.3, 3e-4, 0.0, rng);
  r.true_params.tail(r.model.num_parameters() - r.model.num_geometric()).setZero();
  // Joint-angle errors of the size the real one shows: orders 1-3, ~4 arc-seconds at order 1.
  r.joint_errors = JointAngleErrors::Random(6, 3, 4.0 * kRadPerArcsec, rng);
  r.home_rad = (Eigen::VectorXd(6) << 0.0, -1.57, 1.57, -1.57, -1.57, 0.0).finished();
  // About 2.9 m from the tracker, 1.1 m below it, turned towards it.
  r.world_from_base.translate(Eigen::Vector3d(2300.0, 1600.0, -1100.0));
  r.world_from_base.rotate(Eigen::AngleAxisd(2.6, Eigen::Vector3d::UnitZ()));
  r.identity.protocol = "ur";
  r.identity.vendor = "Universal Robots";
  r.identity.model = "UR10";
  r.identity.serial = "2018301" + std::to_string(100 + seed % 900);
  // The controller's own calibration from the factory: the nominal table, a few tenths of a
  // millimetre and of a milliradian off (what UR's own calibration found, not the truth).
  std::normal_distribution<double> mm(0.0, 2e-4), rad(0.0, 2e-4);
  for (int j = 0; j < 6; ++j) {
    r.kinematics.dh_theta_rad.push_back(rad(rng));
    r.kinematics.dh_a_mm.push_back((kUr10A[j] + (kUr10A[j] != 0 ? mm(rng) : 0.0)) * 1000.0);
    r.kinematics.dh_d_mm.push_back((kUr10D[j] + mm(rng)) * 1000.0);
    r.kinematics.dh_alpha_rad.push_back(kUr10Alpha[j] + rad(rng));
  }
  r.kinematics.calibration_status = 2;
  return r;
}

// An ABB IRB 4600-40/2.55 (models/irb4600.yaml, ABB's joint zero): geometric errors and
// joint-angle errors of the same kind and size as the UR10's (an arm as built; the periodic
// errors of its reducers); its RAPID program's home with the wrist bent (axis 5 at 30°, away
// from the wrist singularity); about 3.4 m from the tracker and 1.2 m below it, facing it.
// Robot Web Services tells no kinematic table: none here. One arm, whatever the seed (as the
// PUMA's Table 3): its errors and serial number are its own, so a demo run again on the same
// database is that arm's next session; the seed draws only the instruments' noise and plans.
VirtualRobot Irb4600(const calibration::RobotModel& model, unsigned) {
  VirtualRobot r;
  r.name = "abb";
  r.description = "an ABB IRB 4600-40/2.55";
  r.model = model;
  std::mt19937 rng(4600);
  r.true_params = calibration::RandomParameters(r.model, 0.3, 3e-4, 0.0, rng);
  r.true_params.tail(r.model.num_parameters() - r.model.num_geometric()).setZero();
  r.joint_errors = JointAngleErrors::Random(6, 3, 4.0 * kRadPerArcsec, rng);
  r.home_rad = (Eigen::VectorXd(6) << 0.0, 0.0, 0.0, 0.0, 30.0 * kRadPerDeg, 0.0).finished();
  r.world_from_base.translate(Eigen::Vector3d(2900.0, 1800.0, -1200.0));
  r.world_from_base.rotate(Eigen::AngleAxisd(std::atan2(-1800.0, -2900.0), Eigen::Vector3d::UnitZ()));
  r.identity.protocol = "abb";
  r.identity.vendor = "ABB";
  r.identity.model = "IRB 4600-40/2.55";
  r.identity.serial = "4600-501234";
  return r;
}

// A KUKA KR 16-2 on a KR C4 (models/kr16_2.yaml, in KUKA's joint convention), errors of the
// same kind and size as the UR10's. Its model's joint-1 frame is $ROBROOT turned half a turn
// about x, so the base carries that turn.
VirtualRobot Kr16(const calibration::RobotModel& model, unsigned seed) {
  VirtualRobot r;
  r.name = "kuka";
  r.description = "a KUKA KR 16-2 on a KR C4";
  r.model = model;
  std::mt19937 rng(seed + 16);
  r.true_params = calibration::RandomParameters(r.model, 0.3, 3e-4, 0.0, rng);
  r.true_params.tail(r.model.num_parameters() - r.model.num_geometric()).setZero();
  r.joint_errors = JointAngleErrors::Random(6, 3, 4.0 * kRadPerArcsec, rng);
  r.home_rad = (Eigen::VectorXd(6) << 0.0, -kPi / 2, kPi / 2, 0.0, 0.0, 0.0).finished();
  // On the floor 1.3 m below the tracker, 2.6 m from it, facing it.
  r.world_from_base.translate(Eigen::Vector3d(2100.0, 1500.0, -1300.0));
  r.world_from_base.rotate(Eigen::AngleAxisd(-2.52, Eigen::Vector3d::UnitZ()));
  r.world_from_base.rotate(Eigen::AngleAxisd(kPi, Eigen::Vector3d::UnitX()));
  r.identity.protocol = "kuka";
  r.identity.vendor = "KUKA";
  r.identity.model = "KR16_2";  // the arm of $TRAFONAME[] "#KR16_2 C4 FLR"
  r.identity.serial = std::to_string(501000 + seed % 1000);
  r.identity.software = "KS V8.3.38";
  return r;  // a KR C4 does not tell its own kinematics
}

struct Entry {
  const char* name;
  VirtualRobot (*make)(const calibration::RobotModel& model, unsigned seed);
  int joints;
};
constexpr Entry kRobots[] = {{"ur10", Ur10, 6}, {"kuka", Kr16, 6}, {"abb", Irb4600, 6}};

// The truth of a robot whose model has a known tool mounting, from the truth drawn on the
// same model with a fitted one (so that the arm's other errors, its joint-angle errors and
// everything else the seed draws stay those of the demo's robot): the probe sits where the
// model file says (a b c{n+1} = 0, as a machined adapter puts it) and the flange has a turn of
// its own after the last joint, kPlantedFlangeTurnRad about u1 and u2 (1 mrad in all, 0.24 mm
// at the IRB 4600's 238 mm lever).
constexpr double kPlantedFlangeTurnRad[2] = {0.8e-3, -0.6e-3};

Eigen::VectorXd KnownMountingTruth(const calibration::RobotModel& known,
                                   const Eigen::VectorXd& fitted_truth) {
  Eigen::VectorXd p = Eigen::VectorXd::Zero(known.num_parameters());
  const int tool = known.tool_index();
  p.head(tool) = fitted_truth.head(tool);
  const int turn = known.flange_turn_index();
  p(turn) = kPlantedFlangeTurnRad[0];
  p(turn + 1) = kPlantedFlangeTurnRad[1];
  const int terms = known.num_parameters() - known.num_geometric();
  p.tail(terms) = fitted_truth.tail(terms);
  return p;
}

}  // namespace

VirtualRobot MakeVirtualRobot(const std::string& name, const calibration::RobotModel& model,
                              unsigned seed) {
  for (const auto& e : kRobots) {
    if (name != e.name) continue;
    if (model.num_joints() != e.joints)
      throw std::invalid_argument("virtual robot " + name + ": the model has " +
                                  std::to_string(model.num_joints()) + " joints");
    if (!model.known_mounting()) return e.make(model, seed);
    calibration::RobotModel fitted = model;
    fitted.tool_mounting = calibration::ToolMounting::kFitted;
    VirtualRobot r = e.make(fitted, seed);
    r.model = model;
    r.true_params = KnownMountingTruth(model, r.true_params);
    return r;
  }
  throw std::invalid_argument("no virtual robot " + name);
}

std::vector<std::string> VirtualRobotNames() {
  std::vector<std::string> names;
  for (const auto& e : kRobots) names.push_back(e.name);
  return names;
}

}  // namespace armsig::simulation
