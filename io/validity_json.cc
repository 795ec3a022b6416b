#include "io/validity_json.h"

#include <cmath>
#include <numbers>

#include "core/error.h"

namespace armsig::io {

namespace {

nlohmann::json Number(double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(); }

}  // namespace

nlohmann::json ValidityToJson(const calibration::SetValidity& v) {
  nlohmann::json arcs = nlohmann::json::array();
  for (const auto& a : v.term_arcs) arcs.push_back({a.start_rad, a.length_rad});
  return {{"term_arcs_rad", arcs},
          {"sigma",
           {{"inside_mm", Number(v.sigma_inside_mm)},
            {"outside_mm", Number(v.sigma_outside_mm)},
            {"coverage_inside", Number(v.coverage_inside)},
            {"coverage_outside", Number(v.coverage_outside)},
            {"outside_folds", v.outside_folds}}}};
}

calibration::SetValidity ValidityFromJson(const nlohmann::json& json, int num_joints,
                                          const std::string& source) {
  auto fail = [&](const std::string& field, const std::string& message) {
    return InputError({source, 0, 0, field}, "validity: " + message);
  };
  constexpr double kTurn = 2.0 * std::numbers::pi;
  if (!json.is_object()) throw fail("", "expected a JSON object");
  calibration::SetValidity v;
  const auto arcs = json.find("term_arcs_rad");
  if (arcs == json.end() || !arcs->is_array()) throw fail("term_arcs_rad", "expected an array");
  if (static_cast<int>(arcs->size()) != num_joints) {
    throw fail("term_arcs_rad", "expected one arc per joint (" + std::to_string(num_joints) +
                                    "), got " + std::to_string(arcs->size()));
  }
  for (size_t j = 0; j < arcs->size(); ++j) {
    const auto& a = (*arcs)[j];
    const std::string field = "term_arcs_rad[" + std::to_string(j) + "]";
    if (!a.is_array() || a.size() != 2 || !a[0].is_number() || !a[1].is_number())
      throw fail(field, "expected [start, length] in rad");
    const double start = a[0].get<double>(), length = a[1].get<double>();
    if (!(std::abs(start) <= 2.0 * kTurn)) throw fail(field, "start beyond two turns");
    if (!(length > 0.0 && length <= kTurn)) throw fail(field, "length outside (0, 2π]");
    v.term_arcs.push_back({start, length});
  }
  const auto sigma = json.find("sigma");
  if (sigma != json.end() && !sigma->is_null()) {
    if (!sigma->is_object()) throw fail("sigma", "expected an object");
    auto number = [&](const char* key, double max) {
      const auto it = sigma->find(key);
      if (it == sigma->end() || it->is_null()) return std::numeric_limits<double>::quiet_NaN();
      if (!it->is_number()) throw fail(std::string("sigma.") + key, "expected a number or null");
      const double x = it->get<double>();
      if (!(x >= 0.0 && x <= max))
        throw fail(std::string("sigma.") + key, "outside 0 … " + std::to_string(max));
      return x;
    };
    v.sigma_inside_mm = number("inside_mm", 1000.0);
    v.sigma_outside_mm = number("outside_mm", 1000.0);
    v.coverage_inside = number("coverage_inside", 1.0);
    v.coverage_outside = number("coverage_outside", 1.0);
    if (const auto f = sigma->find("outside_folds"); f != sigma->end() && f->is_string())
      v.outside_folds = f->get<std::string>().substr(0, 200);
  }
  return v;
}

}  // namespace armsig::io
