// Generated non-geometric terms: compliance under gravity torques and the
// joints' transmission harmonics.
#include "calibration/terms.h"

#include <ceres/jet.h>
#include <gtest/gtest.h>

#include <random>

#include "calibration/compensation.h"
#include "calibration/estimation.h"
#include "calibration/synthetic.h"
#include "test_support.h"

namespace armsig::calibration {
namespace {

constexpr double kNoiseMm = 0.02;

Eigen::Isometry3d LabBase() {
  Eigen::Isometry3d base = Eigen::Isometry3d::Identity();
  base.translate(Eigen::Vector3d(400.0, -3200.0, 150.0));
  base.rotate(Eigen::AngleAxisd(-1.2, Eigen::Vector3d::UnitZ()));
  return base;
}

// The UR10 without the file's h-terms, plus the asked families.
RobotModel Ur10With(const std::vector<TermFamily>& families) {
  RobotModel model = testing::Ur10();
  model.nongeometric.clear();
  return WithGeneratedTerms(model, families);
}

std::vector<std::string> TermNames(const RobotModel& model) {
  std::vector<std::string> names;
  for (const auto& t : model.nongeometric) names.push_back(t.name);
  return names;
}

// Height (along −gravity) of a unit mass at the origin of joint j's frame (j = n: the
// target), from a model truncated after that frame: an independent route to the torque.
double MassHeight(const RobotModel& model, int mass_at, Eigen::VectorXd q) {
  RobotModel part = model;
  part.nongeometric.clear();
  if (mass_at < model.num_joints()) {
    part.links.resize(mass_at);
    part.tool_mm.setZero();
    q.conservativeResize(mass_at + 1);
  }
  Kinematics kin(part);
  const Eigen::Vector3d p = kin.Position(Eigen::Isometry3d::Identity(),
                                         Eigen::VectorXd::Zero(part.num_parameters()), q.data());
  return -model.gravity_in_base.dot(p);
}

// A truth whose geometric part sits in the slots the data identify (see estimation_test:
// the Euler-angle H makes other slots first-order dependencies only), with `terms` set.
Eigen::VectorXd Truth(const RobotModel& model, const std::vector<Eigen::VectorXd>& joints,
                      const std::vector<std::pair<std::string, double>>& terms, unsigned seed) {
  std::vector<int> geometric(model.num_geometric());
  for (int i = 0; i < model.num_geometric(); ++i) geometric[i] = i;
  const auto report =
      AnalyseJacobian(StackedJacobian(model, Eigen::Isometry3d::Identity(),
                                      Eigen::VectorXd::Zero(model.num_parameters()), joints),
                      geometric);
  std::mt19937 rng(seed);
  const Eigen::VectorXd random = RandomParameters(model, 0.5, 1e-3, 0.0, rng);
  Eigen::VectorXd truth = Eigen::VectorXd::Zero(model.num_parameters());
  for (int k : report.identified) truth(k) = random(k);
  for (const auto& [name, value] : terms) truth(model.IndexOf(name)) = value;
  return truth;
}

}  // namespace

TEST(GeneratedTerms, Ur10GetsOnlyTermsThatCanMoveItsTarget) {
  // Joint 1 turns about the vertical: no gravity torque. Joint 6's axis carries the probe:
  // it moves nothing. Frame 5 lies on joint 4's axis (d4 along it) and frame 6 on joint 5's:
  // no torque; and frame 5 is frame 4 shifted along axes parallel to joints 2 and 3, so its
  // torque about them duplicates frame 4's.
  const RobotModel model = Ur10With({TermFamily::kCompliance, TermFamily::kHarmonics});
  const std::vector<std::string> expected = {
      "k2_3",  "k2_4",  "k2_6",  "k2_7",  "k3_4",  "k3_6",  "k3_7",  "k4_6",  "k4_7",  "k5_7",
      "e1_s1", "e1_c1", "e1_s2", "e1_c2", "e2_s1", "e2_c1", "e2_s2", "e2_c2", "e3_s1", "e3_c1",
      "e3_s2", "e3_c2", "e4_s1", "e4_c1", "e4_s2", "e4_c2", "e5_s1", "e5_c1", "e5_s2", "e5_c2"};
  EXPECT_EQ(TermNames(model), expected);
  EXPECT_EQ(model.num_parameters(), 39 + 30);
  EXPECT_EQ(model.UnitOf(model.IndexOf("k2_3")), ParameterUnit::kRad);
  EXPECT_EQ(model.UnitOf(model.IndexOf("e3_s2")), ParameterUnit::kRad);
  // Generating a family the model already has adds nothing.
  EXPECT_EQ(WithGeneratedTerms(model, {TermFamily::kHarmonics}).num_parameters(),
            model.num_parameters());
}

TEST(GeneratedTerms, ComplianceBasisIsTheGravityTorqueOfAUnitMass) {
  const RobotModel model = Ur10With({TermFamily::kCompliance});
  std::mt19937 rng(3);
  std::vector<double> f(model.nongeometric.size());
  for (const auto& q : RandomConfigurations(model, 10, rng, 3.0)) {
    EvaluateTerms(model, q.data(), f.data());
    // By hand: the upper arm (a2 = −612 mm) is horizontal at q2 = 0 and the elbow's lever
    // about the shoulder is 0.612 m · cos q2, whatever the other joints do.
    EXPECT_NEAR(f[0], 0.612 * std::cos(q(1)), 1e-12);
    // Virtual work: the torque about joint i is the derivative of the mass's fall along
    // gravity by θ_i (τ = −∂V/∂θ_i), here by central differences on the truncated chain.
    for (size_t k = 0; k < model.nongeometric.size(); ++k) {
      const auto& term = model.nongeometric[k];
      const double h = 1e-6;
      Eigen::VectorXd plus = q, minus = q;
      plus(term.joint) += h;
      minus(term.joint) -= h;
      const double torque_m =
          -(MassHeight(model, term.mass_at, plus) - MassHeight(model, term.mass_at, minus)) /
          (2 * h) / 1000.0;
      EXPECT_NEAR(f[k], torque_m, 1e-8) << term.name;
    }
  }
}

TEST(GeneratedTerms, GravityDirectionComesFromTheModel) {
  // The same arm hung on a wall (gravity along base −x): joint 1 now carries torques, from
  // the elbow on (frame 2 lies on joint 1's axis).
  RobotModel model = testing::Ur10();
  model.nongeometric.clear();
  model.gravity_in_base = -Eigen::Vector3d::UnitX();
  const RobotModel wall = WithGeneratedTerms(model, {TermFamily::kCompliance});
  ASSERT_FALSE(wall.nongeometric.empty());
  EXPECT_EQ(wall.nongeometric[0].name, "k1_3");
  const Eigen::VectorXd q = (Eigen::VectorXd(6) << 0.3, -0.8, 1.1, 0.2, 0.9, 0.0).finished();
  std::vector<double> f(wall.nongeometric.size());
  EvaluateTerms(wall, q.data(), f.data());
  for (size_t k = 0; k < wall.nongeometric.size(); ++k) {
    const auto& term = wall.nongeometric[k];
    const Eigen::VectorXd step = 1e-6 * Eigen::VectorXd::Unit(6, term.joint);
    const double torque_m =
        -(MassHeight(wall, term.mass_at, q + step) - MassHeight(wall, term.mass_at, q - step)) /
        2e-6 / 1000.0;
    EXPECT_NEAR(f[k], torque_m, 1e-8) << term.name;
  }
}

TEST(GeneratedTerms, HarmonicsAreSinAndCosOfTheJointsOwnAngle) {
  const RobotModel model = Ur10With({TermFamily::kHarmonics});
  const Eigen::VectorXd q = (Eigen::VectorXd(6) << 0.3, -0.8, 1.1, 0.2, 0.9, 2.0).finished();
  std::vector<double> f(model.nongeometric.size());
  EvaluateTerms(model, q.data(), f.data());
  for (int joint = 0; joint < 5; ++joint) {
    const double a = q(joint);
    const double expected[] = {std::sin(a), std::cos(a), std::sin(2 * a), std::cos(2 * a)};
    for (int k = 0; k < 4; ++k) {
      EXPECT_EQ(model.nongeometric[4 * joint + k].joint, joint);
      EXPECT_NEAR(f[4 * joint + k], expected[k], 1e-15);
    }
  }
  // Added to the joint's true angle.
  Eigen::VectorXd params = Eigen::VectorXd::Zero(model.num_parameters());
  params(model.IndexOf("e3_s2")) = 1e-3;
  params(model.IndexOf("e3_c1")) = -2e-3;
  Kinematics kin(model);
  double t[6];
  kin.TrueJointAngles(params, q.data(), t);
  EXPECT_NEAR(t[2], 1.1 + 1e-3 * std::sin(2.2) - 2e-3 * std::cos(1.1), 1e-15);
  EXPECT_EQ(t[1], q(1));
}

TEST(GeneratedTerms, AnalyticJacobianMatchesCentralDifferencesAndJets) {
  const RobotModel model = Ur10With({TermFamily::kCompliance, TermFamily::kHarmonics});
  constexpr int kParams = 69;
  ASSERT_EQ(model.num_parameters(), kParams);
  std::mt19937 rng(5);
  for (int trial = 0; trial < 10; ++trial) {
    const Eigen::VectorXd params = RandomParameters(model, 2.0, 5e-3, 3e-3, rng);
    const Eigen::VectorXd q = RandomConfigurations(model, 1, rng, 3.0)[0];
    Kinematics kin(model);
    Eigen::Matrix<double, 3, Eigen::Dynamic> analytic(3, kParams);
    const Eigen::Vector3d x = kin.PositionAndJacobian(LabBase(), params, q.data(), analytic);
    for (int k = 0; k < kParams; ++k) {
      const double h = model.UnitOf(k) == ParameterUnit::kMm ? 1e-3 : 1e-6;
      Eigen::VectorXd plus = params, minus = params;
      plus(k) += h;
      minus(k) -= h;
      const Eigen::Vector3d numeric =
          (kin.Position(LabBase(), plus, q.data()) - kin.Position(LabBase(), minus, q.data())) /
          (2 * h);
      EXPECT_LT((analytic.col(k) - numeric).norm(), 1e-6 * std::max(1.0, numeric.norm()))
          << model.ParameterNames()[k];
    }
    using Jet = ceres::Jet<double, kParams>;
    std::vector<Jet> p(kParams);
    for (int k = 0; k < kParams; ++k) p[k] = Jet(params(k), k);
    const Eigen::Matrix<Jet, 3, 1> y = TargetPosition(model, LabBase(), p.data(), q.data());
    for (int r = 0; r < 3; ++r) {
      EXPECT_NEAR(y(r).a, x(r), 1e-9);
      EXPECT_LT((y(r).v.transpose() - analytic.row(r)).norm(), 1e-9);
    }
  }
}

TEST(GeneratedTerms, PlantedComplianceIsRecoveredWithinPropagatedSigma) {
  const RobotModel model = Ur10With({TermFamily::kCompliance});
  std::mt19937 rng(21);
  const auto joints = RandomConfigurations(model, 300, rng, 3.0);
  // Stiffness-like coefficients of a few 1e-4 rad per unit mass and metre, 1e-3 for the
  // wrist (smaller gears; and their short levers need it to be seen at 0.02 mm noise).
  const Eigen::VectorXd truth = Truth(model, joints,
                                      {{"k2_3", 3e-4},
                                       {"k2_4", 1.5e-4},
                                       {"k2_6", -2e-4},
                                       {"k2_7", 1e-4},
                                       {"k3_4", 2.5e-4},
                                       {"k3_6", 5e-4},
                                       {"k3_7", -3e-4},
                                       {"k4_6", 1e-3},
                                       {"k4_7", 1e-3},
                                       {"k5_7", -1e-3}},
                                      1);
  const auto poses = SimulatePoses(model, LabBase(), truth, joints, kNoiseMm, rng);
  EstimationOptions o;
  o.parameters = ParseParameterSpec(model, "geometric,compliance");
  const auto r = Estimate(model, poses, o);
  ASSERT_TRUE(r.status.ok()) << r.status.message;
  int checked = 0;
  for (int k = model.num_geometric(); k < model.num_parameters(); ++k) {
    const std::string& name = model.nongeometric[k - model.num_geometric()].name;
    ASSERT_TRUE(std::isfinite(r.sigmas(k))) << name << " not identified";
    EXPECT_LT(std::abs(r.params(k) - truth(k)), 4.0 * r.sigmas(k)) << name;
    EXPECT_LT(r.sigmas(k), std::abs(truth(k)) / 3.0) << name << ": the data must resolve it";
    ++checked;
  }
  EXPECT_EQ(checked, 10);
  EXPECT_LT(r.sigma0_mm, 1.2 * kNoiseMm);  // nothing left but the noise
}

TEST(GeneratedTerms, PlantedHarmonicsAreRecoveredWithinPropagatedSigma) {
  const RobotModel model = Ur10With({TermFamily::kHarmonics});
  std::mt19937 rng(22);
  const auto joints = RandomConfigurations(model, 300, rng, 3.0);
  std::vector<std::pair<std::string, double>> planted;
  std::normal_distribution<double> amplitude(0.0, 2e-4);
  for (const auto& t : model.nongeometric) planted.push_back({t.name, amplitude(rng)});
  const Eigen::VectorXd truth = Truth(model, joints, planted, 2);
  const auto poses = SimulatePoses(model, LabBase(), truth, joints, kNoiseMm, rng);
  EstimationOptions o;
  o.parameters = ParseParameterSpec(model, "geometric,harmonics");
  const auto r = Estimate(model, poses, o);
  ASSERT_TRUE(r.status.ok()) << r.status.message;
  // A joint's cos θ is its own γ's constant offset plus a function no geometric parameter
  // makes: every harmonic is identifiable next to the geometric model.
  double chi2 = 0.0;
  for (int k = model.num_geometric(); k < model.num_parameters(); ++k) {
    const std::string& name = model.nongeometric[k - model.num_geometric()].name;
    ASSERT_TRUE(std::isfinite(r.sigmas(k))) << name << " not identified";
    EXPECT_LT(std::abs(r.params(k) - truth(k)), 4.0 * r.sigmas(k)) << name;
    EXPECT_LT(r.sigmas(k), 2e-5) << name;
    chi2 += std::pow((r.params(k) - truth(k)) / r.sigmas(k), 2);
  }
  // 20 standardised errors: their squares sum like χ²(20) (99.9 % below 45.3) when the
  // propagated sigmas are honest.
  EXPECT_LT(chi2, 45.3);
}

TEST(GeneratedTerms, CorrectedModelKeepsThemAsFixedValues) {
  // The exported model folds the geometric parameters into its links and keeps the terms'
  // values. Harmonics depend on the angles only: exact. Compliances are recomputed on the
  // corrected links, whose axes and levers differ from the nominal ones by the geometric
  // errors (1e-3 rad, mm in m): a second-order change, 0.011 mm here with all ten compliances
  // at 1e-3 rad per unit-mass metre (the UR10 split fits one, k2_4 = 1.1e-3) and 1 mrad errors.
  const RobotModel model = Ur10With({TermFamily::kCompliance, TermFamily::kHarmonics});
  std::mt19937 rng(41);
  Eigen::VectorXd params = RandomParameters(model, 0.5, 1e-3, 0.0, rng);
  for (int k = model.num_geometric(); k < model.num_parameters(); ++k) {
    params(k) = model.nongeometric[k - model.num_geometric()].family == TermFamily::kCompliance
                    ? 1e-3
                    : 2e-4;
  }
  Eigen::VectorXd harmonics_only = params;
  for (int k = model.num_geometric(); k < model.num_parameters(); ++k) {
    if (model.nongeometric[k - model.num_geometric()].family == TermFamily::kCompliance) {
      harmonics_only(k) = 0.0;
    }
  }
  for (const auto& [p, tolerance] : {std::pair{harmonics_only, 1e-9}, std::pair{params, 0.02}}) {
    const RobotModel corrected = CorrectedModel(model, p, LabBase());
    Kinematics calibrated(model), exported(corrected);
    const Eigen::VectorXd zero = Eigen::VectorXd::Zero(corrected.num_parameters());
    double worst = 0.0;
    for (const auto& q : RandomConfigurations(model, 50, rng, 3.0)) {
      worst = std::max(worst, (calibrated.Position(LabBase(), p, q.data()) -
                               exported.Position(*corrected.base, zero, q.data()))
                                  .norm());
    }
    EXPECT_LT(worst, tolerance);
  }
}

TEST(GeneratedTerms, ParameterListsNameFamilies) {
  const RobotModel model = Ur10With({TermFamily::kCompliance, TermFamily::kHarmonics});
  EXPECT_EQ(ParseParameterSpec(model, "geometric,compliance").size(), 39u + 10u);
  EXPECT_EQ(ParseParameterSpec(model, "geometric,harmonics,k2_3").size(), 39u + 21u);
  EXPECT_EQ(FamiliesNamedIn("geometric, harmonics,h2,compliance,harmonics"),
            (std::vector<TermFamily>{TermFamily::kHarmonics, TermFamily::kCompliance}));
  EXPECT_TRUE(FamiliesNamedIn("auto").empty());
  // A family the model does not have is an error that says how to get it.
  try {
    ParseParameterSpec(testing::Puma(), "geometric,compliance");
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("generated_terms"), std::string::npos) << e.what();
  }
}

TEST(TermSelection, AutoAddsThePlantedTermsAndNothingElse) {
  const RobotModel model = Ur10With({TermFamily::kCompliance, TermFamily::kHarmonics});
  std::mt19937 rng(31);
  const auto joints = RandomConfigurations(model, 400, rng, 3.0);
  // Terms whose functions no other candidate makes (k3_4: a3 cos(q2+q3) on joint 3).
  const Eigen::VectorXd truth = Truth(
      model, joints, {{"e2_s2", 2e-4}, {"e3_c1", -1.5e-4}, {"e5_s1", 3e-4}, {"k3_4", 2e-4}}, 3);
  const auto poses = SimulatePoses(model, LabBase(), truth, joints, kNoiseMm, rng);
  EstimationOptions o;
  o.parameters = ParseParameterSpec(model, "all");
  const auto selection = SelectTerms(model, poses, o);
  std::vector<std::string> added;
  for (int k : selection.parameters) {
    if (k >= model.num_geometric()) added.push_back(model.ParameterNames()[k]);
  }
  std::sort(added.begin(), added.end());
  EXPECT_EQ(added, (std::vector<std::string>{"e2_s2", "e3_c1", "e5_s1", "k3_4"}));
  // Every added term passed its F-test on the fitted models and lowered the CV error.
  int accepted = 0;
  double cv = selection.cv_mean_mm_geometric;
  for (const auto& t : selection.tests) {
    if (!t.accepted) continue;
    ++accepted;
    EXPECT_TRUE(t.significant);
    EXPECT_LT(t.cv_mean_mm, cv);
    cv = t.cv_mean_mm;
  }
  EXPECT_EQ(accepted, 4);
  // At the end the cross-validated error is the noise's: mean length of a 3-D
  // N(0, 0.02²) vector, 0.032 mm, against ~0.1 mm and more without the terms.
  EXPECT_LT(selection.cv_mean_mm, 0.036);
  EXPECT_GT(selection.cv_mean_mm_geometric, 0.06);
}

TEST(TermSelection, GeometricRobotGetsNoTerms) {
  const RobotModel model = Ur10With({TermFamily::kCompliance, TermFamily::kHarmonics});
  std::mt19937 rng(32);
  const auto joints = RandomConfigurations(model, 400, rng, 3.0);
  const auto poses =
      SimulatePoses(model, LabBase(), Truth(model, joints, {}, 4), joints, kNoiseMm, rng);
  EstimationOptions o;
  o.parameters = ParseParameterSpec(model, "all");
  const auto selection = SelectTerms(model, poses, o);
  EXPECT_EQ(selection.parameters, ParseParameterSpec(model, "geometric"));
  EXPECT_GE(selection.tests.size(), 30u);  // every candidate was tested
}

}  // namespace armsig::calibration
