// Using the active arm signature:
//   armsig predict    --robot NAME --joints J.csv [--out P.csv] [--frame robot|measurement]
//   armsig compensate --robot NAME --targets T.csv --out J.csv [--frame …] [--seed-deg …]
//   armsig export     --robot NAME --format json|model|urdf --out FILE [--frame …]
#include <fmt/format.h>

#include <iostream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "app/command.h"
#include "app/signature.h"
#include "calibration/compensation.h"
#include "core/error.h"
#include "core/units.h"
#include "db/database.h"
#include "io/atomic_file.h"
#include "io/csv.h"
#include "io/model_export.h"

namespace armsig::app {

struct SignatureOptions {
  std::string robot, joints, targets, out, format, frame = "robot", seed_deg;
};

namespace {

// The frame positions are given in: the robot's own (its aligned base, N1 = I) or the
// measuring frame of the data the active set was fitted on.
Eigen::Isometry3d Frame(const ActiveSignature& a, const std::string& frame) {
  if (frame == "robot") return Eigen::Isometry3d::Identity();
  if (frame == "measurement") {
    if (!a.signature.world_from_base)
      throw InputError({"--frame", 0, 0, ""}, "the active set has no stored measuring frame");
    return *a.signature.world_from_base;
  }
  throw InputError({"--frame", 0, 0, ""}, "expected robot or measurement, got '" + frame + "'");
}

}  // namespace

int RunPredict(const SignatureOptions& o, const GlobalOptions& global) {
  db::Database database(global.DbPath());
  const ActiveSignature a = LoadActiveSignature(database, o.robot);
  const Eigen::Isometry3d frame = Frame(a, o.frame);
  const io::CsvTable t = io::ReadCsvFile(o.joints);
  const int id = t.Column("pose");
  std::vector<io::AngleColumn> q;
  for (int i = 1; i <= a.model.num_joints(); ++i)
    q.push_back(t.AngleColumnOf("q" + std::to_string(i)));
  calibration::Kinematics kin(a.model);
  const Eigen::VectorXd zero = Eigen::VectorXd::Zero(a.model.num_parameters());
  std::string out = "pose,x_mm,y_mm,z_mm,nominal_x_mm,nominal_y_mm,nominal_z_mm,correction_mm\n";
  for (const auto& row : t.rows()) {
    Eigen::VectorXd joints(a.model.num_joints());
    for (size_t i = 0; i < q.size(); ++i) joints(i) = t.AngleRad(row, q[i]);
    const Eigen::Vector3d x = kin.Position(frame, a.signature.params, joints.data());
    const Eigen::Vector3d nominal = kin.Position(frame, zero, joints.data());
    out += fmt::format("{},{:.6f},{:.6f},{:.6f},{:.6f},{:.6f},{:.6f},{:.6f}\n",
                       io::CsvEscape(t.Text(row, id)), x.x(), x.y(), x.z(), nominal.x(),
                       nominal.y(), nominal.z(), (x - nominal).norm());
  }
  if (o.out.empty())
    std::cout << out;
  else
    io::WriteFileAtomically(o.out, out);
  return kOk;
}

int RunCompensate(const SignatureOptions& o, const GlobalOptions& global) {
  db::Database database(global.DbPath());
  const ActiveSignature a = LoadActiveSignature(database, o.robot);
  const Eigen::Isometry3d frame = Frame(a, o.frame);
  const int n = a.model.num_joints();
  const io::CsvTable t = io::ReadCsvFile(o.targets);
  const int id = t.Column("point");
  const int cx = t.Column("x_mm"), cy = t.Column("y_mm"), cz = t.Column("z_mm");
  std::vector<io::AngleColumn> q;
  for (int i = 1; i <= n; ++i) {
    if (auto c = t.FindAngleColumn("q" + std::to_string(i))) q.push_back(*c);
  }
  if (!q.empty() && static_cast<int>(q.size()) != n) {
    throw InputError({o.targets, 1, 0, ""},
                     "give all of q1…q" + std::to_string(n) + " (the nominal program) or none");
  }
  Eigen::VectorXd seed = Eigen::VectorXd::Zero(n);
  if (n >= 3) seed(2) = kPi / 2;
  if (!o.seed_deg.empty()) {
    std::stringstream in(o.seed_deg);
    std::string item;
    for (int i = 0; i < n && std::getline(in, item, ','); ++i)
      seed(i) = std::stod(item) * kRadPerDeg;
  }
  const Eigen::VectorXd zero = Eigen::VectorXd::Zero(a.model.num_parameters());
  std::string out = "point";
  for (int i = 1; i <= n; ++i) out += fmt::format(",q{}_deg", i);
  for (int i = 1; i <= n; ++i) out += fmt::format(",nominal_q{}_deg", i);
  out += ",residual_mm,status\n";
  int unreachable = 0;
  for (const auto& row : t.rows()) {
    const Eigen::Vector3d target(t.Number(row, cx), t.Number(row, cy), t.Number(row, cz));
    // The nominal solution: the program's joints, or the nominal model's own solution.
    Eigen::VectorXd nominal(n);
    calibration::JointSolution nominal_solution;
    if (!q.empty()) {
      for (int i = 0; i < n; ++i) nominal(i) = t.AngleRad(row, q[i]);
    } else {
      nominal_solution = calibration::SolveJoints(a.model, frame, zero, target, seed);
      nominal = nominal_solution.joints_rad;
    }
    const auto s = calibration::SolveJoints(a.model, frame, a.signature.params, target, nominal);
    const bool ok =
        s.status == calibration::JointSolveStatus::kConverged &&
        (q.size() || nominal_solution.status == calibration::JointSolveStatus::kConverged);
    out += io::CsvEscape(t.Text(row, id));
    for (int i = 0; i < n; ++i)
      out += ok ? fmt::format(",{:.8f}", s.joints_rad(i) / kRadPerDeg) : std::string(",");
    for (int i = 0; i < n; ++i) out += fmt::format(",{:.8f}", nominal(i) / kRadPerDeg);
    out += fmt::format(",{:.6f},{}\n", s.residual_mm, ok ? "ok" : "unreachable");
    if (!ok) {
      ++unreachable;
      std::cerr << "armsig compensate: target " << t.Text(row, id) << " (" << o.targets << ":"
                << row.line << "): " << (s.reason.empty() ? nominal_solution.reason : s.reason)
                << "\n";
    }
  }
  io::WriteFileAtomically(o.out, out);
  std::cout << fmt::format(
      "{} targets, {} compensated with arm signature version {}, {} unreachable -> {}\n",
      t.rows().size(), t.rows().size() - unreachable, a.signature.version, unreachable, o.out);
  return unreachable ? kFailure : kOk;
}

int RunExport(const SignatureOptions& o, const GlobalOptions& global) {
  db::Database database(global.DbPath());
  const ActiveSignature a = LoadActiveSignature(database, o.robot);
  const std::optional<Eigen::Isometry3d> frame = Frame(a, o.frame);
  std::string text;
  if (o.format == "json") {
    const auto names = a.model.ParameterNames();
    nlohmann::json params = nlohmann::json::array();
    for (int k = 0; k < a.model.num_parameters(); ++k) {
      params.push_back(
          {{"name", names[k]},
           {"value", a.signature.params(k)},
           {"unit", a.model.UnitOf(k) == calibration::ParameterUnit::kMm ? "mm" : "rad"},
           {"identified", std::isfinite(a.signature.sigmas(k))},
           {"sigma", std::isfinite(a.signature.sigmas(k)) ? nlohmann::json(a.signature.sigmas(k))
                                                          : nlohmann::json(nullptr)}});
    }
    text = nlohmann::json{{"robot", o.robot},
                          {"model", a.model.name},
                          {"version", a.signature.version},
                          {"parameters", params}}
               .dump(2) +
           "\n";
  } else if (o.format == "model" || o.format == "urdf") {
    const auto corrected = calibration::CorrectedModel(a.model, a.signature.params, frame);
    if (o.format == "model") {
      text = io::FormatRobotModelYaml(
          corrected, fmt::format("armsig export: robot {}, arm signature version {}, {} frame",
                                 o.robot, a.signature.version, o.frame));
    } else {
      std::string warning;
      text = io::FormatUrdf(corrected, &warning);
      if (!warning.empty()) std::cerr << "armsig export: " << warning << "\n";
    }
  } else {
    throw InputError({"--format", 0, 0, ""},
                     "expected json, model or urdf, got '" + o.format + "'");
  }
  io::WriteFileAtomically(o.out, text);
  std::cout << "armsig export: " << o.format << " of " << o.robot << " version "
            << a.signature.version << " -> " << o.out << "\n";
  return kOk;
}

void SetupSignatureCommands(CLI::App& parent, const GlobalOptions& global, Runner& run) {
  auto p = std::make_shared<SignatureOptions>();
  auto* predict = parent.add_subcommand(
      "predict", "Calibrated target positions for joint angles (active arm signature)");
  predict->add_option("--robot", p->robot, "Robot name")->required();
  predict->add_option("--joints", p->joints, "CSV: pose,q1_deg,…")->required();
  predict->add_option("--out", p->out, "Positions CSV (default: stdout)");
  predict->add_option("--frame", p->frame, "robot | measurement")->capture_default_str();
  predict->callback([&run, &global, p] { run = [&global, p] { return RunPredict(*p, global); }; });

  auto c = std::make_shared<SignatureOptions>();
  auto* compensate = parent.add_subcommand(
      "compensate", "Joint angles that make the calibrated robot reach targets");
  compensate->add_option("--robot", c->robot, "Robot name")->required();
  compensate
      ->add_option("--targets", c->targets,
                   "CSV: point,x_mm,y_mm,z_mm[,q1_deg,… the nominal program]")
      ->required();
  compensate->add_option("--out", c->out, "Joints CSV")->required();
  compensate->add_option("--frame", c->frame, "robot | measurement")->capture_default_str();
  compensate->add_option("--seed-deg", c->seed_deg,
                         "Start of the nominal solution when the targets carry no joints");
  compensate->callback(
      [&run, &global, c] { run = [&global, c] { return RunCompensate(*c, global); }; });

  auto e = std::make_shared<SignatureOptions>();
  auto* exp = parent.add_subcommand(
      "export", "The active arm signature as JSON, a corrected model YAML or a URDF");
  exp->add_option("--robot", e->robot, "Robot name")->required();
  exp->add_option("--format", e->format, "json | model | urdf")->required();
  exp->add_option("--out", e->out, "File to write")->required();
  exp->add_option("--frame", e->frame, "robot | measurement")->capture_default_str();
  exp->callback([&run, &global, e] { run = [&global, e] { return RunExport(*e, global); }; });
}

}  // namespace armsig::app
