// The program side of the virtual ABB controller (simulation/rws_simulator.h): how a lab
// gets a RAPID program onto an IRC5 or an OmniCore and runs it over Robot Web Services.
//
// Followed: ABB, "Application Manual - Robot Web Services", 3HAC050973-001 Revision M (RWS
// 1.0): "Upload a file" (PUT /fileservice/{device|environment_variable|directory}/{file}:
// 201 Created, 200 when it replaced a file), "Load module into a rapid task" (POST
// /rw/rapid/tasks/{task}?action=loadmod, modulepath, replace; RAPID mastership required),
// "Unload module from a rapid task" (…?action=unloadmod, module), "Set the Program pointer
// position to routine" (POST /rw/rapid/tasks/{task}/pcp?action=set-pp-routine, module,
// routine, userlevel; auto mode), "Reset RAPID program pointer to main" (POST
// /rw/rapid/execution?action=resetpp). RWS 2.0 (RobotWare 7): the same resources as ABB's
// OmniCore App SDK 1.5.0 (omnicore-rws.js) addresses them — PUT /fileservice/… with
// Content-Type text/plain;v=2.0, POST /rw/rapid/tasks/{task}/pcp/routine?mastership=implicit,
// POST /rw/rapid/execution/resetpp — and /rw/rapid/tasks/{task}/loadmod and /unloadmod (the
// App SDK does not wrap these two: the RWS 2.0 path form of the 1.0 action, an assumption).
//
// A module is compiled as the controller does when loading it: programs/rapid.h reads it
// (what it cannot read — a string that never ends, a block that does not close — is a
// syntax error: the load is refused with HTTP 400, the controller's message names the file
// and line, nothing is loaded), simulation/rapid_module.h names its routines and data, and a
// module whose name or routine names are already in the task is refused (ambiguous names).
// Its routine runs as simulation/program_runner.h executes motions: each target through the
// controller's inverse kinematics on its nominal model (programs/controller.h), MoveAbsJ
// as written, and each WaitTime with a number the time it says, in the order written; the
// routine's end stops the execution (the program pointer stays there until set again).
#pragma once

#include <Eigen/Core>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "robots/rws_codec.h"
#include "programs/controller.h"
#include "programs/program.h"
#include "simulation/program_runner.h"
#include "simulation/rapid_module.h"

namespace armsig::simulation {

class RwsPrograms {
 public:
  // `resident`: the module the task runs besides (ArmsigServer, whose main is the task's).
  RwsPrograms(std::string task, programs::ControllerModel controller,
              std::optional<RapidModule> resident);

  struct Request {
    std::string method, path, body;
    std::vector<std::pair<std::string, std::string>> query, form;
    bool v1 = true;
    bool mastership = false;  // the session holds RAPID mastership (or asked for it implicitly)
    bool automatic = true;    // the operating mode is AUTO
    bool running = false;     // RAPID executes
  };
  struct Answer {
    unsigned status = 204;
    robots::rws::Document document;
  };
  // PUT of a file below $HOME, and the task's module, program-pointer and resetpp resources;
  // nullopt for any other request.
  std::optional<Answer> Route(const Request& request);

  // Whether the program pointer is in a loaded module's routine: the task runs it (from
  // where it is) instead of the resident module's main.
  bool Armed() const { return pp_.has_value(); }
  // Execution start with the program pointer in a routine: why it cannot start, or nullopt
  // (started, or continuing after a stop).
  std::optional<std::string> Start(const Eigen::VectorXd& at_rad);
  // The routine's next step once the arm is ready; kFinished at its end.
  ProgramPlayer::Status Tick(VirtualArm& arm,
                             const std::function<void(const Eigen::VectorXd&)>& move);
  // Where the routine is (module, routine), for messages.
  std::string Pointer() const;
  int routines_run() const { return routines_run_; }
  // What is in $HOME (file name → text), for tests.
  const std::map<std::string, std::string>& files() const { return files_; }

 private:
  struct Loaded {
    std::string file;
    programs::Program program;
    RapidModule declared;
  };
  struct ProgramPointer {
    std::string module, routine;
    std::optional<ProgramPlayer> player;  // once started
  };
  Answer PutFile(const std::string& path, const std::string& body);
  Answer LoadModule(const std::string& modulepath, bool replace);
  Answer UnloadModule(const std::string& name);
  Answer SetPointer(const std::string& module, const std::string& routine);
  std::map<std::string, Loaded>::iterator FindModule(const std::string& name);

  std::string task_;
  programs::ControllerModel controller_;
  std::optional<RapidModule> resident_;
  std::map<std::string, std::string> files_;  // $HOME/NAME → text
  std::map<std::string, Loaded> modules_;     // upper-case module name → module
  std::optional<ProgramPointer> pp_;
  int routines_run_ = 0;
};

}  // namespace armsig::simulation
