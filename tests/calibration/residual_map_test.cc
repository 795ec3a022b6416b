// The residual map: a cross-validated kernel regression of what the parametric
// model leaves, used only where it helps and only where it has data.
#include "calibration/residual_map.h"

#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <Eigen/QR>
#include <random>

#include "calibration/compensation.h"
#include "calibration/synthetic.h"
#include "test_support.h"

namespace armsig::calibration {
namespace {

constexpr double kMapNoiseMm = 0.02;

Eigen::Isometry3d MapLabBase() {
  Eigen::Isometry3d base = Eigen::Isometry3d::Identity();
  base.translate(Eigen::Vector3d(2500.0, -1200.0, -400.0));
  base.rotate(Eigen::AngleAxisd(0.9, Eigen::Vector3d(0.1, 0.2, 1.0).normalized()));
  return base;
}

// A smooth error no joint-angle term of the models makes (base frame, mm): link bending
// and the like, about 0.3 mm.
Eigen::Vector3d Unmodelled(const Eigen::VectorXd& q) {
  return 0.3 * Eigen::Vector3d(std::sin(q(1)) * std::cos(q(2) + q(3)),
                               std::cos(q(1) - q(2)) * std::sin(q(4)),
                               0.5 * std::sin(q(1) + q(4)) + 0.3 * std::cos(q(0) - q(2)));
}

struct Lab {
  RobotModel model;
  Eigen::VectorXd truth;
  std::vector<MeasuredPose> fit, validation;
};

// Geometric truth (random, every slot), plus `extra` (0 or 1 × Unmodelled) in the
// measurements.
Lab MakeLab(RobotModel model, int fit_count, int validation_count, double extra, unsigned seed,
            double range_rad = 2.5) {
  Lab lab;
  lab.model = std::move(model);
  std::mt19937 rng(seed);
  lab.truth = RandomParameters(lab.model, 0.3, 5e-4, 0.0, rng);
  auto simulate = [&](int count) {
    const auto joints = RandomConfigurations(lab.model, count, rng, range_rad);
    auto poses = SimulatePoses(lab.model, MapLabBase(), lab.truth, joints, kMapNoiseMm, rng);
    for (auto& p : poses)
      p.target_in_world += MapLabBase().linear() * (extra * Unmodelled(p.joints_rad));
    return poses;
  };
  lab.fit = simulate(fit_count);
  lab.validation = simulate(validation_count);
  return lab;
}

EstimationResult FitGeometric(const Lab& lab) {
  EstimationOptions o;
  o.parameters = ParseParameterSpec(lab.model, "geometric");
  return Estimate(lab.model, lab.fit, o);
}

// Mean error distance on the validation poses, with the map where it applies.
double ValidationMean(const Lab& lab, const EstimationResult& r, const ResidualMap* map) {
  std::vector<Eigen::VectorXd> q;
  for (const auto& p : lab.validation) q.push_back(p.joints_rad);
  const auto predicted = PredictPositions(lab.model, r.world_from_base, r.params, map, q);
  double sum = 0.0;
  for (size_t i = 0; i < q.size(); ++i) {
    sum += (predicted[i].position_mm - lab.validation[i].target_in_world).norm();
  }
  return sum / static_cast<double>(q.size());
}

// Scaled features of a configuration (sin, cos per feature joint), written out.
Eigen::VectorXd FeaturesOf(const ResidualMapData& d, const double* angle_of_feature_joint) {
  Eigen::VectorXd u(2 * d.joints.size());
  for (size_t k = 0; k < d.joints.size(); ++k) {
    u(2 * k) = d.feature_scale[2 * k] * std::sin(angle_of_feature_joint[k]);
    u(2 * k + 1) = d.feature_scale[2 * k + 1] * std::cos(angle_of_feature_joint[k]);
  }
  return u;
}

// The Gaussian kernel between a configuration and a centre.
double Kernel(const ResidualMapData& d, const Eigen::VectorXd& q, const std::vector<double>& c) {
  std::vector<double> a;
  for (int j : d.joints) a.push_back(q(j));
  const double d2 = (FeaturesOf(d, a.data()) - FeaturesOf(d, c.data())).squaredNorm();
  return std::exp(-d2 / (2.0 * d.length_scale * d.length_scale));
}

}  // namespace

TEST(ResidualMap, GeometricOnlyRobotLeavesTheMapOff) {
  RobotModel model = testing::Ur10();
  model.nongeometric.clear();
  const Lab lab = MakeLab(model, 400, 10, 0.0, 1);
  const auto r = FitGeometric(lab);
  ASSERT_TRUE(r.status.ok()) << r.status.message;
  const auto fit = FitResidualMap(lab.model, r, lab.fit);
  EXPECT_FALSE(fit.used) << fit.decision;
  // Both figures reported: the noise floor (0.032 mm for 3-D N(0, 0.02²)), and no gain.
  EXPECT_NEAR(fit.cv_mean_mm_parametric, 0.032, 0.004);
  EXPECT_GT(fit.cv_mean_mm_with_map, 0.98 * fit.cv_mean_mm_parametric);
  EXPECT_GE(fit.grid.size(), 5u);             // the search looked around
  EXPECT_FALSE(fit.map.centres_rad.empty());  // fitted and reported even when not used
}

// A stop request ends the map's fit at its next cross-validation with core::Stopped.
TEST(ResidualMap, AStopRequestEndsTheFit) {
  RobotModel model = testing::Ur10();
  model.nongeometric.clear();
  const Lab lab = MakeLab(model, 200, 10, 0.0, 1);
  const auto r = FitGeometric(lab);
  ASSERT_TRUE(r.status.ok()) << r.status.message;
  std::atomic<bool> stop{true};
  ResidualMapOptions o;
  o.stop = core::StopToken(&stop);
  EXPECT_THROW(FitResidualMap(lab.model, r, lab.fit, o), core::Stopped);
  stop = false;
  EXPECT_FALSE(FitResidualMap(lab.model, r, lab.fit, o).grid.empty());
}

TEST(ResidualMap, LearnsASmoothErrorTheParametricModelCannotMake) {
  RobotModel model = testing::Ur10();
  model.nongeometric.clear();
  const Lab lab = MakeLab(model, 600, 300, 1.0, 2);
  const auto r = FitGeometric(lab);
  ASSERT_TRUE(r.status.ok()) << r.status.message;
  const auto fit = FitResidualMap(lab.model, r, lab.fit);
  ASSERT_TRUE(fit.used) << fit.decision;
  EXPECT_LT(fit.cv_mean_mm_with_map, 0.7 * fit.cv_mean_mm_parametric);
  const ResidualMap map(fit.map);
  EXPECT_EQ(fit.map.joints, (std::vector<int>{0, 1, 2, 3, 4}));  // joint 6 moves no probe
  const double parametric = ValidationMean(lab, r, nullptr);
  const double mapped = ValidationMean(lab, r, &map);
  // On poses never used: the map removes most of the unmodelled 0.3 mm, and the CV figure
  // predicted the held-out one.
  EXPECT_LT(mapped, 0.6 * parametric);
  EXPECT_NEAR(mapped, fit.cv_mean_mm_with_map, 0.25 * fit.cv_mean_mm_with_map);
  EXPECT_NEAR(parametric, fit.cv_mean_mm_parametric, 0.15 * fit.cv_mean_mm_parametric);
}

TEST(ResidualMap, IsKernelRidgeRegressionAndItsGaussianProcessVariance) {
  for (int fit_count : {30, 90}) {
    const Lab lab = MakeLab(testing::Puma(), fit_count, 8, 1.0, 3);
    const auto r = FitGeometric(lab);
    ASSERT_TRUE(r.status.ok()) << r.status.message;
    const auto fit = FitResidualMap(lab.model, r, lab.fit);
    const ResidualMapData& d = fit.map;
    ASSERT_EQ(d.centres_rad.size(), lab.fit.size());  // every fit pose is a centre
    const int m = static_cast<int>(lab.fit.size());
    // Written out: K, the corrections Y (base frame), α = (K + λI)⁻¹ Y.
    Eigen::MatrixXd k(m, m);
    for (int i = 0; i < m; ++i)
      for (int c = 0; c < m; ++c) k(i, c) = Kernel(d, lab.fit[i].joints_rad, d.centres_rad[c]);
    Eigen::MatrixXd y(m, 3);
    for (int i = 0; i < m; ++i) {
      y.row(i) = -(r.world_from_base.linear().transpose() * r.fit_residuals[i]).transpose();
    }
    const Eigen::LDLT<Eigen::MatrixXd> regularised(k + d.regularisation *
                                                           Eigen::MatrixXd::Identity(m, m));
    const Eigen::MatrixXd alpha = regularised.solve(y);
    const ResidualMap map(d);
    const double s2 = d.noise_sigma_mm * d.noise_sigma_mm / d.regularisation;  // prior amplitude
    ASSERT_GT(s2, 0.0);
    int compared = 0;
    for (const auto& p : lab.validation) {
      Eigen::VectorXd kx(m);
      for (int c = 0; c < m; ++c) kx(c) = Kernel(d, p.joints_rad, d.centres_rad[c]);
      const MapPrediction got = map.Predict(p.joints_rad.data());
      const double gp_sigma = std::sqrt(s2 * (1.0 - kx.dot(regularised.solve(kx))));
      const double local_sigma = map.CorrectionSigmaMm(p.joints_rad.data());
      if (m <= 32) {
        // Conditioned on every centre: the exact posterior.
        EXPECT_NEAR(local_sigma, gp_sigma, 1e-9 * std::sqrt(s2));
      } else {
        // On the 32 nearest only: never surer than the exact posterior, and close to it.
        EXPECT_GE(local_sigma, gp_sigma - 1e-9);
        EXPECT_LT(local_sigma, gp_sigma + 0.1 * std::sqrt(s2));
      }
      if (!got.supported) continue;
      const Eigen::Vector3d expected = alpha.transpose() * kx;
      EXPECT_LT((got.correction_in_base_mm - expected).norm(), 1e-9 * (1 + expected.norm()));
      ++compared;
    }
    EXPECT_GE(compared, 4);
    // Near a fit pose the GP is surer than its prior.
    EXPECT_LT(map.CorrectionSigmaMm(lab.fit[0].joints_rad.data()), 0.9 * std::sqrt(s2));
  }
}

TEST(ResidualMap, CrossValidatedFiguresMatchABruteForceComputation) {
  const Lab lab = MakeLab(testing::Puma(), 80, 1, 1.0, 4);
  const auto r = FitGeometric(lab);
  ASSERT_TRUE(r.status.ok()) << r.status.message;
  ResidualMapOptions options;
  const auto fit = FitResidualMap(lab.model, r, lab.fit, options);
  const ResidualMapData& d = fit.map;
  const int m = static_cast<int>(lab.fit.size());
  ASSERT_EQ(static_cast<int>(d.centres_rad.size()), m);
  // The chosen point is the best evaluated, and no grid neighbour of it is better.
  double best = INFINITY;
  for (const auto& g : fit.grid) best = std::min(best, g.cv_mean_mm);
  EXPECT_EQ(fit.cv_mean_mm_with_map, best);
  EXPECT_GE(fit.grid.size(), 5u);
  // Brute force at the chosen (ℓ, λ): per fold, the parametric least squares on the
  // training rows (QR), then kernel ridge regression on the training poses.
  const std::vector<int>& subset = r.identifiability.identified;
  Eigen::MatrixXd j(3 * m, subset.size());
  Eigen::VectorXd res(3 * m);
  Kinematics kin(lab.model);
  Eigen::Matrix<double, 3, Eigen::Dynamic> block(3, lab.model.num_parameters());
  for (int i = 0; i < m; ++i) {
    res.segment<3>(3 * i) =
        kin.PositionAndJacobian(r.world_from_base, r.params, lab.fit[i].joints_rad.data(), block) -
        lab.fit[i].target_in_world;
    for (size_t c = 0; c < subset.size(); ++c) j.block<3, 1>(3 * i, c) = block.col(subset[c]);
  }
  const Eigen::Matrix3d rot = r.world_from_base.linear();
  const auto folds = AssignFolds(m, options.folds, options.seed);
  double parametric = 0.0, mapped = 0.0;
  for (int f = 0; f < options.folds; ++f) {
    std::vector<int> train, test;
    for (int i = 0; i < m; ++i) (folds[i] == f ? test : train).push_back(i);
    Eigen::MatrixXd a(3 * train.size(), subset.size());
    Eigen::VectorXd b(3 * train.size());
    for (size_t t = 0; t < train.size(); ++t) {
      a.middleRows<3>(3 * t) = j.middleRows<3>(3 * train[t]);
      b.segment<3>(3 * t) = -res.segment<3>(3 * train[t]);
    }
    const Eigen::VectorXd refit = res + j * a.colPivHouseholderQr().solve(b);
    const int nt = static_cast<int>(train.size());
    Eigen::MatrixXd ktt(nt, nt), yt(nt, 3);
    for (int t = 0; t < nt; ++t) {
      for (int c = 0; c < nt; ++c) {
        ktt(t, c) = Kernel(d, lab.fit[train[t]].joints_rad, d.centres_rad[train[c]]);
      }
      yt.row(t) = -(rot.transpose() * refit.segment<3>(3 * train[t])).transpose();
    }
    ktt.diagonal().array() += d.regularisation;
    const Eigen::MatrixXd alpha = ktt.ldlt().solve(yt);
    for (int i : test) {
      Eigen::VectorXd kx(nt);
      for (int c = 0; c < nt; ++c)
        kx(c) = Kernel(d, lab.fit[i].joints_rad, d.centres_rad[train[c]]);
      const Eigen::Vector3d e = rot.transpose() * refit.segment<3>(3 * i);
      parametric += e.norm() / m;
      mapped += (e + alpha.transpose() * kx).norm() / m;
    }
  }
  EXPECT_NEAR(fit.cv_mean_mm_parametric, parametric, 1e-9);
  // The search runs in single precision: agreement to ~1e-5 of the figure.
  EXPECT_NEAR(fit.cv_mean_mm_with_map, mapped, 1e-5 * mapped);
}

TEST(ResidualMap, FarConfigurationsGetTheParametricPredictionAndAFlag) {
  RobotModel model = testing::Ur10();
  model.nongeometric.clear();
  // Fit poses within ±1 rad of the null configuration only.
  const Lab lab = MakeLab(model, 500, 400, 1.0, 5, 1.0);
  const auto r = FitGeometric(lab);
  ASSERT_TRUE(r.status.ok()) << r.status.message;
  const auto fit = FitResidualMap(lab.model, r, lab.fit);
  ASSERT_TRUE(fit.used) << fit.decision;
  const ResidualMap map(fit.map);
  // Fresh configurations like the fit poses: almost all inside the support.
  int flagged = 0;
  for (const auto& p : lab.validation) flagged += !map.Predict(p.joints_rad.data()).supported;
  EXPECT_LE(flagged, 8) << "of 400";  // the radius is the 99th percentile × 1.25
  // The shoulder turned far outside what was measured: no correction, and a flag.
  Eigen::VectorXd far = lab.validation[0].joints_rad;
  far(1) = 2.8;
  const MapPrediction p = map.Predict(far.data());
  EXPECT_FALSE(p.supported);
  EXPECT_GT(p.support_distance, fit.map.support_radius);
  EXPECT_EQ(p.correction_in_base_mm, Eigen::Vector3d::Zero());
  const auto positions =
      PredictPositions(lab.model, r.world_from_base, r.params, &map, {far, lab.fit[0].joints_rad});
  EXPECT_TRUE(positions[0].extrapolated);
  EXPECT_FALSE(positions[0].map_applied);
  // What is left is the parametric model at the angles the joint curves correct (the
  // encoder angles when the map has none): the kernel adds nothing there.
  Eigen::VectorXd corrected(far.size());
  map.CorrectJoints(far.data(), corrected.data());
  Kinematics kin(lab.model);
  EXPECT_EQ(positions[0].position_mm, kin.Position(r.world_from_base, r.params, corrected.data()));
  EXPECT_TRUE(positions[1].map_applied);
  EXPECT_GT((positions[1].position_mm - positions[1].parametric_mm).norm(), 0.01);
  // The support distance is the distance to the nearest centre in the scaled features.
  double nearest = INFINITY;
  std::vector<double> a;
  for (int j : fit.map.joints) a.push_back(far(j));
  for (const auto& c : fit.map.centres_rad) {
    nearest =
        std::min(nearest, (FeaturesOf(fit.map, a.data()) - FeaturesOf(fit.map, c.data())).norm());
  }
  EXPECT_NEAR(p.support_distance, nearest, 1e-9);
}

TEST(ResidualMap, JointDerivativeMatchesCentralDifferences) {
  RobotModel model = testing::Ur10();
  model.nongeometric.clear();
  const Lab lab = MakeLab(model, 300, 5, 1.0, 6);
  const auto r = FitGeometric(lab);
  ASSERT_TRUE(r.status.ok()) << r.status.message;
  for (const char* frame : {"base", "joint1"}) {
    ResidualMapOptions options;
    options.output_frame = frame;
    const ResidualMap map(FitResidualMap(lab.model, r, lab.fit, options).map);
    for (const auto& pose : lab.validation) {
      Eigen::Matrix<double, 3, Eigen::Dynamic> analytic(3, 6);
      const MapPrediction p = map.PredictWithJacobian(pose.joints_rad.data(), analytic);
      if (!p.supported) continue;
      EXPECT_LT(
          (p.correction_in_base_mm - map.Predict(pose.joints_rad.data()).correction_in_base_mm)
              .norm(),
          1e-15);
      for (int j = 0; j < 6; ++j) {
        const double h = 1e-6;
        Eigen::VectorXd plus = pose.joints_rad, minus = pose.joints_rad;
        plus(j) += h;
        minus(j) -= h;
        const Eigen::Vector3d numeric = (map.Predict(plus.data()).correction_in_base_mm -
                                         map.Predict(minus.data()).correction_in_base_mm) /
                                        (2 * h);
        EXPECT_LT((analytic.col(j) - numeric).norm(), 1e-6 * std::max(1.0, numeric.norm()))
            << frame << " joint " << j + 1;
      }
    }
  }
}

TEST(ResidualMap, BatchPredictionAgreesWithOneByOne) {
  const Lab lab = MakeLab(testing::Puma(), 200, 600, 1.0, 7, 3.0);
  const auto r = FitGeometric(lab);
  ASSERT_TRUE(r.status.ok()) << r.status.message;
  ResidualMapOptions options;
  options.output_frame = "joint1";
  options.max_training_poses = 120;  // a farthest-point subset of the fit poses trains it
  const ResidualMap map(FitResidualMap(lab.model, r, lab.fit, options).map);
  EXPECT_EQ(map.centres(), 120);
  Eigen::MatrixXd q(6, lab.validation.size());
  for (size_t i = 0; i < lab.validation.size(); ++i) q.col(i) = lab.validation[i].joints_rad;
  Eigen::Matrix3Xd batch;
  std::vector<char> supported;
  map.PredictBatch(q, batch, supported);
  int outside = 0;
  double largest = 0.0;
  for (size_t i = 0; i < lab.validation.size(); ++i) {
    const MapPrediction one = map.Predict(lab.validation[i].joints_rad.data());
    EXPECT_EQ(static_cast<bool>(supported[i]), one.supported);
    // Single precision in the batch: within 10 nm.
    EXPECT_LT((batch.col(i) - one.correction_in_base_mm).norm(), 1e-5);
    largest = std::max(largest, one.correction_in_base_mm.norm());
    outside += !one.supported;
  }
  EXPECT_GT(largest, 0.1);  // the map does something
  EXPECT_LT(outside, 30);
}

TEST(ResidualMap, RefusesInconsistentData) {
  const Lab lab = MakeLab(testing::Puma(), 60, 1, 1.0, 8);
  const auto r = FitGeometric(lab);
  const ResidualMapData good = FitResidualMap(lab.model, r, lab.fit).map;
  EXPECT_NO_THROW(ResidualMap{good});
  auto broken = [&](auto change) {
    ResidualMapData d = good;
    change(d);
    return d;
  };
  EXPECT_THROW(ResidualMap(broken([](auto& d) { d.version = 3; })), std::invalid_argument);
  EXPECT_THROW(ResidualMap(broken([](auto& d) { d.kind = "mlp"; })), std::invalid_argument);
  EXPECT_THROW(ResidualMap(broken([](auto& d) { d.length_scale = 0; })), std::invalid_argument);
  EXPECT_THROW(ResidualMap(broken([](auto& d) { d.weights_mm.pop_back(); })),
               std::invalid_argument);
  EXPECT_THROW(ResidualMap(broken([](auto& d) { d.centres_rad[3].push_back(0.0); })),
               std::invalid_argument);
  EXPECT_THROW(ResidualMap(broken([](auto& d) { d.joints[0] = 6; })), std::invalid_argument);
  EXPECT_THROW(ResidualMap(broken([](auto& d) { d.feature_scale.pop_back(); })),
               std::invalid_argument);
  EXPECT_THROW(ResidualMap(broken([](auto& d) { d.weights_mm[0][1] = NAN; })),
               std::invalid_argument);
  EXPECT_THROW(ResidualMap(broken([](auto& d) { d.output_frame = "tool"; })),
               std::invalid_argument);
}

TEST(ResidualMap, PaperProgressionOnThePumaIsNotMadeWorse) {
  // The demo's robot: Table 3 as truth, 80 fit poses, 0.02 mm noise. With every term the
  // residual is noise and the map stays off; with fewer terms it may only help.
  Lab lab;
  lab.model = testing::Puma();
  lab.truth = PaperTable3Parameters();
  std::mt19937 rng(2);
  lab.fit = SimulatePoses(lab.model, MapLabBase(), lab.truth, RandomConfigurations(lab.model, 80, rng),
                          kMapNoiseMm, rng);
  lab.validation = SimulatePoses(lab.model, MapLabBase(), lab.truth,
                                 RandomConfigurations(lab.model, 200, rng), kMapNoiseMm, rng);
  for (const char* spec : {"geometric", "geometric,h3,h4", "all"}) {
    EstimationOptions o;
    o.parameters = ParseParameterSpec(lab.model, spec);
    const auto r = Estimate(lab.model, lab.fit, o);
    ASSERT_TRUE(r.status.ok()) << r.status.message;
    const auto fit = FitResidualMap(lab.model, r, lab.fit);
    const ResidualMap map(fit.map);
    const double parametric = ValidationMean(lab, r, nullptr);
    const double final_mean = fit.used ? ValidationMean(lab, r, &map) : parametric;
    EXPECT_LE(final_mean, 1.005 * parametric) << spec << ": " << fit.decision;
    if (std::string(spec) == "all") {
      EXPECT_FALSE(fit.used) << fit.decision;
    }
  }
}

TEST(Compensation, SolveJointsWithAMapLandsTheMappedModelOnTheTarget) {
  RobotModel model = testing::Ur10();
  model.nongeometric.clear();
  const Lab lab = MakeLab(model, 400, 10, 1.0, 9);
  const auto r = FitGeometric(lab);
  ASSERT_TRUE(r.status.ok()) << r.status.message;
  const auto fit = FitResidualMap(lab.model, r, lab.fit);
  ASSERT_TRUE(fit.used) << fit.decision;
  const ResidualMap map(fit.map);
  int solved = 0;
  double miss_with = 0.0, miss_without = 0.0;
  for (const auto& pose : lab.validation) {
    if (!map.Predict(pose.joints_rad.data()).supported) continue;
    // The measured point is the target; the nominal angles of the program are the seed.
    const JointSolution with = SolveJoints(lab.model, r.world_from_base, r.params,
                                           pose.target_in_world, pose.joints_rad, {}, &map);
    ASSERT_TRUE(with.status.ok()) << with.status.message;
    EXPECT_FALSE(with.map_extrapolated);
    const auto landed =
        PredictPositions(lab.model, r.world_from_base, r.params, &map, {with.joints_rad})[0];
    EXPECT_TRUE(landed.map_applied);
    EXPECT_LT((landed.position_mm - pose.target_in_world).norm(), 1e-5);
    // Without the map the solution differs by about the map's correction.
    const JointSolution without =
        SolveJoints(lab.model, r.world_from_base, r.params, pose.target_in_world, pose.joints_rad);
    ASSERT_TRUE(without.status.ok());
    EXPECT_GT((with.joints_rad - without.joints_rad).norm(), 1e-6);
    // The mapped model is the better one: the true robot at the joints it chose lands
    // nearer the targets.
    Kinematics truth(lab.model);
    const Eigen::Vector3d true_with = truth.Position(MapLabBase(), lab.truth, with.joints_rad.data()) +
                                      MapLabBase().linear() * Unmodelled(with.joints_rad);
    const Eigen::Vector3d true_without =
        truth.Position(MapLabBase(), lab.truth, without.joints_rad.data()) +
        MapLabBase().linear() * Unmodelled(without.joints_rad);
    miss_with += (true_with - pose.target_in_world).norm();
    miss_without += (true_without - pose.target_in_world).norm();
    ++solved;
  }
  EXPECT_GE(solved, 8);
  EXPECT_LT(miss_with, 0.6 * miss_without);
}

}  // namespace armsig::calibration
