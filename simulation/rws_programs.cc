#include "simulation/rws_programs.h"

#include <fmt/format.h>

#include <cctype>

#include "core/error.h"
#include "programs/rapid.h"

namespace armsig::simulation {

namespace rws = robots::rws;

namespace {

std::string Upper(std::string_view s) {
  std::string out(s);
  for (char& c : out) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  return out;
}

std::string Param(const std::vector<std::pair<std::string, std::string>>& list, const char* name) {
  for (const auto& [n, v] : list)
    if (n == name) return v;
  return "";
}

RwsPrograms::Answer Refuse(unsigned status, int64_t code, std::string message) {
  RwsPrograms::Answer a;
  a.status = status;
  a.document.status = rws::Status{code, std::move(message)};
  return a;
}

// "$HOME/NAME.mod" (any case of $HOME; the fileservice's own prefix allowed) → "NAME.mod";
// "" for a path outside $HOME, the only directory this controller serves.
std::string HomeFile(std::string path) {
  if (path.rfind("/fileservice/", 0) == 0) path = path.substr(13);
  if (Upper(path.substr(0, 6)) != "$HOME/") return "";
  const std::string name = path.substr(6);
  if (name.empty() || name.find('/') != std::string::npos || name.find("..") != std::string::npos)
    return "";
  return name;
}

}  // namespace

RwsPrograms::RwsPrograms(std::string task, programs::ControllerModel controller,
                         std::optional<RapidModule> resident)
    : task_(std::move(task)), controller_(std::move(controller)), resident_(std::move(resident)) {}

std::optional<RwsPrograms::Answer> RwsPrograms::Route(const Request& r) {
  if (r.path.rfind("/fileservice/", 0) == 0) {
    if (r.method == "PUT") return PutFile(r.path, r.body);
    return std::nullopt;
  }
  if (r.method != "POST") return std::nullopt;
  const std::string task = "/rw/rapid/tasks/" + task_;
  auto is = [&](const std::string& v1_path, const char* v1_action, const std::string& v2_path) {
    return r.v1 ? r.path == v1_path && Param(r.query, "action") == v1_action : r.path == v2_path;
  };
  const bool load = is(task, "loadmod", task + "/loadmod"),
             unload = is(task, "unloadmod", task + "/unloadmod");
  const bool pointer = is(task + "/pcp", "set-pp-routine", task + "/pcp/routine");
  const bool reset = is("/rw/rapid/execution", "resetpp", "/rw/rapid/execution/resetpp");
  if (!load && !unload && !pointer && !reset) return std::nullopt;
  if (r.running)
    return Refuse(400, rws::code::kWrongState, "Operation not allowed while RAPID executes");
  const bool implicit = !r.v1 && Param(r.query, "mastership") == "implicit";
  if (!r.mastership && !implicit)
    return Refuse(403, rws::code::kNoMastership, "The user does not have required mastership");
  if (load) return LoadModule(Param(r.form, "modulepath"), Param(r.form, "replace") == "true");
  if (unload) return UnloadModule(Param(r.form, "module"));
  if (!r.automatic)
    return Refuse(400, rws::code::kWrongState, "The controller is not in auto mode");
  if (pointer) return SetPointer(Param(r.form, "module"), Param(r.form, "routine"));
  pp_.reset();  // back to main: the resident module's
  return Answer{};
}

RwsPrograms::Answer RwsPrograms::PutFile(const std::string& path, const std::string& body) {
  const std::string name = HomeFile(path);
  if (name.empty()) return Refuse(403, rws::code::kRejected, "Writing is allowed below $HOME only");
  const bool replaced = files_.count(name) > 0;
  files_[name] = body;
  Answer a;
  a.status = replaced ? 200 : 201;
  return a;
}

std::map<std::string, RwsPrograms::Loaded>::iterator RwsPrograms::FindModule(
    const std::string& name) {
  return modules_.find(Upper(name));
}

RwsPrograms::Answer RwsPrograms::LoadModule(const std::string& modulepath, bool replace) {
  const std::string name = HomeFile(modulepath);
  const auto file = files_.find(name);
  if (file == files_.end())
    return Refuse(400, rws::code::kNotFound, fmt::format("Module file {} not found", modulepath));
  Loaded loaded;
  loaded.file = name;
  try {
    loaded.program = programs::ParseRapid({name, file->second});
    loaded.declared = ParseRapidModule(file->second, name);
  } catch (const InputError& e) {
    return Refuse(400, rws::code::kModuleNotLoaded, fmt::format("Syntax error: {}", e.what()));
  }
  const std::string key = Upper(loaded.declared.name);
  if (resident_ && Upper(resident_->name) == key)
    return Refuse(400, rws::code::kModuleNotLoaded,
                  fmt::format("Module {} is the task's own", loaded.declared.name));
  if (modules_.count(key) && !replace)
    return Refuse(400, rws::code::kModuleNotLoaded,
                  fmt::format("Module {} is already loaded", loaded.declared.name));
  for (const std::string& routine : loaded.declared.routines) {
    if (!resident_) break;
    for (const std::string& own : resident_->routines)
      if (Upper(own) == Upper(routine))
        return Refuse(400, rws::code::kModuleNotLoaded,
                      fmt::format("Semantic error in {}: ambiguous name {} (also in module {})",
                                  name, routine, resident_->name));
  }
  if (pp_ && Upper(pp_->module) == key) pp_.reset();
  modules_[key] = std::move(loaded);
  return Answer{};
}

RwsPrograms::Answer RwsPrograms::UnloadModule(const std::string& name) {
  const auto it = FindModule(name);
  if (it == modules_.end())
    return Refuse(404, rws::code::kNotFound, fmt::format("Module {} not found", name));
  if (pp_ && Upper(pp_->module) == it->first) pp_.reset();
  modules_.erase(it);
  return Answer{};
}

RwsPrograms::Answer RwsPrograms::SetPointer(const std::string& module, const std::string& routine) {
  const auto it = FindModule(module);
  if (it == modules_.end())
    return Refuse(400, rws::code::kNotFound, fmt::format("Module {} not found", module));
  for (const std::string& r : it->second.declared.routines) {
    if (Upper(r) != Upper(routine)) continue;
    pp_ = ProgramPointer{it->second.declared.name, r, std::nullopt};
    return Answer{};
  }
  return Refuse(400, rws::code::kNotFound,
                fmt::format("Routine {} not found in module {}", routine, module));
}

std::optional<std::string> RwsPrograms::Start(const Eigen::VectorXd& at_rad) {
  if (!pp_) return "the program pointer is not in a routine";
  if (pp_->player) {
    if (pp_->player->next() == pp_->player->size())
      return "the program pointer is at the end of routine " + pp_->routine;
    return std::nullopt;  // continues
  }
  const Loaded& loaded = FindModule(pp_->module)->second;
  programs::Program routine = loaded.program;
  std::erase_if(routine.motions,
                [&](const programs::Motion& m) { return Upper(m.routine) != Upper(pp_->routine); });
  std::erase_if(routine.waits,
                [&](const programs::Wait& w) { return Upper(w.routine) != Upper(pp_->routine); });
  const Execution run = RunProgram(routine, controller_, at_rad);
  if (!run.skipped.empty())
    return fmt::format("{}: {}", programs::Where(routine, run.skipped.front().place),
                       run.skipped.front().why);
  pp_->player.emplace(StepsOf(run, routine.waits));
  ++routines_run_;
  return std::nullopt;
}

ProgramPlayer::Status RwsPrograms::Tick(VirtualArm& arm,
                                        const std::function<void(const Eigen::VectorXd&)>& move) {
  if (!pp_ || !pp_->player) return ProgramPlayer::Status::kFinished;
  return pp_->player->Tick(arm, move);
}

std::string RwsPrograms::Pointer() const {
  return pp_ ? pp_->module + "/" + pp_->routine : std::string("main");
}

}  // namespace armsig::simulation
