#include "acquisition/plan.h"

#include <fmt/format.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <nlohmann/json.hpp>
#include <optional>
#include <random>
#include <set>
#include <string_view>

#include "calibration/identifiability.h"
#include "calibration/selection.h"
#include "calibration/synthetic.h"
#include "core/error.h"
#include "core/plausibility.h"
#include "core/text.h"
#include "core/units.h"
#include "io/csv.h"

namespace armsig::acquisition {

namespace {

// The `motion` column of a row: empty (a joint move without a speed, a linear move with one),
// "joint", "linear", "via" (the via point of a circular move to the next row) or "circular"
// (the row after a via); each with the speed it needs, and a via row's move completed by the
// next row (the last row checked at the end).
void CheckMotion(const io::CsvTable& t, const io::CsvRow& row, int column, const Plan& before,
                 PlannedConfiguration& c) {
  const std::string word = t.Text(row, column);
  const bool after_via = !before.empty() && before.back().via;
  const auto refuse = [&](const std::string& why) {
    throw InputError(t.Where(row, column), fmt::format("pose {}: {}", Quoted(c.label), why));
  };
  if (word != "" && word != "joint" && word != "linear" && word != "via" && word != "circular")
    refuse(fmt::format("motion {} (expected joint, linear, via or circular)", Quoted(word)));
  if (after_via != (word == "circular"))
    refuse(after_via ? "the row after a via point is its circular move's target (motion circular)"
                     : "a circular move's target follows its via point (motion via)");
  // Empty: the speed says (a joint move without one, a linear move with one).
  if (word == "joint" && c.linear_speed_mm_s) refuse("a joint move takes no speed_mm_s");
  if (!word.empty() && word != "joint" && !c.linear_speed_mm_s)
    refuse("a " + word + " move needs its speed_mm_s");
  c.via = word == "via";
}

Plan ReadPlanCsvWithin(const std::string& path, int num_joints,
                       const calibration::RobotModel* model) {
  const io::CsvTable t = io::ReadCsvFile(path);
  std::vector<std::string> known = {"pose", "x_mm", "y_mm", "z_mm", "speed_mm_s", "motion"};
  for (int i = 1; i <= num_joints; ++i) known.push_back("q" + std::to_string(i) + "_*");
  t.RefuseUnreadUnits(known);
  const int id = t.Column("pose");
  const std::optional<int> speed = t.FindColumn("speed_mm_s");
  const std::optional<int> motion = t.FindColumn("motion");
  // A target only when all three coordinates are there (one or two is a broken file).
  const std::optional<int> tx = t.FindColumn("x_mm"), ty = t.FindColumn("y_mm"),
                           tz = t.FindColumn("z_mm");
  const int target_columns = !!tx + !!ty + !!tz;
  if (target_columns != 0 && target_columns != 3) {
    throw InputError({path, t.header_line(), 0, ""},
                     "give the target as all of x_mm, y_mm and z_mm, or none of them");
  }
  std::vector<io::AngleColumn> q;
  for (int i = 1; i <= num_joints; ++i) q.push_back(t.AngleColumnOf("q" + std::to_string(i)));
  Plan plan;
  std::set<std::string> labels;
  for (const auto& row : t.rows()) {
    PlannedConfiguration c;
    c.label = t.Name(row, id);
    if (!labels.insert(c.label).second)
      throw InputError(t.Where(row, id), "duplicate pose " + Quoted(c.label));
    c.joints_rad.resize(num_joints);
    for (int i = 0; i < num_joints; ++i) {
      c.joints_rad(i) = t.AngleRad(row, q[i], plausible::Quantity::kJointAngle);
      if (model && static_cast<int>(model->joint_min_rad.size()) == num_joints &&
          static_cast<int>(model->joint_max_rad.size()) == num_joints &&
          (c.joints_rad(i) < model->joint_min_rad[i] || c.joints_rad(i) > model->joint_max_rad[i])) {
        const double per = FromRad(1.0, q[i].unit);
        throw InputError(
            t.Where(row, q[i].index),
            fmt::format("pose {}: joint {} at {:g} is outside the limits of model {} ({:g} to {:g} "
                        "{}): the robot cannot go there",
                        Quoted(c.label), i + 1, c.joints_rad(i) * per, model->name,
                        model->joint_min_rad[i] * per, model->joint_max_rad[i] * per,
                        plausible::UnitOf(q[i].unit).name));
      }
    }
    if (target_columns == 3) {
      using plausible::Quantity;
      c.target_mm = Eigen::Vector3d(t.Number(row, *tx, Quantity::kCoordinate),
                                    t.Number(row, *ty, Quantity::kCoordinate),
                                    t.Number(row, *tz, Quantity::kCoordinate));
    }
    if (const std::optional<double> v = speed ? t.OptionalNumber(row, *speed) : std::nullopt) {
      if (!(*v > 0.0 && *v <= kMostLinearSpeedMmS)) {
        throw InputError(t.Where(row, *speed),
                         fmt::format("pose {}: a linear move at {:g} mm/s (expected a speed above "
                                     "0 and at most {:g} mm/s, or the cell empty for a joint move)",
                                     Quoted(c.label), *v, kMostLinearSpeedMmS));
      }
      if (plan.empty()) {
        throw InputError(t.Where(row, *speed),
                         fmt::format("pose {}: the first configuration is reached by a joint move "
                                     "(a linear move needs a configuration to start from; leave "
                                     "its speed_mm_s empty)",
                                     Quoted(c.label)));
      }
      c.linear_speed_mm_s = *v;
    }
    if (motion) CheckMotion(t, row, *motion, plan, c);
    plan.push_back(std::move(c));
  }
  if (plan.empty()) throw InputError({path, 0, 0, ""}, "empty plan");
  if (plan.back().via) {
    throw InputError({path, 0, 0, "motion"},
                     fmt::format("pose {}: the last row is a via point with no target after it",
                                 Quoted(plan.back().label)));
  }
  return plan;
}

}  // namespace

Plan ReadPlanCsv(const std::string& path, int num_joints) {
  return ReadPlanCsvWithin(path, num_joints, nullptr);
}

Plan ReadPlanCsv(const std::string& path, const calibration::RobotModel& model) {
  return ReadPlanCsvWithin(path, model.num_joints(), &model);
}

std::string FormatPlanCsv(const Plan& plan) {
  std::string out = "pose";
  const int n = plan.empty() ? 0 : static_cast<int>(plan[0].joints_rad.size());
  for (int i = 1; i <= n; ++i) out += ",q" + std::to_string(i) + "_deg";
  out += "\n";
  for (const auto& c : plan) {
    out += io::CsvEscape(c.label);
    for (int i = 0; i < n; ++i) out += fmt::format(",{:.6f}", c.joints_rad(i) / kRadPerDeg);
    out += "\n";
  }
  return out;
}

Plan WellSpreadPlan(const calibration::RobotModel& model, int count, int candidates,
                    unsigned seed) {
  std::mt19937 rng(seed);
  const auto pool = calibration::RandomConfigurations(model, candidates, rng, 2.6);
  std::vector<int> all(model.num_parameters());
  for (int i = 0; i < model.num_parameters(); ++i) all[i] = i;
  const auto id = calibration::AnalyseJacobian(
      calibration::StackedJacobian(model, Eigen::Isometry3d::Identity(),
                                   Eigen::VectorXd::Zero(model.num_parameters()), pool),
      all);
  calibration::SelectionOptions options;
  options.count = count;
  const auto selection = calibration::SelectConfigurations(model, pool, id.identified, options);
  Plan plan;
  for (int i : selection.selected) plan.push_back({"C" + std::to_string(plan.size() + 1), pool[i]});
  return plan;
}

Plan SingleJointPlan(const Eigen::VectorXd& start, int joint, double lo_rad, double hi_rad,
                     int steps) {
  Plan plan;
  for (int k = 0; k < steps; ++k) {
    Eigen::VectorXd q = start;
    q(joint) = steps == 1 ? lo_rad : lo_rad + (hi_rad - lo_rad) * k / (steps - 1);
    plan.push_back({fmt::format("J{}-{:03d}", joint + 1, k + 1), q});
  }
  return plan;
}

namespace {

// A whole decimal number in [lo, hi] (no sign, no trailing text, no overflow).
std::optional<int> WholeNumber(std::string_view text, int lo, int hi) {
  int value = 0;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (ec != std::errc() || end != text.data() + text.size() || value < lo || value > hi)
    return std::nullopt;
  return value;
}

}  // namespace

Plan MakePlan(const std::string& spec, const calibration::RobotModel& model, unsigned seed) {
  constexpr int kMostConfigurations = 100000;
  if (spec.rfind("auto:", 0) == 0) {
    const auto count = WholeNumber(std::string_view(spec).substr(5), 1, kMostConfigurations);
    if (!count) {
      throw InputError({"--plan", 0, 0, ""},
                       fmt::format("expected auto:N with N a whole number from 1 to {}, got '{}'",
                                   kMostConfigurations, spec));
    }
    return WellSpreadPlan(model, *count, std::max(2000, 20 * *count), seed);
  }
  if (spec.rfind("single-joint:", 0) == 0) {
    const std::string_view rest = std::string_view(spec).substr(13);
    const size_t colon = rest.find(':');
    const auto joint = colon == std::string_view::npos
                           ? std::nullopt
                           : WholeNumber(rest.substr(0, colon), 1, model.num_joints());
    const auto steps = colon == std::string_view::npos
                           ? std::nullopt
                           : WholeNumber(rest.substr(colon + 1), 2, kMostConfigurations);
    if (!joint || !steps) {
      throw InputError({"--plan", 0, 0, ""},
                       fmt::format("expected single-joint:J:STEPS with J in 1..{} and STEPS in "
                                   "2..{}, got '{}'",
                                   model.num_joints(), kMostConfigurations, spec));
    }
    const int joint_number = *joint;
    double lo = -150 * kRadPerDeg, hi = 150 * kRadPerDeg;
    if (static_cast<int>(model.joint_min_rad.size()) == model.num_joints()) {
      lo = std::max(lo, model.joint_min_rad[joint_number - 1]);
      hi = std::min(hi, model.joint_max_rad[joint_number - 1]);
    }
    Eigen::VectorXd start = Eigen::VectorXd::Zero(model.num_joints());
    if (model.num_joints() >= 3) start(2) = 90 * kRadPerDeg;  // elbow bent, target in reach
    return SingleJointPlan(start, joint_number - 1, lo, hi, *steps);
  }
  return ReadPlanCsv(spec, model);
}

bool HasLinearMoves(const Plan& plan) {
  return std::any_of(plan.begin(), plan.end(),
                     [](const PlannedConfiguration& c) { return c.linear_speed_mm_s.has_value(); });
}

std::string PlanToJson(const Plan& plan) {
  nlohmann::json j = nlohmann::json::array();
  for (const auto& c : plan) {
    nlohmann::json item = {
        {"label", c.label},
        {"joints_rad",
         std::vector<double>(c.joints_rad.data(), c.joints_rad.data() + c.joints_rad.size())}};
    if (c.target_mm) item["target_mm"] = {c.target_mm->x(), c.target_mm->y(), c.target_mm->z()};
    if (c.linear_speed_mm_s) item["linear_speed_mm_s"] = *c.linear_speed_mm_s;
    if (c.via) item["via"] = true;
    j.push_back(std::move(item));
  }
  return JsonText(j);
}

Plan PlanFromJson(const std::string& json, const db::JsonCell& where) {
  return db::ReadStoredJson(json, where, [&](const nlohmann::json& items) {
    if (!items.is_array()) db::RefuseStoredJson(where, "expected a list of configurations");
    Plan plan;
    for (const auto& item : items) {
      const auto q = item.at("joints_rad").get<std::vector<double>>();
      PlannedConfiguration c{item.at("label").get<std::string>(),
                             Eigen::Map<const Eigen::VectorXd>(q.data(), q.size())};
      if (item.contains("target_mm")) {
        const auto x = item.at("target_mm").get<std::vector<double>>();
        if (x.size() != 3) db::RefuseStoredJson(where, "expected target_mm as [x, y, z]");
        c.target_mm = Eigen::Vector3d(x[0], x[1], x[2]);
      }
      if (item.contains("linear_speed_mm_s")) {
        const double v = item.at("linear_speed_mm_s").get<double>();
        if (!(v > 0.0 && v <= kMostLinearSpeedMmS))
          db::RefuseStoredJson(where, "expected linear_speed_mm_s above 0 and at most 10000");
        c.linear_speed_mm_s = v;
      }
      if (item.contains("via")) c.via = item.at("via").get<bool>();
      plan.push_back(std::move(c));
    }
    return plan;
  });
}

}  // namespace armsig::acquisition
