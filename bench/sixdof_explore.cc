// What does the measured orientation give? An exploration program (not a benchmark): a
// prototype of the six-degree-of-freedom fit built from the library's pieces (the
// kinematics' pose Jacobian, the identifiability analysis, the base alignment, the residual
// map), measured on the UR10 data:
//   - on an inner split of series C's fit poses (the first 1,273 of the fixed permutation
//     fitted, the next 500 validated: the held-out 1,000 are not looked at), the position and
//     angle errors of position-only and 6-DoF fits under several weightings;
//   - on series B, the set-up placed from a few B poses with and without their orientation.
//
// Usage: sixdof_explore inner|split|transfer [SERIES_B.csv]
#include <Eigen/Cholesky>
#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include "calibration/compensation.h"
#include "calibration/estimation.h"
#include "calibration/identifiability.h"
#include "calibration/orientation.h"
#include "calibration/residual_map.h"
#include "core/rotation.h"
#include "io/model_yaml.h"
#include "io/poses_csv.h"

using namespace armsig;
using namespace armsig::calibration;

namespace {

const std::string kSource = ARMSIG_SOURCE_DIR;
constexpr double kDegree = 3.14159265358979323846 / 180.0;

// A 6-DoF fit: the parameters, the reference base (held: joint 1 absorbs it), the target
// frame's rotation in the last link frame, and the weights found.
struct Fit6 {
  EstimationResult result;  // params, base, identifiability, position residuals
  Eigen::Matrix3d tool_rotation = Eigen::Matrix3d::Identity();
  double weight_mm_per_rad = 0.0;  // √w: orientation rows in mm-equivalent
  double sigma_position_mm = 0.0, sigma_orientation_rad = 0.0;
  int rank = 0;
};

struct Fit6Options {
  std::vector<int> parameters;
  // ≤ 0: variance components (the weight follows the groups' a-posteriori sigmas);
  // > 0: this fixed weight (mm per rad).
  double weight_mm_per_rad = 0.0;
  bool orientation = true;  // false: the position-only fit (the library's Estimate)
  int vce_rounds = 4;
};

Fit6 FitSixDof(const RobotModel& model, const std::vector<MeasuredPose>& poses, const Fit6Options& o) {
  Fit6 out;
  EstimationOptions eo;
  eo.parameters = o.parameters;
  eo.use_orientation = o.orientation;
  eo.orientation_weight_mm_per_rad = o.weight_mm_per_rad;
  out.result = Estimate(model, poses, eo);
  out.rank = out.result.identifiability.rank;
  if (const Eigen::Matrix3d* tool = out.result.tool_rotation_of(out.result.reference_frame)) {
    out.tool_rotation = *tool;
  }
  out.weight_mm_per_rad = out.result.orientation_weight_mm_per_rad;
  out.sigma_position_mm = out.result.sigma0_mm;
  out.sigma_orientation_rad = out.result.sigma0_rad;
  return out;
}

struct Held {
  double position_mm = 0, angle_deg = 0;
};
Held Evaluate(const RobotModel& model, const Eigen::Isometry3d& base, const Eigen::VectorXd& params,
              const Eigen::Matrix3d* tool, const ResidualMap* map, const std::vector<MeasuredPose>& poses) {
  std::vector<Eigen::VectorXd> q;
  for (const auto& p : poses) q.push_back(p.joints_rad);
  const auto predicted = PredictPositions(model, base, params, map, q);
  Kinematics kin(model);
  Held h;
  for (size_t i = 0; i < poses.size(); ++i) {
    h.position_mm += (predicted[i].position_mm - poses[i].target_in_world).norm() / poses.size();
    if (tool) {
      kin.Position(base, params, poses[i].joints_rad.data());
      h.angle_deg += Eigen::AngleAxisd(poses[i].orientation->world_from_target.transpose() *
                                       kin.LastRotation() * *tool)
                         .angle() /
                     kDegree / poses.size();
    }
  }
  return h;
}

std::vector<MeasuredPose> LoadC() {
  return io::ImportPoses(kSource + "/tests/data/ur10-ipa/series_C-measurements_random_poses.csv",
                         io::PoseImportOptions::UrIpa());
}

std::vector<int> Permutation() {
  std::ifstream file(kSource + "/tests/data/ur10-ipa-split/series_C-permutation.txt");
  std::vector<int> p;
  for (int i; file >> i;) p.push_back(i);
  return p;
}

int Split(bool inner) {
  const RobotModel model = io::LoadRobotModel(kSource + "/models/ur10.yaml");
  const auto c = LoadC();
  const auto perm = Permutation();
  std::vector<MeasuredPose> fit, val;
  const int fit_count = inner ? 1273 : 1773;
  for (int k = 0; k < fit_count; ++k) fit.push_back(c[perm[k]]);
  for (int k = fit_count; k < (inner ? 1773 : 2773); ++k) val.push_back(c[perm[k]]);
  std::printf("%s: fit %zu, validate %zu\n", inner ? "inner split of the fit poses" : "the split", fit.size(),
              val.size());
  std::vector<MeasuredPose> fit_positions = fit;
  for (auto& p : fit_positions) p.orientation.reset();
  EstimationOptions all;
  all.parameters = ParseParameterSpec(model, "all");
  const auto auto_terms = SelectTerms(model, fit_positions, all).parameters;
  std::printf("auto terms (position-only selection):");
  for (int p : auto_terms) if (p >= model.num_geometric()) std::printf(" %s", model.ParameterNames()[p].c_str());
  std::printf("\n");
  struct Variant {
    const char* name;
    bool orientation;
    double weight;
  };
  const Variant variants[] = {{"position only", false, 0},   {"6-DoF, VCE", true, 0},
                              {"6-DoF, w 100", true, 100},   {"6-DoF, w 300", true, 300},
                              {"6-DoF, w 1000", true, 1000}, {"6-DoF, w 3000", true, 3000}};
  for (const char* spec : {"geometric", "auto"}) {
    for (const auto& v : variants) {
      Fit6Options o;
      o.parameters = std::string(spec) == "auto" ? auto_terms : ParseParameterSpec(model, "geometric");
      o.orientation = v.orientation;
      o.weight_mm_per_rad = v.weight;
      const Fit6 f = FitSixDof(model, v.orientation ? fit : fit_positions, o);
      Eigen::Matrix3d tool = f.tool_rotation;
      if (!v.orientation) {
        // The tool rotation of a position-only fit: the mean of what the fit poses measure.
        std::vector<Eigen::Matrix3d> rel;
        Kinematics kin(model);
        for (const auto& p : fit) {
          kin.Position(f.result.world_from_base, f.result.params, p.joints_rad.data());
          rel.push_back(kin.LastRotation().transpose() * p.orientation->world_from_target);
        }
        tool = MeanRotation(rel);
      }
      const Held h = Evaluate(model, f.result.world_from_base, f.result.params, &tool, nullptr, val);
      const Held hf = Evaluate(model, f.result.world_from_base, f.result.params, &tool, nullptr, fit);
      std::string map_text;
      if (true) {
        EstimationResult er = f.result;
        if (!v.orientation) er = f.result;
        const auto mf = FitResidualMap(model, er, fit_positions);
        if (mf.used) {
          const ResidualMap map(mf.map);
          const Held hm = Evaluate(model, f.result.world_from_base, f.result.params, nullptr, &map, val);
          char buffer[96];
          std::snprintf(buffer, sizeof buffer, " map: cv %.3f → %.3f, validation %.3f", mf.cv_mean_mm_parametric,
                        mf.cv_mean_mm_with_map, hm.position_mm);
          map_text = buffer;
        } else {
          map_text = " map not used";
        }
      }
      std::printf("%-9s %-15s rank %2d  fit %.3f mm %.4f°  validation %.3f mm %.4f°  (w %.0f mm/rad, σp %.3f mm, σo %.4f°)%s\n",
                  spec, v.name, f.rank, hf.position_mm, hf.angle_deg, h.position_mm, h.angle_deg,
                  f.weight_mm_per_rad, f.sigma_position_mm, f.sigma_orientation_rad / kDegree, map_text.c_str());
      std::fflush(stdout);
    }
  }
  return 0;
}

// Fitted on all of C, used on B placed from a few of its poses, with and without their
// orientations: the signature folded into the model (its corrected model), then the first
// joint's six parameters — the base — refitted on the placing poses (and, with
// orientations, the probe's rotation on the flange).
int Transfer(const std::string& b_path) {
  const RobotModel model = io::LoadRobotModel(kSource + "/models/ur10.yaml");
  const auto c = LoadC();
  const auto b = io::ImportPoses(b_path, io::PoseImportOptions::UrIpa());
  std::vector<MeasuredPose> c_positions = c;
  for (auto& p : c_positions) p.orientation.reset();
  EstimationOptions all;
  all.parameters = ParseParameterSpec(model, "all");
  const auto auto_terms = SelectTerms(model, c_positions, all).parameters;
  const int n = static_cast<int>(b.size());
  for (const char* spec : {"geometric", "auto"}) {
    for (bool six : {false, true}) {
      Fit6Options o;
      o.parameters = std::string(spec) == "auto" ? auto_terms : ParseParameterSpec(model, "geometric");
      o.orientation = six;
      const Fit6 f = FitSixDof(model, six ? c : c_positions, o);
      RobotModel corrected = CorrectedModel(model, f.result.params, f.result.world_from_base);
      corrected.base.reset();
      std::printf("%s fitted on C %s (w %.0f):", spec, six ? "6-DoF" : "positions only",
                  f.weight_mm_per_rad);
      for (int k : f.result.identifiability.identified) {
        if (k >= model.num_geometric() || k % 6 >= 3 || k >= 6 * model.num_joints())
          std::printf(" %s %.3g", model.ParameterNames()[k].c_str(), f.result.params(k));
      }
      std::printf("\n");
      for (int count : {30, 10}) {
        for (int layout = 0; layout < 2; ++layout) {
          std::vector<char> in(n, 0);
          for (int k = 0; k < count; ++k) {
            in[layout == 0 ? k : static_cast<int>((k + 0.5) * n / count)] = 1;
          }
          std::vector<MeasuredPose> place, rest;
          for (int i = 0; i < n; ++i) (in[i] ? place : rest).push_back(b[i]);
          EstimationOptions po;
          po.parameters = ParseParameterSpec(corrected, "a1,b1,c1,alpha1,beta1,gamma1");
          Held h[2];
          for (int with : {0, 1}) {
            po.use_orientation = with == 1;
            const auto r = Estimate(corrected, place, po);
            const Eigen::Matrix3d* tool = r.tool_rotation_of(r.reference_frame);
            h[with] = Evaluate(corrected, r.world_from_base, r.params, tool, nullptr, rest);
          }
          std::printf("   %s %d placing: positions %.3f mm; with orientations %.3f mm (%.4f°)\n",
                      layout == 0 ? "first" : "spread", count, h[0].position_mm, h[1].position_mm,
                      h[1].angle_deg);
          std::fflush(stdout);
        }
      }
    }
  }
  return 0;
}

// What the orientation residuals of a 6-DoF fit on all of C look like: their rms per
// component in the target frame (z: about the probe's axis, the joint-6 axis), and how the
// component about that axis follows joint 6's angle (first and second harmonics).
int Components() {
  const RobotModel model = io::LoadRobotModel(kSource + "/models/ur10.yaml");
  const auto c = LoadC();
  for (const char* spec : {"geometric", "all"}) {
    EstimationOptions o;
    o.parameters = ParseParameterSpec(model, spec);
    if (std::string(spec) == "all") {
      std::vector<MeasuredPose> positions = c;
      for (auto& p : positions) p.orientation.reset();
      o.parameters = SelectTerms(model, positions, o).parameters;
    }
    const auto r = Estimate(model, c, o);
    Eigen::Vector3d sum_sq = Eigen::Vector3d::Zero();
    Eigen::MatrixXd a(c.size(), 5);
    Eigen::VectorXd z(c.size());
    for (size_t i = 0; i < c.size(); ++i) {
      const Eigen::Vector3d e = *r.fit_orientation_residuals[i];
      sum_sq += e.cwiseAbs2() / c.size();
      const double q6 = c[i].joints_rad(5);
      a.row(i) << 1, std::sin(q6), std::cos(q6), std::sin(2 * q6), std::cos(2 * q6);
      z(i) = e.z();
    }
    const Eigen::VectorXd coef = a.colPivHouseholderQr().solve(z);
    const double explained = 1.0 - (z - a * coef).squaredNorm() / (z.array() - z.mean()).square().sum();
    std::printf("%s (%s): orientation residual rms per component (target frame) %.4f %.4f %.4f deg;\n"
                "  about the probe axis vs q6: harmonics explain %.0f %% (amplitudes s1 %.4f c1 %.4f s2 %.4f c2 %.4f deg)\n",
                spec, std::string(spec) == "all" ? "auto terms" : "39",
                std::sqrt(sum_sq.x()) / kDegree, std::sqrt(sum_sq.y()) / kDegree, std::sqrt(sum_sq.z()) / kDegree,
                100 * explained, coef(1) / kDegree, coef(2) / kDegree, coef(3) / kDegree, coef(4) / kDegree);
  }
  return 0;
}

// Does the error drift with time? The rows of series C are in measuring order (its time
// stamps were damaged, the order was not): the residuals of one fit on all of C, averaged
// over windows of 100 consecutive rows, and against the logged temperature.
int Drift() {
  const RobotModel model = io::LoadRobotModel(kSource + "/models/ur10.yaml");
  auto c = LoadC();
  for (auto& p : c) p.orientation.reset();
  EstimationOptions o;
  o.parameters = ParseParameterSpec(model, "geometric");
  const auto r = Estimate(model, c, o);
  const Eigen::Matrix3d to_base = r.world_from_base.linear().transpose();
  std::printf("geometric fit on all of C: mean %.3f mm, σ0 %.3f mm\n", r.fit.mean_mm, r.sigma0_mm);
  const int window = 100;
  for (size_t start = 0; start < c.size(); start += window) {
    const size_t end = std::min(c.size(), start + window);
    Eigen::Vector3d mean = Eigen::Vector3d::Zero();
    double distance = 0;
    for (size_t i = start; i < end; ++i) {
      mean += to_base * r.fit_residuals[i] / (end - start);
      distance += r.fit_residuals[i].norm() / (end - start);
    }
    std::printf("  rows %4zu-%4zu: mean residual (base) %+.3f %+.3f %+.3f (|%.3f|), mean distance %.3f\n", start,
                end - 1, mean.x(), mean.y(), mean.z(), mean.norm(), distance);
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  const std::string mode = argc > 1 ? argv[1] : "inner";
  if (mode == "inner" || mode == "split") return Split(mode == "inner");
  if (mode == "drift") return Drift();
  if (mode == "components") return Components();
  if (mode == "transfer" || mode == "params")
    return Transfer(argc > 2 ? argv[2]
                             : "/work/shared/data/ur10-ipa/series_B-measurements_joint_configurations.csv");
  std::fprintf(stderr, "usage: sixdof_explore inner|split\n");
  return 2;
}
