// Does the nightly job's default set make the robot worse on another day's set-up? An
// exploration program (not a benchmark) over the library: series C of the real UR10 fitted
// as the nightly job fits it (the model's own subset, 60 % selected, orientations, the
// residual map), then used on series B: every B pose predicted in the robot frame, one rigid
// frame fitted to all of B's measured positions (the tracker moved), the error distances
// left. Against the nominal model placed the same way, pose by pose (issue 37's rule: no
// pose worse than twice its nominal error plus 1 mm), and C's own held-out poses.
//
// Usage: never_worse_explore [VARIANT …]  (default: all of them)
//   all | auto | geometric, each with "-support" (terms held to the fit poses' joint arcs,
//   as a stored set is used) and/or "-nomap" (the residual map off)
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "calibration/iso9283_figures.h"
#include "calibration/residual_map.h"
#include "io/model_yaml.h"
#include "io/poses_csv.h"
#include "workflows/calibration_run.h"

using namespace armsig;
using namespace armsig::calibration;

namespace {

const std::string kSource = ARMSIG_SOURCE_DIR;

std::vector<Eigen::VectorXd> JointsOf(const std::vector<MeasuredPose>& poses) {
  std::vector<Eigen::VectorXd> q;
  for (const auto& p : poses) q.push_back(p.joints_rad);
  return q;
}

struct FrameFit {
  double mean = 0, max = 0;
  std::vector<double> distance;
};

// Predicted positions (robot frame) rigidly fitted onto the measured ones.
FrameFit PlaceAll(const std::vector<Eigen::Vector3d>& predicted,
                  const std::vector<MeasuredPose>& poses) {
  std::vector<Eigen::Vector3d> measured;
  for (const auto& p : poses) measured.push_back(p.target_in_world);
  const auto a = iso9283::AlignRigidly(measured, predicted);
  FrameFit f;
  f.distance = a->residual_mm;
  for (double d : f.distance) f.mean += d / f.distance.size(), f.max = std::max(f.max, d);
  return f;
}

void Run(const std::string& variant, const RobotModel& model, const std::vector<MeasuredPose>& c,
         const std::vector<MeasuredPose>& b, const FrameFit& nominal) {
  workflows::CalibrateSettings s;
  std::string v = variant;
  const bool nomap = v.ends_with("-nomap");
  if (nomap) v = v.substr(0, v.size() - 6);
  const bool support = v.ends_with("-support");
  if (support) v = v.substr(0, v.size() - 8);
  s.params = v == "geometric" ? "geometric" : v == "all" ? "all" : "auto";
  s.model_subset = true;
  s.residual_model = nomap ? "off" : "auto";
  s.select = static_cast<int>(c.size() * 6 / 10);
  RobotModel used = model;
  const workflows::CalibrationRun run = workflows::RunCalibration(model, c, {}, s);
  if (support) {
    std::vector<MeasuredPose> fit;
    for (const auto& p : c) {
      if (std::find(run.fit_pose_ids.begin(), run.fit_pose_ids.end(), p.id) !=
          run.fit_pose_ids.end())
        fit.push_back(p);
    }
    used.term_support = ArcsCovering(JointsOf(fit), model.num_joints());
  }
  std::unique_ptr<ResidualMap> map;
  if (run.map_used()) map = std::make_unique<ResidualMap>(run.residual_map->map);
  const auto predicted = PredictPositions(used, Eigen::Isometry3d::Identity(), run.estimate.params,
                                          map.get(), JointsOf(b));
  std::vector<Eigen::Vector3d> x;
  int outside = 0, held = 0;
  for (size_t i = 0; i < predicted.size(); ++i) {
    x.push_back(predicted[i].position_mm);
    outside += predicted[i].extrapolated;
    held += !TermsHeldAtSupport(used, b[i].joints_rad.data()).terms.empty();
  }
  const FrameFit f = PlaceAll(x, b);
  int worse = 0;
  for (size_t i = 0; i < f.distance.size(); ++i) {
    worse += f.distance[i] > 2.0 * nominal.distance[i] + 1.0;
  }
  std::string terms;
  const auto names = model.ParameterNames();
  for (int k : run.estimate.identifiability.identified) {
    if (k >= model.num_geometric()) terms += names[k] + " ";
  }
  const auto val = workflows::StatsOf(run.validation_residuals);
  std::printf(
      "%-16s B frame-fit mean %.3f max %.2f mm, %d poses worse than 2*nominal+1, %d outside map, "
      "%d with held terms | C held out %.4f mm | map %s | terms %s\n",
      variant.c_str(), f.mean, f.max, worse, outside, held, val.mean_mm,
      run.map_used() ? "used" : "off", terms.c_str());
  if (run.residual_map) {
    const auto& m = *run.residual_map;
    std::printf("    map: %s\n    transfer (%s): parametric %.4f curves %.4f map %.4f\n",
                m.decision.c_str(), m.transfer_folds.c_str(), m.transfer_mean_mm_parametric,
                m.transfer_mean_mm_curves, m.transfer_mean_mm_with_map);
  }
  if (run.auto_terms) std::printf("    terms chosen on %s\n", run.auto_terms->folds.c_str());
  std::fflush(stdout);
}

}  // namespace

int main(int argc, char** argv) {
  const std::string data = kSource + "/tests/data/ur10-ipa/";
  const RobotModel model = io::LoadRobotModel(kSource + "/models/ur10.yaml");
  auto c = io::ImportPoses(data + "series_C-measurements_random_poses.csv",
                           io::PoseImportOptions::UrIpa());
  auto b = io::ImportPoses(data + "series_B-measurements_joint_configurations.csv",
                           io::PoseImportOptions::UrIpa());
  for (auto& p : c) p.frame = 1;
  std::vector<Eigen::Vector3d> nominal_x;
  const auto nominal_positions =
      PredictPositions(model, Eigen::Isometry3d::Identity(),
                       Eigen::VectorXd::Zero(model.num_parameters()), nullptr, JointsOf(b));
  for (const auto& p : nominal_positions) nominal_x.push_back(p.position_mm);
  const FrameFit nominal = PlaceAll(nominal_x, b);
  std::printf("nominal          B frame-fit mean %.3f max %.2f mm\n", nominal.mean, nominal.max);
  std::vector<std::string> variants;
  for (int i = 1; i < argc; ++i) variants.push_back(argv[i]);
  if (variants.empty()) variants = {"all", "all-support", "auto", "auto-support", "geometric"};
  for (const auto& v : variants) Run(v, model, c, b, nominal);
}
