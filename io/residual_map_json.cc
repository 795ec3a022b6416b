#include "io/residual_map_json.h"

#include <cmath>
#include <set>
#include <stdexcept>

#include "core/error.h"

namespace armsig::io {

using calibration::ResidualMapData;

nlohmann::json ResidualMapToJson(const ResidualMapData& map) {
  nlohmann::json joints = nlohmann::json::array();
  for (int j : map.joints) joints.push_back(j + 1);
  nlohmann::json weights = nlohmann::json::array();
  for (const auto& w : map.weights_mm) weights.push_back({w[0], w[1], w[2]});
  nlohmann::json out = {{"version", map.version},
          {"kind", map.kind},
          {"output_frame", map.output_frame},
          {"num_joints", map.num_joints},
          {"joints", joints},
          {"feature_scale", map.feature_scale},
          {"length_scale", map.length_scale},
          {"regularisation", map.regularisation},
          {"noise_sigma_mm", map.noise_sigma_mm},
          {"support_radius", map.support_radius},
          {"centres_rad", map.centres_rad},
          {"weights_mm", weights}};
  if (!map.curves.empty()) {
    nlohmann::json curve_joints = nlohmann::json::array();
    for (int j : map.curves.joints) curve_joints.push_back(j + 1);
    out["curves"] = {{"knots", map.curves.knots},
                     {"joints", curve_joints},
                     {"smoothing", map.curves.smoothing},
                     {"values_rad", map.curves.values_rad},
                     {"measured", map.curves.measured}};
  }
  return out;
}

nlohmann::json ResidualModelJson(const calibration::ResidualMapFit& fit) {
  const ResidualMapData& map = fit.map;
  const bool fitted = !map.centres_rad.empty();
  nlohmann::json grid = nlohmann::json::array();
  for (const auto& g : fit.grid) {
    grid.push_back({{"length_scale", g.length_scale},
                    {"regularisation", g.regularisation},
                    {"cv_mean_mm", g.cv_mean_mm}});
  }
  nlohmann::json hyperparameters = nullptr;
  if (fitted) {
    hyperparameters = {{"length_scale", map.length_scale},
                       {"regularisation", map.regularisation},
                       {"noise_sigma_mm", map.noise_sigma_mm},
                       {"support_radius", map.support_radius},
                       {"centres", map.centres_rad.size()}};
    if (!map.curves.empty()) {
      hyperparameters["curve_knots"] = map.curves.knots;
      hyperparameters["curve_smoothing"] = map.curves.smoothing;
    }
  }
  auto number = [](double v) {
    return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr);
  };
  return {{"used", fit.used},
          {"kind", fitted ? nlohmann::json(map.kind) : nlohmann::json(nullptr)},
          {"cv_mean_mm_parametric", number(fit.cv_mean_mm_parametric)},
          {"cv_mean_mm_with_map", number(fit.cv_mean_mm_with_map)},
          {"cv_mean_mm_curves", number(fit.cv_mean_mm_curves)},
          {"transfer",
           {{"folds", fit.transfer_folds},
            {"mean_mm_parametric", number(fit.transfer_mean_mm_parametric)},
            {"mean_mm_curves", number(fit.transfer_mean_mm_curves)},
            {"mean_mm_with_map", number(fit.transfer_mean_mm_with_map)}}},
          {"decision", fit.decision},
          {"hyperparameters", hyperparameters},
          {"grid", grid}};
}

ResidualMapData ResidualMapFromJson(const nlohmann::json& json, const std::string& source) {
  auto fail = [&](const std::string& field, const std::string& message) -> InputError {
    return InputError({source, 0, 0, field}, "residual map: " + message);
  };
  if (!json.is_object()) throw fail("", "expected a JSON object");
  static const std::set<std::string> kKeys = {"version",        "kind",           "output_frame",
                                              "num_joints",     "joints",         "feature_scale",
                                              "length_scale",   "regularisation", "noise_sigma_mm",
                                              "support_radius", "centres_rad",    "weights_mm",
                                              "curves"};
  for (const auto& item : json.items()) {
    if (!kKeys.count(item.key())) throw fail(item.key(), "unknown key '" + item.key() + "'");
  }
  auto field = [&](const char* key) -> const nlohmann::json& {
    if (!json.contains(key)) throw fail(key, std::string("missing '") + key + "'");
    return json.at(key);
  };
  ResidualMapData map;
  try {
    map.version = field("version").get<int>();
    if (map.version < 1 || map.version > ResidualMapData::kVersion) {
      throw fail("version", "version " + std::to_string(map.version) +
                                " was written by a newer armsig (this one reads version " +
                                std::to_string(ResidualMapData::kVersion) + ")");
    }
    map.kind = field("kind").get<std::string>();
    map.output_frame = field("output_frame").get<std::string>();
    map.num_joints = field("num_joints").get<int>();
    for (int j : field("joints").get<std::vector<int>>()) map.joints.push_back(j - 1);
    map.feature_scale = field("feature_scale").get<std::vector<double>>();
    map.length_scale = field("length_scale").get<double>();
    map.regularisation = field("regularisation").get<double>();
    map.noise_sigma_mm = field("noise_sigma_mm").get<double>();
    map.support_radius = field("support_radius").get<double>();
    map.centres_rad = field("centres_rad").get<std::vector<std::vector<double>>>();
    map.weights_mm = field("weights_mm").get<std::vector<std::array<double, 3>>>();
    if (json.contains("curves")) {
      const nlohmann::json& c = json.at("curves");
      static const std::set<std::string> kCurveKeys = {"knots", "joints", "smoothing",
                                                       "values_rad", "measured"};
      if (!c.is_object()) throw fail("curves", "expected a JSON object");
      for (const auto& item : c.items()) {
        if (!kCurveKeys.count(item.key()))
          throw fail("curves." + item.key(), "unknown key '" + item.key() + "'");
      }
      for (const char* key : {"knots", "joints", "smoothing", "values_rad", "measured"}) {
        if (!c.contains(key)) throw fail(std::string("curves.") + key, std::string("missing '") + key + "'");
      }
      map.curves.knots = c.at("knots").get<int>();
      for (int j : c.at("joints").get<std::vector<int>>()) map.curves.joints.push_back(j - 1);
      map.curves.smoothing = c.at("smoothing").get<double>();
      map.curves.values_rad = c.at("values_rad").get<std::vector<std::vector<double>>>();
      map.curves.measured = c.at("measured").get<std::vector<std::vector<int>>>();
    }
  } catch (const nlohmann::json::exception& e) {
    throw fail("", std::string("malformed field: ") + e.what());
  }
  try {
    calibration::ResidualMap check(map);  // every consistency rule in one place
  } catch (const std::invalid_argument& e) {
    throw fail("", e.what());
  }
  return map;
}

}  // namespace armsig::io
