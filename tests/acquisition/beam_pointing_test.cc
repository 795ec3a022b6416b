// Where a laser tracker's beam points: the robot model's target through the robot base,
// the lab file's base until enough points are measured, then the rigid best fit to them.
#include "acquisition/beam_pointing.h"

#include <gtest/gtest.h>

#include <random>

#include "calibration/compensation.h"
#include "calibration/synthetic.h"
#include "test_support.h"

namespace armsig::acquisition {
namespace {

struct Truth {
  calibration::RobotModel model = testing::Puma();
  Eigen::Isometry3d world_from_base = Eigen::Isometry3d::Identity();
  Eigen::VectorXd params = calibration::PaperTable3Parameters();
  Truth() {
    world_from_base.translate(Eigen::Vector3d(2300.0, 1600.0, -1100.0));
    world_from_base.rotate(Eigen::AngleAxisd(2.6, Eigen::Vector3d::UnitZ()));
  }
  Eigen::Vector3d Target(const Eigen::VectorXd& q) const {
    calibration::Kinematics kin(model);
    return kin.Position(world_from_base, params, q.data());
  }
};

}  // namespace

TEST(TargetPredictor, NoBaseUntilThreePointsOffALineThenTheRigidFitOfThem) {
  const Truth truth;
  std::mt19937 rng(4);
  const auto q = calibration::RandomConfigurations(truth.model, 60, rng);
  const Eigen::VectorXd nominal = Eigen::VectorXd::Zero(truth.model.num_parameters());
  TargetPredictor p(truth.model, nominal, std::nullopt);
  EXPECT_FALSE(p.Predict(q[0]).has_value());
  EXPECT_NE(p.Describe().find("no base yet (0 of 3"), std::string::npos) << p.Describe();
  // One configuration measured three times: its points are one point, no rotation follows.
  for (int k = 0; k < 3; ++k) p.Add(q[0], truth.Target(q[0]));
  EXPECT_FALSE(p.fitted());
  EXPECT_FALSE(p.Predict(q[1]).has_value());
  // Two more configurations: the base is the rigid fit of the nominal model to the five
  // measured points, the same as calibration's base alignment computes it.
  std::vector<MeasuredPose> measured;
  for (int k = 0; k < 3; ++k) measured.push_back({"", q[0], truth.Target(q[0])});
  for (int k = 1; k <= 2; ++k) {
    p.Add(q[k], truth.Target(q[k]));
    measured.push_back({"", q[k], truth.Target(q[k])});
  }
  ASSERT_TRUE(p.fitted());
  const auto reference = calibration::AlignBaseWithParams(truth.model, nominal, measured);
  ASSERT_TRUE(reference.has_value());
  EXPECT_LT((p.base()->matrix() - reference->matrix()).norm(), 1e-9);
  EXPECT_NE(p.Describe().find("base fitted to 5 measured points"), std::string::npos);
  // The nominal model through that base points within the robot's own errors (the paper's
  // PUMA: 5.9 mm mean, 10 mm worst) plus what three points leave of the base; with every
  // measured point the fit improves.
  auto worst = [&](TargetPredictor& predictor) {
    double w = 0.0;
    for (int k = 40; k < 60; ++k) w = std::max(w, (*predictor.Predict(q[k]) - truth.Target(q[k])).norm());
    return w;
  };
  const double after_three = worst(p);
  for (int k = 3; k < 40; ++k) p.Add(q[k], truth.Target(q[k]));
  const double after_forty = worst(p);
  EXPECT_LT(after_forty, 20.0);
  EXPECT_LT(after_forty, after_three + 1e-9);
  std::cout << "nominal model: worst pointing error " << after_three << " mm after 3 configurations, "
            << after_forty << " mm after 40\n";

  // The robot's arm signature (here the truth) points exactly, from three points on.
  TargetPredictor calibrated(truth.model, truth.params, std::nullopt);
  for (int k = 1; k <= 3; ++k) calibrated.Add(q[k], truth.Target(q[k]));
  EXPECT_LT(worst(calibrated), 1e-6);
}

// Points that follow the robot pass (the nominal model misses the true PUMA by mm); a
// reflector left in a nest, or points off by centimetres (a wrong tool offset), are named.
TEST(TargetPredictor, NamesPointsThatDoNotFollowTheRobot) {
  const Truth truth;
  std::mt19937 rng(8);
  const auto q = calibration::RandomConfigurations(truth.model, 30, rng);
  const Eigen::VectorXd nominal = Eigen::VectorXd::Zero(truth.model.num_parameters());
  TargetPredictor following(truth.model, nominal, std::nullopt);
  TargetPredictor nest(truth.model, nominal, std::nullopt);
  TargetPredictor scattered(truth.model, nominal, std::nullopt);
  std::normal_distribution<double> cm(0.0, 60.0);
  const Eigen::Vector3d nest_at(1900.0, 1200.0, -300.0);
  for (int k = 0; k < 30; ++k) {
    following.Add(q[k], truth.Target(q[k]));
    nest.Add(q[k], nest_at + Eigen::Vector3d(0.01 * k, 0.0, 0.0));
    scattered.Add(q[k], truth.Target(q[k]) + Eigen::Vector3d(cm(rng), cm(rng), cm(rng)));
    if (k < 2) {  // too few points to tell
      EXPECT_FALSE(nest.FollowProblem(25.0).has_value());
    }
  }
  EXPECT_FALSE(following.FollowProblem(25.0).has_value()) << *following.FollowProblem(25.0);
  EXPECT_LT(*following.fit_rms_mm(), 25.0);
  const auto stays = nest.FollowProblem(25.0);
  ASSERT_TRUE(stays.has_value());
  EXPECT_NE(stays->find("does not follow the robot"), std::string::npos) << *stays;
  const auto off = scattered.FollowProblem(25.0);
  ASSERT_TRUE(off.has_value());
  EXPECT_NE(off->find("do not follow the robot model"), std::string::npos) << *off;
  EXPECT_NE(off->find("max_base_fit_rms_mm"), std::string::npos) << *off;
  // The limit is the lab's: a generous one lets the scattered points pass.
  EXPECT_FALSE(scattered.FollowProblem(500.0).has_value());
}

TEST(TargetPredictor, TheLabFilesBaseUntilItsOwnFitTakesOver) {
  const Truth truth;
  std::mt19937 rng(5);
  const auto q = calibration::RandomConfigurations(truth.model, 10, rng);
  Eigen::Isometry3d given = truth.world_from_base;
  given.translate(Eigen::Vector3d(3.0, -2.0, 1.0));  // measured by hand, a few mm off
  TargetPredictor p(truth.model, truth.params, given);
  calibration::Kinematics kin(truth.model);
  ASSERT_TRUE(p.Predict(q[0]).has_value());
  EXPECT_LT((*p.Predict(q[0]) - kin.Position(given, truth.params, q[0].data())).norm(), 1e-12);
  EXPECT_EQ(p.Describe(), "the lab file's robot base");
  for (int k = 0; k < 3; ++k) p.Add(q[k], truth.Target(q[k]));
  ASSERT_TRUE(p.fitted());
  EXPECT_LT((*p.Predict(q[9]) - truth.Target(q[9])).norm(), 1e-6);  // the fit, not the file
}

}  // namespace armsig::acquisition
