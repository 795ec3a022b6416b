#include "workflows/signature.h"

#include <fmt/format.h>

#include <nlohmann/json.hpp>

#include "calibration/compensation.h"
#include "core/error.h"
#include "core/text.h"
#include "core/units.h"
#include "io/csv.h"
#include "io/model_export.h"
#include "io/model_yaml.h"
#include "workflows/hint.h"

namespace armsig::workflows {

Signature SignatureOf(const calibration::RobotModel& model, const db::StoredCalibration& stored) {
  Signature s;
  s.version = stored.version;
  s.params = Eigen::VectorXd::Zero(model.num_parameters());
  s.sigmas = Eigen::VectorXd::Constant(model.num_parameters(), NAN);
  for (const auto& p : stored.parameters) {
    const int k = model.IndexOf(p.name);
    if (k < 0) continue;
    s.params(k) = p.value;
    if (p.identified) s.sigmas(k) = p.sigma;
  }
  s.world_from_base = stored.world_from_base;
  return s;
}

ActiveSignature LoadActiveSignature(db::Database& database, const std::string& robot) {
  const auto id = db::FindRobot(database, robot);
  if (!id) throw InputError({database.path(), 0, 0, "--robot"}, UnknownRobotMessage(database.path(), robot));
  const auto active = db::ActiveCalibration(database, *id);
  if (!active) {
    throw InputError({database.path(), 0, 0, "--robot"},
                     "robot " + ShellWord(robot) + " has no active parameter set (fit one: " +
                         Hint(database.path(), {"recalibrate", "--robot", robot}) + ")");
  }
  ActiveSignature out{
      io::ParseRobotModel(db::RobotModelYaml(database, *id), "model of robot " + robot), {}};
  out.signature = SignatureOf(out.model, *active);
  return out;
}

Eigen::Isometry3d FrameOf(const ActiveSignature& a, const std::string& frame) {
  if (frame == "robot") return Eigen::Isometry3d::Identity();
  if (frame == "measurement") {
    if (!a.signature.world_from_base)
      throw InputError({"--frame", 0, 0, ""}, "the active set has no stored measuring frame");
    return *a.signature.world_from_base;
  }
  throw InputError({"--frame", 0, 0, ""}, "expected robot or measurement, got " + Quoted(frame));
}

std::string PredictCsv(const ActiveSignature& a, const Eigen::Isometry3d& frame,
                       const std::string& joints_csv) {
  const io::CsvTable t = io::ReadCsvFile(joints_csv);
  std::vector<std::string> known = {"pose"};
  for (int i = 1; i <= a.model.num_joints(); ++i) known.push_back("q" + std::to_string(i) + "_*");
  t.RefuseUnreadUnits(known);
  const int id = t.Column("pose");
  std::vector<io::AngleColumn> q;
  for (int i = 1; i <= a.model.num_joints(); ++i)
    q.push_back(t.AngleColumnOf("q" + std::to_string(i)));
  calibration::Kinematics kin(a.model);
  const Eigen::VectorXd zero = Eigen::VectorXd::Zero(a.model.num_parameters());
  std::string out = "pose,x_mm,y_mm,z_mm,nominal_x_mm,nominal_y_mm,nominal_z_mm,correction_mm\n";
  for (const auto& row : t.rows()) {
    Eigen::VectorXd joints(a.model.num_joints());
    for (size_t i = 0; i < q.size(); ++i)
      joints(i) = t.AngleRad(row, q[i], plausible::Quantity::kJointAngle);
    const Eigen::Vector3d x = kin.Position(frame, a.signature.params, joints.data());
    const Eigen::Vector3d nominal = kin.Position(frame, zero, joints.data());
    out += fmt::format("{},{:.6f},{:.6f},{:.6f},{:.6f},{:.6f},{:.6f},{:.6f}\n",
                       io::CsvEscape(t.Name(row, id)), x.x(), x.y(), x.z(), nominal.x(),
                       nominal.y(), nominal.z(), (x - nominal).norm());
  }
  return out;
}

CompensationResult Compensate(const ActiveSignature& a, const Eigen::Isometry3d& frame,
                              const std::string& targets_csv,
                              const std::optional<Eigen::VectorXd>& seed_rad) {
  const int n = a.model.num_joints();
  const io::CsvTable t = io::ReadCsvFile(targets_csv);
  std::vector<std::string> known = {"point", "x_mm", "y_mm", "z_mm"};
  for (int i = 1; i <= n; ++i) known.push_back("q" + std::to_string(i) + "_*");
  t.RefuseUnreadUnits(known);
  const int id = t.Column("point");
  const int cx = t.Column("x_mm"), cy = t.Column("y_mm"), cz = t.Column("z_mm");
  std::vector<io::AngleColumn> q;
  for (int i = 1; i <= n; ++i) {
    if (auto c = t.FindAngleColumn("q" + std::to_string(i))) q.push_back(*c);
  }
  if (!q.empty() && static_cast<int>(q.size()) != n) {
    throw InputError({targets_csv, 1, 0, ""},
                     "give all of q1…q" + std::to_string(n) + " (the nominal program) or none");
  }
  Eigen::VectorXd seed = Eigen::VectorXd::Zero(n);
  if (n >= 3) seed(2) = kPi / 2;
  if (seed_rad) {
    if (seed_rad->size() != n)
      throw InputError({"--seed-deg", 0, 0, ""},
                       fmt::format("expected {} joint angles, got {}", n, seed_rad->size()));
    seed = *seed_rad;
  }
  const Eigen::VectorXd zero = Eigen::VectorXd::Zero(a.model.num_parameters());
  CompensationResult result;
  result.csv = "point";
  for (int i = 1; i <= n; ++i) result.csv += fmt::format(",q{}_deg", i);
  for (int i = 1; i <= n; ++i) result.csv += fmt::format(",nominal_q{}_deg", i);
  result.csv += ",residual_mm,status\n";
  for (const auto& row : t.rows()) {
    ++result.targets;
    using plausible::Quantity;
    const Eigen::Vector3d target(t.Number(row, cx, Quantity::kCoordinate),
                                 t.Number(row, cy, Quantity::kCoordinate),
                                 t.Number(row, cz, Quantity::kCoordinate));
    // The nominal solution: the program's joints, or the nominal model's own solution.
    Eigen::VectorXd nominal(n);
    calibration::JointSolution nominal_solution;
    if (!q.empty()) {
      for (int i = 0; i < n; ++i) nominal(i) = t.AngleRad(row, q[i], Quantity::kJointAngle);
    } else {
      nominal_solution = calibration::SolveJoints(a.model, frame, zero, target, seed);
      nominal = nominal_solution.joints_rad;
    }
    const auto s = calibration::SolveJoints(a.model, frame, a.signature.params, target, nominal);
    const bool ok = s.status.ok() && (q.size() || nominal_solution.status.ok());
    result.csv += io::CsvEscape(t.Name(row, id));
    for (int i = 0; i < n; ++i)
      result.csv += ok ? fmt::format(",{:.8f}", s.joints_rad(i) / kRadPerDeg) : std::string(",");
    for (int i = 0; i < n; ++i) result.csv += fmt::format(",{:.8f}", nominal(i) / kRadPerDeg);
    result.csv += fmt::format(",{:.6f},{}\n", s.residual_mm, ok ? "ok" : "unreachable");
    if (!ok) {
      result.unreachable.push_back(
          fmt::format("target {} ({}:{}): {}", t.Text(row, id), targets_csv, row.line,
                      s.status.ok() ? nominal_solution.status.message : s.status.message));
    }
  }
  return result;
}

ExportResult ExportSignature(const ActiveSignature& a, const std::string& robot,
                             const std::string& format, const std::string& frame_name) {
  const Eigen::Isometry3d frame = FrameOf(a, frame_name);
  ExportResult result;
  if (format == "json") {
    const auto names = a.model.ParameterNames();
    nlohmann::json params = nlohmann::json::array();
    for (int k = 0; k < a.model.num_parameters(); ++k) {
      const bool identified = std::isfinite(a.signature.sigmas(k));
      params.push_back(
          {{"name", names[k]},
           {"value", a.signature.params(k)},
           {"unit", a.model.UnitOf(k) == calibration::ParameterUnit::kMm ? "mm" : "rad"},
           {"identified", identified},
           {"sigma",
            identified ? nlohmann::json(a.signature.sigmas(k)) : nlohmann::json(nullptr)}});
    }
    result.text = JsonText(nlohmann::json{{"robot", robot},
                                          {"model", a.model.name},
                                          {"version", a.signature.version},
                                          {"parameters", params}},
                           2) +
                  "\n";
  } else if (format == "model" || format == "urdf") {
    const auto corrected = calibration::CorrectedModel(a.model, a.signature.params, frame);
    if (format == "model") {
      result.text = io::FormatRobotModelYaml(
          corrected, fmt::format("armsig export: robot {}, arm signature version {}, {} frame",
                                 robot, a.signature.version, frame_name));
    } else {
      result.text = io::FormatUrdf(corrected, &result.warning);
    }
  } else {
    throw InputError({"--format", 0, 0, ""}, "expected json, model or urdf, got " + Quoted(format));
  }
  return result;
}

}  // namespace armsig::workflows
