#include "calibration/estimation.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <iostream>
#include <random>

#include "calibration/synthetic.h"
#include "test_support.h"

namespace armsig::calibration {
namespace {

constexpr double kNoiseMm = 0.02;  // the paper's theodolite accuracy per metre of travel

Eigen::Isometry3d LabBase() {
  // Robot base seen from the measuring frame: turned and 3 m away.
  Eigen::Isometry3d base = Eigen::Isometry3d::Identity();
  base.translate(Eigen::Vector3d(3000.0, -1500.0, -700.0));
  base.rotate(Eigen::AngleAxisd(0.7, Eigen::Vector3d::UnitZ()));
  return base;
}

struct Lab {
  RobotModel model = testing::Puma();
  Eigen::VectorXd truth = PaperTable3Parameters();
  std::vector<MeasuredPose> fit, validation;
};

Lab MakeLab(int fit_count, double noise_mm, unsigned seed, Eigen::Isometry3d base = LabBase()) {
  Lab lab;
  std::mt19937 rng(seed);
  lab.fit = SimulatePoses(lab.model, base, lab.truth,
                          RandomConfigurations(lab.model, fit_count, rng), noise_mm, rng);
  lab.validation = SimulatePoses(lab.model, base, lab.truth,
                                 RandomConfigurations(lab.model, 200, rng), noise_mm, rng);
  return lab;
}

// The paper's Euler-angle H makes the left-out parameters depend on the kept ones to
// first order only (γ1 vs β2 differs at O(α2·β2·L) ≈ 1e-3 mm), so a truth the model can
// reproduce exactly has its errors in the identified slots: Table 3's values there.
Eigen::VectorXd TruthInIdentifiedSlots(const RobotModel& model,
                                       const std::vector<MeasuredPose>& poses) {
  std::vector<Eigen::VectorXd> joints;
  for (const auto& p : poses) joints.push_back(p.joints_rad);
  std::vector<int> all(model.num_parameters());
  for (int i = 0; i < model.num_parameters(); ++i) all[i] = i;
  const auto report = AnalyseJacobian(
      StackedJacobian(model, LabBase(), Eigen::VectorXd::Zero(model.num_parameters()), joints),
      all);
  const Eigen::VectorXd table3 = PaperTable3Parameters();
  Eigen::VectorXd truth = Eigen::VectorXd::Zero(model.num_parameters());
  for (int k : report.identified) truth(k) = table3(k) != 0.0 ? table3(k) : 0.4e-3 + 0.1 * k * 1e-3;
  return truth;
}

ErrorStats Validate(const Lab& lab, const EstimationResult& r) {
  return Summarise(Distances(Residuals(lab.model, r.world_from_base, r.params, lab.validation)));
}

EstimationOptions With(const RobotModel& model, const std::string& spec) {
  EstimationOptions o;
  o.parameters = ParseParameterSpec(model, spec);
  return o;
}

}  // namespace

TEST(Estimation, NoiseFreeDataIsReproducedExactly) {
  Lab lab = MakeLab(80, 0.0, 1);
  lab.truth = TruthInIdentifiedSlots(lab.model, lab.fit);
  std::mt19937 rng(1);
  std::vector<Eigen::VectorXd> fit_q, val_q;
  for (const auto& p : lab.fit) fit_q.push_back(p.joints_rad);
  for (const auto& p : lab.validation) val_q.push_back(p.joints_rad);
  lab.fit = SimulatePoses(lab.model, LabBase(), lab.truth, fit_q, 0.0, rng);
  lab.validation = SimulatePoses(lab.model, LabBase(), lab.truth, val_q, 0.0, rng);
  const auto r = Estimate(lab.model, lab.fit, With(lab.model, "all"));
  ASSERT_TRUE(r.status.ok()) << r.status.message;
  EXPECT_LT(r.fit.max_mm, 1e-6);
  EXPECT_GT(r.nominal.mean_mm, 1.0);         // the hidden errors are millimetres
  EXPECT_LT(Validate(lab, r).max_mm, 1e-6);  // and so are new poses: the model is complete
  EXPECT_EQ(r.identifiability.rank, 29);
  // Unidentified parameters stay exactly zero, as in the paper.
  for (int k : r.identifiability.unidentified) EXPECT_EQ(r.params(k), 0.0);
}

// The paper's progression: geometric only leaves a clearly larger error; with h3, h4
// it shrinks; with all 43 the validation error is at the measurement noise floor.
TEST(Estimation, ReproducesThePapersProgression) {
  const Lab lab = MakeLab(80, kNoiseMm, 2);
  const auto geometric = Estimate(lab.model, lab.fit, With(lab.model, "geometric"));
  const auto h34 = Estimate(lab.model, lab.fit, With(lab.model, "geometric,h3,h4"));
  const auto all = Estimate(lab.model, lab.fit, With(lab.model, "all"));
  ASSERT_TRUE(geometric.usable() && h34.usable() && all.usable());
  const double v_geo = Validate(lab, geometric).mean_mm;
  const double v_h34 = Validate(lab, h34).mean_mm;
  const double v_all = Validate(lab, all).mean_mm;
  EXPECT_GT(geometric.nominal.mean_mm, 3.0);
  EXPECT_GT(v_geo, 3.0 * v_all);
  EXPECT_LT(v_h34, v_geo);
  // Mean length of a 3-D N(0, σ²I) error is 1.596 σ = 0.032 mm; allow for the
  // parameter uncertainty propagated to new poses.
  EXPECT_LT(v_all, 0.045);
  EXPECT_NEAR(all.sigma0_mm, kNoiseMm, 0.2 * kNoiseMm);
}

TEST(Estimation, FarOffBaseIsFoundFromTheData) {
  Eigen::Isometry3d far = Eigen::Isometry3d::Identity();
  far.translate(Eigen::Vector3d(-12000.0, 25000.0, 4000.0));
  far.rotate(Eigen::AngleAxisd(2.8, Eigen::Vector3d(0.2, -0.9, 0.4).normalized()));
  const Lab lab = MakeLab(80, kNoiseMm, 3, far);
  const auto r = Estimate(lab.model, lab.fit, With(lab.model, "all"));
  ASSERT_TRUE(r.status.ok()) << r.status.message;
  EXPECT_LT(Validate(lab, r).mean_mm, 0.045);
  EXPECT_LT(r.nominal.mean_mm, 50.0);  // the aligned base starts the fit close
}

TEST(Estimation, ParameterSigmasAreHonest) {
  // Refit many noisy data sets of the same poses: the scatter of each identified
  // parameter over the refits matches the sigma the fit reports for it, and the scatter
  // of the predicted position of a new pose matches its propagated size.
  const auto model = testing::Puma();
  const Eigen::VectorXd truth = PaperTable3Parameters();
  std::mt19937 rng(4);
  const auto joints = RandomConfigurations(model, 60, rng);
  const Eigen::VectorXd probe = RandomConfigurations(model, 1, rng)[0];
  const int trials = 40;
  std::vector<Eigen::VectorXd> estimates;
  Eigen::VectorXd mean_sigma = Eigen::VectorXd::Zero(model.num_parameters());
  std::vector<int> identified;
  double mse = 0;
  for (int trial = 0; trial < trials; ++trial) {
    const auto poses = SimulatePoses(model, LabBase(), truth, joints, kNoiseMm, rng);
    const auto r = Estimate(model, poses, With(model, "all"));
    ASSERT_TRUE(r.usable());
    if (trial == 0) identified = r.identifiability.identified;
    ASSERT_EQ(r.identifiability.identified, identified) << "same poses, same identified subset";
    estimates.push_back(r.params);
    for (int k : identified) mean_sigma(k) += r.sigmas(k) / trials;
    Kinematics kin(model);
    const Eigen::Vector3d predicted = kin.Position(r.world_from_base, r.params, probe.data());
    const Eigen::Vector3d actual = kin.Position(LabBase(), truth, probe.data());
    mse += (predicted - actual).squaredNorm() / trials;
  }
  ASSERT_GT(identified.size(), 20u);
  std::vector<double> ratios;
  for (int k : identified) {
    double mean = 0, var = 0;
    for (const auto& e : estimates) mean += e(k) / trials;
    for (const auto& e : estimates) var += (e(k) - mean) * (e(k) - mean) / (trials - 1);
    const double ratio = std::sqrt(var) / mean_sigma(k);
    ratios.push_back(ratio);
    // 40 refits: the sample standard deviation is good to ~11 % (1σ); 0.6–1.5 is > 3σ.
    EXPECT_GT(ratio, 0.6) << model.ParameterNames()[k] << " sigma too large";
    EXPECT_LT(ratio, 1.5) << model.ParameterNames()[k] << " sigma too small";
  }
  std::nth_element(ratios.begin(), ratios.begin() + ratios.size() / 2, ratios.end());
  const double median = ratios[ratios.size() / 2];
  EXPECT_GT(median, 0.85);
  EXPECT_LT(median, 1.15);
  // The prediction error of a new pose is a fraction of the noise, and not zero.
  EXPECT_LT(std::sqrt(mse), 3 * kNoiseMm);
  EXPECT_GT(std::sqrt(mse), 0.05 * kNoiseMm);
}

TEST(Estimation, RobustLossReportsBlunderPoses) {
  Lab lab = MakeLab(80, kNoiseMm, 5);
  lab.fit[10].target_in_world += Eigen::Vector3d(4.0, 0, 0);
  lab.fit[33].target_in_world += Eigen::Vector3d(0, -3.0, 2.0);
  EstimationOptions o = With(lab.model, "all");
  o.robust_threshold_mm = 0.1;
  const auto robust = Estimate(lab.model, lab.fit, o);
  ASSERT_TRUE(robust.usable());
  EXPECT_EQ(robust.downweighted, (std::vector<int>{10, 33}));
  const auto plain = Estimate(lab.model, lab.fit, With(lab.model, "all"));
  EXPECT_LT(Validate(lab, robust).mean_mm, 0.06);
  EXPECT_GT(Validate(lab, plain).mean_mm, Validate(lab, robust).mean_mm);
}

// A pose's own weight (a point paired on the move whose clock is uncertain): the weighted
// least-squares solution, computed independently with every pose repeated in proportion to its
// weight (integer weights are repetitions: the same normal equations); a pose of weight 1e-6
// with a 3 mm blunder barely moves the fit; a weight that is not a positive number is refused.
TEST(Estimation, PoseWeightsAreTheWeightedLeastSquaresSolution) {
  const Lab lab = MakeLab(60, kNoiseMm, 12);
  std::vector<MeasuredPose> weighted = lab.fit, repeated;
  for (size_t i = 0; i < weighted.size(); ++i) {
    const int w = 1 + static_cast<int>(i % 3);  // 1, 2, 3
    weighted[i].weight = w;
    for (int k = 0; k < w; ++k) repeated.push_back(lab.fit[i]);
  }
  const auto a = Estimate(lab.model, weighted, With(lab.model, "geometric"));
  ASSERT_TRUE(a.usable());
  // Which of exactly dependent parameters is kept is decided on the poses' joints alone
  // (weights do not change what the data identify); the repeated set is given the same ones.
  EstimationOptions same;
  same.parameters = a.identifiability.identified;
  const auto b = Estimate(lab.model, repeated, same);
  ASSERT_TRUE(b.usable());
  ASSERT_EQ(b.identifiability.identified, a.identifiability.identified);
  EXPECT_LT((a.params - b.params).cwiseAbs().maxCoeff(), 1e-9);
  // Residuals are reported unweighted: the same pose, the same error vector.
  for (size_t i = 0; i < weighted.size(); ++i) {
    size_t j = 0;
    for (size_t k = 0; k < i; ++k) j += 1 + k % 3;
    EXPECT_LT((a.fit_residuals[i] - b.fit_residuals[j]).norm(), 1e-6);
  }
  std::vector<MeasuredPose> blunder = lab.fit;
  blunder[7].target_in_world += Eigen::Vector3d(3.0, 0.0, 0.0);
  const double plain = Validate(lab, Estimate(lab.model, blunder, With(lab.model, "geometric"))).mean_mm;
  blunder[7].weight = 1e-6;
  const double light = Validate(lab, Estimate(lab.model, blunder, With(lab.model, "geometric"))).mean_mm;
  const double clean = Validate(lab, Estimate(lab.model, lab.fit, With(lab.model, "geometric"))).mean_mm;
  EXPECT_GT(plain, clean + 0.01);
  EXPECT_NEAR(light, clean, 0.002);
  blunder[7].weight = 0.0;
  EXPECT_THROW(Estimate(lab.model, blunder, With(lab.model, "geometric")), std::invalid_argument);
}

TEST(Estimation, TooFewPosesIsRefusedWithTheNumbers) {
  const Lab lab = MakeLab(9, kNoiseMm, 6);  // 27 equations < 29 identifiable
  const auto r = Estimate(lab.model, lab.fit, With(lab.model, "all"));
  EXPECT_EQ(r.status.code, SolveCode::kTooFewObservations);
  EXPECT_NE(r.status.message.find("27 equations"), std::string::npos) << r.status.message;
}

TEST(Estimation, DegenerateBaseIsRefused) {
  const Lab lab = MakeLab(2, 0.0, 7);
  EXPECT_EQ(Estimate(lab.model, lab.fit, With(lab.model, "all")).status.code,
            SolveCode::kDegenerate);
}

TEST(Estimation, FrozenJointStillFitsWhatTheDataCanSay) {
  Lab lab = MakeLab(80, 0.0, 8);
  std::mt19937 rng(8);
  auto joints = RandomConfigurations(lab.model, 80, rng);
  for (auto& q : joints) q(4) = -0.4;  // joint 5 never moves
  lab.fit = SimulatePoses(lab.model, LabBase(), lab.truth, joints, 0.0, rng);
  lab.truth = TruthInIdentifiedSlots(lab.model, lab.fit);
  lab.fit = SimulatePoses(lab.model, LabBase(), lab.truth, joints, 0.0, rng);
  const auto r = Estimate(lab.model, lab.fit, With(lab.model, "all"));
  ASSERT_TRUE(r.usable());
  EXPECT_LT(r.identifiability.rank, 29);
  ASSERT_EQ(r.identifiability.frozen_joints.size(), 1u);
  EXPECT_EQ(r.identifiability.frozen_joints[0].joint, 4);
  // The data themselves are still reproduced, to the second-order limit of the Euler-angle
  // parametrisation once the frozen joint merges neighbouring parameters.
  EXPECT_LT(r.fit.max_mm, 0.005);
  EXPECT_GT(r.nominal.mean_mm, 1.0);
}

// Poses that do not move the robot "converged" with σ0 of the targets' scatter.
TEST(Estimation, PosesThatNeverMoveTheRobotAreRefusedWhateverTheTargets) {
  std::mt19937 rng(15);
  const RobotModel model = testing::Puma();
  std::vector<MeasuredPose> poses;
  std::uniform_real_distribution<double> scatter(-500.0, 500.0);
  for (int i = 0; i < 40; ++i) {
    MeasuredPose p;
    p.id = "p" + std::to_string(i);
    p.joints_rad = Eigen::VectorXd::Zero(6);
    p.target_in_world = Eigen::Vector3d(scatter(rng), scatter(rng), scatter(rng));
    poses.push_back(p);
  }
  auto r = Estimate(model, poses, With(model, "all"));  // base: auto
  EXPECT_EQ(r.status.code, SolveCode::kDegenerate);
  EXPECT_NE(r.status.message.find("same joint angles"), std::string::npos) << r.status.message;
  RobotModel given = model;
  given.base = LabBase();  // the base does not need the poses: the joints still say nothing
  for (auto& p : poses) p.joints_rad = Eigen::VectorXd::Constant(6, 0.3);
  r = Estimate(given, poses, With(given, "all"));
  EXPECT_EQ(r.status.code, SolveCode::kDegenerate);
}

TEST(Estimation, PosesThatIdentifyFarFewerParametersThanTheModelAreRefused) {
  // Only joint 1 moves: the data identify a handful of the 29 parameters.
  Lab lab = MakeLab(60, 0.0, 16);
  std::mt19937 rng(16);
  auto joints = RandomConfigurations(lab.model, 60, rng);
  for (auto& q : joints) {
    for (int j = 1; j < 6; ++j) q(j) = 0.2 * j;
  }
  lab.fit = SimulatePoses(lab.model, LabBase(), lab.truth, joints, kNoiseMm, rng);
  const auto r = Estimate(lab.model, lab.fit, With(lab.model, "all"));
  EXPECT_EQ(r.status.code, SolveCode::kDegenerate);
  EXPECT_NE(r.status.message.find("joints that never move: 2, 3, 4, 5, 6"), std::string::npos)
      << r.status.message;
}

// Two sessions are two set-ups of the instruments: the same robot seen from two
// measuring frames. Each frame gets its own base; the latest frame is the datum, the other
// base is estimated with the parameters and found to the noise level.
TEST(Estimation, EachMeasurementFrameGetsItsOwnBase) {
  const RobotModel model = testing::Puma();
  const Eigen::VectorXd truth = PaperTable3Parameters();
  Eigen::Isometry3d moved = LabBase();
  moved.pretranslate(Eigen::Vector3d(850.0, 420.0, -35.0));
  moved.rotate(Eigen::AngleAxisd(0.3, Eigen::Vector3d(0.1, 0.2, 1.0).normalized()));
  std::mt19937 rng(21);
  auto first = SimulatePoses(model, moved, truth, RandomConfigurations(model, 60, rng), kNoiseMm,
                             rng);
  auto second = SimulatePoses(model, LabBase(), truth, RandomConfigurations(model, 60, rng),
                              kNoiseMm, rng);
  const auto validation = SimulatePoses(model, LabBase(), truth,
                                        RandomConfigurations(model, 200, rng), kNoiseMm, rng);
  for (auto& p : first) p.frame = 4;
  for (auto& p : second) p.frame = 7;
  std::vector<MeasuredPose> both = first;
  both.insert(both.end(), second.begin(), second.end());
  EXPECT_EQ(FramesOf(both), (std::vector<int64_t>{4, 7}));

  const auto r = Estimate(model, both, With(model, "all"));
  ASSERT_TRUE(r.status.ok()) << r.status.message;
  EXPECT_EQ(r.reference_frame, 7);
  ASSERT_EQ(r.bases.size(), 2u);
  // One set of parameters fits both frames to the noise: 1.596 σ mean for 3-D noise.
  EXPECT_LT(r.fit.mean_mm, 2.0 * kNoiseMm);
  EXPECT_NEAR(r.sigma0_mm, kNoiseMm, 0.25 * kNoiseMm);
  EXPECT_EQ(r.redundancy, 3 * 120 - r.identifiability.rank - 6);
  // New poses in the datum frame: as good as a fit on one frame.
  EXPECT_LT(Summarise(Distances(Residuals(model, r.bases.at(7), r.params, validation))).mean_mm,
            0.045);
  // The other frame's base differs from the datum's as the truth does: compare the
  // positions both bases give to the same robot-frame points (the gauge between base and
  // first-joint parameters leaves the bases themselves defined only up to it).
  const Eigen::Isometry3d relative_truth = moved * LabBase().inverse();
  const Eigen::Isometry3d relative_fit = r.bases.at(4) * r.bases.at(7).inverse();
  for (const Eigen::Vector3d& x : {Eigen::Vector3d(3000, -1500, -700),
                                  Eigen::Vector3d(3800, -900, 300),
                                  Eigen::Vector3d(2200, -2100, 0)})
    EXPECT_LT((relative_fit * x - relative_truth * x).norm(), 0.05);
  // Residuals with every pose's own base reproduce the fit's.
  const auto per_pose = Distances(Residuals(model, r.bases, r.params, both));
  EXPECT_NEAR(Summarise(per_pose).mean_mm, r.fit.mean_mm, 1e-9);

  // Fitted as if one frame, the two set-ups cannot be told apart: hundreds of mm.
  std::vector<MeasuredPose> merged = both;
  for (auto& p : merged) p.frame = 0;
  const auto wrong = Estimate(model, merged, With(model, "all"));
  EXPECT_GT(wrong.fit.mean_mm, 10.0);
}

TEST(ParameterSpec, ParsesGroupsAndNamesAndRejectsUnknown) {
  const auto model = testing::Puma();
  EXPECT_EQ(ParseParameterSpec(model, "geometric").size(), 39u);
  EXPECT_EQ(ParseParameterSpec(model, "all").size(), 43u);
  const auto v = ParseParameterSpec(model, "geometric, h3 ,h4");
  EXPECT_EQ(v.size(), 41u);
  EXPECT_EQ(v.back(), 42);
  EXPECT_THROW(ParseParameterSpec(model, "geometric,h9"), std::invalid_argument);
  EXPECT_THROW(ParseParameterSpec(model, ""), std::invalid_argument);
}

TEST(FTest, AutoAddsOnlyTheTermsTheRobotHas) {
  // A true robot with joint-3 terms only: the F-tests add h3 and h4, not h1 or h2.
  Lab lab;
  lab.truth(39) = 0.0;
  lab.truth(40) = 0.0;
  std::mt19937 rng(9);
  lab.fit = SimulatePoses(lab.model, LabBase(), lab.truth, RandomConfigurations(lab.model, 80, rng),
                          kNoiseMm, rng);
  EstimationOptions o;
  const auto selection = SelectTermsByFTest(lab.model, lab.fit, o, 0.001);
  std::vector<int> added(selection.parameters.begin() + 39, selection.parameters.end());
  EXPECT_EQ(added, (std::vector<int>{41, 42}));
  EXPECT_GE(selection.tests.size(), 4u);
}

}  // namespace armsig::calibration

namespace armsig::calibration {

TEST(Estimation, APlantedFlangeTurnIsRecoveredWithAKnownMounting) {
  // The PUMA with its target on a machined adapter 238 mm out, off the flange axis
  // (tool_mounting: known): the flange's own turn after the last joint (1 mrad, 0.24 mm at
  // the target) is fitted as alpha7 beta7 and found within 3σ; a b c7 and gamma6 are held.
  RobotModel model = testing::Puma();
  model.tool_mm = Eigen::Vector3d(40.0, 0.0, 235.0);
  model.tool_mounting = ToolMounting::kKnown;
  std::mt19937 rng(36);
  const auto joints = RandomConfigurations(model, 80, rng);
  const std::vector<int> geometric = ParseParameterSpec(model, "geometric");
  for (int k : model.HeldParameters())
    EXPECT_EQ(std::count(geometric.begin(), geometric.end(), k), 0) << model.ParameterNames()[k];
  // A truth the model reproduces: errors of an arm as built in the identified slots.
  const IdentifiabilityReport id =
      AnalyseIdentifiability(model, LabBase(), joints, geometric);
  EXPECT_EQ(id.held, model.HeldParameters());
  const int turn = model.flange_turn_index();
  ASSERT_EQ(std::count(id.identified.begin(), id.identified.end(), turn), 1);
  ASSERT_EQ(std::count(id.identified.begin(), id.identified.end(), turn + 1), 1);
  const Eigen::VectorXd drawn = RandomParameters(model, 0.3, 3e-4, 0.0, rng);
  Eigen::VectorXd truth = Eigen::VectorXd::Zero(model.num_parameters());
  for (int k : id.identified) truth(k) = drawn(k);
  truth(turn) = 0.8e-3;
  truth(turn + 1) = -0.6e-3;
  const auto poses = SimulatePoses(model, LabBase(), truth, joints, kNoiseMm, rng);
  EstimationOptions options;
  options.parameters = geometric;
  const auto r = Estimate(model, poses, options);
  ASSERT_TRUE(r.usable()) << r.status.message;
  for (int k : model.HeldParameters()) EXPECT_EQ(r.params(k), 0.0) << model.ParameterNames()[k];
  for (int k : {turn, turn + 1}) {
    std::cout << model.ParameterNames()[k] << ": planted " << truth(k) * 1e3 << " mrad, found "
              << r.params(k) * 1e3 << " ± " << r.sigmas(k) * 1e3 << " mrad\n";
    EXPECT_LT(std::abs(r.params(k) - truth(k)), 3.0 * r.sigmas(k)) << model.ParameterNames()[k];
    EXPECT_LT(r.sigmas(k), 0.1e-3);
  }
}

TEST(ParameterSpec, AHeldParameterIsRefusedByName) {
  RobotModel model = testing::Puma();
  model.tool_mm = Eigen::Vector3d(40.0, 0.0, 235.0);
  model.tool_mounting = ToolMounting::kKnown;
  EXPECT_EQ(ParseParameterSpec(model, "geometric").size(), 41u - 4u);
  EXPECT_EQ(ParseParameterSpec(model, "all").size(), 45u - 4u);
  EXPECT_EQ(ParseParameterSpec(model, "alpha7,beta7"), (std::vector<int>{39, 40}));
  for (const char* held : {"a7", "c7", "gamma6"}) {
    try {
      ParseParameterSpec(model, std::string("geometric,") + held);
      ADD_FAILURE() << held << " accepted";
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(std::string("'") + held + "' is held at zero"),
                std::string::npos)
          << e.what();
    }
  }
}

}  // namespace armsig::calibration
