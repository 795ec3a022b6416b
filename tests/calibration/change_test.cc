// What changed in a robot, from when: the physical causes against independent kinematics,
// the change point of a run of sessions, and the false-alarm rate of the session test on
// sessions of an unchanged robot.
#include "calibration/change.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <random>

#include "calibration/estimation.h"
#include "calibration/identifiability.h"
#include "calibration/synthetic.h"
#include "core/units.h"
#include "test_support.h"

namespace armsig::calibration {

namespace {

const Cause* Find(const std::vector<Cause>& causes, const std::string& name) {
  for (const auto& c : causes) {
    if (c.name.rfind(name, 0) == 0) return &c;
  }
  return nullptr;
}

// Positions of `params` at `configurations` by the plain kinematics (no Jacobian), the
// second set rigidly aligned onto the first: the change a user sees, computed without any
// of the code under test.
std::vector<double> AlignedChange(const RobotModel& model, const Eigen::VectorXd& a,
                                  const Eigen::VectorXd& b,
                                  const std::vector<Eigen::VectorXd>& configurations) {
  Kinematics kin(model);
  const int m = static_cast<int>(configurations.size());
  Eigen::Matrix3Xd xa(3, m), xb(3, m);
  for (int i = 0; i < m; ++i) {
    xa.col(i) = kin.Position(Eigen::Isometry3d::Identity(), a, configurations[i].data());
    xb.col(i) = kin.Position(Eigen::Isometry3d::Identity(), b, configurations[i].data());
  }
  const Eigen::Matrix4d t = Eigen::umeyama(xb, xa, false);
  std::vector<double> out;
  for (int i = 0; i < m; ++i) {
    out.push_back((t.topLeftCorner<3, 3>() * xb.col(i) + t.topRightCorner<3, 1>() - xa.col(i))
                      .norm());
  }
  return out;
}

FittedSet Exact(const RobotModel& model, const Eigen::VectorXd& params) {
  FittedSet set;
  set.params = params;
  set.identified = ModelIdentifiableSubset(model, ParseParameterSpec(model, "all"));
  set.covariance = 1e-12 * Eigen::MatrixXd::Identity(set.identified.size(), set.identified.size());
  return set;
}

}  // namespace

// The PUMA's causes: a zero, two tilts and three offsets per joint, the lengths of the
// links that have one (link 2: N3's 650 mm along x and 50 mm along z), the tool, h1–h4, the
// scale.
TEST(CandidateCauses, NameThePhysicalQuantitiesOfThePuma) {
  const auto model = testing::Puma();
  const auto causes = CandidateCauses(model);
  const Cause* zero = Find(causes, "joint 2 zero");
  ASSERT_NE(zero, nullptr);
  EXPECT_EQ(zero->parameter, "gamma2");
  EXPECT_TRUE(zero->angle);
  const Cause* link = Find(causes, "link 2 length");
  ASSERT_NE(link, nullptr);
  EXPECT_NE(link->name.find("652 mm"), std::string::npos) << link->name;  // √(650² + 50²)
  EXPECT_NEAR(link->direction(model.IndexOf("a3")), 650.0 / std::hypot(650.0, 50.0), 1e-12);
  EXPECT_NEAR(link->direction(model.IndexOf("c3")), 50.0 / std::hypot(650.0, 50.0), 1e-12);
  EXPECT_NE(Find(causes, "joint 3 term h4"), nullptr);
  EXPECT_NE(Find(causes, "instrument scale"), nullptr);
  EXPECT_EQ(Find(causes, "link 0"), nullptr);
}

// A set that differs from another by one planted cause: that cause explains all of the
// difference, with its size, and its effect in mm is what plain kinematics give; joint 1's
// zero turns the whole arm, which an aligned frame takes away.
TEST(ExplainDifference, NamesAPlantedCauseWithItsSizeAndItsEffectAtTheTool) {
  const auto model = testing::Puma();
  const Eigen::VectorXd before = PaperTable3Parameters();
  const auto spread = SpreadConfigurations(model, 50);
  struct Case {
    std::string cause;
    double size;  // rad or mm
  };
  for (const Case& c : {Case{"joint 2 zero", 0.02 * kRadPerDeg}, Case{"joint 5 zero", -1e-3},
                        Case{"link 2 length", 0.2}, Case{"joint 3 axis tilt about y", 0.5e-3}}) {
    const std::vector<Cause> causes = CandidateCauses(model);
    const Cause* planted = Find(causes, c.cause);
    ASSERT_NE(planted, nullptr) << c.cause;
    const Eigen::VectorXd after = before + c.size * planted->direction;
    const Explanation e = ExplainDifference(
        model, before, SetDifference(model, Exact(model, before), Exact(model, after), spread));
    ASSERT_FALSE(e.causes.empty()) << c.cause;
    const auto& best = e.causes.front();
    EXPECT_EQ(best.cause.name.rfind(c.cause, 0), 0u) << c.cause << ": " << best.cause.name;
    EXPECT_NEAR(best.size, c.size, 0.02 * std::abs(c.size)) << c.cause;
    EXPECT_GT(best.explained, 0.99) << c.cause;
    const auto independent = AlignedChange(model, before, after, spread);
    const double max = *std::max_element(independent.begin(), independent.end());
    EXPECT_NEAR(best.effect_max_mm, max, 0.05 * max) << c.cause;
  }
  const Explanation e = ExplainDifference(
      model, before, SetDifference(model, Exact(model, before), Exact(model, before), spread));
  EXPECT_NE(std::find(e.indistinguishable_from_frame.begin(), e.indistinguishable_from_frame.end(),
                      "joint 1 zero"),
            e.indistinguishable_from_frame.end());
}

// A scale error of the instrument (every length 80 ppm long) is named as such.
TEST(ExplainDifference, NamesTheInstrumentsScale) {
  const auto model = testing::Puma();
  const Eigen::VectorXd params = PaperTable3Parameters();
  std::mt19937 rng(7);
  const auto poses = SimulatePoses(model, Eigen::Isometry3d::Identity(), params,
                                   LabTestConfigurations(model, rng), 0.0, rng);
  Difference d;
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  for (const auto& p : poses) centre += p.target_in_world / poses.size();
  d.change.resize(3 * poses.size());
  for (size_t i = 0; i < poses.size(); ++i) {
    d.configurations.push_back(poses[i].joints_rad);
    d.world_from_base.push_back(Eigen::Isometry3d::Identity());
    d.group.push_back(0);
    d.change.segment<3>(3 * i) = 80e-6 * (poses[i].target_in_world - centre);
  }
  d.sigma_mm = 0.001;
  const auto e = ExplainDifference(model, params, d);
  ASSERT_FALSE(e.causes.empty());
  EXPECT_EQ(e.causes.front().cause.name, "instrument scale");
  EXPECT_NEAR(e.causes.front().size, 80e-6, 2e-6);
  // The change is the scale's own column (each position from its group's centre): it lies
  // in the span of the causes' columns, so all of it is explainable.
  EXPECT_GT(e.sum_squares, 0.0);
  EXPECT_NEAR(e.explainable_sum_squares, e.sum_squares, 1e-9 * e.sum_squares);
}

TEST(LocateChange, FindsTheRunThatReachesTheNewestAndCallsEarlierOnesOutliers) {
  EXPECT_EQ(LocateChange({false, false, false}).first_changed, -1);
  EXPECT_EQ(LocateChange({false, false, true}).first_changed, 2);
  EXPECT_EQ(LocateChange({false, true, true}).first_changed, 1);
  const auto outlier = LocateChange({false, true, false, false});
  EXPECT_EQ(outlier.first_changed, -1);
  EXPECT_EQ(outlier.outliers, std::vector<int>{1});
  const auto both = LocateChange({true, false, true, true});
  EXPECT_EQ(both.first_changed, 2);
  EXPECT_EQ(both.outliers, std::vector<int>{0});
  EXPECT_EQ(LocateChange({}).first_changed, -1);
}

// Sessions of the same robot, each in a new frame, against a set fitted on plenty of its
// data: at the 0.1 % level few disagree (the expected count is 0.1 of 100; 3 or more would
// happen by chance with probability 2e-4), and a session of the robot with joint 3
// re-mastered 0.3 mrad off disagrees every time.
TEST(TestAgainstReference, SessionsOfTheSameRobotRarelyDisagreeAndAChangedOneAlways) {
  const auto model = testing::Puma();
  const Eigen::VectorXd truth = PaperTable3Parameters();
  std::mt19937 rng(20261127);
  std::vector<MeasuredPose> training;
  for (int s = 0; s < 4; ++s) {
    auto poses = SimulatePoses(model, Eigen::Isometry3d::Identity(), truth,
                               LabTestConfigurations(model, rng), 0.01, rng);
    for (auto& p : poses) p.frame = s;
    training.insert(training.end(), poses.begin(), poses.begin() + 60);
  }
  EstimationOptions options;
  options.parameters = ModelIdentifiableSubset(model, ParseParameterSpec(model, "all"));
  const auto fit = Estimate(model, training, options);
  ASSERT_TRUE(fit.status.ok());
  const FittedSet set{fit.params, fit.identifiability.identified, fit.covariance};
  const ChangeReference reference = MakeChangeReference(model, set, 0.01, training);
  EXPECT_EQ(reference.sessions, 4);
  // White noise of the size the reference assumes: the single causes scatter as it says.
  EXPECT_LT(reference.overdispersion, 1.5);
  Eigen::VectorXd changed = truth;
  changed(model.IndexOf("gamma3")) += 0.3e-3;
  int false_alarms = 0, detected = 0;
  const int sessions = 100;
  for (int s = 0; s < sessions; ++s) {
    for (const bool change : {false, true}) {
      if (change && s % 10 != 0) continue;  // ten changed sessions are plenty
      Eigen::Isometry3d frame = Eigen::Isometry3d::Identity();
      frame.rotate(Eigen::AngleAxisd(0.1 * s, Eigen::Vector3d::UnitZ()));
      frame.translation() = Eigen::Vector3d(3.0 * s, -2.0 * s, 1.0);
      auto poses = SimulatePoses(model, frame, change ? changed : truth,
                                 LabTestConfigurations(model, rng), 0.01, rng);
      poses.resize(40);
      for (auto& p : poses) p.frame = 100 + s;
      const auto t = TestAgainstReference(model, reference, poses);
      if (change) {
        detected += t.disagrees;
        EXPECT_EQ(t.explanation.causes.front().cause.name, "joint 3 zero");
      } else {
        false_alarms += t.disagrees;
      }
    }
  }
  EXPECT_LE(false_alarms, 2) << "of " << sessions;
  EXPECT_EQ(detected, 10);
}

}  // namespace armsig::calibration
