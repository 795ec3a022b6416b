#include "io/model_yaml.h"

#include <gtest/gtest.h>

#include "core/error.h"
#include "test_support.h"

namespace armsig::io {

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

}  // namespace armsig::io
