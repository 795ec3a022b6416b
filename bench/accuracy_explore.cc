// TEMPORARY exploration harness (not committed): design choices on the UR10 fit poses only.
#include <chrono>
#include <cstdio>
#include <fstream>
#include <iostream>

#include "calibration/compensation.h"
#include "calibration/estimation.h"
#include "calibration/residual_map.h"
#include "calibration/terms.h"
#include "io/model_yaml.h"
#include "io/poses_csv.h"

using namespace armsig;
using namespace armsig::calibration;

static double Seconds(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

#include "calibration/synthetic.h"
static int Puma() {
  const std::string src = ARMSIG_SOURCE_DIR;
  RobotModel model = io::LoadRobotModel(src + "/models/puma760.yaml");
  Eigen::Isometry3d base = Eigen::Isometry3d::Identity();
  base.translate(Eigen::Vector3d(2500.0, -1200.0, -400.0));
  base.rotate(Eigen::AngleAxisd(0.9, Eigen::Vector3d(0.1, 0.2, 1.0).normalized()));
  std::mt19937 rng(2);
  auto fit = SimulatePoses(model, base, PaperTable3Parameters(), RandomConfigurations(model, 80, rng), 0.02, rng);
  auto val = SimulatePoses(model, base, PaperTable3Parameters(), RandomConfigurations(model, 200, rng), 0.02, rng);
  for (const char* spec : {"geometric", "geometric,h3,h4", "all"}) {
    EstimationOptions o;
    o.parameters = ParseParameterSpec(model, spec);
    const auto r = Estimate(model, fit, o);
    const auto mf = FitResidualMap(model, r, fit);
    ResidualMap map(mf.map);
    std::vector<Eigen::VectorXd> q;
    for (const auto& p : val) q.push_back(p.joints_rad);
    const auto a = PredictPositions(model, r.world_from_base, r.params, nullptr, q);
    const auto b = PredictPositions(model, r.world_from_base, r.params, &map, q);
    double sa = 0, sb = 0;
    for (size_t i = 0; i < q.size(); ++i) { sa += (a[i].position_mm - val[i].target_in_world).norm(); sb += (b[i].position_mm - val[i].target_in_world).norm(); }
    std::printf("PUMA %s: parametric val %.4f, map used %d (cv %.4f -> %.4f), with map %.4f, final %.4f\n", spec, sa / q.size(), mf.used,
                mf.cv_mean_mm_parametric, mf.cv_mean_mm_with_map, sb / q.size(), mf.used ? sb / q.size() : sa / q.size());
  }
  return 0;
}

int main(int argc, char** argv) {
  if (argc > 1 && std::string(argv[1]) == "puma") return Puma();
  const std::string src = ARMSIG_SOURCE_DIR;
  RobotModel model = io::LoadRobotModel(src + "/models/ur10.yaml");
  model = WithGeneratedTerms(model, {TermFamily::kCompliance, TermFamily::kHarmonics});
  std::printf("parameters %d:", model.num_parameters());
  for (const auto& t : model.nongeometric) std::printf(" %s", t.name.c_str());
  std::printf("\n");
  const auto poses = io::ImportPoses(src + "/tests/data/ur10-ipa/series_C-measurements_random_poses.csv",
                                     io::PoseImportOptions::UrIpa());
  std::ifstream perm_file(src + "/tests/data/ur10-ipa-split/series_C-permutation.txt");
  std::vector<int> perm;
  for (int i; perm_file >> i;) perm.push_back(i);
  const std::string mode = argc > 1 ? argv[1] : "inner";
  int fit_count = argc > 2 ? std::atoi(argv[2]) : 1273;
  std::vector<MeasuredPose> fit, val;
  if (mode == "inner") {
    // Inside the 1773 fit poses only.
    for (int k = 0; k < fit_count; ++k) fit.push_back(poses[perm[k]]);
    for (int k = 1273; k < 1773; ++k) val.push_back(poses[perm[k]]);
  } else if (mode == "seriesB") {
    for (int k = 0; k < fit_count; ++k) fit.push_back(poses[perm[k]]);
    val = io::ImportPoses("/work/shared/data/ur10-ipa/series_B-measurements_joint_configurations.csv",
                          io::PoseImportOptions::UrIpa());
  } else {
    for (int k = 0; k < fit_count; ++k) fit.push_back(poses[perm[k]]);
    for (int k = 1773; k < 2773; ++k) val.push_back(poses[perm[k]]);
  }
  std::printf("fit %zu validation %zu (%s)\n", fit.size(), val.size(), mode.c_str());
  auto t0 = std::chrono::steady_clock::now();
  EstimationOptions geo;
  geo.parameters = ParseParameterSpec(model, "geometric");
  const auto g = Estimate(model, fit, geo);
  auto vg = Summarise(Distances(Residuals(model, g.world_from_base, g.params, val)));
  std::printf("geometric: rank %d fit %.4f val %.4f  (%.2f s)\n", g.identifiability.rank, g.fit.mean_mm,
              vg.mean_mm, Seconds(t0));

  const std::string spec = argc > 3 ? argv[3] : "all";
  EstimationOptions all;
  all.parameters = ParseParameterSpec(model, spec);
  t0 = std::chrono::steady_clock::now();
  TermSelectionOptions tso;
  if (argc > 4) tso.min_cv_gain = std::atof(argv[4]);
  const auto sel = SelectTerms(model, fit, all, tso);
  std::printf("selection %.2f s: cv geometric %.4f -> %.4f\n", Seconds(t0), sel.cv_mean_mm_geometric,
              sel.cv_mean_mm);
  for (const auto& t : sel.tests)
    if (t.accepted) std::printf("  + %s F %.1f p %.2g cv %.4f\n", t.added.c_str(), t.f, t.p_value, t.cv_mean_mm);
  EstimationOptions chosen;
  chosen.parameters = sel.parameters;
  const auto e = Estimate(model, fit, chosen);
  auto ve = Summarise(Distances(Residuals(model, e.world_from_base, e.params, val)));
  for (int k : sel.parameters) if (k >= model.num_geometric()) std::printf("  %s = %.3e +- %.1e\n", model.ParameterNames()[k].c_str(), e.params(k), e.sigmas(k));
  std::printf("terms: rank %d fit %.4f val %.4f max %.3f (geometric max %.3f)\n", e.identifiability.rank, e.fit.mean_mm, ve.mean_mm, ve.max_mm, vg.max_mm);

  const std::string frame = argc > 5 ? argv[5] : "base";
  for (auto scaling : {FeatureScaling::kStandardised, FeatureScaling::kUnit}) {
    ResidualMapOptions mo;
    mo.output_frame = frame;
    mo.scaling = scaling;
    if (scaling == FeatureScaling::kUnit) mo.length_scales = {0.05, 0.07, 0.1, 0.15, 0.2, 0.25, 0.35, 0.5};
    t0 = std::chrono::steady_clock::now();
    const auto mf = FitResidualMap(model, e, fit, mo);
    const double secs = Seconds(t0);
    ResidualMap map(mf.map);
    std::vector<Eigen::VectorXd> q;
    for (const auto& p : val) q.push_back(p.joints_rad);
    t0 = std::chrono::steady_clock::now();
    const auto pred = PredictPositions(model, e.world_from_base, e.params, &map, q, true);
    const double psecs = Seconds(t0);
    double sum = 0;
    int flagged = 0;
    for (size_t i = 0; i < val.size(); ++i) {
      sum += (pred[i].position_mm - val[i].target_in_world).norm();
      flagged += pred[i].extrapolated;
    }
    double worst = 0;
    for (size_t i = 0; i < val.size(); ++i) worst = std::max(worst, (pred[i].position_mm - val[i].target_in_world).norm());
    std::printf("  max with map %.3f\n", worst);
    std::printf("map %s %s: %.2f s cv %.4f -> %.4f (l %.2f lambda %.0e) used %d val %.4f flagged %d radius %.3f predict %.1f us/pose\n",
                scaling == FeatureScaling::kUnit ? "unit" : "std", frame.c_str(), secs, mf.cv_mean_mm_parametric, mf.cv_mean_mm_with_map,
                mf.map.length_scale, mf.map.regularisation, mf.used, sum / val.size(), flagged,
                mf.map.support_radius, psecs / val.size() * 1e6);
    double z2 = 0, sig = 0;
    for (size_t i = 0; i < val.size(); ++i) {
      const double s2 = pred[i].sigma_mm * pred[i].sigma_mm + mf.map.noise_sigma_mm * mf.map.noise_sigma_mm;
      z2 += (pred[i].position_mm - val[i].target_in_world).squaredNorm() / s2 / 3;
      sig += pred[i].sigma_mm;
    }
    if (mode == "seriesB") {
      // Base re-aligned on B with the calibrated parametric model (6 dof from B).
      const auto base_b = AlignBaseWithParams(model, e.params, val);
      const auto par_b = Summarise(Distances(Residuals(model, *base_b, e.params, val)));
      const auto pb = PredictPositions(model, *base_b, e.params, &map, q, false);
      double sb = 0; int fb = 0;
      for (size_t i = 0; i < val.size(); ++i) { sb += (pb[i].position_mm - val[i].target_in_world).norm(); fb += pb[i].extrapolated; }
      std::printf("  series B, base realigned: parametric %.4f with map %.4f flagged %d\n", par_b.mean_mm, sb / val.size(), fb);
    }
    std::printf("  noise sigma %.4f mean map sigma %.4f  rms z %.3f\n", mf.map.noise_sigma_mm, sig / val.size(), std::sqrt(z2 / val.size()));
    if (getenv("GRID")) for (const auto& p : mf.grid) std::printf("   l %.2f lam %.0e cv %.4f\n", p.length_scale, p.regularisation, p.cv_mean_mm);
  }
  return 0;
}
