#include "acquisition/plan.h"

#include <fmt/format.h>

#include <cmath>
#include <nlohmann/json.hpp>
#include <random>
#include <set>

#include "calibration/identifiability.h"
#include "calibration/selection.h"
#include "calibration/simulation.h"
#include "core/error.h"
#include "core/units.h"
#include "io/csv.h"

namespace armsig::acquisition {

Plan ReadPlanCsv(const std::string& path, int num_joints) {
  const io::CsvTable t = io::ReadCsvFile(path);
  const int id = t.Column("pose");
  std::vector<io::AngleColumn> q;
  for (int i = 1; i <= num_joints; ++i) q.push_back(t.AngleColumnOf("q" + std::to_string(i)));
  Plan plan;
  std::set<std::string> labels;
  for (const auto& row : t.rows()) {
    PlannedConfiguration c;
    c.label = t.Name(row, id);
    if (!labels.insert(c.label).second)
      throw InputError(t.Where(row, id), "duplicate pose '" + c.label + "'");
    c.joints_rad.resize(num_joints);
    for (int i = 0; i < num_joints; ++i)
      c.joints_rad(i) = t.AngleRad(row, q[i], plausible::Quantity::kJointAngle);
    plan.push_back(std::move(c));
  }
  if (plan.empty()) throw InputError({path, 0, 0, ""}, "empty plan");
  return plan;
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

Plan MakePlan(const std::string& spec, const calibration::RobotModel& model) {
  if (spec.rfind("auto:", 0) == 0) {
    const int count = std::atoi(spec.c_str() + 5);
    if (count < 1) throw InputError({"--plan", 0, 0, ""}, "auto:N needs a positive N");
    return WellSpreadPlan(model, count, std::max(2000, 20 * count), 7);
  }
  if (spec.rfind("single-joint:", 0) == 0) {
    int joint = 0, steps = 0;
    if (std::sscanf(spec.c_str(), "single-joint:%d:%d", &joint, &steps) != 2 || joint < 1 ||
        joint > model.num_joints() || steps < 2) {
      throw InputError({"--plan", 0, 0, ""}, "expected single-joint:J:STEPS with J in 1.." +
                                                 std::to_string(model.num_joints()) +
                                                 " and STEPS ≥ 2");
    }
    double lo = -150 * kRadPerDeg, hi = 150 * kRadPerDeg;
    if (static_cast<int>(model.joint_min_rad.size()) == model.num_joints()) {
      lo = std::max(lo, model.joint_min_rad[joint - 1]);
      hi = std::min(hi, model.joint_max_rad[joint - 1]);
    }
    Eigen::VectorXd start = Eigen::VectorXd::Zero(model.num_joints());
    if (model.num_joints() >= 3) start(2) = 90 * kRadPerDeg;  // elbow bent, target in reach
    return SingleJointPlan(start, joint - 1, lo, hi, steps);
  }
  return ReadPlanCsv(spec, model.num_joints());
}

std::string PlanToJson(const Plan& plan) {
  nlohmann::json j = nlohmann::json::array();
  for (const auto& c : plan) {
    j.push_back({{"label", c.label},
                 {"joints_rad", std::vector<double>(c.joints_rad.data(),
                                                    c.joints_rad.data() + c.joints_rad.size())}});
  }
  return j.dump();
}

Plan PlanFromJson(const std::string& json) {
  Plan plan;
  for (const auto& item : nlohmann::json::parse(json)) {
    const auto q = item["joints_rad"].get<std::vector<double>>();
    plan.push_back(
        {item["label"].get<std::string>(), Eigen::Map<const Eigen::VectorXd>(q.data(), q.size())});
  }
  return plan;
}

}  // namespace armsig::acquisition
