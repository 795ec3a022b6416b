// The capture command's job: open (or resume) a session from a lab file, open the lab's
// devices, run the session, and say what happened. A session is never left `running`:
// whatever stops it (Ctrl-C, a device that cannot be opened, a failure mid-way) leaves
// it `paused`, resumable by the printed command.
#pragma once

#include <atomic>
#include <functional>
#include <string>

#include "acquisition/session.h"

namespace armsig::workflows {

struct CaptureRequest {
  std::string db_path, lab, plan, robot;
  unsigned seed = acquisition::kDefaultPlanSeed;  // of --plan auto:N
  int64_t resume = 0;  // > 0: continue this session
  bool skip_on_fault = false;
  // --on-the-move: a new session sweeps its plan while the tracker measures continuously
  // (acquisition/on_the_move.h); a resumed session keeps how it was captured.
  bool on_the_move = false;
  const std::atomic<bool>* stop = nullptr;  // Ctrl-C
  std::function<void(const acquisition::Progress&)> progress;
  std::function<void(const acquisition::PlannedConfiguration&)> prompt_move;
  std::function<void(const std::string&, const acquisition::PlannedConfiguration&)>
      prompt_reflector;  // a laser tracker's beam missed its reflector (CaptureOptions)
  // A protective stop: true to clear it from here (CaptureOptions::controller_fault).
  std::function<bool(const instruments::ControllerError&)> controller_fault;
};

struct CaptureOutcome {
  acquisition::CaptureSummary summary;
  bool already_complete = false;  // --resume of a completed session: nothing to do
  bool stopped_before_start = false;
  std::string resume_hint;  // the command that continues this session, as printed
  // Success as the exit code tells it: a complete session whose configurations are all
  // usable, or whose failed/flagged/skipped ones --skip-on-fault accepts.
  bool ok = false;
};

// Opens the lab's devices and runs `session` in `db`; whatever escapes (a device that
// cannot be opened, a failure mid-way) leaves the session paused before it is rethrown.
// When the lab has a laser tracker and `options` no prediction parameters, the session's
// robot's active arm signature (if it has one, of the lab's model) predicts where the
// beam points.
acquisition::CaptureSummary CaptureInto(db::Database& db, const io::LabConfig& lab, int64_t session,
                                        const acquisition::CaptureOptions& options);

// Runs the session; throws InputError for a bad lab file, plan or --resume id (nothing
// stored then), and rethrows device failures after pausing the session.
CaptureOutcome RunCaptureSession(const CaptureRequest& request);

// The end-of-run summary: usable, flagged, failed and skipped configurations, each one
// that is not usable named with its reason.
std::string FormatCaptureSummary(const acquisition::CaptureSummary& s);
// The one-line live progress for a terminal `width` columns wide: done/total, the
// configuration, ETA, then what fits of the miss distances and counts, and a bar in what is
// left (none on a narrow terminal). Never longer than `width`.
std::string FormatCaptureProgress(const acquisition::Progress& p, int width);

}  // namespace armsig::workflows
