#include "calibration/drift.h"

#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <Eigen/Geometry>
#include <random>

#include "calibration/estimation.h"
#include "calibration/identifiability.h"
#include "calibration/synthetic.h"
#include "test_support.h"

namespace armsig::calibration {
namespace {

constexpr double kDriftNoiseMm = 0.02;

Eigen::Isometry3d Base(double angle, double x) {
  Eigen::Isometry3d base = Eigen::Isometry3d::Identity();
  base.translate(Eigen::Vector3d(x, -1500.0, -700.0));
  base.rotate(Eigen::AngleAxisd(angle, Eigen::Vector3d::UnitZ()));
  return base;
}

// One night: new configurations, new noise, the lab's frame somewhere else.
FittedSet Night(const RobotModel& model, const Eigen::VectorXd& truth,
                const std::vector<int>& subset, unsigned seed) {
  std::mt19937 rng(seed);
  const auto poses = SimulatePoses(model, Base(0.3 * seed, 2500.0 + 10.0 * seed), truth,
                                   RandomConfigurations(model, 80, rng), kDriftNoiseMm, rng);
  EstimationOptions options;
  options.parameters = subset;
  const auto r = Estimate(model, poses, options);
  EXPECT_TRUE(r.usable());
  return {r.params, r.identifiability.identified, r.covariance};
}

std::vector<int> All(const RobotModel& model) {
  std::vector<int> all(model.num_parameters());
  for (int i = 0; i < model.num_parameters(); ++i) all[i] = i;
  return all;
}

}  // namespace

TEST(ModelIdentifiableSubset, IsDecidedByTheModelAlone) {
  const auto model = testing::Puma();
  const auto subset = ModelIdentifiableSubset(model, All(model));
  EXPECT_EQ(subset, ModelIdentifiableSubset(model, All(model)));
  // The same rank as an independent analysis on many random configurations.
  std::mt19937 rng(3);
  const auto joints = RandomConfigurations(model, 400, rng);
  const auto report =
      AnalyseJacobian(StackedJacobian(model, Eigen::Isometry3d::Identity(),
                                      Eigen::VectorXd::Zero(model.num_parameters()), joints),
                      All(model));
  EXPECT_EQ(static_cast<int>(subset.size()), report.rank);
  // Every night's fit of the same robot then estimates exactly these parameters.
  const Eigen::VectorXd truth = PaperTable3Parameters();
  for (unsigned night = 1; night <= 3; ++night)
    EXPECT_EQ(Night(model, truth, subset, night).identified, subset);
}

// The profile a drift figure draws. Its distances are those of an independent computation
// (the templated kinematics of both sets, b's positions aligned onto a's with Eigen's
// Umeyama); its sigma at the worst configuration is the scatter of |Δx| there when both
// sets are drawn from their covariances and aligned anew each time (Monte Carlo, 3000
// draws: the sample's own standard error is about 1.3 %).
TEST(ProfileDifference, DistancesAndSigmasMatchKinematicsAndMonteCarlo) {
  const auto model = testing::Puma();
  const auto subset = ModelIdentifiableSubset(model, All(model));
  Eigen::VectorXd changed = PaperTable3Parameters();
  changed(6 * 1 + 5) += 2e-4;  // joint 2's zero, 0.2 mrad: a change of tenths of a mm
  const FittedSet a = Night(model, PaperTable3Parameters(), subset, 1);
  const FittedSet b = Night(model, changed, subset, 2);
  const auto configurations = SpreadConfigurations(model, 50);
  const DifferenceProfile profile = ProfileDifference(model, a, b, configurations);
  ASSERT_EQ(profile.distance_mm.size(), configurations.size());
  ASSERT_EQ(profile.sigma_mm.size(), configurations.size());

  // The model's kinematics as the library compiles them (the Monte Carlo below evaluates them
  // 300,000 times: a copy instantiated here would run unoptimised).
  Kinematics kin(model);
  auto positions = [&](const Eigen::VectorXd& params) {
    Eigen::Matrix3Xd x(3, configurations.size());
    for (size_t i = 0; i < configurations.size(); ++i)
      x.col(i) = kin.Position(Eigen::Isometry3d::Identity(), params, configurations[i].data());
    return x;
  };
  auto aligned_difference = [&](const Eigen::VectorXd& pa, const Eigen::VectorXd& pb) {
    const Eigen::Matrix3Xd xa = positions(pa), xb = positions(pb);
    const Eigen::Matrix4d t = Eigen::umeyama(xb, xa, false);
    return Eigen::Matrix3Xd(
        ((t.topLeftCorner<3, 3>() * xb).colwise() + Eigen::Vector3d(t.topRightCorner<3, 1>())) -
        xa);
  };
  const Eigen::Matrix3Xd delta = aligned_difference(a.params, b.params);
  int worst = 0;
  for (int i = 0; i < delta.cols(); ++i) {
    EXPECT_NEAR(profile.distance_mm[i], delta.col(i).norm(), 1e-9) << i;
    if (delta.col(i).norm() > delta.col(worst).norm()) worst = i;
  }
  EXPECT_EQ(profile.worst, worst);
  EXPECT_GT(profile.distance_mm[worst], 0.1);  // the planted change, well above the noise

  // Monte Carlo: both sets drawn from their covariances (on their identified parameters).
  std::mt19937 rng(5);
  std::normal_distribution<double> normal;
  const Eigen::MatrixXd la = Eigen::LLT<Eigen::MatrixXd>(a.covariance).matrixL();
  const Eigen::MatrixXd lb = Eigen::LLT<Eigen::MatrixXd>(b.covariance).matrixL();
  auto draw = [&](const FittedSet& set) {
    const Eigen::MatrixXd& l = &set == &a ? la : lb;
    Eigen::VectorXd z(set.identified.size());
    for (int k = 0; k < z.size(); ++k) z(k) = normal(rng);
    const Eigen::VectorXd step = l * z;
    Eigen::VectorXd p = set.params;
    for (size_t k = 0; k < set.identified.size(); ++k) p(set.identified[k]) += step(k);
    return p;
  };
  const Eigen::Vector3d direction = delta.col(worst).normalized();
  const int draws = 3000;
  double sum = 0.0, sum_sq = 0.0;
  for (int k = 0; k < draws; ++k) {
    const double along = direction.dot(aligned_difference(draw(a), draw(b)).col(worst));
    sum += along;
    sum_sq += along * along;
  }
  const double mc_sigma = std::sqrt((sum_sq - sum * sum / draws) / (draws - 1));
  EXPECT_NEAR(profile.sigma_mm[worst], mc_sigma, 0.06 * mc_sigma)
      << profile.sigma_mm[worst] << " against " << mc_sigma;
  EXPECT_NEAR(sum / draws, profile.distance_mm[worst], 0.2 * profile.sigma_mm[worst]);
}

TEST(CompareModels, IdenticalSetsDoNotDiffer) {
  const auto model = testing::Puma();
  const auto subset = ModelIdentifiableSubset(model, All(model));
  const FittedSet a = Night(model, PaperTable3Parameters(), subset, 1);
  const auto c = CompareModels(model, a, a, SpreadConfigurations(model, 50));
  EXPECT_EQ(c.configurations, 50);
  EXPECT_LT(c.max_mm, 1e-9);
  EXPECT_LT(c.chi2, 1e-9);
  EXPECT_GT(c.dof, 20);
  EXPECT_GT(c.p_value, 0.999);
}

// Only noise between the nights: χ² follows its distribution (mean ≈ dof, a little less
// because the alignment removes rigid motions), and hardly any night looks significant.
TEST(CompareModels, NightsOfTheSameRobotAreNotSignificant) {
  const auto model = testing::Puma();
  const auto subset = ModelIdentifiableSubset(model, All(model));
  const Eigen::VectorXd truth = PaperTable3Parameters();
  const auto configurations = SpreadConfigurations(model, 50);
  const FittedSet first = Night(model, truth, subset, 100);
  double mean_ratio = 0.0;
  int significant = 0;
  const int nights = 20;
  for (int night = 0; night < nights; ++night) {
    const auto c =
        CompareModels(model, first, Night(model, truth, subset, 200 + night), configurations);
    mean_ratio += c.chi2 / c.dof / nights;
    significant += c.p_value < 1e-3;
    EXPECT_LT(c.max_mm, 0.1) << night;  // a few times the 0.02 mm noise at most
  }
  EXPECT_GT(mean_ratio, 0.4);
  EXPECT_LT(mean_ratio, 1.3);
  EXPECT_LE(significant, 1);
}

// Sets stored before the subset was fixed by the model may have identified another,
// aliased subset (the data decided: alpha5 and gamma5 estimated instead of gamma4 and b6).
// Both describe the same arm: nights of the same robot must still not look significant,
// and the comparison has no more degrees of freedom than either subset alone.
TEST(CompareModels, AliasedSubsetsOfTheSameRobotAreNotSignificant) {
  const auto model = testing::Puma();
  const auto subset = ModelIdentifiableSubset(model, All(model));
  const auto names = model.ParameterNames();
  auto index = [&](const std::string& name) {
    return static_cast<int>(std::find(names.begin(), names.end(), name) - names.begin());
  };
  std::vector<int> other = subset;
  for (const char* name : {"gamma4", "b6"}) {
    ASSERT_NE(std::find(other.begin(), other.end(), index(name)), other.end()) << name;
    std::erase(other, index(name));
  }
  for (const char* name : {"alpha5", "gamma5"}) {
    ASSERT_EQ(std::find(other.begin(), other.end(), index(name)), other.end()) << name;
    other.push_back(index(name));
  }
  std::sort(other.begin(), other.end());
  const Eigen::VectorXd truth = PaperTable3Parameters();
  const auto configurations = SpreadConfigurations(model, 50);
  const FittedSet first = Night(model, truth, other, 300);
  ASSERT_EQ(first.identified, other) << "the aliased subset must itself be identifiable";
  int significant = 0;
  for (int night = 0; night < 5; ++night) {
    const auto c =
        CompareModels(model, first, Night(model, truth, subset, 400 + night), configurations);
    EXPECT_LE(c.dof, static_cast<int>(subset.size()) - 6) << night;
    EXPECT_LT(c.chi2 / c.dof, 3.0) << night;
    EXPECT_LT(c.max_mm, 0.1) << night;
    EXPECT_FALSE(c.shared_shape_space);
    significant += c.p_value < 1e-3;
  }
  EXPECT_EQ(significant, 0);
  // A real change is still seen through the shared shape space: 0.2 mm on a3.
  Eigen::VectorXd changed = truth;
  changed(model.IndexOf("a3")) += 0.2;
  const auto c = CompareModels(model, first, Night(model, changed, subset, 500), configurations);
  EXPECT_LT(c.p_value, 1e-9);
  EXPECT_GT(c.max_mm, 0.1);
  // Equal subsets compare on everything.
  EXPECT_TRUE(CompareModels(model, first, first, configurations).shared_shape_space);
}

// A changed robot: 0.2 mm on one link length, or 0.5 mrad on one joint axis.
TEST(CompareModels, PlantedChangesAreSignificantAndSizedInMillimetres) {
  const auto model = testing::Puma();
  const auto subset = ModelIdentifiableSubset(model, All(model));
  const Eigen::VectorXd truth = PaperTable3Parameters();
  const auto configurations = SpreadConfigurations(model, 50);
  const FittedSet before = Night(model, truth, subset, 11);
  Kinematics kin(model);
  for (const auto& [name, change] :
       std::vector<std::pair<std::string, double>>{{"a3", 0.2}, {"beta3", 0.5e-3}}) {
    Eigen::VectorXd changed = truth;
    changed(model.IndexOf(name)) += change;
    // The size of the change at the configurations, independently: largest displacement of
    // the changed robot's positions against the old, before any alignment.
    double largest = 0.0;
    for (const auto& q : configurations) {
      largest = std::max(largest, (kin.Position(Eigen::Isometry3d::Identity(), changed, q.data()) -
                                   kin.Position(Eigen::Isometry3d::Identity(), truth, q.data()))
                                      .norm());
    }
    const auto c = CompareModels(model, before, Night(model, changed, subset, 12), configurations);
    EXPECT_LT(c.p_value, 1e-9) << name;
    EXPECT_GT(c.max_mm, 0.4 * largest) << name;  // alignment may absorb a rigid part
    EXPECT_LT(c.max_mm, largest + 0.05) << name;
    // Named in one gauge: the planted parameter comes first, with its size.
    ASSERT_FALSE(c.parameters.empty());
    EXPECT_EQ(model.ParameterNames()[c.parameters.front().parameter], name);
    EXPECT_NEAR(c.parameters.front().change, change, 0.1 * change) << name;
    EXPECT_GT(std::abs(c.parameters.front().z), 10.0) << name;
  }
}

}  // namespace armsig::calibration
