// The path characteristics of ISO 9283:1998 clause 8 from a commanded path and n attained
// cycles of it, pure computation:
//   path accuracy      AT_p = max_j |x̄_j − x_cj| over m normal planes j, with ATx, ATy, ATz
//                      = x̄_j − x_cj at that plane (x̄_j the barycentre of the n cycles'
//                      crossings of plane j, x_cj the commanded point in it);
//   path repeatability RT_p = max_j (l̄_j + 3 S_lj), l_ij = |x_ij − x̄_j|, S_lj on n − 1;
//   corner deviations  CR = the smallest distance between a corner and the attained path,
//                      CO = the largest deviation from the commanded path after the corner;
//   path velocity      AV = (v̄ − v_c) / v_c · 100 %, RV = ±3 S_v / v_c · 100 % (S_v of
//                      the cycles' mean speeds, on n − 1), FV = the largest v_max − v_min
//                      within one cycle.
// In each plane the figures are the pose figures of calibration/iso9283_figures.h of the
// crossings (AT_pj is AP, RT_pj is RP), as the standard defines them. Positions only: the
// orientation figures ATa… of clause 8 are not computed.
//
// The commanded path is a polyline; its path position s is the arc length from the first
// vertex. A vertex where the direction turns by more than `corner_threshold_rad` is a
// corner; the stretches between the path's start, its corners and its end are its legs.
//
// The steady part of the path (PathMargins) leaves out, measured along the path,
//   - ends_fraction · L at its start and at its end (L the path length): the robot
//     accelerates and brakes there, and a normal plane at the very start may lie before the
//     attained path begins;
//   - corners_fraction · (the shorter of the two legs that meet there) on either side of
//     each corner: there the normal planes of the two legs cross each other, the attained
//     path rounds the corner and the speed dips.
// The normal planes, the speed samples and the end of each corner's overshoot window are
// all taken from this one steady part.
//
// Normal planes: spaced evenly along the whole path, s_j = j · h, h = plane_spacing_mm or
// smaller, so that at least `min_planes` fall in the steady part; those outside it are not
// made. Plane j is perpendicular to the commanded segment holding s_j (the outgoing one at
// a vertex). Each cycle's attained polyline (its samples joined in time order) crosses
// plane j where two consecutive samples lie on either side of it, the crossing linearly
// interpolated between them; of its crossings the one nearest x_cj is the cycle's, if
// it lies within `max_crossing_distance_mm` of x_cj. Otherwise the cycle has no crossing
// there (a missed crossing: counted, and the plane's figures come from the other cycles);
// a plane no cycle crosses is skipped. A polyline circle's commanded points lie on its
// chords, inside the circle by up to r · (1 − cos(π / N)) for N segments.
//
// Speed: the attained speed at a pair of samples k apart (k = speed_stride) is the chord
// between them over the time between them, taken where both samples' path positions (the
// nearest point of the commanded path) lie in the same steady stretch. k > 1 averages an
// instrument's noise out of the differences; on a curve of radius r the chord is shorter
// than the arc a by a factor of about 1 − a² / (24 r²). v̄ is the mean over all cycles'
// such speeds (the standard's 1/(n·m) ΣΣ v_ij), S_v the standard deviation of the cycle
// means; RV is given as the half-width of its ±.
//
// Corners, per cycle: CR is the distance from the corner to the nearest point of the
// attained polyline (the whole cycle). CO is the largest distance of an attained sample
// from the outgoing leg, over the samples after that nearest point (in time) whose nearest
// point on the outgoing leg lies past the corner, up to the first sample beyond the end of
// the window: the outgoing leg up to where the steady part ends again (the next corner's
// margin, or the end margin if the leg ends the path). The distance is unsigned: inside a
// rounded corner the samples just after the nearest point count too (less than CR there).
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <optional>
#include <vector>

#include "calibration/iso9283_cube.h"
#include "core/units.h"

namespace armsig::calibration::iso9283 {

// The commanded path: a polyline in mm (consecutive repeated vertices are dropped), at the
// commanded path speed v_c.
struct PathCommand {
  std::vector<Eigen::Vector3d> vertices_mm;
  double speed_mm_s = 0.0;
};

// One attained cycle: time-stamped positions in time order, in the command's frame (the
// caller aligns the frames).
struct PathSample {
  double t_s = 0.0;
  Eigen::Vector3d position_mm = Eigen::Vector3d::Zero();
};
struct AttainedCycle {
  std::vector<PathSample> samples;
};

// What is left out of the steady part (see above), as fractions in [0, 0.5).
struct PathMargins {
  double ends_fraction = 0.10;     // of the path length, at its start and at its end
  double corners_fraction = 0.10;  // of the shorter leg at the corner, on either side of it
};

struct PathOptions {
  double plane_spacing_mm = 1.0;  // the largest spacing of the normal planes
  int min_planes = 20;            // at least this many planes in the steady part
  double max_crossing_distance_mm = 10.0;
  double corner_threshold_rad = 10.0 * kRadPerDeg;
  PathMargins margins;
  int speed_stride = 1;  // samples between the two of a speed's finite difference
  // Throws std::invalid_argument naming the first option out of range.
  void Check() const;
};

// One normal plane.
struct PlaneFigures {
  double s_mm = 0.0;                                       // path position
  Eigen::Vector3d commanded_mm = Eigen::Vector3d::Zero();  // x_cj
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();        // the commanded direction there
  int n = 0;                                               // cycles that crossed it
  Eigen::Vector3d barycentre_mm = Eigen::Vector3d::Constant(NAN);
  Eigen::Vector3d at_xyz_mm = Eigen::Vector3d::Constant(NAN);  // x̄_j − x_cj
  double at_mm = NAN;
  double mean_l_mm = NAN, s_l_mm = NAN, rt_mm = NAN;  // n ≥ 2
};

struct CornerFigures {
  int vertex = 0;  // index into PathCommand::vertices_mm
  Eigen::Vector3d corner_mm = Eigen::Vector3d::Zero();
  double turn_rad = 0.0;             // the angle between the incoming and the outgoing direction
  std::vector<double> cr_mm, co_mm;  // per cycle; CO NaN where no sample lies in the window
  double cr_max_mm = NAN, co_max_mm = NAN;  // the largest over the cycles
};

struct CycleSpeed {
  int count = 0;  // speeds (finite differences) in the steady part
  double mean_mm_s = NAN, min_mm_s = NAN, max_mm_s = NAN;
};

struct PathFigures {
  int n = 0;  // cycles
  double length_mm = 0.0;
  double plane_spacing_mm = NAN;     // h as used; NaN without a steady part
  int planes_used = 0;               // crossed by at least one cycle
  int planes_skipped = 0;            // in the steady part, crossed by none
  int missed_crossings = 0;          // (plane, cycle) pairs without a crossing
  std::vector<PlaneFigures> planes;  // every plane of the steady part, by path position
  // Path accuracy: the largest AT_pj, its plane (index into `planes`, −1 for none) and
  // components; the mean of AT_pj over the used planes.
  double at_mm = NAN;
  int at_plane = -1;
  Eigen::Vector3d at_xyz_mm = Eigen::Vector3d::Constant(NAN);
  double mean_at_mm = NAN;
  // Path repeatability: the largest RT_pj over the planes with n ≥ 2 (NaN for none).
  double rt_mm = NAN;
  int rt_plane = -1;
  std::vector<CornerFigures> corners;  // in path order
  // Path velocity.
  double commanded_speed_mm_s = 0.0;  // v_c
  double mean_speed_mm_s = NAN;       // v̄
  double av_percent = NAN;
  double s_v_mm_s = NAN, rv_percent = NAN;  // n ≥ 2 cycles with speeds
  double fv_mm_s = NAN;
  std::vector<CycleSpeed> speeds;  // per cycle
};

// Throws std::invalid_argument for fewer than two distinct vertices, a speed that is not
// positive, no cycles, a cycle of fewer than two samples, times that do not increase,
// non-finite values, and options out of range.
PathFigures EvaluatePath(const PathCommand& command, const std::vector<AttainedCycle>& cycles,
                         const PathOptions& options = {});

// The standard's test paths (clause 8.2), in the cube's measuring plane C1–C2–C7–C8
// (calibration/iso9283_cube.h), whose axes are e1 = C1→C2 (+x) and e2 = C1→C8:
//   line       P2 → P4, the plane's diagonal between the test points near C1 and C7:
//              80 % of the distance between the plane's opposite corners;
//   rectangle  P2 → P3 → P4 → P5 (the test points near C1, C2, C7, C8: 80 % of the
//              plane's edges), starting and ending at the middle of the side P5–P2 so
//              that P2…P5 are all corners passed at speed (vertices 1…4);
//   circles    centre P1, the large one of diameter 80 % of the cube's edge, the small one
//              10 % of the large one's; `circle_segments` ≥ 360 chords from P1 + r·e1,
//              turning from e1 towards e2, closed (the last vertex is the first): each
//              vertex turns by 360° / N, no corners.
struct TestPaths {
  std::vector<Eigen::Vector3d> line_mm, rectangle_mm, large_circle_mm, small_circle_mm;
};
inline constexpr double kLargeCircleFraction = 0.80;  // of the cube's edge
inline constexpr double kSmallCircleFraction = 0.10;  // of the large circle's diameter
// Throws std::invalid_argument for an edge that is not positive or fewer than 360 segments.
TestPaths BuildTestPaths(const TestCube& cube, int circle_segments = 360);

// A circular arc from `from` through `via` to `to` (a controller's circular move, URScript
// movec): its centre, radius, the unit vectors e1 (centre → from) and e2 (in the plane, a
// quarter turn on in the direction of travel), and the angle it turns, in (0, 2π).
struct CircleArc {
  Eigen::Vector3d centre_mm = Eigen::Vector3d::Zero();
  Eigen::Vector3d e1 = Eigen::Vector3d::UnitX(), e2 = Eigen::Vector3d::UnitY();
  double radius_mm = 0.0, angle_rad = 0.0;
  double length_mm() const { return radius_mm * angle_rad; }
  // The point at fraction f ∈ [0, 1] of the arc.
  Eigen::Vector3d At(double f) const {
    return centre_mm + radius_mm * (std::cos(f * angle_rad) * e1 + std::sin(f * angle_rad) * e2);
  }
};
// nullopt when the three points are (nearly) on one line or two coincide.
std::optional<CircleArc> ArcThrough(const Eigen::Vector3d& from, const Eigen::Vector3d& via,
                                    const Eigen::Vector3d& to);
// The arc as a polyline from `from` (excluded) to `to` (included), chords turning at most
// `max_step_rad` each.
std::vector<Eigen::Vector3d> ArcPolyline(const CircleArc& arc, double max_step_rad);

}  // namespace armsig::calibration::iso9283
