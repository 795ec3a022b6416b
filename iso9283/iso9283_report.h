// armsig iso9283 report: an ISO 9283 test captured as a session (a plan from `iso9283
// plan` run by `capture --plan`), evaluated in the robot's frame, as text, JSON and the
// certificate page; with the same test compensated (another session) beside it and, when
// the robot has an arm signature, the figures it predicts and its held-out validation.
#pragma once

#include <cstdint>
#include <cstddef>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>

#include "core/types.h"
#include "db/database.h"
#include "iso9283/iso9283.h"

namespace armsig::iso9283 {

struct Iso9283ReportOptions {
  std::string robot;
  int64_t session = 0;
  // The same test run with the compensated plan (0: none). Its commanded positions are its
  // stored plan's targets, else those of `session`'s points of the same name.
  int64_t compensated_session = 0;
  // The plan file (pose → point, cycle, approach, target) for `session`, when its stored
  // plan does not carry the targets; without either, the nominal model's positions of the
  // planned joints are taken as commanded (right for a nominal plan only).
  std::string commanded_csv;
  std::string out_dir;  // "" = no page
  // The frame: false = the robot's frame as the lab knows it (the active arm signature
  // located on each session's measured configurations, else the lab file's `robot:
  // base:`); true = a rigid best fit of the barycentres onto the commanded positions.
  bool align = false;
  std::optional<double> load_kg, speed_percent;  // the conditions, as stated
  std::string generated_at;                      // "" = now (tests fix it)
  Iso9283Limits limits;                          // none stated: not judged
};

struct Iso9283ReportResult {
  Iso9283Evaluation test;
  std::optional<Iso9283Evaluation> compensated;
  // With stated limits: each test's verdict; `pass` is the decisive one's (the compensated
  // test when there is one, else the test).
  std::optional<Iso9283Verdict> verdict, compensated_verdict;
  bool pass = true;
  nlohmann::json json;
  std::string text;       // for stdout
  std::string html_path;  // "" without out_dir
};

// Throws InputError naming the robot or session when they do not exist or do not belong
// together, when a session holds no ISO test poses, and when no frame is known (no
// signature, no lab base and no --align).
Iso9283ReportResult RunIso9283Report(db::Database& db, const Iso9283ReportOptions& options);

// The robot's frame located by its arm signature: the signature's positions of the joints of
// `poses` (at most `most` of them, evenly spread) fitted rigidly onto their measured points
// (method "arm signature", the fit; the caller says on what in `detail`); nullopt when they
// cannot locate it (fewer than three, or on one line). `used` is set to the poses fitted.
std::optional<Iso9283Frame> SignatureFrame(const calibration::RobotModel& model,
                                           const workflows::ActiveSignature& signature,
                                           const std::vector<MeasuredPose>& poses,
                                           size_t most = SIZE_MAX, size_t* used = nullptr);
// The base of the lab file stored with a session (`robot: base:`, method "lab base");
// nullopt when it gives none.
std::optional<Iso9283Frame> LabBaseFrame(const std::string& lab_yaml, int64_t session,
                                         const std::string& db_path);

// "P3-07" → {P3, 7, ""}; "P3-07-y" → {P3, 7, "y"}; via points ("…-via") and other labels:
// nullopt. The labels `iso9283 plan` writes.
struct Iso9283Label {
  std::string point;
  int cycle = 0;
  std::string approach;
};
std::optional<Iso9283Label> ParseIso9283Label(const std::string& label);

}  // namespace armsig::iso9283
