// armsig robot add NAME --model FILE.yaml | robot list [--json]
// armsig sessions [--robot NAME] [--json] | session export ID --poses OUT.csv
// armsig versions --robot NAME [--json] | activate --robot NAME --version N
#include <fmt/format.h>

#include <iostream>

#include "app/command.h"
#include "io/atomic_file.h"
#include "io/poses_csv.h"
#include "workflows/lifecycle.h"

namespace armsig::app {

namespace {

struct LifecycleOptions {
  std::string name, model, robot, poses;
  int64_t session = 0;
  int version = 0;
  bool json = false;
};

void PrintJsonArray(const nlohmann::json& items) { std::cout << items.dump(2) << "\n"; }

int RunRobotList(const LifecycleOptions& o, const GlobalOptions& global) {
  db::Database database(global.DbPath(), db::OpenMode::kMustExist);
  const auto robots = db::ListRobots(database);
  if (o.json) {
    nlohmann::json out = nlohmann::json::array();
    for (const auto& r : robots) out.push_back(workflows::ToJson(r));
    PrintJsonArray(out);
    return kOk;
  }
  if (robots.empty()) std::cout << "no robots in " << database.path() << "\n";
  for (const auto& r : robots) {
    std::cout << fmt::format("{:<20} model {:<12} {:>3} sessions  active version {}\n", r.name,
                             r.model_name, r.sessions,
                             r.active_version ? std::to_string(*r.active_version) : "none");
  }
  return kOk;
}

int RunSessions(const LifecycleOptions& o, const GlobalOptions& global) {
  db::Database database(global.DbPath(), db::OpenMode::kMustExist);
  const auto sessions = workflows::Sessions(database, o.robot);
  if (o.json) {
    nlohmann::json out = nlohmann::json::array();
    for (const auto& s : sessions) out.push_back(workflows::ToJson(s));
    PrintJsonArray(out);
    return kOk;
  }
  if (sessions.empty()) std::cout << "no sessions\n";
  for (const auto& s : sessions) {
    std::cout << fmt::format(
        "{:>4}  {:<16} {:<9} {}  {:>4} measured {:>3} skipped {:>4} usable ({} flagged)  {}\n",
        s.id, s.robot, s.state, s.started_at.substr(0, 19), s.measured, s.skipped, s.usable,
        s.flagged, s.note);
  }
  return kOk;
}

int RunVersions(const LifecycleOptions& o, const GlobalOptions& global) {
  db::Database database(global.DbPath(), db::OpenMode::kMustExist);
  const auto versions = workflows::Versions(database, o.robot);
  if (o.json) {
    nlohmann::json out = nlohmann::json::array();
    for (const auto& v : versions) out.push_back(workflows::ToJson(v));
    PrintJsonArray(out);
    return kOk;
  }
  if (versions.empty()) std::cout << "robot " << o.robot << " has no parameter set yet\n";
  for (const auto& v : versions) {
    std::cout << fmt::format(
        "{} v{:<3} {}  params {:<9} rank {:>2}  fit {:>3} poses  validation mean {:.4f} max "
        "{:.4f} mm on {}  sessions {}\n",
        v.active ? "*" : " ", v.version, v.created_at.substr(0, 19), v.params_spec, v.rank,
        v.poses_fit, v.validation_mean_mm, v.validation_max_mm, v.poses_validation,
        v.sessions.empty() ? std::string("(not recorded)")
                           : fmt::format("{}", fmt::join(v.sessions, ",")));
  }
  return kOk;
}

}  // namespace

void SetupLifecycleCommands(CLI::App& parent, const GlobalOptions& global, Runner& run) {
  auto* robot = parent.add_subcommand("robot", "Register robots and list them");
  robot->require_subcommand(1);
  {
    auto o = std::make_shared<LifecycleOptions>();
    auto* add = robot->add_subcommand("add", "Register a robot with its model file");
    NameOption(add->add_option("name", o->name, "Robot name"))->required();
    add->add_option("--model", o->model, "Robot model YAML")->required();
    add->callback([&run, &global, o] {
      run = [&global, o] {
        db::Database database(global.DbPath());
        const bool added = workflows::RegisterRobot(database, o->name, o->model);
        std::cout << fmt::format("robot {} {} in {}\n", o->name,
                                 added ? "registered" : "already registered with this model",
                                 database.path());
        return kOk;
      };
    });
  }
  {
    auto o = std::make_shared<LifecycleOptions>();
    auto* list = robot->add_subcommand("list", "List the registered robots");
    list->add_flag("--json", o->json, "Machine-readable output");
    list->callback([&run, &global, o] { run = [&global, o] { return RunRobotList(*o, global); }; });
  }
  {
    auto o = std::make_shared<LifecycleOptions>();
    auto* sessions = parent.add_subcommand("sessions", "List the measurement sessions");
    NameOption(sessions->add_option("--robot", o->robot, "Only this robot's"));
    sessions->add_flag("--json", o->json, "Machine-readable output");
    sessions->callback(
        [&run, &global, o] { run = [&global, o] { return RunSessions(*o, global); }; });
  }
  {
    auto o = std::make_shared<LifecycleOptions>();
    auto* session = parent.add_subcommand("session", "One session");
    session->require_subcommand(1);
    auto* exp = session->add_subcommand("export", "A session's measured poses as a poses CSV");
    exp->add_option("id", o->session, "Session id")->required();
    OutputFile(exp->add_option("--poses", o->poses, "Poses CSV to write"))->required();
    exp->callback([&run, &global, o] {
      run = [&global, o] {
        db::Database database(global.DbPath(), db::OpenMode::kMustExist);
        const auto poses = workflows::SessionPoses(database, o->session);
        io::WriteFileAtomically(o->poses, io::FormatPosesCsv(poses));
        std::cout << fmt::format("session {}: {} poses -> {}\n", o->session, poses.size(),
                                 o->poses);
        return kOk;
      };
    });
  }
  {
    auto o = std::make_shared<LifecycleOptions>();
    auto* versions = parent.add_subcommand("versions", "A robot's parameter sets (* = active)");
    NameOption(versions->add_option("--robot", o->robot, "Robot name"))->required();
    versions->add_flag("--json", o->json, "Machine-readable output");
    versions->callback(
        [&run, &global, o] { run = [&global, o] { return RunVersions(*o, global); }; });
  }
  {
    auto o = std::make_shared<LifecycleOptions>();
    auto* activate =
        parent.add_subcommand("activate", "Make a parameter set active (roll back or forward)");
    NameOption(activate->add_option("--robot", o->robot, "Robot name"))->required();
    activate->add_option("--version", o->version, "Version to activate")->required();
    activate->callback([&run, &global, o] {
      run = [&global, o] {
        db::Database database(global.DbPath(), db::OpenMode::kMustExist);
        const auto previous = workflows::Activate(database, o->robot, o->version);
        std::cout << fmt::format("robot {}: version {} active (was {})\n", o->robot, o->version,
                                 previous ? "version " + std::to_string(*previous) : "none");
        return kOk;
      };
    });
  }
}

}  // namespace armsig::app
