#include "io/residual_map_json.h"

#include <fmt/format.h>

#include <cmath>
#include <set>
#include <stdexcept>

#include "core/error.h"
#include "core/text.h"

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
  // A whole number where one is meant: 180.5 knots is a damaged row, not 180.
  auto whole = [&](const nlohmann::json& value, const std::string& key) {
    if (!value.is_number_integer())
      throw fail(key, key + ": expected a whole number, got " + Quoted(JsonText(value), 40));
    return value.get<int>();
  };
  auto wholes = [&](const nlohmann::json& value, const std::string& key) {
    if (!value.is_array()) throw fail(key, key + ": expected an array of whole numbers");
    std::vector<int> out;
    for (const auto& v : value) out.push_back(whole(v, key));
    return out;
  };
  ResidualMapData map;
  try {
    map.version = whole(field("version"), "version");
    if (map.version < 1 || map.version > ResidualMapData::kVersion) {
      throw fail("version", "version " + std::to_string(map.version) +
                                " was written by a newer armsig (this one reads version " +
                                std::to_string(ResidualMapData::kVersion) + ")");
    }
    map.kind = field("kind").get<std::string>();
    map.output_frame = field("output_frame").get<std::string>();
    map.num_joints = whole(field("num_joints"), "num_joints");
    for (int j : wholes(field("joints"), "joints")) map.joints.push_back(j - 1);
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
      map.curves.knots = whole(c.at("knots"), "curves.knots");
      for (int j : wholes(c.at("joints"), "curves.joints")) map.curves.joints.push_back(j - 1);
      map.curves.smoothing = c.at("smoothing").get<double>();
      map.curves.values_rad = c.at("values_rad").get<std::vector<std::vector<double>>>();
      map.curves.measured = c.at("measured").get<std::vector<std::vector<int>>>();
    }
  } catch (const nlohmann::json::exception& e) {
    throw fail("", std::string("malformed field: ") + e.what());
  }
  // Every number within what a fitted map can hold (a stored row damaged or edited: weights of
  // 1e300 mm, a length scale of 1e-300, a joint curve of 1e300 rad would predict NaN or
  // positions metres off), named by its field.
  auto bounded = [&](const std::string& key, double value, double lo, double hi,
                     const char* unit) {
    if (std::isfinite(value) && value >= lo && value <= hi) return;
    throw fail(key, fmt::format("{} {:g} is outside what a fitted map holds ({:g} to {:g}{})",
                                key, value, lo, hi, unit));
  };
  bounded("length_scale", map.length_scale, 1e-3, 1e3, "");
  bounded("regularisation", map.regularisation, 1e-9, 1e6, "");
  bounded("noise_sigma_mm", map.noise_sigma_mm, 0.0, 100.0, " mm");
  bounded("support_radius", map.support_radius, 0.0, 1e3, "");
  for (double s : map.feature_scale) bounded("feature_scale", s, 1e-6, 1e6, "");
  for (const auto& c : map.centres_rad)
    for (double q : c) bounded("centres_rad", q, -100.0, 100.0, " rad");
  for (const auto& w : map.weights_mm)
    for (double v : w) bounded("weights_mm", v, -1e4, 1e4, " mm");
  if (!map.curves.values_rad.empty() || map.curves.knots != 0) {
    bounded("curves.smoothing", map.curves.smoothing, 0.0, 1e12, "");
    for (const auto& curve : map.curves.values_rad)
      for (double v : curve) bounded("curves.values_rad", v, -0.1, 0.1, " rad");
  }
  try {
    calibration::ResidualMap check(map);  // every consistency rule in one place
  } catch (const std::invalid_argument& e) {
    throw fail("", e.what());
  }
  return map;
}

}  // namespace armsig::io
