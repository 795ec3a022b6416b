// armsig robot add NAME --model FILE.yaml | robot list [--json] [--removed]
// armsig robot rename NAME NEW_NAME | remove NAME | restore NAME | history NAME
// armsig session move ID --robot NAME
// armsig sessions [--robot NAME] [--json] | session export ID --poses OUT.csv
// armsig versions --robot NAME [--json] | activate --robot NAME --version N
#include <fmt/format.h>

#include <iostream>

#include "app/command.h"
#include "core/text.h"
#include "io/atomic_file.h"
#include "io/poses_csv.h"
#include "workflows/lifecycle.h"

namespace armsig::app {

namespace {

struct LifecycleOptions {
  std::string name, model, robot, poses, reason;
  int64_t session = 0;
  int version = 0;
  bool json = false, removed = false;
};

}  // namespace

namespace {

// armsig robot add | list | rename | remove | restore | history
void SetupRobotCommands(CLI::App& parent, const GlobalOptions& global, Runner& run) {
  auto* robot = parent.add_subcommand("robot", "Register, list, rename and remove robots, with their history");
  robot->require_subcommand(1);
  {
    auto o = std::make_shared<LifecycleOptions>();
    auto* add = robot->add_subcommand("add", "Register a robot with its model file");
    NameOption(add->add_option("name", o->name, "Robot name"))->required();
    add->add_option("--model", o->model, "Robot model YAML")->type_name("FILE")->required();
    add->callback([&run, &global, o] {
      run = [&global, o] {
        db::Database database(global.DbPath());
        const bool added = workflows::RegisterRobot(database, o->name, o->model);
        std::cout << fmt::format("robot {} {} in {}\n", o->name,
                                 added ? "registered" : "already registered with this model",
                                 Printable(database.path()));
        return kOk;
      };
    });
  }
  auto o = std::make_shared<LifecycleOptions>();
  auto* list = robot->add_subcommand("list", "List the registered robots");
  list->add_flag("--json", o->json, "Machine-readable output");
  list->add_flag("--removed", o->removed, "The removed robots too");
  OnDatabaseToRead(list, global, run, [o = o](db::Database& database) {
    const auto robots = db::ListRobots(database, o->removed);
    std::cout << workflows::FormatRobots(robots, o->json, database.path());
    if (!o->json && !o->removed) {
      const size_t removed = db::ListRobots(database, true).size() - robots.size();
      if (removed > 0) {
        std::cout << fmt::format("({} removed: armsig robot list --removed)\n", removed);
      }
    }
    return kOk;
  });

  // A robot's history when the lab reorganises: every change is recorded with who and why.
  o = std::make_shared<LifecycleOptions>();
  auto* rename = robot->add_subcommand(
      "rename", "Rename a robot; its sessions, parameter sets and history follow it");
  NameOption(rename->add_option("name", o->name, "Robot name"))->required();
  NameOption(rename->add_option("new_name", o->robot, "Its new name"))->required();
  NoteOption(rename->add_option("--reason", o->reason, "Why (kept in its history)"));
  OnExistingDatabase(rename, global, run, [o = o](db::Database& database) {
    workflows::RenameRobot(database, o->name, o->robot, o->reason);
    std::cout << fmt::format("robot {} renamed {}: its sessions, parameter sets and history "
                             "follow it (armsig robot history {})\n",
                             Printable(o->name), Printable(o->robot), Printable(o->robot));
    return kOk;
  });
  o = std::make_shared<LifecycleOptions>();
  auto* remove = robot->add_subcommand(
      "remove", "Retire a robot: hidden, no new work, every session and set kept");
  NameOption(remove->add_option("name", o->name, "Robot name"))->required();
  NoteOption(remove->add_option("--reason", o->reason, "Why (kept in its history)"));
  OnExistingDatabase(remove, global, run, [o = o](db::Database& database) {
    workflows::RemoveRobot(database, o->name, o->reason);
    std::cout << fmt::format("robot {} removed: its history is kept and takes no new work "
                             "(armsig robot restore {} brings it back)\n",
                             Printable(o->name), Printable(o->name));
    return kOk;
  });
  o = std::make_shared<LifecycleOptions>();
  auto* bring_back = robot->add_subcommand("restore", "Bring a removed robot back into use");
  NameOption(bring_back->add_option("name", o->name, "Robot name"))->required();
  NoteOption(bring_back->add_option("--reason", o->reason, "Why (kept in its history)"));
  OnExistingDatabase(bring_back, global, run, [o = o](db::Database& database) {
    workflows::RestoreRobot(database, o->name, o->reason);
    std::cout << fmt::format("robot {} restored\n", Printable(o->name));
    return kOk;
  });
  o = std::make_shared<LifecycleOptions>();
  auto* history = robot->add_subcommand(
      "history", "A robot's renames, removals and sessions moved, with who and why");
  NameOption(history->add_option("name", o->name, "Robot name"))->required();
  history->add_flag("--json", o->json, "Machine-readable output");
  OnDatabaseToRead(history, global, run, [o = o](db::Database& database) {
    std::cout << workflows::FormatRobotHistory(database, o->name, o->json);
    return kOk;
  });
}

}  // namespace

void SetupLifecycleCommands(CLI::App& parent, const GlobalOptions& global, Runner& run) {
  SetupRobotCommands(parent, global, run);
  auto o = std::make_shared<LifecycleOptions>();
  auto* sessions = parent.add_subcommand("sessions", "List the measurement sessions");
  NameOption(sessions->add_option("--robot", o->robot, "Only this robot's"));
  sessions->add_flag("--json", o->json, "Machine-readable output");
  OnDatabaseToRead(sessions, global, run, [o = o](db::Database& database) {
    std::cout << workflows::FormatSessions(workflows::Sessions(database, o->robot), o->json);
    return kOk;
  });

  o = std::make_shared<LifecycleOptions>();
  auto* session = parent.add_subcommand("session", "One session");
  session->require_subcommand(1);
  auto* exp = session->add_subcommand("export", "A session's measured poses as a poses CSV");
  NumberOption(exp->add_option("id", o->session, "Session id"), 1, kMaxId)->required();
  OutputFile(exp->add_option("--poses", o->poses, "Poses CSV to write"))->required();
  OnDatabaseToRead(exp, global, run, [o = o](db::Database& database) {
    const auto poses = workflows::SessionPoses(database, o->session);
    io::WriteFileAtomically(
        o->poses, io::FormatPosesCsv(poses, workflows::SessionJoints(database, o->session)));
    std::cout << fmt::format("session {}: {} poses -> {}\n", o->session, poses.size(),
                             Printable(o->poses));
    return kOk;
  });

  o = std::make_shared<LifecycleOptions>();
  auto* discard = session->add_subcommand(
      "discard", "Keep a session's measurements out of every recalibration (wrong set-up)");
  NumberOption(discard->add_option("id", o->session, "Session id"), 1, kMaxId)->required();
  NoteOption(discard->add_option("--reason", o->name, "Why (stored in the session's note)"));
  OnExistingDatabase(discard, global, run, [o = o](db::Database& database) {
    workflows::DiscardSession(database, o->session, o->name);
    std::cout << fmt::format(
        "session {} discarded: its measurements stay stored, no recalibration uses them "
        "(armsig session restore {} undoes it)\n",
        o->session, o->session);
    return kOk;
  });

  o = std::make_shared<LifecycleOptions>();
  auto* restore =
      session->add_subcommand("restore", "Use a discarded session's measurements again");
  NumberOption(restore->add_option("id", o->session, "Session id"), 1, kMaxId)->required();
  OnExistingDatabase(restore, global, run, [o = o](db::Database& database) {
    const db::SessionState state = workflows::RestoreSession(database, o->session);
    std::cout << fmt::format("session {} restored ({})\n", o->session, db::ToString(state));
    return kOk;
  });

  o = std::make_shared<LifecycleOptions>();
  auto* move = session->add_subcommand(
      "move", "Move a session to another robot (measured under the wrong name), with its history");
  NumberOption(move->add_option("id", o->session, "Session id"), 1, kMaxId)->required();
  NameOption(move->add_option("--robot", o->robot, "The robot it belongs to"))->required();
  NoteOption(move->add_option("--reason", o->reason, "Why (kept in both robots' history)"));
  OnExistingDatabase(move, global, run, [o = o](db::Database& database) {
    const std::string from = workflows::MoveSession(database, o->session, o->robot, o->reason);
    std::cout << fmt::format(
        "session {} moved from robot {} to robot {}: the next recalibration of each uses what "
        "it now holds; sets already fitted keep what they were fitted on\n",
        o->session, Printable(from), Printable(o->robot));
    return kOk;
  });

  o = std::make_shared<LifecycleOptions>();
  auto* kind = session->add_subcommand(
      "kind", "What a session is for: calibration (fitted by the nightly job) | check | test");
  NumberOption(kind->add_option("id", o->session, "Session id"), 1, kMaxId)->required();
  ChoiceOption(kind->add_option("kind", o->name, "calibration | check | test"),
               {"calibration", "check", "test"})
      ->required();
  OnExistingDatabase(kind, global, run, [o = o](db::Database& database) {
    const db::SessionKind was =
        workflows::SetSessionKind(database, o->session, *db::SessionKindNamed(o->name));
    std::cout << fmt::format("session {}: {} ({} before)\n", o->session, o->name, db::ToString(was));
    return kOk;
  });

  o = std::make_shared<LifecycleOptions>();
  auto* versions = parent.add_subcommand("versions", "A robot's parameter sets (* = active)");
  NameOption(versions->add_option("--robot", o->robot, "Robot name"))->required();
  versions->add_flag("--json", o->json, "Machine-readable output");
  OnDatabaseToRead(versions, global, run, [o = o](db::Database& database) {
    std::cout << workflows::FormatVersions(workflows::Versions(database, o->robot), o->json,
                                           o->robot);
    return kOk;
  });

  o = std::make_shared<LifecycleOptions>();
  auto* activate =
      parent.add_subcommand("activate", "Make a parameter set active (roll back or forward)");
  NameOption(activate->add_option("--robot", o->robot, "Robot name"))->required();
  NumberOption(activate->add_option("--version", o->version, "Version to activate"), 1, kMaxId)
      ->required();
  OnExistingDatabase(activate, global, run, [o = o](db::Database& database) {
    const auto previous = workflows::Activate(database, o->robot, o->version);
    if (previous == o->version) {
      std::cout << fmt::format("robot {}: version {} was already active (nothing recorded)\n",
                               o->robot, o->version);
    } else {
      std::cout << fmt::format("robot {}: version {} active (was {})\n", o->robot, o->version,
                               previous ? "version " + std::to_string(*previous) : "none");
    }
    return kOk;
  });
}

}  // namespace armsig::app
