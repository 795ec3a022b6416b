#include "workflows/signature.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <limits>
#include <nlohmann/json.hpp>

#include "calibration/compensation.h"
#include "core/error.h"
#include "core/rotation.h"
#include "core/text.h"
#include "core/units.h"
#include "db/stored_json.h"
#include "io/csv.h"
#include "io/model_export.h"
#include "io/model_yaml.h"
#include "io/residual_map_json.h"
#include "io/validity_json.h"
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
  s.tool_rotation = stored.tool_rotation;
  for (const auto& name : stored.covariance_parameters) s.identified.push_back(model.IndexOf(name));
  const bool known = std::find(s.identified.begin(), s.identified.end(), -1) == s.identified.end();
  if (known && stored.covariance.rows() == static_cast<int>(s.identified.size()))
    s.covariance = stored.covariance;
  else
    s.identified.clear();
  if (!stored.residual_map_json.empty()) {
    const std::string source =
        fmt::format("table calibrations, row {}, column residual_map_json (parameter set {})",
                    stored.id, stored.version);
    const auto json = nlohmann::json::parse(stored.residual_map_json, nullptr, false);
    if (json.is_discarded())
      throw InputError({source, 0, 0, ""}, "the stored map is not JSON (a damaged database?)");
    s.map = std::make_shared<const calibration::ResidualMap>(
        io::ResidualMapFromJson(json, source));
    if (s.map->data().num_joints != model.num_joints()) {
      throw InputError({source, 0, 0, ""},
                       fmt::format("the map is for {} joints, the model has {}",
                                   s.map->data().num_joints, model.num_joints()));
    }
  }
  if (!stored.validity_json.empty()) {
    const std::string source =
        fmt::format("table calibrations, row {}, column validity_json (parameter set {})",
                    stored.id, stored.version);
    const auto json = nlohmann::json::parse(stored.validity_json, nullptr, false);
    if (json.is_discarded())
      throw InputError({source, 0, 0, ""}, "the stored validity is not JSON (a damaged database?)");
    s.validity = io::ValidityFromJson(json, model.num_joints(), source);
  }
  return s;
}

namespace {

std::vector<int64_t> SessionsOf(db::Database& database, const db::StoredCalibration& c) {
  if (c.inputs_json.empty()) return {};
  return InputSessions(db::ParseStoredJson(c.inputs_json, {database.path(), "calibrations", c.id, "inputs_json"}));
}

// The model as a stored set uses it: terms held to the arcs the set was fitted on.
ActiveSignature Signed(db::Database& database, calibration::RobotModel model,
                       const db::StoredCalibration& stored) {
  ActiveSignature out{std::move(model), {}, {}};
  out.signature = SignatureOf(out.model, stored);
  out.model.term_support = out.signature.validity.term_arcs;
  out.sessions = SessionsOf(database, stored);
  return out;
}

}  // namespace

calibration::FittedSet FittedSetOf(const calibration::RobotModel& model, const Signature& sig,
                                   const db::StoredCalibration& stored) {
  calibration::FittedSet set;
  set.params = sig.params;
  for (const auto& name : stored.covariance_parameters)
    set.identified.push_back(model.IndexOf(name));
  set.covariance = stored.covariance;
  return set;
}

std::vector<int64_t> InputSessions(const nlohmann::json& inputs) {
  std::vector<int64_t> out;
  if (!inputs.is_object() || !inputs.contains("sessions") || !inputs["sessions"].is_array()) return out;
  for (const auto& s : inputs["sessions"]) {
    if (s.is_number_integer()) out.push_back(s.get<int64_t>());
    if (!s.is_string()) continue;
    const std::string text = s.get<std::string>();
    int64_t id = 0;
    const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), id);
    if (error == std::errc() && end == text.data() + text.size() && id > 0) out.push_back(id);
  }
  return out;
}

ActiveSignature LoadSignature(db::Database& database, const std::string& robot,
                              std::optional<int> version) {
  if (!version) return LoadActiveSignature(database, robot);
  const auto id = db::FindRobot(database, robot);
  if (!id) throw InputError({database.path(), 0, 0, "--robot"}, UnknownRobotMessage(database, robot));
  const auto history = db::CalibrationHistory(database, *id);
  for (const auto& c : history) {
    if (c.version != *version) continue;
    return Signed(database,
                  io::ParseRobotModel(db::RobotModelYaml(database, *id), "model of robot " + robot), c);
  }
  throw InputError({"--set", 0, 0, ""},
                   history.empty()
                       ? "robot " + ShellWord(robot) + " has no stored parameter set"
                       : fmt::format("robot {} has no version {} (versions {} to {}: {})",
                                     ShellWord(robot), *version, history.front().version,
                                     history.back().version,
                                     Hint(database.path(), {"versions", "--robot", robot})));
}

ActiveSignature LoadActiveSignature(db::Database& database, const std::string& robot) {
  const auto id = db::FindRobot(database, robot);
  if (!id) throw InputError({database.path(), 0, 0, "--robot"}, UnknownRobotMessage(database, robot));
  const auto active = db::ActiveCalibration(database, *id);
  if (!active) {
    throw InputError({database.path(), 0, 0, "--robot"},
                     "robot " + ShellWord(robot) + " has no active parameter set (fit one: " +
                         Hint(database.path(), {"recalibrate", "--robot", robot}) + ")");
  }
  return Signed(database,
                io::ParseRobotModel(db::RobotModelYaml(database, *id), "model of robot " + robot), *active);
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

double ParametricSigmaMm(const calibration::RobotModel& model, const Signature& signature,
                         const Eigen::VectorXd& joints_rad) {
  if (signature.identified.empty()) return std::numeric_limits<double>::quiet_NaN();
  calibration::Kinematics kin(model);
  Eigen::Matrix<double, 3, Eigen::Dynamic> all(3, model.num_parameters());
  kin.PositionAndJacobian(Eigen::Isometry3d::Identity(), signature.params, joints_rad.data(), all);
  Eigen::Matrix<double, 3, Eigen::Dynamic> j(3, signature.identified.size());
  for (size_t c = 0; c < signature.identified.size(); ++c) j.col(c) = all.col(signature.identified[c]);
  return std::sqrt(std::max((j * signature.covariance * j.transpose()).trace() / 3.0, 0.0));
}

std::string PredictCsv(const ActiveSignature& a, const Eigen::Isometry3d& frame,
                       const std::string& joints_csv, bool map_sigma) {
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
  std::vector<Eigen::VectorXd> joints;
  for (const auto& row : t.rows()) {
    Eigen::VectorXd q_rad(a.model.num_joints());
    for (size_t i = 0; i < q.size(); ++i)
      q_rad(i) = t.AngleRad(row, q[i], plausible::Quantity::kJointAngle);
    joints.push_back(std::move(q_rad));
  }
  const calibration::ResidualMap* map = a.signature.map.get();
  const auto calibrated = calibration::PredictPositions(a.model, frame, a.signature.params, map,
                                                        joints, map != nullptr && map_sigma,
                                                        joints.size() >= 2048 ? 2 : 1);
  const double noise = map ? map->data().noise_sigma_mm : 0.0;
  const std::optional<Eigen::Matrix3d>& tool = a.signature.tool_rotation;
  std::string out =
      "pose,x_mm,y_mm,z_mm,nominal_x_mm,nominal_y_mm,nominal_z_mm,correction_mm,map,map_sigma_mm,"
      "model_sigma_mm,sigma_mm,support";
  out += tool ? ",rx_deg,ry_deg,rz_deg\n" : "\n";
  int outside = 0, beyond = 0;
  for (size_t k = 0; k < joints.size(); ++k) {
    const Eigen::Vector3d& x = calibrated[k].position_mm;
    const Eigen::Vector3d nominal = kin.Position(frame, zero, joints[k].data());
    const char* state = !map ? "none" : calibrated[k].map_applied ? "applied" : "outside";
    outside += calibrated[k].extrapolated ? 1 : 0;
    const std::string sigma =
        map && map_sigma ? fmt::format("{:.6f}", std::sqrt(calibrated[k].sigma_mm * calibrated[k].sigma_mm +
                                              noise * noise))
            : std::string();
    const double model_sigma = ParametricSigmaMm(a.model, a.signature, joints[k]);
    // Where the set was fitted (its terms' arcs, its map's support), and the σ measured on
    // held-out data for such a configuration (calibration/validity.h).
    const calibration::Support support = calibration::SupportAt(
        a.model, a.signature.params, a.signature.validity, joints[k], calibrated[k].extrapolated);
    beyond += support.joints_outside.empty() ? 0 : 1;
    const double total = calibration::PredictionSigmaMm(model_sigma, a.signature.validity,
                                                        support.inside);
    out += fmt::format("{},{:.6f},{:.6f},{:.6f},{:.6f},{:.6f},{:.6f},{:.6f},{},{},{},{},{}",
                       io::CsvEscape(t.Name(t.rows()[k], id)), x.x(), x.y(), x.z(), nominal.x(),
                       nominal.y(), nominal.z(), (x - nominal).norm(), state, sigma,
                       std::isnan(model_sigma) ? std::string() : fmt::format("{:.6f}", model_sigma),
                       std::isnan(total) ? std::string() : fmt::format("{:.6f}", total),
                       io::CsvEscape(support.Describe(joints[k], a.signature.validity)));
    if (tool) {
      kin.Position(frame, a.signature.params, joints[k].data());
      const Eigen::Vector3d angles = RxRyRzFromRotation(kin.LastRotation() * *tool) / kRadPerDeg;
      out += fmt::format(",{:.8f},{:.8f},{:.8f}", angles.x(), angles.y(), angles.z());
    }
    out += "\n";
  }
  if (outside > 0) {
    spdlog::warn(
        "predict: {} of {} configurations are outside the residual map's support (far from the "
        "poses it was fitted on, or a joint at an angle its curve had no data for): only the "
        "parts of the map that have data there apply (column map = outside)",
        outside, joints.size());
  }
  if (beyond > 0) {
    spdlog::warn(
        "predict: {} of {} configurations have a joint outside the range parameter set {} was "
        "fitted on: its non-geometric terms are held at their value at the range's edge there, "
        "and sigma_mm is the error measured beside the fit poses (column support)",
        beyond, joints.size(), a.signature.version);
  }
  return out;
}

namespace {

// No target where the set was validated (in its measured volume, not in the robot's base)
// while at least 80 % of them lie there read in another length unit: the file's unit is
// wrong, not the targets (0.8 in an x_mm column is 0.8 m).
void CheckTargetsUnit(const io::CsvTable& t, int cx, int cy, int cz, const Eigen::Isometry3d& frame,
                      const programs::ValidatedVolume& volume) {
  constexpr double kSlackMm = 1.0;
  const Eigen::Isometry3d base_from_world = frame.inverse();
  // Where a target can be: inside the measured volume, no nearer the robot's origin than half
  // the nearest measured point (the hull of points around a robot holds its base).
  auto possible = [&](const Eigen::Vector3d& robot_frame) {
    return volume.DistanceOutside(robot_frame) <= kSlackMm &&
           robot_frame.norm() >= 0.5 * volume.nearest_mm();
  };
  std::vector<Eigen::Vector3d> targets;
  for (const auto& row : t.rows()) {
    const Eigen::Vector3d target(t.Number(row, cx, plausible::Quantity::kCoordinate),
                                 t.Number(row, cy, plausible::Quantity::kCoordinate),
                                 t.Number(row, cz, plausible::Quantity::kCoordinate));
    if (possible(base_from_world * target)) return;  // one where a target can be
    targets.push_back(target);
  }
  spdlog::debug("compensate: no target where the set was validated ({}; the nearest measured "
                "point {:.1f} mm from the robot's origin)",
                volume.source(), volume.nearest_mm());
  for (const auto& [unit, factor] : {std::pair<const char*, double>{"metres", 1000.0},
                                     std::pair<const char*, double>{"inches", 25.4}}) {
    const double scale = factor;  // a structured binding cannot be captured in C++20 clang 14
    const auto inside = std::count_if(targets.begin(), targets.end(), [&](const auto& x) {
      return possible(base_from_world * (scale * x));
    });
    // Most of a program's targets lie where the robot was measured; a few may not.
    if (inside < 0.8 * static_cast<double>(targets.size())) continue;
    throw InputError(t.Where(t.rows().front(), cx),
                     fmt::format("no target lies where the set was validated ({}), and read "
                                 "in {} {} of the {} lie there: the columns say mm; "
                                 "give the unit in their names (x_m, y_m, z_m) or convert",
                                 volume.source(), unit, inside, targets.size()));
  }
}

}  // namespace

CompensationResult Compensate(const ActiveSignature& a, const Eigen::Isometry3d& frame,
                              const std::string& targets_csv,
                              const std::optional<Eigen::VectorXd>& seed_rad,
                              const programs::ValidatedVolume* volume) {
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
  if (t.rows().empty()) {  // an empty joints file would say "done" for a program never made
    throw InputError({targets_csv, 2, 0, ""},
                     "a header and no targets (expected one row per target: point,x_mm,y_mm,z_mm)");
  }
  if (volume) CheckTargetsUnit(t, cx, cy, cz, frame, *volume);
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
  result.csv += ",residual_mm,status,model_sigma_mm,sigma_mm,support\n";
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
    const auto s = calibration::SolveJoints(a.model, frame, a.signature.params, target, nominal,
                                            {}, a.signature.map.get());
    const bool ok = s.status.ok() && (q.size() || nominal_solution.status.ok());
    result.csv += io::CsvEscape(t.Name(row, id));
    for (int i = 0; i < n; ++i)
      result.csv += ok ? fmt::format(",{:.8f}", s.joints_rad(i) / kRadPerDeg) : std::string(",");
    for (int i = 0; i < n; ++i) result.csv += fmt::format(",{:.8f}", nominal(i) / kRadPerDeg);
    // Outside the residual map's support the solution is the parametric model's: usable,
    // and flagged.
    // The parametric model's standard error where the compensated joints put the tool: what
    // the stored covariance lets one expect there (empty without one or without a solution).
    const double model_sigma =
        ok ? ParametricSigmaMm(a.model, a.signature, s.joints_rad) : std::nan("");
    const calibration::Support support =
        ok ? calibration::SupportAt(a.model, a.signature.params, a.signature.validity,
                                    s.joints_rad, s.map_extrapolated)
           : calibration::Support{};
    const double total =
        ok ? calibration::PredictionSigmaMm(model_sigma, a.signature.validity, support.inside)
           : std::nan("");
    const char* status = !ok                             ? "unreachable"
                         : s.map_extrapolated            ? "ok_outside_map"
                         : !support.joints_outside.empty() ? "ok_outside_fit"
                                                           : "ok";
    result.csv += fmt::format(",{:.6f},{},{},{},{}\n", s.residual_mm, status,
                              std::isnan(model_sigma) ? std::string()
                                                      : fmt::format("{:.6f}", model_sigma),
                              std::isnan(total) ? std::string() : fmt::format("{:.6f}", total),
                              ok ? io::CsvEscape(support.Describe(s.joints_rad, a.signature.validity))
                                 : std::string());
    if (ok && s.map_extrapolated) ++result.outside_map;
    if (ok && !s.map_extrapolated && !support.joints_outside.empty()) ++result.outside_fit;
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
    // The frame the set is used in (--frame) and the measuring frame of its data: a 4x4
    // row-major matrix, mm, each the frame from the robot's base.
    auto matrix = [](const Eigen::Isometry3d& t) {
      nlohmann::json rows = nlohmann::json::array();
      for (int r = 0; r < 4; ++r) {
        rows.push_back(nlohmann::json::array(
            {t.matrix()(r, 0), t.matrix()(r, 1), t.matrix()(r, 2), t.matrix()(r, 3)}));
      }
      return rows;
    };
    nlohmann::json out{{"robot", robot},
                       {"model", a.model.name},
                       {"version", a.signature.version},
                       {"frame", {{"name", frame_name}, {"frame_from_base", matrix(frame)}}},
                       {"world_from_base", a.signature.world_from_base
                                               ? matrix(*a.signature.world_from_base)
                                               : nlohmann::json(nullptr)},
                       {"parameters", params},
                       {"residual_map", a.signature.map ? io::ResidualMapToJson(a.signature.map->data())
                                                        : nlohmann::json(nullptr)}};
    result.text = JsonText(out, 2) + "\n";
  } else if (format == "model" || format == "urdf") {
    const auto corrected = calibration::CorrectedModel(a.model, a.signature.params, frame);
    if (format == "model") {
      result.text = io::FormatRobotModelYaml(
          corrected, fmt::format("armsig export: robot {}, arm signature version {}, {} frame",
                                 robot, a.signature.version, frame_name));
    } else {
      result.text = io::FormatUrdf(corrected, &result.warning);
    }
    if (a.signature.map) {
      const std::string lost = fmt::format(
          "arm signature version {} uses a residual map ({} centres), which a {} cannot carry: "
          "the exported kinematics are the parametric model's alone (held-out error without the "
          "map, see `armsig versions`); export --format json keeps the map",
          a.signature.version, a.signature.map->centres(),
          format == "urdf" ? "URDF" : "model YAML");
      result.warning = result.warning.empty() ? lost : result.warning + "; " + lost;
    }
  } else {
    throw InputError({"--format", 0, 0, ""}, "expected json, model or urdf, got " + Quoted(format));
  }
  return result;
}

}  // namespace armsig::workflows
