// armsig capture --lab LAB.yaml --plan PLAN --robot NAME [--skip-on-fault] [--on-the-move]
// armsig capture --lab LAB.yaml --resume SESSION
#include <unistd.h>

#include <iostream>

#include "app/command.h"
#include "core/units.h"
#include "instruments/device.h"
#include "workflows/capture.h"

namespace armsig::app {

namespace {

// Asks the operator to move the robot when the controller cannot be commanded.
void PromptMove(const acquisition::PlannedConfiguration& c) {
  std::cerr << "\nmove the robot to " << c.label << " (deg:";
  for (int i = 0; i < c.joints_rad.size(); ++i) std::cerr << " " << c.joints_rad(i) / kRadPerDeg;
  if (::isatty(STDIN_FILENO)) {
    std::cerr << ") and press Enter ";
    std::string line;
    std::getline(std::cin, line);
  } else {
    std::cerr << "); not a terminal: measuring where the robot is\n";
  }
}

// Asks the operator to point a laser tracker's beam at its reflector (only on a terminal;
// otherwise such a configuration is an instrument fault).
void PromptReflector(const std::string& station, const acquisition::PlannedConfiguration& c) {
  std::cerr << "\n"
            << station << ": the reflector is not where the beam points (configuration " << c.label
            << "); point the beam at it (the tracker's camera, or turn the head by hand) and "
               "press Enter ";
  std::string line;
  std::getline(std::cin, line);
}

// A protective stop: said on the terminal; Enter has armsig clear it from here (after the
// operator has looked at why the arm stopped), else it waits until it is cleared on the
// pendant. Not a terminal: the session waits for the pendant.
bool ClearProtectiveStop(const instruments::ControllerError& e) {
  std::cerr << "\n" << e.what() << "\n";
  if (!::isatty(STDIN_FILENO)) {
    std::cerr << "waiting until it is cleared on the controller (Ctrl-C pauses the session)\n";
    return false;
  }
  std::cerr << "look at why the arm stopped; then press Enter to clear it from here, or clear "
               "it on the pendant (Ctrl-C pauses the session) ";
  std::string line;
  std::getline(std::cin, line);
  return static_cast<bool>(std::cin);
}

}  // namespace

void SetupCaptureCommand(CLI::App& parent, const GlobalOptions& global, Runner& run) {
  auto o = std::make_shared<workflows::CaptureRequest>();
  auto* sub = parent.add_subcommand("capture", "Run a capture session with the lab's instruments");
  sub->add_option("--lab", o->lab, "Lab configuration YAML")->type_name("FILE")->required();
  sub->add_option("--plan", o->plan, "PLAN.csv, auto:N (well spread) or single-joint:J:STEPS")
      ->type_name("PLAN");
  NameOption(sub->add_option("--robot", o->robot,
                             "Robot name (a new name registers the lab's robot; one a typo away "
                             "from a registered robot is refused)"));
  NumberOption(sub->add_option("--seed", o->seed,
                               "Draw of --plan auto:N: the same seed, the same configurations "
                               "(default 7); another, another well-spread set"),
               0, 4294967295.0);
  NumberOption(sub->add_option("--resume", o->resume, "Continue this session where it stopped"), 1,
               kMaxId);
  sub->add_flag("--skip-on-fault", o->skip_on_fault,
                "Record a configuration whose instrument keeps failing as skipped and go on "
                "(default: pause), and exit 0 although configurations failed or were flagged "
                "(default: exit 1, naming them)");
  sub->add_flag("--on-the-move", o->on_the_move,
                "Sweep the plan without stopping while the laser tracker measures continuously; "
                "each point paired with the joints at its own time stamp, the two clocks' "
                "offset and drift estimated from the data (one emscon tracker and a ur "
                "controller with can_move: true)");
  sub->callback([&run, &global, o] {
    run = [&global, o] {
      workflows::CaptureRequest request = *o;
      request.db_path = global.DbPath();
      request.stop = &StopRequested();  // Ctrl-C from the first moment
      request.progress = TerminalCaptureProgress(false);
      const bool tty = request.progress != nullptr;
      request.prompt_move = PromptMove;
      if (::isatty(STDIN_FILENO)) request.prompt_reflector = PromptReflector;
      request.controller_fault = ClearProtectiveStop;
      const auto outcome = workflows::RunCaptureSession(request);
      if (outcome.already_complete) {
        std::cout << "session " << outcome.summary.session << " is already complete\n";
        return kOk;
      }
      if (tty) std::cerr << "\n";
      if (!outcome.stopped_before_start)
        std::cout << workflows::FormatCaptureSummary(outcome.summary);
      // Ctrl-C (or SIGTERM, SIGHUP): the session is paused, resumable; 130 as every command
      // a signal stops.
      if (outcome.stopped_before_start || outcome.summary.stopped) return kStopped;
      return outcome.ok ? kOk : kFailure;
    };
  });
}

}  // namespace armsig::app
