// Measuring on the move (`capture --on-the-move`): the robot sweeps the session's plan (its
// configurations are the waypoints) without stopping to measure, while one laser tracker
// measures continuously and the controller streams its joints. The sweep runs in segments of
// a few waypoints; each segment's raw streams (joint packages on the controller's clock,
// tracker records on the tracker's) are stored in one transaction, so Ctrl-C or a fault loses
// at most the segment in flight and a resume continues at the first segment not stored.
//
// Once every segment is stored the streams are paired (calibration/clock_sync.h): the clock
// offset and drift estimated from the data, first with the nominal model, then again with
// the model fitted to the paired points (the nominal model's millimetres would bias a clock
// that moves points by tenths), until the clock settles; every tracker point then becomes a
// configuration of the session — pose (the joints at its instant), observation (its Hz, V,
// distance) and reduced point, whose covariance carries the synchronisation's share (speed ×
// σ_t) — so that `reduce`, `calibrate` and `recalibrate` use them as stationary readings.
// Points in a gap of the joint stream, near a high acceleration, or whose clock uncertainty
// alone would move them beyond a bound are left out and counted; a beam break is named.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "acquisition/session.h"

namespace armsig::acquisition {

// The leading joint's speed (rad/s) at which `clock_sigma_s` of clock uncertainty moves a
// target `reach_mm` from the first joint less than `noise_mm`, within [0.05, 1.05] rad/s.
double SweepSpeed(double noise_mm, double clock_sigma_s, double reach_mm);

// A sweep's segment: configurations first…last of its plan (inclusive), stored as one.
struct SweepSpan {
  int index = 0;
  size_t first = 0, last = 0;
};
// A path plan's segments (HasLinearMoves: an ISO 9283 path plan): each from a configuration
// reached by a joint move (a path cycle's start, where the arm stands) through the linear
// moves after it at one speed (a change of speed starts the next segment where this one
// ends). A plan without linear moves is swept in segments of SweepOptions::
// waypoints_per_segment waypoints instead.
std::vector<SweepSpan> PathSegments(const Plan& plan);

// Runs (or resumes) `session` on the move: `instruments` must hold one laser tracker (an
// emScon device) and `controller` must stream its joints (RobotController::Sweep); anything
// else is an InputError naming what is needed. The CaptureSummary counts configurations as
// paired points (measured = usable = paired) and carries the sweep's figures in `sweep`;
// the sweep's options are options.sweep (defaults when absent).
CaptureSummary RunSweepCapture(
    db::Database& db, const io::LabConfig& lab, int64_t session,
    std::vector<std::unique_ptr<instruments::DistanceInstrument>>& instruments,
    instruments::RobotController& controller, const CaptureOptions& options);

// The lab can be measured on the move (one emScon tracker, a controller protocol that streams
// its joints and that armsig moves); else InputError naming what is missing. Checked before a
// session is made.
void CheckOnTheMoveLab(const io::LabConfig& lab);

// The plan in the order a sweep takes it: from the first configuration, each next the nearest
// (the smallest largest joint turn) of those left, so the robot's time goes into measuring,
// not into crossing the workspace back and forth. Labels are kept.
Plan SweepOrder(const Plan& plan);

// Whether a stored session was captured on the move (sessions.sync_json says so).
bool IsOnTheMoveSession(db::Database& db, int64_t session);
// Marks a new session as one captured on the move (before its first segment).
void MarkOnTheMove(db::Database& db, int64_t session);

}  // namespace armsig::acquisition
