// armsig iso9283 plan --robot NAME (--cube CX,CY,CZ,EDGE_MM | --auto [--centre X,Y,Z])
//                     [--orientation A,B,C] [--cycles 30] [--compensated]
//                     [--approach [--approach-mm 100]] [--path line,rectangle,… [--speed 250]]
//                     --out PLAN.csv
#include <fmt/format.h>

#include <iostream>

#include "app/command.h"
#include "calibration/iso9283_cube.h"
#include "core/error.h"
#include "core/plausibility.h"
#include "core/units.h"
#include "db/robots.h"
#include "io/atomic_file.h"
#include "io/model_yaml.h"
#include "workflows/hint.h"
#include "iso9283/iso9283.h"
#include "workflows/signature.h"

namespace armsig::app {

struct Iso9283PlanCommandOptions {
  std::string robot, out;
  std::vector<double> cube, centre, orientation_deg, seed_deg;
  bool auto_cube = false;
  iso9283::Iso9283PlanOptions plan;
  const CLI::Option* cycles = nullptr;  // given or not: a path test's default is 10
};

int RunIso9283Plan(const Iso9283PlanCommandOptions& o, db::Database& db) {
  if (o.cube.empty() == !o.auto_cube)
    throw InputError({"--cube", 0, 0, ""}, "give the cube (--cube CX,CY,CZ,EDGE_MM) or --auto");
  iso9283::Iso9283PlanOptions options = o.plan;
  auto vector3 = [](const std::vector<double>& v, const char* option, int count) {
    if (static_cast<int>(v.size()) != count)
      throw InputError({option, 0, 0, ""},
                       fmt::format("expected {} numbers, got {}", count, v.size()));
    return Eigen::Vector3d(v[0], v[1], v[2]);
  };
  if (!o.cube.empty()) {
    options.cube = calibration::iso9283::TestCube{vector3(o.cube, "--cube", 4), o.cube[3]};
    if (!(o.cube[3] >= calibration::iso9283::kMinCubeEdgeMm)) {
      throw InputError({"--cube", 0, 0, ""},
                       fmt::format("an edge of {:g} mm is no test of the working space (ISO "
                                   "9283: the largest cube it holds; expected at least {:g} mm)",
                                   o.cube[3], calibration::iso9283::kMinCubeEdgeMm));
    }
    if (!o.centre.empty()) throw InputError({"--centre", 0, 0, ""}, "--centre goes with --auto");
  }
  options.auto_cube = o.auto_cube;
  // The standard's number of cycles: 30 for the pose test, 10 for a path.
  if (!options.paths.empty() && o.cycles && o.cycles->count() == 0) options.cycles = 10;
  if (!o.centre.empty()) options.centre_mm = vector3(o.centre, "--centre", 3);
  if (!o.orientation_deg.empty())
    options.orientation_rad = vector3(o.orientation_deg, "--orientation", 3) * kRadPerDeg;
  if (!o.seed_deg.empty()) {
    options.seed_rad =
        Eigen::Map<const Eigen::VectorXd>(o.seed_deg.data(), o.seed_deg.size()) * kRadPerDeg;
  }
  const auto robot_id = db::FindRobot(db, o.robot);
  if (!robot_id)
    throw InputError({db.path(), 0, 0, "--robot"},
                     workflows::UnknownRobotMessage(db, o.robot));
  const auto model =
      io::ParseRobotModel(db::RobotModelYaml(db, *robot_id), "model of robot " + o.robot);
  std::optional<workflows::ActiveSignature> signature;
  if (options.compensated) signature = workflows::LoadActiveSignature(db, o.robot);
  const auto plan =
      iso9283::MakeIso9283Plan(model, o.robot, options, signature ? &*signature : nullptr);
  io::WriteFileAtomically(o.out, plan.csv);
  std::vector<std::string> capture = {"capture", "--lab",  "LAB.yaml", "--plan",
                                      workflows::AbsolutePath(o.out), "--robot", o.robot};
  if (!options.paths.empty()) capture.push_back("--on-the-move");  // linear moves, measured moving
  std::cout << iso9283::FormatIso9283PlanSummary(plan, o.out)
            << "capture it: " << workflows::Hint(db.path(), capture) << "\n";
  return kOk;
}

void SetupIso9283PlanCommand(CLI::App& iso, const GlobalOptions& global, Runner& run) {
  auto o = std::make_shared<Iso9283PlanCommandOptions>();
  auto* sub = iso.add_subcommand(
      "plan", "The ISO 9283 test plan: cube, P1-P5, cycles, joints by the model's inverse");
  NameOption(sub->add_option("--robot", o->robot, "Robot name"))->required();
  auto* cube = sub->add_option("--cube", o->cube,
                               "The cube: centre and edge, CX,CY,CZ,EDGE_MM "
                               "(robot frame)")
                   ->delimiter(',')
                   ->check(NumberCheck(-plausible::kMaxLengthMm, plausible::kMaxLengthMm));
  auto* automatic =
      sub->add_flag("--auto", o->auto_cube, "The largest cube the model reaches around --centre");
  cube->excludes(automatic);
  sub->add_option("--centre", o->centre,
                  "Centre of the --auto cube, X,Y,Z mm (default: the target at the seed posture)")
      ->delimiter(',')
      ->check(NumberCheck(-plausible::kMaxLengthMm, plausible::kMaxLengthMm));
  sub->add_option("--orientation", o->orientation_deg,
                  "Tool orientation at every pose, A,B,C deg (last link frame, R = Rz(C) Ry(B) "
                  "Rx(A); default: the orientation the inverse gives P1)")
      ->delimiter(',')
      ->check(NumberCheck(-360.0, 360.0));
  o->cycles = NumberOption(sub->add_option("--cycles", o->plan.cycles,
                                           "Cycles (the standard: 30; 10 for --path)"),
                           1, 10000)
                  ->capture_default_str();
  sub->add_flag("--compensated", o->plan.compensated,
                "Joints from the robot's active arm signature (compensated program)");
  auto* approach = sub->add_flag(
      "--approach", o->plan.multi_directional,
      "Multi-directional test (vAP): approach each point from its +x, +y and +z side");
  auto* path = sub->add_option("--path", o->plan.paths,
                               "A path test instead (ISO 9283 clause 8): line, rectangle, "
                               "circle-large, circle-small (comma-separated), linear and "
                               "circular moves measured on the move")
                   ->delimiter(',')
                   ->check(CLI::IsMember({"line", "rectangle", "circle-large", "circle-small"}));
  path->excludes(approach);
  NumberOption(sub->add_option("--speed", o->plan.path_speed_mm_s,
                               "The path speed of --path, mm/s (URScript movel's default 250)"),
               1.0, 5000.0)
      ->capture_default_str()
      ->needs(path);
  NumberOption(sub->add_option("--approach-mm", o->plan.approach_mm,
                               "Distance of the via points of --approach"),
               1.0, 2000.0)
      ->capture_default_str();
  sub->add_option("--seed-deg", o->seed_deg,
                  "Start of the inverse for P1, q1,…,qn deg (default 0,0,90,0,30,0)")
      ->delimiter(',')
      ->check(NumberCheck(-720.0, 720.0));
  OutputFile(sub->add_option("--out", o->out, "The plan CSV (capture --plan reads it)"))
      ->required();
  OnDatabaseToRead(sub, global, run, [o](db::Database& db) { return RunIso9283Plan(*o, db); });
}

}  // namespace armsig::app
