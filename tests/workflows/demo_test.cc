#include "workflows/demo.h"

#include <gtest/gtest.h>

#include "core/error.h"
#include "io/builtin_models.h"
#include "io/model_yaml.h"
#include "test_support.h"

namespace armsig::workflows {
namespace {

DemoLimits PumaLimits() {
  return DemoLimitsOf(io::ParseRobotModel(io::kPuma760Yaml, "built-in PUMA 760"), 1985);
}

std::string Refusal(int configurations, int select) {
  try {
    DemoSelectCount(configurations, select, PumaLimits());
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

}  // namespace

// The PUMA's 43 candidates with the target on the joint-6 axis: 29 identifiable (the
// paper's 25 geometric + h1…h4), so a fit needs 10 configurations (30 equations > 29),
// and the validation as many: 20 in all.
TEST(DemoLimits, ComeFromTheModelsIdentifiableParameters) {
  const DemoLimits limits = PumaLimits();
  EXPECT_EQ(limits.identifiable, 29);
  EXPECT_EQ(limits.min_fit, 10);
  EXPECT_EQ(limits.min_validation, 10);
  EXPECT_EQ(limits.min_configurations, 20);
}

TEST(DemoLimits, DefaultSelectionIsFortyPercentWithinTheLimits) {
  const DemoLimits limits = PumaLimits();
  EXPECT_EQ(DemoSelectCount(200, 0, limits), 80);  // the paper's 80 of ~200
  EXPECT_EQ(DemoSelectCount(60, 0, limits), 24);
  EXPECT_EQ(DemoSelectCount(20, 0, limits), 10);  // 8 would be too few to fit
  EXPECT_EQ(DemoSelectCount(60, 50, limits), 50);
  EXPECT_EQ(DemoSelectCount(60, 10, limits), 10);
}

TEST(DemoLimits, TooFewConfigurationsOrASelectionOutsideTheLimitsAreRefused) {
  const std::string few = Refusal(19, 0);
  EXPECT_NE(few.find("--configurations"), std::string::npos) << few;
  EXPECT_NE(few.find("at least 20"), std::string::npos) << few;
  const std::string many = Refusal(60, 51);  // leaves 9 to validate
  EXPECT_NE(many.find("--select"), std::string::npos) << many;
  EXPECT_NE(many.find("10…50"), std::string::npos) << many;
  EXPECT_NE(Refusal(60, 9).find("10…50"), std::string::npos);
  EXPECT_EQ(Refusal(60, 40), "");
}

}  // namespace armsig::workflows
