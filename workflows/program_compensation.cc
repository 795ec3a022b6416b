#include "workflows/program_compensation.h"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <filesystem>

#include "calibration/residual_map.h"
#include "core/error.h"
#include "core/text.h"
#include "core/units.h"
#include "db/sessions.h"
#include "io/atomic_file.h"
#include "io/yaml_reader.h"
#include "programs/krl.h"
#include "programs/rapid.h"
#include "programs/urscript.h"
#include "workflows/signature.h"

namespace armsig::workflows {

namespace {

namespace fs = std::filesystem;

std::string LowerCaseName(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

// The .dat beside a .src: the same name with .dat (or .DAT).
std::optional<std::string> DatBeside(const std::string& src) {
  for (const char* ext : {".dat", ".DAT", ".Dat"}) {
    const fs::path p = fs::path(src).replace_extension(ext);
    std::error_code error;
    if (fs::is_regular_file(p, error)) return p.string();
  }
  return std::nullopt;
}

programs::UrKinematics LoadUrKinematics(const std::string& path) {
  return io::YamlDocument::Load(path).Read([&](const io::YamlValue& root) {
    const io::YamlMap map = root.Map({"dh_theta", "dh_a", "dh_d", "dh_alpha", "checksum", "source"});
    programs::UrKinematics k;
    auto six = [&](const char* key, std::array<double, 6>* out) {
      const std::vector<double> v =
          map.Required(key, "six numbers (metres or radians, as KinematicsInfo sends them)").Numbers(6);
      std::copy(v.begin(), v.end(), out->begin());
    };
    six("dh_theta", &k.theta);
    six("dh_a", &k.a);
    six("dh_d", &k.d);
    six("dh_alpha", &k.alpha);
    k.source = path;
    return k;
  });
}

programs::ControllerModel ProgramController(programs::Language language, const calibration::RobotModel& model,
                                        const ProgramCompensationOptions& o) {
  using programs::ControllerKind;
  const ControllerKind kind = language == programs::Language::kUrScript ? ControllerKind::kUniversalRobots
                              : language == programs::Language::kKrl    ? ControllerKind::kKuka
                                                                        : ControllerKind::kAbb;
  if (!o.controller_kinematics.empty()) {
    if (kind != ControllerKind::kUniversalRobots)
      throw InputError({"--controller-kinematics", 0, 0, ""},
                       "a controller's own kinematics are read for URScript programs (a UR's KinematicsInfo)");
    programs::ControllerModel c = programs::UrController(LoadUrKinematics(o.controller_kinematics));
    if (c.num_joints() != model.num_joints())
      throw InputError({o.controller_kinematics, 0, 0, ""},
                       fmt::format("six joints, robot {}'s model has {}", Quoted(o.robot), model.num_joints()));
    return c;
  }
  return programs::NominalController(model, kind, fmt::format("the nominal model {}", model.name));
}

programs::Program ParseProgramFiles(programs::Language language, const ProgramCompensationOptions& o) {
  programs::ProgramFile file{o.program_path, io::ReadWholeFile(o.program_path, io::kProgramFileLimit)};
  if (!o.config_dat.empty() && language != programs::Language::kKrl)
    throw InputError({"--config-dat", 0, 0, ""}, "a $config.dat is read for KUKA KRL programs (.src)");
  switch (language) {
    case programs::Language::kUrScript:
      return programs::ParseUrScript(std::move(file));
    case programs::Language::kRapid:
      return programs::ParseRapid(std::move(file));
    case programs::Language::kKrl:
      break;
  }
  std::optional<programs::KrlControllerData> config;
  if (!o.config_dat.empty())
    config = programs::ParseKrlConfigDat({o.config_dat, io::ReadWholeFile(o.config_dat, io::kProgramFileLimit)});
  std::optional<programs::ProgramFile> dat;
  if (auto path = DatBeside(o.program_path)) dat = programs::ProgramFile{*path, io::ReadWholeFile(*path, io::kProgramFileLimit)};
  return programs::ParseKrl(std::move(file), std::move(dat), config ? &*config : nullptr);
}

std::string VolumeSessions(const std::vector<int64_t>& sessions) {
  std::string out;
  for (std::size_t k = 0; k < sessions.size(); ++k) out += (k ? ", " : "") + std::to_string(sessions[k]);
  return out;
}

std::string ProgramTargetLabel(const programs::Target& t) { return t.name.empty() ? std::string("(literal)") : t.name; }

// What the σ column promises, and how well the set's held-out data kept that promise.
std::string PromiseLine(const calibration::SetValidity& v) {
  if (v.empty() || (std::isnan(v.sigma_inside_mm) && std::isnan(v.sigma_outside_mm)))
    return "the set stores no held-out error (fitted before they were): σ is the parameters' own only";
  auto share = [](double c) { return std::isnan(c) ? std::string("not measured") : fmt::format("{:.0f} %", 100 * c); };
  auto held_out = [&](double sigma, double coverage, const char* where) {
    return std::isnan(sigma) ? fmt::format("not measured {}", where)
                             : fmt::format("{:.3f} mm {} ({} within)", sigma, where, share(coverage));
  };
  return fmt::format("per coordinate, the landing within {:.2f} σ of the target 95 % of the time; held out {}, {}{}",
                     calibration::kCoverageRadius, held_out(v.sigma_inside_mm, v.coverage_inside, "inside the set's support"),
                     held_out(v.sigma_outside_mm, v.coverage_outside, "beside it"),
                     std::isnan(v.sigma_outside_mm) && !std::isnan(v.sigma_inside_mm)
                         ? " (beside it, the figure inside is promised: never better there)"
                         : "");
}

}  // namespace

programs::Language LanguageOfProgram(const std::string& path) {
  const std::string ext = LowerCaseName(fs::path(path).extension().string());
  if (ext == ".script") return programs::Language::kUrScript;
  if (ext == ".src") return programs::Language::kKrl;
  if (ext == ".mod" || ext == ".modx") return programs::Language::kRapid;
  throw InputError({"--program", 0, 0, ""},
                   "expected a .script (URScript), a .src (KUKA KRL, its .dat beside it) or a .mod / .modx "
                   "(ABB RAPID), got " + Quoted(path));
}

std::optional<programs::ValidatedVolume> ValidatedVolumeOf(db::Database& database,
                                                           const ActiveSignature& active,
                                                           std::string* description) {
  // The arcs of the joints the set was fitted on (stored with it; for a set stored before they
  // were, those of its sessions' configurations) and its calibration point where those
  // sessions measured it.
  if (active.sessions.empty()) return std::nullopt;
  std::vector<Eigen::VectorXd> joints;
  for (int64_t id : active.sessions)
    for (const auto& pose : db::LoadSessionPoses(database, id)) joints.push_back(pose.joints_rad);
  if (joints.empty()) return std::nullopt;
  std::vector<Eigen::Vector3d> points;
  for (const auto& p : calibration::PredictPositions(
           active.model, Eigen::Isometry3d::Identity(), active.signature.params,
           active.signature.map.get(), joints, false, joints.size() >= 2048 ? 2 : 1))
    points.push_back(p.position_mm);
  const bool stored = !active.signature.validity.term_arcs.empty();
  std::string text = fmt::format("the joint arcs {}; the points of session{} {}: {} configurations",
                                 stored ? "stored with the set" : "of its sessions",
                                 active.sessions.size() == 1 ? "" : "s",
                                 VolumeSessions(active.sessions), joints.size());
  if (description) *description = text;
  return programs::ValidatedVolume(
      stored ? active.signature.validity.term_arcs
             : calibration::ArcsCovering(joints, active.model.num_joints()),
      points, text);
}

ProgramCompensationRun CompensateProgramFiles(db::Database& database, const ProgramCompensationOptions& o) {
  const programs::Language language = LanguageOfProgram(o.program_path);
  if (LanguageOfProgram(o.out_path) != language)
    throw InputError({"--out", 0, 0, ""}, fmt::format("the compensated program is {} like its input: give "
                                                      "--out the same extension as {}",
                                                      programs::ToString(language), Quoted(o.program_path)));
  ProgramCompensationRun run;
  run.program = ParseProgramFiles(language, o);
  const ActiveSignature active = LoadSignature(database, o.robot, o.set);
  run.version = active.signature.version;
  run.controller = ProgramController(language, active.model, o);

  programs::SignedRobot robot;
  robot.model = &active.model;
  robot.params = active.signature.params;
  robot.map = active.signature.map.get();
  robot.orientation_measured = active.signature.tool_rotation.has_value();
  run.orientation_measured = robot.orientation_measured;
  run.tool_mounting = active.model.tool_mounting;
  if (!active.signature.validity.empty()) robot.validity = &active.signature.validity;
  robot.identified = active.signature.identified;
  robot.covariance = active.signature.covariance;
  run.validity = active.signature.validity;

  std::optional<programs::ValidatedVolume> volume = ValidatedVolumeOf(database, active, &run.volume);
  programs::CompensationOptions options;
  options.allow_outside = o.allow_outside;
  run.result = programs::CompensateProgram(run.program, run.controller, robot, volume ? &*volume : nullptr, options);
  if (!run.result.written()) return run;

  // The program written again: OUT, and OUT's .dat for a KRL pair (both or neither).
  const std::vector<std::string> texts = programs::ApplyEdits(run.program.files, run.result.edits);
  std::vector<io::PreparedFile> files;
  files.emplace_back(o.out_path, texts[0]);
  if (texts.size() > 1) {
    const std::string dat_ext = fs::path(run.program.files[1].name).extension().string();
    files.emplace_back(fs::path(o.out_path).replace_extension(dat_ext).string(), texts[1]);
  }
  for (auto& f : files) f.Ready();
  for (auto& f : files) {
    f.Commit();
    run.written.push_back(f.path());
  }
  return run;
}

// A target's lever from the calibration point is said from here on: below it, the TCP is the
// calibration point's place (a reflector in the program's tool).
constexpr double kShownLeverMm = 1.0;

std::string FormatProgramCompensation(const ProgramCompensationRun& run) {
  const programs::Program& p = run.program;
  const programs::ProgramCompensation& r = run.result;
  std::string out = fmt::format("{} ({}): {} target{}, arm signature version {}, the controller's model: {}\n",
                                Printable(p.files[0].name), programs::ToString(p.language), r.targets.size(),
                                r.targets.size() == 1 ? "" : "s", run.version, Printable(run.controller.description));
  out += fmt::format("validated volume: {}\n", run.volume.empty() ? "not recorded with the set (not checked)" : run.volume);
  out += fmt::format("predicted σ: {}\n", PromiseLine(run.validity));
  int inside = 0;
  if (!r.targets.empty()) {
    out += fmt::format("{:<24} {:<22} {:<6} {:>13} {:>13} {:>8}  {}\n", "where", "target", "kind", "correction mm",
                       "correction °", "σ mm", "status");
    for (const auto& t : r.targets) {
      const programs::Target& target = p.targets[static_cast<std::size_t>(t.target)];
      const std::string mm = std::isnan(t.correction_mm) ? "–" : fmt::format("{:.4f}", t.correction_mm);
      const std::string deg = std::isnan(t.correction_deg) ? "–" : fmt::format("{:.5f}", t.correction_deg);
      const std::string sigma = std::isnan(t.sigma_mm) ? "–" : fmt::format("{:.3f}", t.sigma_mm);
      const bool solved = t.compensated_joints_rad.size() > 0;
      inside += t.inside_support ? 1 : 0;
      out += fmt::format("{:<24} {:<22} {:<6} {:>13} {:>13} {:>8}  {}{}\n", Printable(programs::Where(p, target.place)),
                         Printable(ProgramTargetLabel(target)), programs::ToString(target.kind()), mm, deg, sigma,
                         programs::ToString(t.status), solved && !t.inside_support ? " (outside the set's support)" : "");
      if (!t.why.empty()) out += fmt::format("    {}\n", Printable(t.why));
      if (solved && !t.inside_support && t.support != t.why)
        out += fmt::format("    support: {}\n", Printable(t.support));
      if (!t.note.empty()) out += fmt::format("    note: {}\n", Printable(t.note));
      if (t.lever_mm >= kShownLeverMm)
        out += fmt::format("    tool: {:.1f} mm from the calibration point: {:.3f} mm per mrad of the "
                           "flange's turn, which this set does not know\n",
                           t.lever_mm, t.lever_mm / 1000.0);
    }
    out += fmt::format("{} of {} target{} inside the set's support\n", inside, r.targets.size(),
                       r.targets.size() == 1 ? "" : "s");
  }
  out += fmt::format("orientation: {}\n", run.orientation_measured
                                              ? "compensated as the set measured it (fitted to 6-DoF data)"
                                              : "compensated as the set's model gives it (fitted to positions "
                                                "only: the orientation correction is not measured)");
  out += run.tool_mounting == calibration::ToolMounting::kKnown
             ? "tool mounting: known (the flange's turn after the last joint is the set's and carries to "
               "the TCP)\n"
             : "tool mounting: fitted (the flange's turn after the last joint is not known: it misses a "
               "TCP by its lever from the calibration point; 'tool_mounting: known' in the model file)\n";
  for (const auto& n : p.not_evaluated)
    out += fmt::format("not compensated, left as written: {}: {}\n", Printable(programs::Where(p, n.place)),
                       Printable(n.why));
  for (const auto& n : p.notes)
    out += fmt::format("note: {}: {}\n", Printable(programs::Where(p, n.place)), Printable(n.why));
  if (r.refused > 0) {
    out += fmt::format("{} target{} refused{}\n", r.refused, r.refused == 1 ? "" : "s",
                       r.allow_outside ? ": written anyway where compensated joints exist (--allow-outside)"
                                       : ": nothing written (--allow-outside writes them anyway)");
  }
  for (const auto& f : run.written) out += fmt::format("-> {}\n", Printable(f));
  return out;
}

nlohmann::json ProgramCompensationJson(const ProgramCompensationRun& run, const std::string& robot) {
  using nlohmann::json;
  const programs::Program& p = run.program;
  auto vector = [](const Eigen::VectorXd& v) {
    json a = json::array();
    for (Eigen::Index i = 0; i < v.size(); ++i) a.push_back(v(i));
    return a;
  };
  auto number = [](double v) { return std::isnan(v) ? json(nullptr) : json(v); };
  json targets = json::array();
  for (const auto& t : run.result.targets) {
    const programs::Target& target = p.targets[static_cast<std::size_t>(t.target)];
    json motions = json::array();
    for (int line : t.motions) motions.push_back(line);
    targets.push_back({{"line", target.place.line},
                       {"file", p.files[static_cast<std::size_t>(target.place.file)].name},
                       {"name", target.name},
                       {"kind", programs::ToString(target.kind())},
                       {"correction_mm", number(t.correction_mm)},
                       {"correction_rad", number(t.correction_deg * kRadPerDeg)},
                       {"status", programs::ToString(t.status)},
                       {"why", t.why},
                       {"note", t.note},
                       {"motions", motions},
                       {"residual_mm", number(t.residual_mm)},
                       {"inside_support", t.inside_support},
                       {"support", t.support},
                       {"sigma_mm", number(t.sigma_mm)},
                       {"map", t.compensated_joints_rad.size() == 0 ? "none"
                               : t.map_extrapolated               ? "outside"
                                                                  : "applied"},
                       {"written", t.written},
                       {"tool", std::isnan(t.lever_mm) ? json(nullptr)
                                                       : json{{"lever_mm", t.lever_mm},
                                                              {"mm_per_mrad", t.lever_mm / 1000.0}}},
                       {"nominal_joints_rad", vector(t.nominal_joints_rad)},
                       {"compensated_joints_rad", vector(t.compensated_joints_rad)}});
  }
  json named = json::array();
  for (const auto& n : p.not_evaluated)
    named.push_back({{"file", p.files[static_cast<std::size_t>(n.place.file)].name}, {"line", n.place.line}, {"why", n.why}});
  json notes = json::array();
  for (const auto& n : p.notes)
    notes.push_back({{"file", p.files[static_cast<std::size_t>(n.place.file)].name}, {"line", n.place.line}, {"why", n.why}});
  json written = json::array();
  for (const auto& f : run.written) written.push_back(f);
  return {{"program", p.files[0].name},
          {"language", programs::ToString(p.language)},
          {"robot", robot},
          {"set", run.version},
          {"controller", run.controller.description},
          {"orientation", run.orientation_measured ? "measured" : "model"},
          {"tool_mounting", calibration::ToString(run.tool_mounting)},
          {"volume", run.volume},
          {"sigma_inside_mm", number(run.validity.sigma_inside_mm)},
          {"sigma_outside_mm", number(run.validity.sigma_outside_mm)},
          {"refused", run.result.refused},
          {"written", written},
          {"targets", targets},
          {"not_evaluated", named},
          {"notes", notes}};
}

}  // namespace armsig::workflows
