// Using an arm signature (the active one, or a stored one with --set N):
//   armsig predict    --robot NAME [--set N] --joints J.csv [--out P.csv] [--frame robot|measurement]
//   armsig compensate --robot NAME [--set N] --targets T.csv --out J.csv [--frame …] [--seed-deg …]
//   armsig compensate --robot NAME [--set N] --program IN --out OUT [--json REPORT] [--allow-outside]
//                     [--config-dat $config.dat] [--controller-kinematics K.yaml]
//   armsig export     --robot NAME [--set N] --format json|model|urdf --out FILE [--frame …]
//   armsig report     --robot NAME [--set N] --out DIR
#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <iostream>

#include "app/command.h"
#include "core/error.h"
#include "core/text.h"
#include "core/units.h"
#include "io/atomic_file.h"
#include "workflows/program_compensation.h"
#include "workflows/signature.h"
#include "report/stored_report.h"

namespace armsig::app {

namespace {

struct SignatureOptions {
  std::string robot, joints, targets, out, format, frame = "robot";
  std::string program, json, config_dat, controller_kinematics;
  bool allow_outside = false;
  std::optional<int> set;  // --set N: a stored version (default: the active one)
  std::vector<double> seed_deg;
  bool map_sigma = false;
};

CLI::App* Command(CLI::App& parent, const char* name, const char* help, SignatureOptions& o) {
  auto* sub = parent.add_subcommand(name, help);
  NameOption(sub->add_option("--robot", o.robot, "Robot name"))->required();
  AddSetOption(*sub, o.set);
  ChoiceOption(sub->add_option("--frame", o.frame, "robot | measurement"), {"robot", "measurement"})
      ->capture_default_str();
  return sub;
}

}  // namespace

void SetupSignatureCommands(CLI::App& parent, const GlobalOptions& global, Runner& run) {
  auto p = std::make_shared<SignatureOptions>();
  auto* predict = Command(
      parent, "predict", "Calibrated target positions for joint angles (active arm signature)", *p);
  predict->add_option("--joints", p->joints, "CSV: pose,q1_deg,…")->type_name("FILE")->required();
  predict->add_flag("--map-sigma", p->map_sigma,
                    "Fill map_sigma_mm: the residual map's predictive sigma per configuration");
  OutputFile(predict->add_option("--out", p->out, "Positions CSV (default: stdout)"));
  OnDatabaseToRead(predict, global, run, [p](db::Database& database) {
    const auto active = workflows::LoadSignature(database, p->robot, p->set);
    const std::string csv =
        workflows::PredictCsv(active, workflows::FrameOf(active, p->frame), p->joints, p->map_sigma);
    if (p->out.empty())
      std::cout << csv;
    else
      io::WriteFileAtomically(p->out, csv);
    return kOk;
  });

  auto c = std::make_shared<SignatureOptions>();
  auto* compensate = Command(
      parent, "compensate",
      "Joint angles, or a whole robot program, that make the calibrated robot reach its targets", *c);
  auto* targets = compensate->add_option("--targets", c->targets,
                                         "CSV: point,x_mm,y_mm,z_mm[,q1_deg,… the nominal program]")
                      ->type_name("FILE");
  auto* program =
      compensate
          ->add_option("--program", c->program,
                       "A robot program: .script (URScript), .src (KUKA KRL, its .dat beside it), "
                       ".mod / .modx (ABB RAPID); every target rewritten, every other byte kept")
          ->type_name("FILE");
  targets->excludes(program);
  OutputFile(compensate->add_option("--out", c->out, "Joints CSV, or the compensated program"))->required();
  OutputFile(compensate->add_option("--json", c->json, "With --program: the report per target as JSON"));
  compensate->add_flag("--allow-outside", c->allow_outside,
                       "With --program: write targets outside the validated volume anyway (and leave "
                       "the others refused as written) instead of writing nothing");
  compensate
      ->add_option("--config-dat", c->config_dat,
                   "With a KRL program: the robot's $config.dat, for its TOOL_DATA and BASE_DATA")
      ->type_name("FILE");
  compensate
      ->add_option("--controller-kinematics", c->controller_kinematics,
                   "With a URScript program: the UR's own kinematics (YAML: dh_theta, dh_a, dh_d, "
                   "dh_alpha as KinematicsInfo sends them); default the robot's nominal model")
      ->type_name("FILE");
  compensate
      ->add_option("--seed-deg", c->seed_deg,
                   "Start of the nominal solution when the targets carry no joints (q1,…,qn)")
      ->delimiter(',')
      ->check(NumberCheck(-720.0, 720.0));
  OnDatabaseToRead(compensate, global, run, [c](db::Database& database) {
    if (!c->program.empty()) {
      if (c->frame != "robot")
        throw InputError({"--frame", 0, 0, ""},
                         "a program's targets are in the robot's own frame (its controller's base): "
                         "--frame goes with --targets");
      workflows::ProgramCompensationOptions o;
      o.robot = c->robot;
      o.set = c->set;
      o.program_path = c->program;
      o.out_path = c->out;
      o.allow_outside = c->allow_outside;
      o.config_dat = c->config_dat;
      o.controller_kinematics = c->controller_kinematics;
      const auto result = workflows::CompensateProgramFiles(database, o);
      if (!c->json.empty())
        io::WriteFileAtomically(c->json, JsonText(workflows::ProgramCompensationJson(result, c->robot), 2) + "\n");
      std::cout << workflows::FormatProgramCompensation(result);
      return result.result.written() ? kOk : kQualityGate;
    }
    if (c->targets.empty())
      throw InputError({"--targets", 0, 0, ""}, "give --targets T.csv (joint angles) or --program IN (a robot program)");
    if (c->allow_outside || !c->json.empty() || !c->config_dat.empty() || !c->controller_kinematics.empty())
      throw InputError({"--program", 0, 0, ""},
                       "--json, --allow-outside, --config-dat and --controller-kinematics go with --program");
    const auto active = workflows::LoadSignature(database, c->robot, c->set);
    std::optional<Eigen::VectorXd> seed;
    if (!c->seed_deg.empty()) {
      seed = Eigen::Map<const Eigen::VectorXd>(c->seed_deg.data(), c->seed_deg.size()) * kRadPerDeg;
    }
    // Where the set was validated: a file whose every target lies outside it and inside it
    // in another unit is refused.
    const auto volume = workflows::ValidatedVolumeOf(database, active);
    const auto result = workflows::Compensate(active, workflows::FrameOf(active, c->frame),
                                              c->targets, seed, volume ? &*volume : nullptr);
    for (const auto& why : result.unreachable) spdlog::warn("compensate: {}", why);
    if (result.outside_map > 0) {
      spdlog::warn(
          "compensate: {} targets lie outside the residual map's support: only the parts of the "
          "map that have data there shaped their joints (status ok_outside_map)",
          result.outside_map);
    }
    io::WriteFileAtomically(c->out, result.csv);
    std::cout << fmt::format(
        "{} targets, {} compensated with arm signature version {}, {} unreachable -> {}\n",
        result.targets, result.targets - result.unreachable.size(), active.signature.version,
        result.unreachable.size(), Printable(c->out));
    return result.unreachable.empty() ? kOk : kFailure;
  });

  auto e = std::make_shared<SignatureOptions>();
  auto* exp = Command(parent, "export",
                      "The active arm signature as JSON, a corrected model YAML or a URDF", *e);
  ChoiceOption(exp->add_option("--format", e->format, "json | model | urdf"), {"json", "model", "urdf"})
      ->required();
  OutputFile(exp->add_option("--out", e->out, "File to write"))->required();
  OnDatabaseToRead(exp, global, run, [e](db::Database& database) {
    const auto active = workflows::LoadSignature(database, e->robot, e->set);
    const auto result = workflows::ExportSignature(active, e->robot, e->format, e->frame);
    if (!result.warning.empty()) spdlog::warn("export: {}", result.warning);
    io::WriteFileAtomically(e->out, result.text);
    std::cout << "armsig export: " << e->format << " of " << e->robot << " version "
              << active.signature.version << " -> " << Printable(e->out) << "\n";
    return kOk;
  });

  auto r = std::make_shared<SignatureOptions>();
  auto* report = parent.add_subcommand(
      "report", "The HTML report of a stored parameter set (the active one, or --set N)");
  NameOption(report->add_option("--robot", r->robot, "Robot name"))->required();
  AddSetOption(*report, r->set);
  OutputDirectory(report->add_option("--out", r->out, "Folder for index.html and its figures"))
      ->required();
  OnDatabaseToRead(report, global, run, [r](db::Database& database) {
    const auto written = report::WriteStoredReport(database, r->robot, r->set, r->out);
    std::cout << fmt::format("armsig report: {} version {} -> {}\n", r->robot, written.version,
                             Printable(written.path));
    return kOk;
  });
}

}  // namespace armsig::app
