#include "workflows/capture.h"

#include "acquisition/on_the_move.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <optional>
#include <string>
#include <vector>

#include "acquisition/controller_record.h"
#include "acquisition/device_claims.h"
#include "acquisition/lab.h"
#include "acquisition/plan.h"
#include "acquisition/session_owner.h"
#include "core/error.h"
#include "core/text.h"
#include "core/text_layout.h"
#include "core/wording.h"
#include "db/database.h"
#include "db/sessions.h"
#include "db/streams.h"
#include "db/store.h"
#include "workflows/hint.h"
#include "workflows/signature.h"

namespace armsig::workflows {

namespace {

std::string Duration(double seconds) {
  const int s = static_cast<int>(seconds + 0.5);
  return s >= 60 ? fmt::format("{}m{:02d}s", s / 60, s % 60) : fmt::format("{}s", s);
}

// A length for the progress line: "-" when there is none.
std::string Mm(std::optional<double> mm) { return mm ? fmt::format("{:.3f}", *mm) : "-"; }

// "C3 (parallel_rays: …), C7 (…)"
std::string Named(const std::vector<acquisition::ConfigurationVerdict>& list) {
  std::string out;
  for (const auto& v : list) out += (out.empty() ? "" : ", ") + v.label + " (" + v.why + ")";
  return out;
}

}  // namespace

namespace {

// The session's robot's active arm signature, when it has one of the lab's model: a laser
// tracker's beam then points where the calibrated robot puts the target.
std::optional<Eigen::VectorXd> ActiveParameters(db::Database& db, const io::LabConfig& lab,
                                                int64_t session) {
  const auto row = db::LoadSession(db, session);
  if (!row) return std::nullopt;
  const auto robot = db::FindRobot(db, row->robot);
  if (!robot) return std::nullopt;
  const auto active = db::ActiveCalibration(db, *robot);
  if (!active) return std::nullopt;
  const Signature signature = SignatureOf(lab.model, *active);
  spdlog::debug("capture: predicting tracker targets with version {} of robot {}",
                signature.version, row->robot);
  return signature.params;
}

}  // namespace

namespace {

// What a session stopped by an error keeps, said beside its resume hint: after "the
// transaction was rolled back, nothing of it was stored" (a full disk) the technician must not
// think the session lost. "paused (9 configurations stored)", or "interrupted (…)" when its
// pause could not be written either (the same disk); both resume alike.
std::string WhatTheStopKept(db::Database& db, int64_t session) {
  try {
    const std::string stored =
        acquisition::IsOnTheMoveSession(db, session)
            ? Count(static_cast<int64_t>(db::StoredStreamSegments(db, session).size()),
                    "sweep segment")
            : Count(static_cast<int64_t>(db::StoredSeqs(db, session).size()), "configuration");
    const auto row = db::LoadSession(db, session);
    if (row && row->state == db::SessionState::kRunning)
      return "interrupted (" + stored + " stored; its pause could not be written)";
    return "paused (" + stored + " stored)";
  } catch (const std::exception& e) {
    return std::string("paused (what it stored could not be read now: ") + e.what() + ")";
  }
}

// A session on opened devices; a failure leaves it paused (resumable, never running).
acquisition::CaptureSummary CaptureWith(
    db::Database& db, const io::LabConfig& lab, int64_t session,
    std::vector<std::unique_ptr<instruments::DistanceInstrument>>& devices,
    instruments::RobotController& controller, const acquisition::CaptureOptions& options) {
  try {
    if (acquisition::IsOnTheMoveSession(db, session)) {
      // A path (ISO 9283) pairs its points with the robot's active signature when it has one:
      // one plane's paths identify no model of their own to pair with.
      acquisition::CaptureOptions with_signature = options;
      if (!with_signature.prediction_params)
        with_signature.prediction_params = ActiveParameters(db, lab, session);
      return acquisition::RunSweepCapture(db, lab, session, devices, controller, with_signature);
    }
    const bool tracker = std::any_of(lab.instruments.begin(), lab.instruments.end(),
                                     [](const auto& i) { return i.protocol == io::InstrumentProtocol::kEmScon; });
    if (tracker && !options.prediction_params) {
      acquisition::CaptureOptions with_signature = options;
      with_signature.prediction_params = ActiveParameters(db, lab, session);
      return acquisition::RunCapture(db, lab, session, devices, controller, with_signature);
    }
    return acquisition::RunCapture(db, lab, session, devices, controller, options);
  } catch (...) {
    db::SetSessionState(db, session, db::SessionState::kPaused);
    throw;
  }
}

// Asks every instrument who it is and the controller where the robot is: each device
// answers, or the capture ends naming it (exit 1) before anything is stored. A raised stop
// flag cuts a call short.
std::vector<instruments::DeviceInfo> ProbeDevices(
    const io::LabConfig& lab,
    std::vector<std::unique_ptr<instruments::DistanceInstrument>>& devices,
    instruments::RobotController& controller, const std::atomic<bool>* stop,
    acquisition::ControllerFacts* facts) {
  const acquisition::InterruptScope interrupts(devices, controller, stop);
  std::vector<instruments::DeviceInfo> identities;
  for (size_t i = 0; i < devices.size(); ++i) {
    const auto& config = lab.instruments[i];
    try {
      const instruments::DeviceInfo info = devices[i]->Identify();
      identities.push_back(info);
      spdlog::info("capture: station {}: {} on {}{}{}", config.station,
                   info.name.empty() ? io::NameOf(config.protocol) : info.name, devices[i]->name(),
                   info.serial.empty() ? std::string() : ", serial " + info.serial,
                   info.firmware.empty() ? std::string() : ", firmware " + info.firmware);
    } catch (const std::exception& e) {
      if (stop && *stop) throw;
      throw std::runtime_error(fmt::format("station {}: the instrument does not answer ({}); "
                                           "check that it is on and its {}; nothing was stored",
                                           config.station, e.what(),
                                           config.tcp ? "address" : "port"));
    }
  }
  // A laser tracker checks its reading convention now (the reflector where its beam is,
  // read in two coordinate-system types); with no reflector in the beam (or no reading
  // yet), it checks with its first reading, still before that reading is stored.
  for (size_t i = 0; i < devices.size(); ++i) {
    auto* beam = dynamic_cast<instruments::BeamSteering*>(devices[i].get());
    if (!beam) continue;
    const auto& config = lab.instruments[i];
    try {
      beam->CheckConvention();
    } catch (const instruments::ConventionMismatch& e) {
      throw std::runtime_error(
          fmt::format("station {}: {}; nothing was stored", config.station, e.what()));
    } catch (const instruments::InstrumentError& e) {
      if (stop && *stop) throw;
      spdlog::info(
          "capture: station {}: {}; the tracker's coordinate convention is checked "
          "with its first reading",
          config.station,
          beam->ReflectorLost(e.code()) ? "no reflector in the beam yet"
                                        : "no reading yet (" + std::string(e.what()) + ")");
    }
  }
  try {
    *facts = acquisition::AskController(controller);
    // A controller armsig moves must take moves now (an emergency stop, local mode, the arm
    // powered off are named before a session is made).
    if (controller.CanMove()) controller.CheckReady();
    const Eigen::VectorXd q = controller.ReadJointsRad();
    spdlog::debug("capture: controller {}: the robot reads {} joints", controller.name(), q.size());
  } catch (const instruments::ControllerError& e) {
    if (stop && *stop) throw;
    // A state of the controller (local mode, an emergency stop): named with what to do.
    throw std::runtime_error(fmt::format("the robot controller: {}; nothing was stored", e.what()));
  } catch (const std::exception& e) {
    if (stop && *stop) throw;
    throw std::runtime_error(fmt::format("the robot controller does not answer ({}); check that "
                                         "it is on and its {}; nothing was stored",
                                         e.what(), lab.controller.host.empty() ? "port" : "address"));
  }
  return identities;
}

// What each instrument says it is, for the instruments table: one that does not say (or a
// Ctrl-C while it is asked: the run then stops at its first configuration) is named by its
// protocol and port.
std::vector<instruments::DeviceInfo> Identities(
    std::vector<std::unique_ptr<instruments::DistanceInstrument>>& devices,
    instruments::RobotController& controller, const std::atomic<bool>* stop) {
  const acquisition::InterruptScope interrupts(devices, controller, stop);
  std::vector<instruments::DeviceInfo> out(devices.size());
  for (size_t i = 0; i < devices.size() && !(stop && *stop); ++i) {
    try {
      out[i] = devices[i]->Identify();
    } catch (const std::exception& e) {
      spdlog::debug("capture: {}: no identity ({})", devices[i]->name(), e.what());
    }
  }
  return out;
}

}  // namespace

acquisition::CaptureSummary CaptureInto(db::Database& db, const io::LabConfig& lab, int64_t session,
                                        const acquisition::CaptureOptions& options) {
  std::vector<std::unique_ptr<instruments::DistanceInstrument>> devices;
  std::unique_ptr<instruments::RobotController> controller;
  acquisition::CaptureOptions identified = options;
  try {
    devices = acquisition::OpenInstruments(lab);
    controller = acquisition::OpenController(lab);
    identified.identities = Identities(devices, *controller, options.stop);
  } catch (...) {
    db::SetSessionState(db, session, db::SessionState::kPaused);  // resumable, never left running
    throw;
  }
  return CaptureWith(db, lab, session, devices, *controller, identified);
}

CaptureOutcome RunCaptureSession(const CaptureRequest& request) {
  CaptureOutcome out;
  // Resuming only continues what is there: a mistyped --db must not become a new file.
  std::optional<db::Database> opened;
  if (request.resume > 0) opened.emplace(request.db_path, db::OpenMode::kMustExist);
  const io::LabConfig lab = io::LoadLab(request.lab);
  if (lab.stations.empty()) {
    throw InputError({request.lab, 0, 0, "stations"},
                     "no oriented stations (give 'stations:' the file that armsig orient wrote: "
                     "armsig orient --observations OBS.csv --scale-bar A:B=LEN_MM --out "
                     "stations.yaml)");
  }
  int64_t session = request.resume;
  if (session == 0 && (request.plan.empty() || request.robot.empty())) {
    throw InputError({"capture", 0, 0, ""},
                     "a new session needs --plan and --robot (or --resume SESSION)");
  }
  // The lab's devices are this capture's until it ends: a second capture on them is
  // refused before a session is made or a byte is sent.
  const acquisition::DeviceClaims claims = acquisition::ClaimDevices(
      lab, fmt::format("armsig capture --lab {}{}", AbsolutePath(request.lab),
                       session > 0 ? " --resume " + std::to_string(session) : std::string()));
  // The plan is made before the database is touched: a bad plan stores nothing.
  std::optional<acquisition::Plan> plan;
  if (session == 0) plan = acquisition::MakePlan(request.plan, lab.model, request.seed);
  if (plan && !request.on_the_move && acquisition::HasLinearMoves(*plan)) {
    // Stop-and-go would measure the vertices standing: no path, and no path test to report.
    throw InputError({request.plan, 0, 0, "speed_mm_s"},
                     "a path plan (linear moves, from iso9283 plan --path) is measured on the "
                     "move: add --on-the-move");
  }
  if (request.on_the_move) {
    acquisition::CheckOnTheMoveLab(lab);
    // A path plan is swept in its own order (its cycles are the test); any other nearest-first.
    if (plan && !acquisition::HasLinearMoves(*plan)) plan = acquisition::SweepOrder(*plan);
  }
  // Every device answers before a session is made or claimed (a new session: before the
  // database is touched): an instrument switched off, a wrong port or address is named
  // now and leaves nothing behind.
  std::vector<std::unique_ptr<instruments::DistanceInstrument>> devices;
  std::unique_ptr<instruments::RobotController> controller;
  std::vector<instruments::DeviceInfo> identities;
  acquisition::ControllerFacts facts;
  // false: Ctrl-C while a device was asked (nothing changed: a new session was not made,
  // a resumed one keeps its state).
  const auto open_devices = [&] {
    try {
      devices = acquisition::OpenInstruments(lab);
      controller = acquisition::OpenController(lab);
      identities = ProbeDevices(lab, devices, *controller, request.stop, &facts);
      return true;
    } catch (...) {
      if (!request.stop || !*request.stop) throw;
      out.stopped_before_start = true;
      spdlog::warn("capture: stopped while the devices were asked; nothing was stored");
      return false;
    }
  };
  if (session == 0 && !open_devices()) return out;
  if (!opened) opened.emplace(request.db_path);  // a new session: after the inputs are read
  db::Database& database = *opened;
  if (session > 0) {
    const auto row = db::LoadSession(database, session);
    if (!row) {
      throw InputError({database.path(), 0, 0, ""},
                       fmt::format("no session {} to resume ({} lists them)", session,
                                   Hint(database.path(), {"sessions"})));
    }
    if (row->state == db::SessionState::kAborted) {
      throw InputError({database.path(), 0, 0, ""},
                       fmt::format("session {} was discarded ({}); start a new session, or "
                                   "{} first if its set-up was right after all",
                                   session, row->note,
                                   Hint(database.path(), {"session", "restore",
                                                          std::to_string(session)})));
    }
    if (row->state == db::SessionState::kCompleted) {
      out.already_complete = out.ok = true;
      out.summary.session = session;
      return out;
    }
    if (request.on_the_move && !acquisition::IsOnTheMoveSession(database, session)) {
      throw InputError({"--on-the-move", 0, 0, ""},
                       fmt::format("session {} was captured standing; resume it without "
                                   "--on-the-move",
                                   session));
    }
    if (!open_devices()) return out;
    // Refused while another live process runs it; an interrupted one is ours now.
    spdlog::debug("capture: session {} is {} (stored state {}); claiming it", session,
                  acquisition::DisplayState(row->state, row->owner), db::ToString(row->state));
    acquisition::ClaimSession(database, session);
  } else {
    // Another arm than the lab's robot (its model) or the robot as registered (its model and
    // serial number) is refused before a session is made.
    acquisition::CheckControllerFacts(database, lab, request.robot, 0, facts);
    session = acquisition::CreateSession(database, lab, request.robot, *plan);
    if (request.on_the_move) acquisition::MarkOnTheMove(database, session);
    spdlog::info("capture: session {}, {} configurations", session, plan->size());
  }
  out.summary.session = session;
  out.resume_hint = Hint(database.path(), {"capture", "--lab", AbsolutePath(request.lab),
                                           "--resume", std::to_string(session)});
  if (request.stop != nullptr && *request.stop) {  // before any device was opened
    db::SetSessionState(database, session, db::SessionState::kPaused);
    out.stopped_before_start = true;
    spdlog::warn("capture: stopped before the first configuration; resume with: {}",
                 out.resume_hint);
    return out;
  }
  acquisition::CaptureOptions options;
  options.skip_on_fault = request.skip_on_fault;
  options.stop = request.stop;
  options.progress = request.progress;
  options.prompt_move = request.prompt_move;
  options.prompt_reflector = request.prompt_reflector;
  options.controller_fault = request.controller_fault;
  options.identities = identities;
  try {
    out.summary = CaptureWith(database, lab, session, devices, *controller, options);
  } catch (...) {
    spdlog::info("capture: session {} {}; resume with: {}", session,
                 WhatTheStopKept(database, session), out.resume_hint);
    throw;
  }
  const auto& s = out.summary;
  if (s.discarded) {
    spdlog::error("capture: session {} discarded: {}", s.session, s.pause_reason);
    spdlog::info(
        "its {} stored configurations stay in the database, but no recalibration uses them; "
        "fix the set-up and start a new session ({} if they are good after all)",
        s.already + s.measured,
        Hint(database.path(), {"session", "restore", std::to_string(s.session)}));
  } else if (s.paused) {
    spdlog::error("capture: session {} paused: {}", s.session, s.pause_reason);
    spdlog::info("fix it, then resume with: {}", out.resume_hint);
  } else if (s.stopped) {
    spdlog::warn("capture: stopped; resume with: {}", out.resume_hint);
  } else if (s.already + s.usable == 0) {
    spdlog::error("capture: session {} has no usable configuration", s.session);
  } else if (s.failed + s.flagged + s.skipped > 0 && !request.skip_on_fault) {
    spdlog::error(
        "capture: session {}: {} failed and {} flagged configurations (named above); "
        "--skip-on-fault accepts such a session",
        s.session, s.failed, s.flagged);
  } else {
    out.ok = true;
  }
  return out;
}

namespace {

// A session measured on the move: the sweep's segments, the clock, what was paired and left.
std::string FormatSweepSummary(const acquisition::CaptureSummary& s) {
  const acquisition::SweepSummary& w = *s.sweep;
  std::string text = fmt::format(
      "session {} (on the move): {} of {} sweep segments stored ({} before); {} joint packages "
      "and {} tracker points this run, {:.1f} s of robot time at {}\n",
      s.session, w.segments_before + (s.completed ? w.segments - w.segments_before : s.measured),
      w.segments, w.segments_before, w.joint_packages, w.tracker_records, w.robot_time_s,
      w.path_speed_mm_s > 0.0
          ? fmt::format("{:g} mm/s (linear moves: an ISO 9283 path test, see iso9283 report)",
                        w.path_speed_mm_s)
          : fmt::format("{:.2f} rad/s", w.speed_rad_s));
  if (w.clock) {
    const auto& c = *w.clock;
    text += c.assumed
                ? fmt::format("  clock ASSUMED (not estimated): tracker = controller + {:.3f} ms\n",
                              c.offset_ms)
                : fmt::format("  clock estimated from the data: tracker = controller + {:.4f} ms, "
                              "drift {:.2f} ppm, σ {:.4f} ms (fit RMS {:.4f} mm)\n",
                              c.offset_ms, c.drift_ppm, c.sigma_ms, c.sigma0_mm);
    text += fmt::format(
        "  {} points paired as configurations (synchronisation σ mean {:.4f} mm, max {:.4f} mm); "
        "left out: {} accelerating, {} in gaps of the joint stream, {} outside it, {} too "
        "uncertain in time\n",
        w.paired, w.mean_sync_sigma_mm, w.max_sync_sigma_mm, w.left_accelerating, w.left_gaps,
        w.left_outside, w.left_uncertain);
  }
  if (w.refused_records > 0)
    text += fmt::format("  {} tracker records refused (status or range)\n", w.refused_records);
  for (const auto& b : w.beam_breaks) text += "  beam break: " + b + "\n";
  return text;
}

}  // namespace

std::string FormatCaptureSummary(const acquisition::CaptureSummary& s) {
  if (s.sweep) return FormatSweepSummary(s);
  std::string text = fmt::format(
      "session {}: {} of {} stored ({} now, {} before): {} usable, {} flagged, {} failed, {} "
      "skipped; {} re-measured\n",
      s.session, s.already + s.measured + s.skipped, Count(s.total, "configuration"),
      s.measured + s.skipped, s.already, s.usable, s.flagged, s.failed, s.skipped, s.remeasured);
  if (s.single_ray && s.usable > 0) {
    text += "  one instrument per point: no second ray, no miss distance (each reading checked "
            "against its own sigmas)\n";
  } else if (s.mean_miss_mm) {
    text += fmt::format("  miss distance of the usable points: mean {:.4f} mm, max {:.4f} mm\n",
                        *s.mean_miss_mm, *s.max_miss_mm);
  } else if (s.measured > 0) {
    text += "  no usable point in this run: no miss distance to report\n";
  }
  if (!s.failed_configurations.empty())
    text += "  failed (no point): " + Named(s.failed_configurations) + "\n";
  if (!s.flagged_configurations.empty())
    text += "  flagged (beyond tolerances): " + Named(s.flagged_configurations) + "\n";
  if (!s.skipped_configurations.empty())
    text += "  skipped (instrument fault): " + Named(s.skipped_configurations) + "\n";
  if (s.beam_predicted + s.beam_searches + s.beam_operator > 0 || !s.beam_base.empty()) {
    text += fmt::format(
        "  laser tracker beams: {} pointed at the predicted target, {} searches, {} pointed by "
        "the operator; {}\n",
        s.beam_predicted, s.beam_searches, s.beam_operator, s.beam_base);
  }
  if (!s.controller.empty()) text += "  robot controller: " + s.controller + "\n";
  if (s.controller_waits > 0) {
    text += fmt::format("  the controller stopped the arm {} time{} (protective stop); waited {:.1f} "
                        "s in all, each configuration measured again after it\n",
                        s.controller_waits, s.controller_waits == 1 ? "" : "s",
                        s.controller_wait_s);
  }
  if (s.moving_refused > 0) {
    text += fmt::format("  {} reading{} refused: the arm was moving\n", s.moving_refused,
                        s.moving_refused == 1 ? "" : "s");
  }
  if (const int n = s.measured + s.skipped; n > 0) {
    // Two different times, each named: the whole configuration (the move and the arm's
    // settling included) and the measuring alone.
    text += fmt::format(
        "  {:.1f} s in all, {:.2f} s a configuration with its move; measuring {:.1f} ms a "
        "configuration ({:.2f} ms software, {:.2f} ms storing)\n",
        s.seconds, s.seconds / n, s.mean_cycle_ms, s.mean_overhead_ms, s.mean_store_ms);
  }
  return text;
}

std::string FormatCaptureProgress(const acquisition::Progress& p, int width) {
  // What must be there, then what is added while it fits, most useful first; the bar takes
  // what is left (up to 30 columns, none below 10).
  std::string line = fmt::format("{}/{} {}", p.done, p.total, p.label);
  if (!p.waiting.empty()) {
    line += " WAITING: " + p.waiting;
    if (DisplayWidth(line) > width) line = std::string(TruncateUtf8(line, std::max(width, 0)));
    return line;
  }
  const std::string eta = " ETA " + Duration(p.eta_s);
  std::vector<std::string> extras = {fmt::format(" miss {} mm", Mm(p.last_miss_mm))};
  if (p.flagged) extras.push_back(fmt::format(" flagged {}", p.flagged));
  if (p.failed) extras.push_back(fmt::format(" failed {}", p.failed));
  if (p.skipped) extras.push_back(fmt::format(" skipped {}", p.skipped));
  if (p.remeasured) extras.push_back(fmt::format(" remeasured {}", p.remeasured));
  extras.push_back(fmt::format(" (mean {}, max {})", Mm(p.mean_miss_mm), Mm(p.max_miss_mm)));
  const int kBarMin = 10 + 3, kBarMax = 30 + 3;  // "[" bar "] "
  int used = DisplayWidth(line) + DisplayWidth(eta);
  for (const auto& extra : extras) {
    const int w = DisplayWidth(extra);
    if (used + w + kBarMin > width) continue;  // a later, shorter one may still fit
    line += extra;
    used += w;
  }
  line += eta;
  const int bar = std::min(kBarMax, width - used) - 3;
  if (bar >= kBarMin - 3) {
    const int filled = p.total ? bar * p.done / p.total : bar;
    line = "[" + std::string(filled, '#') + std::string(bar - filled, ' ') + "] " + line;
  }
  if (DisplayWidth(line) > width) line = std::string(TruncateUtf8(line, std::max(width, 0)));
  return line;
}

}  // namespace armsig::workflows
