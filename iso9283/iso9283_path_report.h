// ISO 9283 path characteristics (clause 8) of a path test captured on the move: a plan from
// `iso9283 plan --path` (its cycles of linear moves, each from a vertex where the arm stands)
// run by `capture --on-the-move`. Each cycle is the tracker's continuous records of its
// segment of the sweep (acquisition/on_the_move.h PathSegments: the segment's number is the
// cycle's place in the plan), brought into the robot's frame and evaluated against the
// commanded polyline (the plan's targets) by calibration/iso9283_path.h: AT, RT, the corners'
// CR and CO, AV, RV, FV. The tracker's records alone: no joint and no clock enters a figure;
// the frame is the robot's as the lab knows it (the active arm signature located on the
// session's paired configurations, else the lab file's `robot: base:`).
#pragma once

#include <cstdint>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "acquisition/plan.h"
#include "calibration/iso9283_path.h"
#include "calibration/model.h"
#include "db/database.h"
#include "iso9283/iso9283.h"
#include "workflows/signature.h"

namespace armsig::iso9283 {

// One of the standard's paths as tested: the commanded polyline and speed, the attained
// cycles (robot frame), the figures.
struct Iso9283PathTest {
  std::string name;  // "line", "rectangle"
  calibration::iso9283::PathCommand command;
  std::vector<calibration::iso9283::AttainedCycle> cycles;
  calibration::iso9283::PathFigures figures;
};

struct Iso9283PathEvaluation {
  int64_t session = 0;
  std::string started_at;
  std::vector<Iso9283PathTest> paths;  // in the plan's order
  Iso9283Frame frame;
  int records = 0;  // the tracker records evaluated
  std::vector<std::string> notes;
};

// "line-03-v2" → {"line", 3, 2}; nullopt for any other label (`iso9283 plan --path` writes
// them).
struct Iso9283PathLabel {
  std::string path;
  int cycle = 0, vertex = 0;
};
std::optional<Iso9283PathLabel> ParseIso9283PathLabel(const std::string& label);

// Whether a session's stored plan is a path test (linear moves: acquisition::HasLinearMoves).
bool IsIso9283PathSession(db::Database& db, int64_t session);

// The options a tracker's records need: speeds over 25 records (100 ms at 4 ms), not over
// one (the noise of two records 4 ms apart alone is some 10 mm/s).
calibration::iso9283::PathOptions DefaultIso9283PathOptions();

// The session's paths evaluated. Throws InputError naming the session when it holds no
// stored stream for a path, when its cycles command different vertices, or when no frame is
// known (no signature and no lab base).
Iso9283PathEvaluation EvaluateIso9283PathSession(
    db::Database& db, int64_t session, const calibration::RobotModel& model,
    const workflows::ActiveSignature* signature,
    const calibration::iso9283::PathOptions& options = DefaultIso9283PathOptions());

// {"paths":[{"path","cycles","speed_mm_s","length_mm","AT_mm","ATx_mm","ATy_mm","ATz_mm",
//   "mean_AT_mm","RT_mm","planes","planes_skipped","missed_crossings","mean_speed_mm_s",
//   "AV_percent","RV_percent","FV_mm_s","corners":[{"vertex","corner_mm","turn_deg","CR_mm",
//   "CO_mm"}]}…], "records", "alignment":{"method","detail"[,"rms_mm"]}, "notes"}
nlohmann::json Iso9283PathJson(const Iso9283PathEvaluation& e);
// The figures as a table for a terminal.
std::string FormatIso9283PathFigures(const Iso9283PathEvaluation& e);

struct Iso9283PathPageInput {
  std::string generated_at;  // "" = now
  std::string armsig_version, robot, model;
  const Iso9283PathEvaluation* test = nullptr;
  const Iso9283PathEvaluation* compensated = nullptr;  // the same paths, compensated
  std::vector<std::string> instruments;
};
// Writes DIR/index.html (figures per path, the attained deviation along each path) and its
// PNGs; returns the HTML path.
std::string WriteIso9283PathPage(const std::string& dir, const Iso9283PathPageInput& input);

}  // namespace armsig::iso9283
