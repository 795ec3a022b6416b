// Using the active arm signature:
//   armsig predict    --robot NAME --joints J.csv [--out P.csv] [--frame robot|measurement]
//   armsig compensate --robot NAME --targets T.csv --out J.csv [--frame …] [--seed-deg …]
//   armsig export     --robot NAME --format json|model|urdf --out FILE [--frame …]
#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <iostream>

#include "app/command.h"
#include "core/units.h"
#include "db/database.h"
#include "io/atomic_file.h"
#include "workflows/signature.h"

namespace armsig::app {

struct SignatureOptions {
  std::string robot, joints, targets, out, format, frame = "robot";
  std::vector<double> seed_deg;
};

int RunPredict(const SignatureOptions& o, const GlobalOptions& global) {
  db::Database database(global.DbPath(), db::OpenMode::kMustExist);
  const auto active = workflows::LoadActiveSignature(database, o.robot);
  const std::string csv =
      workflows::PredictCsv(active, workflows::FrameOf(active, o.frame), o.joints);
  if (o.out.empty())
    std::cout << csv;
  else
    io::WriteFileAtomically(o.out, csv);
  return kOk;
}

int RunCompensate(const SignatureOptions& o, const GlobalOptions& global) {
  db::Database database(global.DbPath(), db::OpenMode::kMustExist);
  const auto active = workflows::LoadActiveSignature(database, o.robot);
  std::optional<Eigen::VectorXd> seed;
  if (!o.seed_deg.empty()) {
    seed = Eigen::Map<const Eigen::VectorXd>(o.seed_deg.data(), o.seed_deg.size()) * kRadPerDeg;
  }
  const auto result =
      workflows::Compensate(active, workflows::FrameOf(active, o.frame), o.targets, seed);
  for (const auto& why : result.unreachable) spdlog::warn("compensate: {}", why);
  io::WriteFileAtomically(o.out, result.csv);
  std::cout << fmt::format(
      "{} targets, {} compensated with arm signature version {}, {} unreachable -> {}\n",
      result.targets, result.targets - result.unreachable.size(), active.signature.version,
      result.unreachable.size(), o.out);
  return result.unreachable.empty() ? kOk : kFailure;
}

int RunExport(const SignatureOptions& o, const GlobalOptions& global) {
  db::Database database(global.DbPath(), db::OpenMode::kMustExist);
  const auto active = workflows::LoadActiveSignature(database, o.robot);
  const auto result = workflows::ExportSignature(active, o.robot, o.format, o.frame);
  if (!result.warning.empty()) spdlog::warn("export: {}", result.warning);
  io::WriteFileAtomically(o.out, result.text);
  std::cout << "armsig export: " << o.format << " of " << o.robot << " version "
            << active.signature.version << " -> " << o.out << "\n";
  return kOk;
}

void SetupSignatureCommands(CLI::App& parent, const GlobalOptions& global, Runner& run) {
  auto p = std::make_shared<SignatureOptions>();
  auto* predict = parent.add_subcommand(
      "predict", "Calibrated target positions for joint angles (active arm signature)");
  NameOption(predict->add_option("--robot", p->robot, "Robot name"))->required();
  predict->add_option("--joints", p->joints, "CSV: pose,q1_deg,…")->required();
  OutputFile(predict->add_option("--out", p->out, "Positions CSV (default: stdout)"));
  predict->add_option("--frame", p->frame, "robot | measurement")->capture_default_str();
  predict->callback([&run, &global, p] { run = [&global, p] { return RunPredict(*p, global); }; });

  auto c = std::make_shared<SignatureOptions>();
  auto* compensate = parent.add_subcommand(
      "compensate", "Joint angles that make the calibrated robot reach targets");
  NameOption(compensate->add_option("--robot", c->robot, "Robot name"))->required();
  compensate
      ->add_option("--targets", c->targets,
                   "CSV: point,x_mm,y_mm,z_mm[,q1_deg,… the nominal program]")
      ->required();
  OutputFile(compensate->add_option("--out", c->out, "Joints CSV"))->required();
  compensate->add_option("--frame", c->frame, "robot | measurement")->capture_default_str();
  compensate
      ->add_option("--seed-deg", c->seed_deg,
                   "Start of the nominal solution when the targets carry no joints (q1,…,qn)")
      ->delimiter(',');
  compensate->callback(
      [&run, &global, c] { run = [&global, c] { return RunCompensate(*c, global); }; });

  auto e = std::make_shared<SignatureOptions>();
  auto* exp = parent.add_subcommand(
      "export", "The active arm signature as JSON, a corrected model YAML or a URDF");
  NameOption(exp->add_option("--robot", e->robot, "Robot name"))->required();
  exp->add_option("--format", e->format, "json | model | urdf")->required();
  OutputFile(exp->add_option("--out", e->out, "File to write"))->required();
  exp->add_option("--frame", e->frame, "robot | measurement")->capture_default_str();
  exp->callback([&run, &global, e] { run = [&global, e] { return RunExport(*e, global); }; });
}

}  // namespace armsig::app
