// ISO 9283 performance tests, the jobs behind `armsig iso9283 plan` and `armsig iso9283
// evaluate`: the test plan (the cube, P1–P5, the cycles, each pose's joints by the model's
// inverse, optionally compensated by the robot's arm signature), and the figures from
// commanded and attained poses (AP, RP, AD, RD, vAP, orientation, a bootstrap interval of
// RP, the frame alignment), as text and as the JSON the interface reference fixes.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "calibration/iso9283_cube.h"
#include "calibration/iso9283_figures.h"
#include "calibration/model.h"
#include "iso9283/iso9283_csv.h"
#include "workflows/signature.h"

namespace armsig::iso9283 {

// ---- The plan ----

struct Iso9283PlanOptions {
  std::optional<calibration::iso9283::TestCube> cube;  // --cube CX,CY,CZ,EDGE_MM
  // --auto: the largest cube around `centre_mm` (default: the target at the seed posture)
  // whose corners and test points the model reaches (within its joint limits) with the
  // plan's tool orientation, rounded down to 10 mm.
  bool auto_cube = false;
  std::optional<Eigen::Vector3d> centre_mm;
  // The last link frame's orientation at every pose, a, b, c (calibration/iso9283_figures.h
  // convention); default: the orientation the model's inverse gives P1 from the seed.
  std::optional<Eigen::Vector3d> orientation_rad;
  int cycles = 30;
  // Joints from the robot's active arm signature (its residual map included), so that the
  // calibrated robot reaches the targets; the nominal joints otherwise.
  bool compensated = false;
  // The multi-directional test (vAP): every cycle visits each point three times, from a via
  // point `approach_mm` away on its +x, +y and +z side (the via points are measured too; the
  // evaluation leaves them out).
  bool multi_directional = false;
  double approach_mm = 100.0;
  // Start of the inverse for P1: default 0, 0, 90°, 0, 30°, 0 (elbow bent, wrist off its
  // singularity; 0, 0, 90°, 0, … for other joint counts).
  std::optional<Eigen::VectorXd> seed_rad;
  // A path test (clause 8) instead of the pose test: the standard's paths in the cube's
  // measuring plane ("line", "rectangle", "circle-large", "circle-small":
  // calibration/iso9283_path.h BuildTestPaths), in the order given, each cycle from its first
  // vertex (reached by a joint move, where the arm stands) along the others by linear moves,
  // a circle by two circular moves (via its quarter points to its half and back to its
  // start), at `path_speed_mm_s` (the plan's speed_mm_s and motion columns), measured on the
  // move (`capture --on-the-move`).
  std::vector<std::string> paths;
  double path_speed_mm_s = 250.0;
};

// The paths `iso9283 plan --path` knows, by name.
inline constexpr const char* kIso9283PathNames[] = {"line", "rectangle", "circle-large",
                                                     "circle-small"};

struct Iso9283PlannedPoint {
  std::string name;
  Eigen::Vector3d target_mm = Eigen::Vector3d::Zero();  // robot frame
  Eigen::VectorXd nominal_joints_rad, joints_rad;  // joints_rad: the plan's (compensated or not)
  double compensation_mm = 0.0;  // how far the nominal model puts the target at joints_rad
};

struct Iso9283Plan {
  calibration::iso9283::TestCube cube;
  Eigen::Matrix3d tool_rotation = Eigen::Matrix3d::Identity();  // every pose's last link frame
  std::vector<Iso9283PlannedPoint> points;                      // P1…P5
  std::vector<iso9283::Iso9283PlanRow> rows;                         // the cycles, in order
  // A path plan's paths: name and commanded vertices (robot frame), as in `rows`.
  std::vector<std::pair<std::string, std::vector<Eigen::Vector3d>>> paths;
  int signature_version = 0;                                    // compensated with; 0 = nominal
  std::string conditions;  // robot, model, cube, measuring plane, order, tool orientation (lines)
  std::string csv;
};

// Throws InputError naming --cube, --centre or --orientation when a point cannot be reached
// (with the model's message), and --compensated when there is no signature to compensate
// with.
Iso9283Plan MakeIso9283Plan(const calibration::RobotModel& model, const std::string& robot,
                            const Iso9283PlanOptions& options, const workflows::ActiveSignature* signature);
std::string FormatIso9283PlanSummary(const Iso9283Plan& plan, const std::string& out_path);

// ---- The figures ----

// How the attained positions were brought into the commanded (robot) frame.
struct Iso9283Frame {
  // "as given" (one frame), "rigid best fit" (of the barycentres onto the commanded
  // positions), "arm signature" (the active signature located on the session's
  // measured configurations), "lab base" (the lab file's `robot: base:`).
  std::string method = "as given";
  Eigen::Isometry3d commanded_from_attained = Eigen::Isometry3d::Identity();
  // The fit's residuals: per test point for a rigid best fit; for "arm signature" the rms
  // of the signature's positions against this session's measured points.
  std::optional<calibration::iso9283::Alignment> fit;
  std::string detail;  // one line for people
};

struct Iso9283Evaluation {
  // The attained poses as evaluated (in the commanded frame), beside their figures.
  std::vector<calibration::iso9283::PointData> data;
  std::vector<calibration::iso9283::PointFigures> points;
  std::vector<std::optional<calibration::iso9283::Interval>> rp_intervals;  // per point
  std::vector<calibration::iso9283::DistanceFigures> distances;             // P2–P4, then P3–P5
  Iso9283Frame frame;
  std::vector<std::string> notes;
};

// The figures of `points` (commanded and attained in one frame, or with `align` by a rigid
// best fit of the barycentres onto the commanded positions, which `frame` then reports).
// Distances for P2–P4 and P3–P5 when those points are there. Throws InputError when
// `align` cannot fit (fewer than three points, or on one line).
Iso9283Evaluation EvaluateIso9283(std::vector<calibration::iso9283::PointData> points, bool align,
                                  const Iso9283Frame& frame = {});

// armsig iso9283 evaluate: the two files (iso9283/iso9283_csv.h). An attained point that is not
// commanded is an input error naming its line; a commanded point never attained is noted.
Iso9283Evaluation EvaluateIso9283Files(const std::string& commanded_csv,
                                       const std::string& attained_csv, bool align);

// {"points":[{"point","n","commanded_mm","barycentre_mm","AP_mm","APx_mm","APy_mm","APz_mm",
// "RP_mm","l_mean_mm","S_l_mm","RP_interval_mm"[,"APa_deg"…,"RPa_deg"…][,"vAP_mm"]}…],
// "distance":{…P2–P4…}?, "distances":[…], "alignment":{…}}
nlohmann::json Iso9283Json(const Iso9283Evaluation& e);
// The figures as a table for a terminal (every point up to 20; more: a summary of AP).
std::string FormatIso9283Figures(const Iso9283Evaluation& e);

// ---- Pass / fail against stated limits ----

// The limits a test is judged against, as stated by whoever states them: the maker's data
// sheet (RP, the one figure data sheets give), a customer's acceptance (AP, RP, AD, RD).
// Absent: not judged.
struct Iso9283Limits {
  std::optional<double> ap_mm, rp_mm, ad_mm, rd_mm;
  std::string source;  // "KUKA KR 16-2 data sheet", "customer acceptance 2026-11"
  bool any() const { return ap_mm || rp_mm || ad_mm || rd_mm; }
};
// "AP=0.5" → limits.ap_mm = 0.5 (KEY: AP, RP, AD or RD; mm, positive and finite); throws
// InputError naming --limit and what was expected.
void ParseIso9283Limit(const std::string& text, Iso9283Limits& limits);
struct Iso9283Check {
  std::string figure;  // "AP", "RP", "AD", "RD"
  std::string where;   // "P3", "P2-P4"
  double value_mm = NAN, limit_mm = NAN;
  bool pass = false;
};
struct Iso9283Verdict {
  std::vector<Iso9283Check> checks;  // every stated limit at every point (or distance)
  bool pass = true;                  // every check passed
  std::string summary;  // "PASS: …" or "FAIL: RP at P3 0.052 mm > 0.040 mm; …"
};
// Each stated limit at every point (AP, RP) or distance (AD as |D̄ − D_c|, RD) the test has;
// a figure the test does not have (RP of a single cycle) fails: not shown to be within.
Iso9283Verdict JudgeIso9283(const Iso9283Evaluation& e, const Iso9283Limits& limits);
// {"source", "AP_mm"?…, "pass", "summary", "checks":[{"figure","where","value_mm","limit_mm","pass"}]}
nlohmann::json Iso9283VerdictJson(const Iso9283Verdict& v, const Iso9283Limits& limits);

}  // namespace armsig::iso9283
