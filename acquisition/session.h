// A capture session: for every planned configuration, move the robot (or have the
// operator move it), let it settle, read the joints and trigger every instrument at
// once, intersect on the spot, check the miss distance and the repeatability, re-measure
// when needed, and commit the configuration's joint readings, raw readings and reduced
// point in one transaction. A session survives anything: resuming continues at the first
// configuration not stored, and nothing committed is lost or duplicated.
#pragma once

#include <Eigen/Core>
#include <atomic>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "acquisition/lab.h"
#include "acquisition/plan.h"
#include "calibration/clock_sync.h"
#include "db/database.h"
#include "instruments/device.h"

namespace armsig::acquisition {

struct Progress {
  int done = 0, total = 0, skipped = 0, remeasured = 0;
  int flagged = 0, failed = 0;  // this run (see CaptureSummary)
  std::string label;
  // Absent when there is none: the last configuration gave no usable point, or no
  // configuration of this run has one yet.
  std::optional<double> last_miss_mm, mean_miss_mm, max_miss_mm;
  double elapsed_s = 0.0, eta_s = 0.0;
  // The session waits for the controller (a protective stop): what it waits for, else empty.
  std::string waiting;
};

// Measuring on the move (acquisition/on_the_move.h).
struct SweepOptions {
  // The leading joint's speed on the sweep; 0: SweepSpeed (chosen so the synchronisation's
  // error stays under the tracker's noise).
  double speed_rad_s = 0.0;
  double acceleration_rad_s2 = 1.4;
  int tracker_separation_ms = 50;  // the tracker's continuous time separation
  // A path plan's (linear moves, ISO 9283): its records a millimetre or so apart at a path
  // speed of a few hundred mm/s, for the standard's normal planes and corners.
  int path_tracker_separation_ms = 4;
  double linear_acceleration_mm_s2 = 1200.0;  // a path's linear moves (URScript movel's default)
  int waypoints_per_segment = 6;
  calibration::ClockOptions clock;
  calibration::PairingOptions pairing;
  // Rounds of (fit the model to the paired points, refine the clock with it).
  int clock_rounds = 3;
  // Testing what the estimate is worth: the clock taken as this offset (ms) with no drift,
  // never estimated (a lab that trusted its clocks).
  std::optional<double> assumed_offset_ms;
};


struct ClockEstimate {
  double offset_ms = 0.0, drift_ppm = 0.0, sigma_ms = 0.0;  // tracker = offset + (1+drift)·controller
  double sigma0_mm = 0.0;                                   // the last refinement's RMS residual
  bool assumed = false;                                      // SweepOptions::assumed_offset_ms
};

struct SweepSummary {
  int segments = 0, segments_before = 0;  // in all; stored by an earlier run
  int joint_packages = 0, tracker_records = 0;
  int paired = 0, left_accelerating = 0, left_gaps = 0, left_outside = 0, left_uncertain = 0;
  int refused_records = 0;
  std::vector<std::string> beam_breaks;  // named: station, tracker time, what the tracker said
  double robot_time_s = 0.0;             // the controller's time the sweeps took (this run's)
  double speed_rad_s = 0.0;
  double path_speed_mm_s = 0.0;  // an ISO 9283 path plan's linear moves (0: joint moves)
  std::optional<ClockEstimate> clock;
  double mean_sync_sigma_mm = 0.0, max_sync_sigma_mm = 0.0;
};


struct CaptureOptions {
  bool skip_on_fault = false;               // else pause the session
  const std::atomic<bool>* stop = nullptr;  // Ctrl-C: stop between configurations
  std::function<void(const Progress&)> progress;
  // Called when the controller cannot be commanded: the operator moves the robot.
  std::function<void(const PlannedConfiguration&)> prompt_move;
  // Called when a laser tracker does not find its reflector where its beam points, even
  // after searching around it (FindReflector): the operator points the beam at the
  // reflector (the tracker's camera or by hand), then it measures again. Without it such
  // a configuration is an instrument fault (retried, then paused or skipped).
  std::function<void(const std::string& station, const PlannedConfiguration&)> prompt_reflector;
  // The model's parameters to predict where a tracker's beam should point (the robot's
  // active arm signature); the nominal model when absent.
  std::optional<Eigen::VectorXd> prediction_params;
  // What each instrument said it is when the capture began (model, serial number, firmware:
  // workflows' ProbeDevices), for the instruments table; by device, may be shorter.
  std::vector<instruments::DeviceInfo> identities;
  // The controller stopped the arm in a way the session waits out (a protective stop): told
  // once per stop, with the controller's message and what the operator must do. Returns true
  // when the operator asks armsig to clear it from here (RobotController::
  // ClearProtectiveStop, e.g. after inspecting the cell), false to wait until it is cleared
  // on the controller. Without it the session waits.
  std::function<bool(const instruments::ControllerError&)> controller_fault;
  // How long the session waits for such a stop to be cleared before it pauses; 0: as long as
  // it takes (Ctrl-C ends the wait).
  double max_controller_wait_s = 0.0;
  // Measuring on the move: how the sweep runs (a session marked on the move uses the
  // defaults when this is absent).
  std::optional<SweepOptions> sweep;
};

// A configuration that gave no usable point, and why (its point flags, or the fault).
struct ConfigurationVerdict {
  std::string label;
  std::string why;
};

// Every configuration of this run is stored with its readings (measured) or without
// (skipped); a measured one is usable (intersected, within tolerances), flagged (its
// point still exceeded the miss or repeat tolerance after re-measuring) or failed (no
// point could be intersected: parallel rays, one ray, no convergence, non-finite).
struct CaptureSummary {
  int64_t session = 0;
  int total = 0, measured = 0, skipped = 0, remeasured = 0, already = 0;
  int usable = 0, flagged = 0, failed = 0;  // usable + flagged + failed = measured
  std::vector<ConfigurationVerdict> flagged_configurations, failed_configurations,
      skipped_configurations;
  bool completed = false, paused = false, stopped = false;
  // The session's set-up check failed (its points do not follow the robot): it is paused
  // and discarded (db::DiscardSession), so no recalibration uses its points.
  bool discarded = false;
  std::string pause_reason;
  // Over this run's usable points only; nullopt when there is none.
  std::optional<double> mean_miss_mm, max_miss_mm;
  double seconds = 0.0;
  double mean_cycle_ms = 0.0;  // per configuration: pointing the trackers and measuring
  // Software time per configuration beyond the device calls it waits for (the slowest of
  // each parallel step: pointing, every round of readings), from the first command to the
  // reduced point, and the time to store the configuration (one committed transaction).
  double mean_overhead_ms = 0.0;
  double mean_store_ms = 0.0;
  // Laser trackers: beams pointed at a predicted target (GoPosition), searches around the
  // beam (FindReflector), beams the operator pointed; how the prediction's base was known
  // at the end of the run.
  int beam_predicted = 0, beam_searches = 0, beam_operator = 0;
  std::string beam_base;
  // One instrument gives each point (a tracker alone): no second ray, no miss distance.
  bool single_ray = false;
  // The controller as it identified itself (acquisition/controller_record.h), "" when it
  // cannot say; the stops the session waited out (protective stops) and their total wait.
  std::string controller;
  int controller_waits = 0;
  double controller_wait_s = 0.0;
  // Readings refused because the arm moved (before or while the instruments measured).
  int moving_refused = 0;
  // A session measured on the move: its sweep's figures (total, already and measured then
  // count the sweep's segments until the streams are paired, then measured = usable = the
  // paired points).
  std::optional<SweepSummary> sweep;
};

// A new session: the robot (created if new), the lab text, the plan and the stations'
// set-ups, in one transaction. Returns its id. Every run of a session (RunCapture) asks the
// controller who it is first and refuses another arm (acquisition/controller_record.h).
int64_t CreateSession(db::Database& db, const io::LabConfig& lab, const std::string& robot,
                      const Plan& plan);

// Hands the stop flag to every device for the duration of a capture, so that a device
// call in flight (a flooding port, a long move) ends within a few milliseconds.
class InterruptScope {
 public:
  InterruptScope(std::vector<std::unique_ptr<instruments::DistanceInstrument>>& devices,
                 instruments::RobotController& controller, const std::atomic<bool>* stop)
      : devices_(devices), controller_(controller) {
    if (!stop) return;
    for (auto& d : devices_) d->SetInterrupt(stop);
    controller_.SetInterrupt(stop);
  }
  ~InterruptScope() {
    for (auto& d : devices_) d->SetInterrupt(nullptr);
    controller_.SetInterrupt(nullptr);
  }
  InterruptScope(const InterruptScope&) = delete;
  InterruptScope& operator=(const InterruptScope&) = delete;

 private:
  std::vector<std::unique_ptr<instruments::DistanceInstrument>>& devices_;
  instruments::RobotController& controller_;
};

CaptureSummary RunCapture(
    db::Database& db, const io::LabConfig& lab, int64_t session,
    std::vector<std::unique_ptr<instruments::DistanceInstrument>>& instruments,
    instruments::RobotController& controller, const CaptureOptions& options);

}  // namespace armsig::acquisition
