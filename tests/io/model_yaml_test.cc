#include "io/model_yaml.h"

#include <gtest/gtest.h>

#include <filesystem>

#include <Eigen/Geometry>
#include <random>

#include "calibration/model.h"
#include "core/error.h"
#include "io/model_export.h"
#include "test_support.h"

namespace armsig::io {

namespace {
InputError ModelRefusal(const std::string& text) {
  try {
    ParseRobotModel(text, "m.yaml");
  } catch (const InputError& e) {
    return e;
  }
  ADD_FAILURE() << "expected an InputError for\n" << text;
  return InputError("none");
}
const char* kOneLink = "links:\n  - [[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]\n";
}  // namespace

TEST(ModelYaml, LoadsThePaperPuma) {
  const auto model = testing::Puma();
  EXPECT_EQ(model.num_joints(), 6);
  EXPECT_EQ(model.num_geometric(), 39);
  EXPECT_EQ(model.num_parameters(), 43);
  EXPECT_FALSE(model.base.has_value());  // auto
  // Paper N3: upper arm 650 mm along x, 50 mm offset along z.
  EXPECT_DOUBLE_EQ(model.links[1].translation().x(), 650.0);
  EXPECT_DOUBLE_EQ(model.links[1].translation().z(), 50.0);
  EXPECT_EQ(model.ParameterNames().front(), "a1");
  EXPECT_EQ(model.ParameterNames()[38], "c7");
  EXPECT_EQ(model.ParameterNames()[42], "h4");
  ASSERT_EQ(model.nongeometric.size(), 4u);
  EXPECT_EQ(model.nongeometric[3].joint, 2);  // joint 3, 0-based
  EXPECT_EQ(model.nongeometric[3].basis, calibration::NongeometricTerm::Basis::kSignCos);
}

TEST(ModelYaml, DhRowsFoldTheLastLinkIntoTheTool) {
  const auto model = testing::Ur10();
  EXPECT_EQ(model.num_joints(), 6);
  // Last DH row Tz(92.2) then the probe 109 mm along the flange axis.
  EXPECT_NEAR(model.tool_mm.z(), 92.2 + 109.0, 1e-9);
  EXPECT_NEAR(model.links[1].translation().x(), -612.0, 1e-9);
}

TEST(ModelYaml, MalformedYamlNamesLineAndColumn) {
  try {
    ParseRobotModel("name: x\nlinks: [[1,0,0,0],\n  - oops\n", "bad.yaml");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(e.where().file, "bad.yaml");
    EXPECT_GT(e.where().line, 0);
  }
}

TEST(ModelYaml, BadMatrixEntryNamesItsPosition) {
  const std::string text =
      "name: x\n"
      "links:\n"
      "  - [[1,0,0,0],[0,1,0,0],[0,0,1,zz],[0,0,0,1]]\n";
  try {
    ParseRobotModel(text, "m.yaml");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(e.where().line, 3);
    EXPECT_NE(std::string(e.what()).find("'zz'"), std::string::npos);
  }
}

TEST(ModelYaml, RejectsNonRotationAndBadTerms) {
  EXPECT_THROW(ParseRobotModel("links:\n  - [[2,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]\n", "m"),
               InputError);
  EXPECT_THROW(ParseRobotModel("links:\n  - [[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]\n"
                               "nongeometric:\n  - {name: h1, joint: 5, basis: cos, of: [1]}\n",
                               "m"),
               InputError);
  EXPECT_THROW(ParseRobotModel("links:\n  - [[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]\n"
                               "nongeometric:\n  - {name: h1, joint: 1, basis: tan, of: [1]}\n",
                               "m"),
               InputError);
  EXPECT_THROW(ParseRobotModel("name: nolinks\n", "m"), InputError);
}

// Today a typo in tool_mm would drop a 109 mm tool without a word: it is refused.
TEST(ModelYaml, MisspeltKeyIsRefusedWithLineAndSuggestion) {
  const InputError e = ModelRefusal(std::string("name: x\n") + kOneLink + "tool_m: [0, 0, 109]\n");
  EXPECT_STREQ(e.what(), "m.yaml:4:1: unknown key 'tool_m' (did you mean 'tool_mm'?)");
}

TEST(ModelYaml, MisspeltKeyInsideAListItemIsRefused) {
  const InputError term = ModelRefusal(
      std::string(kOneLink) + "nongeometric:\n  - {name: h1, joint: 1, bases: cos, of: [1]}\n");
  EXPECT_STREQ(term.what(), "m.yaml:4:26: unknown key 'bases' (did you mean 'basis'?)");
  const InputError dh = ModelRefusal("dh:\n  - {d_mm: 1, a_mm: 0, alpha_dg: 90}\n");
  EXPECT_STREQ(dh.what(), "m.yaml:2:24: unknown key 'alpha_dg' (did you mean 'alpha_deg'?)");
}

TEST(ModelYaml, WrongShapeNamesPositionAndWhatWasExpected) {
  const InputError tool = ModelRefusal(std::string(kOneLink) + "tool_mm: {x: 1}\n");
  EXPECT_STREQ(tool.what(),
               "m.yaml:3:10 (tool_mm): expected a list of 3 numbers [x, y, z], got a mapping");
  const InputError link = ModelRefusal("links:\n  - 42\n");
  EXPECT_STREQ(link.what(),
               "m.yaml:2:5 (links): expected a 4x4 matrix as a list of 4 rows, got '42'");
  const InputError joint = ModelRefusal(
      std::string(kOneLink) + "nongeometric:\n  - {name: h1, joint: 1.5, basis: cos, of: [1]}\n");
  EXPECT_EQ(joint.where().line, 4);
  EXPECT_EQ(joint.message(), "expected an integer from 1 to 2, got '1.5'");
  const InputError base = ModelRefusal(std::string(kOneLink) + "base: identity\n");
  EXPECT_EQ(base.message(), "expected 'auto' or a 4x4 matrix, got 'identity'");
}

// Issue 38: `of: [2, 2, 2]` was read as cos(3 q2) under a name that says three joints.
TEST(ModelYaml, AJointListedTwiceInATermIsRefusedAtItsPosition) {
  const std::string two_links =
      "links:\n  - [[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]\n"
      "  - [[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]\n";
  const InputError e = ModelRefusal(
      two_links + "nongeometric:\n  - {name: h1, joint: 1, basis: cos, of: [2, 1, 2]}\n");
  EXPECT_EQ(e.where().line, 5);
  EXPECT_EQ(e.where().column, 49);  // the second 2
  EXPECT_EQ(e.message(),
            "joint 2 is listed twice in 'of' (expected distinct joints; a harmonic of one joint "
            "is 'of: [2]' with 'order: N')");
  EXPECT_NO_THROW(ParseRobotModel(
      two_links + "nongeometric:\n  - {name: h1, joint: 1, basis: cos, of: [2, 1], order: 3}\n",
      "m.yaml"));
}

TEST(ModelYaml, GeneratedTermsAndGravityAreRead) {
  // The UR10 file asks for both families: its h1…h4, then 10 compliances and 20 harmonics.
  const auto ur10 = testing::Ur10();
  ASSERT_EQ(ur10.num_parameters(), 39 + 4 + 30);
  EXPECT_EQ(ur10.ParameterNames()[43], "k2_3");
  EXPECT_EQ(ur10.nongeometric[4].basis, calibration::NongeometricTerm::Basis::kGravityTorque);
  EXPECT_EQ(ur10.nongeometric[4].family, calibration::TermFamily::kCompliance);
  EXPECT_EQ(ur10.ParameterNames().back(), "e5_c2");
  EXPECT_EQ(ur10.gravity_in_base, Eigen::Vector3d(0, 0, -1));
  // Gravity is a direction: any length, normalised; it changes which terms exist.
  const std::string dh = testing::ReadText(testing::SourcePath("models/ur10.yaml"));
  const auto wall = ParseRobotModel(dh + "gravity: [-2, 0, 0]\n", "wall.yaml");
  EXPECT_EQ(wall.gravity_in_base, Eigen::Vector3d(-1, 0, 0));
  EXPECT_NE(wall.IndexOf("k1_3"), -1);  // joint 1 carries torque on a wall
  EXPECT_EQ(ur10.IndexOf("k1_3"), -1);
  // Explicit entries of the new bases.
  const auto explicit_terms = ParseRobotModel(
      std::string(kOneLink) +
          "nongeometric:\n"
          "  - {name: s, joint: 1, basis: sin, of: [1], order: 2, value_rad: 1e-4}\n"
          "  - {name: k, joint: 1, basis: gravity_torque, mass_at: 3, value_rad: 2e-4}\n"
          "gravity: [1, 0, 0]\n",
      "m.yaml");
  ASSERT_EQ(explicit_terms.nongeometric.size(), 2u);
  EXPECT_EQ(explicit_terms.nongeometric[0].order, 2);
  EXPECT_EQ(explicit_terms.nongeometric[0].fixed_rad, 1e-4);
  EXPECT_EQ(explicit_terms.nongeometric[1].mass_at, 2);  // 0-based: the target of 2 joints
  EXPECT_EQ(explicit_terms.nongeometric[1].fixed_rad, 2e-4);
}

TEST(ModelYaml, RefusesMisusedTermKeys) {
  const std::string terms = std::string(kOneLink) + "nongeometric:\n  - ";
  EXPECT_EQ(ModelRefusal(std::string(kOneLink) + "generated_terms: [thermal]\n").message(),
            "expected 'compliance' or 'harmonics', got 'thermal'");
  EXPECT_EQ(ModelRefusal(terms + "{name: k, joint: 1, basis: gravity_torque, of: [1]}\n").message(),
            "a gravity_torque term takes 'mass_at', not 'of'");
  EXPECT_EQ(
      ModelRefusal(terms + "{name: k, joint: 1, basis: gravity_torque, mass_at: 1}\n").message(),
      "expected an integer from 2 to 3, got '1'");  // a mass after the joint
  EXPECT_EQ(
      ModelRefusal(terms + "{name: h, joint: 1, basis: sign_cos, of: [1], order: 2}\n").message(),
      "only cos and sin terms take a harmonic 'order'");
  EXPECT_EQ(ModelRefusal(std::string(kOneLink) + "gravity: [0, 0, 0]\n").message(),
            "expected a non-zero direction [x, y, z]");
  // A generated name already taken by the file's own terms (the tool off the axes, so
  // both joints move it and have harmonics).
  EXPECT_NE(ModelRefusal(terms + "{name: e1_s1, joint: 1, basis: cos, of: [1]}\n" +
                         "tool_mm: [100, 0, 0]\ngenerated_terms: [harmonics]\n")
                .message()
                .find("'e1_s1'"),
            std::string::npos);
}

TEST(ModelYaml, EveryShippedModelLoads) {
  int models = 0;
  for (const auto& entry : std::filesystem::directory_iterator(testing::SourcePath("models"))) {
    if (entry.path().extension() != ".yaml") continue;
    ++models;
    EXPECT_EQ(LoadRobotModel(entry.path().string()).num_joints(), 6) << entry.path();
  }
  EXPECT_EQ(models, 4);  // puma760, ur10, kr16_2, irb4600
}

TEST(ModelExport, FormattedModelReadsBackToTheSameNumbers) {
  calibration::RobotModel model = testing::Ur10();
  Eigen::Isometry3d base = Eigen::Isometry3d::Identity();
  base.rotate(Eigen::AngleAxisd(0.123, Eigen::Vector3d(0.3, -1, 2).normalized()));
  base.translation() = Eigen::Vector3d(1500.0 / 7.0, -0.1, 2.5e-7);
  model.base = base;
  for (size_t k = 0; k < model.nongeometric.size(); ++k) {
    model.nongeometric[k].fixed_rad = 1e-4 / static_cast<double>(k + 3);
  }
  const std::string text = FormatRobotModelYaml(model, "corrected ur10");
  EXPECT_EQ(text.rfind("# corrected ur10\n", 0), 0u) << text;
  const calibration::RobotModel back = ParseRobotModel(text, "export");
  EXPECT_EQ(back.name, model.name);
  ASSERT_TRUE(back.base.has_value());
  EXPECT_EQ(back.base->matrix(), model.base->matrix());
  ASSERT_EQ(back.links.size(), model.links.size());
  for (size_t i = 0; i < model.links.size(); ++i) {
    EXPECT_EQ(back.links[i].matrix(), model.links[i].matrix()) << "link " << i;
  }
  EXPECT_EQ(back.tool_mm, model.tool_mm);
  ASSERT_EQ(back.nongeometric.size(), model.nongeometric.size());
  for (size_t k = 0; k < model.nongeometric.size(); ++k) {
    EXPECT_EQ(back.nongeometric[k].name, model.nongeometric[k].name);
    EXPECT_EQ(back.nongeometric[k].joint, model.nongeometric[k].joint);
    EXPECT_EQ(back.nongeometric[k].basis, model.nongeometric[k].basis);
    EXPECT_EQ(back.nongeometric[k].of, model.nongeometric[k].of);
    EXPECT_EQ(back.nongeometric[k].fixed_rad, model.nongeometric[k].fixed_rad);
    // Generated terms too (order, mass, family): the whole term reads back.
    EXPECT_TRUE(back.nongeometric[k] == model.nongeometric[k]) << model.nongeometric[k].name;
  }
  EXPECT_EQ(back.gravity_in_base, model.gravity_in_base);
  ASSERT_EQ(back.joint_min_rad.size(), 6u);
  for (int i = 0; i < 6; ++i) {
    EXPECT_NEAR(back.joint_min_rad[i], model.joint_min_rad[i], 1e-14);  // via degrees
    EXPECT_NEAR(back.joint_max_rad[i], model.joint_max_rad[i], 1e-14);
  }
}

}  // namespace armsig::io

namespace armsig::io {
namespace {

// The IRB 4600-40/2.55 file against the same arm written the other way ROS-Industrial's
// abb_irb4600_support writes it (irb4600_40_255_macro.xacro): each joint a translation then
// a rotation about a base axis, ABB's joint zero and directions. The reflector sits 100 mm
// beyond the flange and 40 mm above its axis (flange frame: x along the axis, z up at zero).
TEST(ModelYaml, Irb4600IsAbbsJointZeroAndDirections) {
  const calibration::RobotModel model = LoadRobotModel(testing::SourcePath("models/irb4600.yaml"));
  ASSERT_EQ(model.num_joints(), 6);
  calibration::Kinematics kinematics(model);
  const Eigen::VectorXd nominal = Eigen::VectorXd::Zero(model.num_parameters());
  auto urdf = [](const Eigen::VectorXd& q) {
    using T = Eigen::Translation3d;
    using A = Eigen::AngleAxisd;
    const Eigen::Vector3d x = Eigen::Vector3d::UnitX(), y = Eigen::Vector3d::UnitY(),
                          z = Eigen::Vector3d::UnitZ();
    const Eigen::Isometry3d flange = T(0, 0, 495) * A(q(0), z) * T(175, 0, 0) * A(q(1), y) *
                                     T(0, 0, 1095) * A(q(2), y) * T(0, 0, 175) * A(q(3), x) *
                                     T(1270, 0, 0) * A(q(4), y) * T(135, 0, 0) * A(q(5), x);
    return Eigen::Vector3d(flange * Eigen::Vector3d(100, 0, 40));
  };
  const Eigen::VectorXd zero = Eigen::VectorXd::Zero(6);
  EXPECT_LT((kinematics.Position(Eigen::Isometry3d::Identity(), nominal, zero.data()) -
             Eigen::Vector3d(1680, 0, 1805))
                .norm(),
            1e-9);
  std::mt19937 rng(4600);
  for (int k = 0; k < 50; ++k) {
    Eigen::VectorXd q(6);
    for (int i = 0; i < 6; ++i) {
      q(i) = std::uniform_real_distribution<double>(model.joint_min_rad[static_cast<size_t>(i)],
                                                    model.joint_max_rad[static_cast<size_t>(i)])(rng);
    }
    EXPECT_LT((kinematics.Position(Eigen::Isometry3d::Identity(), nominal, q.data()) - urdf(q))
                  .norm(),
              1e-9)
        << q.transpose();
  }
}

}  // namespace
}  // namespace armsig::io

namespace armsig::io {

// tool_mounting: known (the target on a machined adapter at tool_mm) reads and writes back;
// fitted is the default and is not written.
TEST(ModelYaml, AKnownToolMountingReadsAndWritesBack) {
  const std::string text = std::string("name: x\n") + kOneLink + "tool_mm: [40, 0, 235]\ntool_mounting: known\n";
  const calibration::RobotModel model = ParseRobotModel(text, "m.yaml");
  EXPECT_EQ(model.tool_mounting, calibration::ToolMounting::kKnown);
  EXPECT_EQ(model.num_geometric(), 6 * 2 + 3 + 2);
  EXPECT_EQ(model.ParameterNames()[15], "alpha3");
  const std::string written = FormatRobotModelYaml(model, "");
  EXPECT_NE(written.find("tool_mounting: known"), std::string::npos) << written;
  const calibration::RobotModel back = ParseRobotModel(written, "w.yaml");
  EXPECT_TRUE(calibration::ModelDifferences(model, back).empty());
  EXPECT_EQ(back.tool_mounting, calibration::ToolMounting::kKnown);

  const calibration::RobotModel fitted =
      ParseRobotModel(std::string(kOneLink) + "tool_mm: [40, 0, 235]\ntool_mounting: fitted\n", "m.yaml");
  EXPECT_EQ(fitted.tool_mounting, calibration::ToolMounting::kFitted);
  EXPECT_EQ(fitted.num_geometric(), 15);
  EXPECT_EQ(FormatRobotModelYaml(fitted, "").find("tool_mounting"), std::string::npos);
  EXPECT_EQ(testing::Ur10().tool_mounting, calibration::ToolMounting::kFitted);
}

TEST(ModelYaml, AKnownToolMountingWithoutALeverIsRefused) {
  const InputError none = ModelRefusal(std::string(kOneLink) + "tool_mm: [0, 0.5, 0.5]\ntool_mounting: known\n");
  EXPECT_EQ(none.where().line, 4);
  EXPECT_NE(std::string(none.what()).find("m.yaml:4:16 (tool_mounting): 'tool_mounting: known' needs the target at "
                                          "least 1 mm from the last joint's frame"),
            std::string::npos)
      << none.what();
  const InputError word = ModelRefusal(std::string(kOneLink) + "tool_mm: [0, 0, 100]\ntool_mounting: measured\n");
  EXPECT_STREQ(word.what(), "m.yaml:4:16 (tool_mounting): expected tool_mounting 'known' or 'fitted', got 'measured'");
}

}  // namespace armsig::io
