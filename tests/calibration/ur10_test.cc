// The real UR10 laser-tracker data (tests/data/ur10-ipa, MIT): calibrate on a selected
// subset of series C and validate on the held-out poses.
#include <gtest/gtest.h>

#include "calibration/estimation.h"
#include "calibration/selection.h"
#include "io/poses_csv.h"
#include "test_support.h"

namespace armsig::calibration {

TEST(Ur10RealData, GeometricModelValidatesBelowHalfAMillimetre) {
  const auto model = testing::Ur10();
  const auto poses =
      io::ImportPoses(testing::DataPath("ur10-ipa/series_C-measurements_random_poses.csv"),
                      io::PoseImportOptions::UrIpa());
  // Fit on every second pose, validate on the others (independent of the selection code).
  std::vector<MeasuredPose> fit, validation;
  for (size_t i = 0; i < poses.size(); ++i) (i % 2 ? validation : fit).push_back(poses[i]);
  EstimationOptions o;
  o.parameters = ParseParameterSpec(model, "geometric");
  const auto r = Estimate(model, fit, o);
  ASSERT_TRUE(r.status.ok()) << r.status.message;
  const auto nominal = Summarise(Distances(Residuals(
      model, r.world_from_base, Eigen::VectorXd::Zero(model.num_parameters()), validation)));
  const auto calibrated =
      Summarise(Distances(Residuals(model, r.world_from_base, r.params, validation)));
  // Reference figures: about 5.2 mm nominal, about 0.44 mm after a 39-parameter fit.
  EXPECT_GT(nominal.mean_mm, 3.0);
  EXPECT_LT(nominal.mean_mm, 8.0);
  // Even the in-sample fit on all 2,773 poses leaves 0.430 mm: this is the model's floor
  // on this robot, so held-out poses land at the reference's 0.44 mm, not below it.
  EXPECT_LT(calibrated.mean_mm, 0.45);
  EXPECT_LT(calibrated.mean_mm, 0.15 * nominal.mean_mm);
}

}  // namespace armsig::calibration
