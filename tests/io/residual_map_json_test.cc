#include "io/residual_map_json.h"

#include <gtest/gtest.h>

#include <random>

#include "calibration/estimation.h"
#include "calibration/synthetic.h"
#include "core/error.h"
#include "test_support.h"

namespace armsig::io {
namespace {

using calibration::ResidualMap;
using calibration::ResidualMapData;

// A small fitted map: a PUMA with an error the geometric model cannot make.
calibration::ResidualMapFit Fit() {
  const auto model = testing::Puma();
  std::mt19937 rng(1);
  const auto joints = calibration::RandomConfigurations(model, 60, rng);
  auto poses = calibration::SimulatePoses(model, Eigen::Isometry3d::Identity(),
                                          calibration::PaperTable3Parameters(), joints, 0.02, rng);
  for (auto& p : poses) p.target_in_world.x() += 0.3 * std::sin(p.joints_rad(1) + p.joints_rad(2));
  calibration::EstimationOptions o;
  o.parameters = calibration::ParseParameterSpec(model, "geometric");
  const auto fit = calibration::Estimate(model, poses, o);
  calibration::ResidualMapOptions kernel_only;  // a map as stored before the joint curves
  kernel_only.curve_knots = 0;
  return calibration::FitResidualMap(model, fit, poses, kernel_only);
}
ResidualMapData FittedMap() { return Fit().map; }

// A map with joint curves: the PUMA's joint 2 off by 30″ sin 12θ̄ (a curve of its own angle).
ResidualMapData CurveMap() {
  const auto model = testing::Puma();
  std::mt19937 rng(4);
  auto joints = calibration::RandomConfigurations(model, 200, rng);
  auto actual = joints;
  for (auto& q : actual) q(1) += 30.0 / 206264.8 * std::sin(12 * q(1));
  auto poses = calibration::SimulatePoses(model, Eigen::Isometry3d::Identity(),
                                          calibration::PaperTable3Parameters(), actual, 0.01, rng);
  for (size_t i = 0; i < poses.size(); ++i) poses[i].joints_rad = joints[i];
  calibration::EstimationOptions o;
  o.parameters = calibration::ParseParameterSpec(model, "geometric");
  return calibration::FitResidualMap(model, calibration::Estimate(model, poses, o), poses).map;
}

InputError MapJsonRefusal(const nlohmann::json& json) {
  try {
    ResidualMapFromJson(json, "set 3");
  } catch (const InputError& e) {
    return e;
  }
  ADD_FAILURE() << "expected an InputError for " << json.dump().substr(0, 200);
  return InputError("none");
}

}  // namespace

TEST(ResidualMapJson, RoundTripKeepsEveryPrediction) {
  const ResidualMapData map = FittedMap();
  ASSERT_FALSE(map.centres_rad.empty());
  const nlohmann::json json = ResidualMapToJson(map);
  EXPECT_EQ(json["kind"], "gaussian_kernel_ridge");
  // Without joint curves, written as before them (version 1).
  ASSERT_TRUE(map.curves.empty());
  EXPECT_EQ(json["version"], 1);
  EXPECT_FALSE(json.contains("curves"));
  EXPECT_EQ(json["joints"], nlohmann::json::array({1, 2, 3, 4, 5}));  // 1-based in files
  const ResidualMapData back = ResidualMapFromJson(nlohmann::json::parse(json.dump()), "set 3");
  EXPECT_EQ(back.joints, map.joints);
  EXPECT_EQ(back.centres_rad, map.centres_rad);
  EXPECT_EQ(back.weights_mm, map.weights_mm);
  EXPECT_EQ(back.feature_scale, map.feature_scale);
  const ResidualMap a(map), b(back);
  std::mt19937 rng(2);
  for (const auto& q : calibration::RandomConfigurations(testing::Puma(), 20, rng)) {
    const auto pa = a.Predict(q.data()), pb = b.Predict(q.data());
    EXPECT_EQ(pa.supported, pb.supported);
    EXPECT_EQ(pa.correction_in_base_mm, pb.correction_in_base_mm);  // bit for bit
    EXPECT_EQ(a.CorrectionSigmaMm(q.data()), b.CorrectionSigmaMm(q.data()));
  }
}

TEST(ResidualMapJson, JointCurvesRoundTripBitForBit) {
  const ResidualMapData map = CurveMap();
  ASSERT_FALSE(map.curves.empty());
  const nlohmann::json json = ResidualMapToJson(map);
  EXPECT_EQ(json["version"], 2);
  EXPECT_EQ(json["curves"]["knots"], map.curves.knots);
  EXPECT_EQ(json["curves"]["joints"][0], map.curves.joints[0] + 1);  // 1-based in files
  const ResidualMapData back = ResidualMapFromJson(nlohmann::json::parse(json.dump()), "set 4");
  EXPECT_EQ(back.curves.values_rad, map.curves.values_rad);
  EXPECT_EQ(back.curves.measured, map.curves.measured);
  EXPECT_EQ(back.curves.smoothing, map.curves.smoothing);
  const ResidualMap a(map), b(back);
  std::mt19937 rng(5);
  for (const auto& q : calibration::RandomConfigurations(testing::Puma(), 20, rng)) {
    Eigen::VectorXd qa(q.size()), qb(q.size());
    EXPECT_EQ(a.CorrectJoints(q.data(), qa.data()), b.CorrectJoints(q.data(), qb.data()));
    EXPECT_EQ(qa, qb);
  }
  nlohmann::json j = json;
  j["curves"]["colour"] = "red";
  EXPECT_EQ(MapJsonRefusal(j).message(), "residual map: unknown key 'colour'");
  j = json;
  j["curves"].erase("measured");
  EXPECT_EQ(MapJsonRefusal(j).message(), "residual map: missing 'measured'");
  j = json;
  j["curves"]["values_rad"][0].erase(0);
  EXPECT_NE(MapJsonRefusal(j).message().find("one value and one measured flag per knot"),
            std::string::npos);
  j = json;
  j["version"] = 1;
  EXPECT_NE(MapJsonRefusal(j).message().find("version-1 map has no joint curves"), std::string::npos);
}

TEST(ResidualMapJson, RefusesWhatItCannotUse) {
  const nlohmann::json good = ResidualMapToJson(FittedMap());
  nlohmann::json j = good;
  j["colour"] = "red";
  EXPECT_EQ(MapJsonRefusal(j).message(), "residual map: unknown key 'colour'");
  j = good;
  j["version"] = 3;
  EXPECT_NE(MapJsonRefusal(j).message().find("newer armsig"), std::string::npos);
  j = good;
  j.erase("weights_mm");
  EXPECT_EQ(MapJsonRefusal(j).message(), "residual map: missing 'weights_mm'");
  j = good;
  j["length_scale"] = "wide";
  EXPECT_NE(MapJsonRefusal(j).message().find("malformed"), std::string::npos);
  j = good;
  j["weights_mm"].erase(0);
  EXPECT_NE(MapJsonRefusal(j).message().find("one weight vector per centre"), std::string::npos);
  j = good;
  j["joints"][0] = 7;
  EXPECT_NE(MapJsonRefusal(j).message().find("out of range"), std::string::npos);
  EXPECT_EQ(MapJsonRefusal(j).where().file, "set 3");
}

// Absurd finite numbers in a stored map (a damaged or edited row) are refused naming their
// field, as a file's would be: they would predict NaN or positions metres off.
TEST(ResidualMapJson, RefusesNumbersNoFittedMapHolds) {
  const nlohmann::json good = ResidualMapToJson(FittedMap());
  const nlohmann::json curved = ResidualMapToJson(CurveMap());
  ASSERT_TRUE(curved.contains("curves"));
  EXPECT_NO_THROW(ResidualMapFromJson(good, "set 3"));
  EXPECT_NO_THROW(ResidualMapFromJson(curved, "set 3"));
  const auto refused = [](nlohmann::json j, const std::string& field, const std::string& words) {
    const InputError e = MapJsonRefusal(j);
    EXPECT_EQ(e.where().column_name, field) << e.message();
    EXPECT_NE(e.message().find(words), std::string::npos) << e.message();
  };
  nlohmann::json j = good;
  j["weights_mm"][0][1] = 1e300;
  refused(j, "weights_mm", "weights_mm 1e+300 is outside what a fitted map holds");
  j = good;
  j["length_scale"] = 1e-300;
  refused(j, "length_scale", "length_scale 1e-300 is outside");
  j = good;
  j["noise_sigma_mm"] = 5e3;
  refused(j, "noise_sigma_mm", "noise_sigma_mm 5000 is outside");
  j = good;
  j["centres_rad"][0][0] = -1e200;
  refused(j, "centres_rad", "centres_rad -1e+200 is outside");
  j = curved;
  j["curves"]["values_rad"][0][3] = 1e300;
  refused(j, "curves.values_rad", "curves.values_rad 1e+300 is outside");
  j = curved;
  j["curves"]["knots"] = 180.5;
  refused(j, "curves.knots", "curves.knots: expected a whole number, got '180.5'");
  j = good;
  j["num_joints"] = 6.5;
  refused(j, "num_joints", "expected a whole number");
}

TEST(ResidualMapJson, ResidualModelSummaryHasTheSpecShape) {
  const calibration::ResidualMapFit fit = Fit();
  const nlohmann::json j = ResidualModelJson(fit);
  EXPECT_EQ(j["used"], fit.used);
  EXPECT_EQ(j["kind"], "gaussian_kernel_ridge");
  EXPECT_EQ(j["cv_mean_mm_parametric"], fit.cv_mean_mm_parametric);
  EXPECT_EQ(j["cv_mean_mm_with_map"], fit.cv_mean_mm_with_map);
  EXPECT_EQ(j["hyperparameters"]["length_scale"], fit.map.length_scale);
  EXPECT_EQ(j["hyperparameters"]["regularisation"], fit.map.regularisation);
  EXPECT_EQ(j["hyperparameters"]["centres"], fit.map.centres_rad.size());
  EXPECT_EQ(j["grid"].size(), fit.grid.size());
  // Too few poses: no map, and the JSON says so with nulls rather than numbers.
  calibration::ResidualMapFit none;
  none.decision = "too few poses";
  const nlohmann::json n = ResidualModelJson(none);
  EXPECT_FALSE(n["used"]);
  EXPECT_TRUE(n["kind"].is_null());
  EXPECT_TRUE(n["hyperparameters"].is_null());
  EXPECT_TRUE(n["cv_mean_mm_with_map"].is_null());
  EXPECT_TRUE(n["cv_mean_mm_parametric"].is_null());
}

}  // namespace armsig::io
