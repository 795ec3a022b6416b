#include "iso9283/iso9283.h"

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <optional>
#include <utility>

#include "acquisition/plan.h"
#include "calibration/compensation.h"
#include "calibration/iso9283_path.h"
#include "calibration/pose_solver.h"
#include "core/error.h"
#include "core/text.h"
#include "core/units.h"
#include "workflows/hint.h"

namespace armsig::iso9283 {

namespace iso = calibration::iso9283;

namespace {

// 0, 0, 90°, 0, 30°, 0: the elbow bent (the target well inside the reach) and, on a
// six-joint arm, the wrist off its singularity (joint 5 at zero lines up joints 4 and 6,
// where holding the tool's orientation would leave them free).
Eigen::VectorXd DefaultSeed(int n) {
  Eigen::VectorXd seed = Eigen::VectorXd::Zero(n);
  if (n >= 3) seed(2) = kPi / 2;
  if (n == 6) seed(4) = kPi / 6;
  return seed;
}

std::string Mm(const Eigen::Vector3d& v) {
  return fmt::format("({:.3f}, {:.3f}, {:.3f})", v.x(), v.y(), v.z());
}

std::string Degrees(const Eigen::VectorXd& q) {
  std::string out;
  for (int i = 0; i < q.size(); ++i)
    out += fmt::format("{}{:.3f}", i ? ", " : "", q(i) / kRadPerDeg);
  return out;
}

// The nominal model's inverse for one pose: position and tool orientation for a six-joint
// arm, the position alone otherwise (fewer joints cannot hold an orientation too).
class NominalInverse {
 public:
  NominalInverse(const calibration::RobotModel& model, const Eigen::Matrix3d& rotation)
      : model_(model), rotation_(rotation), zero_(Eigen::VectorXd::Zero(model.num_parameters())) {}
  // From `seed` (the solution at `from_mm`); when the damped least squares stalls in a
  // local minimum on the way, again along the straight line from `from_mm` in small
  // steps, each from the last one's joints (a continuation: it follows one branch).
  calibration::JointSolution Solve(const Eigen::Vector3d& target_mm, const Eigen::VectorXd& seed,
                                   const Eigen::Vector3d& from_mm) const {
    calibration::JointSolution s = SolveOnce(target_mm, seed);
    if (s.status.code != SolveCode::kNotConverged) return s;
    constexpr int kSteps = 10;
    Eigen::VectorXd q = seed;
    for (int k = 1; k <= kSteps; ++k) {
      s = SolveOnce(from_mm + (target_mm - from_mm) * k / kSteps, q);
      if (s.status.code == SolveCode::kNotConverged || s.status.code == SolveCode::kNonFinite)
        return s;
      q = s.joints_rad;
    }
    return s;
  }

 private:
  calibration::JointSolution SolveOnce(const Eigen::Vector3d& target_mm,
                                       const Eigen::VectorXd& seed) const {
    if (model_.num_joints() == 6) {
      return calibration::SolvePose(model_, Eigen::Isometry3d::Identity(), zero_, target_mm,
                                    rotation_, seed);
    }
    return calibration::SolveJoints(model_, Eigen::Isometry3d::Identity(), zero_, target_mm, seed);
  }

  const calibration::RobotModel& model_;
  Eigen::Matrix3d rotation_;
  Eigen::VectorXd zero_;
};

std::string CycleLabel(int cycle, int cycles) {
  return cycles < 100 ? fmt::format("{:02d}", cycle) : fmt::format("{:03d}", cycle);
}

// Makes the standard's plan in its order: P1 and the tool orientation every pose keeps, the
// test cube (given, or the largest the model reaches), the test points P1…P5, the
// multi-directional test's via points, the cycles, and the file's comment. The steps share
// the model's inverse at the plan's tool orientation and P1's joints, so they are the
// methods of one object that is used once.
class Iso9283Planner {
 public:
  Iso9283Planner(const calibration::RobotModel& model, const std::string& robot,
                 const Iso9283PlanOptions& options, const workflows::ActiveSignature* signature);
  Iso9283Plan Make();

 private:
  void SolveCentre();
  bool Reachable(const iso::TestCube& cube) const;
  void ChooseCube();
  Eigen::VectorXd Compensated(const Eigen::Vector3d& target, const Eigen::VectorXd& nominal,
                              const std::string& what) const;
  void PlanTestPoints();
  void PlanViaPoints();
  void PlanCycles();
  void PlanPaths();
  std::string Conditions() const;

  const calibration::RobotModel& model_;
  const std::string& robot_;
  const Iso9283PlanOptions& o_;
  const workflows::ActiveSignature* signature_;
  const int n_;  // joints
  const Eigen::VectorXd zero_;
  Eigen::VectorXd seed_;
  calibration::Kinematics kin_;
  Eigen::Vector3d centre_;
  const char* where_;  // the option that placed the cube
  Iso9283Plan plan_;
  calibration::JointSolution centre_solution_;  // P1's
  Eigen::VectorXd q_centre_;
  std::optional<NominalInverse> inverse_;  // at the plan's tool orientation
  // The multi-directional test's via points, per point and side.
  std::vector<std::array<Eigen::VectorXd, 3>> via_joints_;
  std::vector<std::array<Eigen::Vector3d, 3>> via_targets_;
};

// Refuses a plan without cycles, --compensated without a signature and a seed of the
// wrong length; the cube's centre: the given cube's, --centre, or the target at the seed.
Iso9283Planner::Iso9283Planner(const calibration::RobotModel& model, const std::string& robot,
                               const Iso9283PlanOptions& options, const workflows::ActiveSignature* signature)
    : model_(model),
      robot_(robot),
      o_(options),
      signature_(signature),
      n_(model.num_joints()),
      zero_(Eigen::VectorXd::Zero(model.num_parameters())),
      kin_(model),
      where_(options.cube ? "--cube" : "--centre") {
  if (o_.cycles < 1) throw InputError({"--cycles", 0, 0, ""}, "expected at least one cycle");
  if (o_.compensated && !signature_) {
    throw InputError({"--compensated", 0, 0, ""},
                     "robot " + workflows::ShellWord(robot_) +
                         " has no active arm signature to compensate with (fit one with "
                         "recalibrate, or plan without --compensated)");
  }
  seed_ = o_.seed_rad.value_or(DefaultSeed(n_));
  if (seed_.size() != n_)
    throw InputError({"--seed-deg", 0, 0, ""}, fmt::format("expected {} joint angles", n_));
  centre_ = o_.cube ? o_.cube->centre_mm
                    : o_.centre_mm.value_or(
                          kin_.Position(Eigen::Isometry3d::Identity(), zero_, seed_.data()));
}

Iso9283Plan Iso9283Planner::Make() {
  SolveCentre();
  ChooseCube();
  PlanTestPoints();
  if (!o_.paths.empty()) {
    PlanPaths();
  } else {
    PlanViaPoints();
    PlanCycles();
  }
  plan_.conditions = Conditions();
  plan_.csv = iso9283::FormatIso9283PlanCsv(plan_.rows);
  return std::move(plan_);
}

// P1 first: it fixes the tool orientation of every pose (unless --orientation does), and
// the model's inverse for the other points starts from its joints.
void Iso9283Planner::SolveCentre() {
  if (o_.orientation_rad && n_ == 6) {
    plan_.tool_rotation = iso::RotationFromAbc(*o_.orientation_rad);
    centre_solution_ = calibration::SolvePose(model_, Eigen::Isometry3d::Identity(), zero_, centre_,
                                              plan_.tool_rotation, seed_);
  } else {
    centre_solution_ =
        calibration::SolveJoints(model_, Eigen::Isometry3d::Identity(), zero_, centre_, seed_);
  }
  if (!centre_solution_.status.ok()) {
    throw InputError(
        {o_.orientation_rad ? "--orientation" : where_, 0, 0, ""},
        fmt::format("the centre {} mm cannot be reached by model {}{}: {}", Mm(centre_),
                    model_.name, o_.orientation_rad ? " with that tool orientation" : "",
                    centre_solution_.status.message));
  }
  q_centre_ = centre_solution_.joints_rad;
  if (!(o_.orientation_rad && n_ == 6))
    plan_.tool_rotation =
        calibration::LastLinkRotation(model_, Eigen::Isometry3d::Identity(), zero_, q_centre_);
  if (o_.orientation_rad && n_ != 6)
    spdlog::warn(
        "iso9283 plan: model {} has {} joints: the tool orientation cannot be held, "
        "only the positions are commanded",
        model_.name, n_);
  inverse_.emplace(model_, plan_.tool_rotation);
}

// Whether the model reaches every corner and test point of `cube` from P1.
bool Iso9283Planner::Reachable(const iso::TestCube& cube) const {
  for (const auto& c : iso::CubeCorners(cube))
    if (!inverse_->Solve(c, q_centre_, centre_).status.ok()) return false;
  for (const auto& p : iso::TestPoints(cube))
    if (!inverse_->Solve(p.position_mm, q_centre_, centre_).status.ok()) return false;
  return true;
}

// The cube: --cube's, or (--auto) the largest reachable around the centre, rounded down to
// 10 mm. Corners the model does not reach are said: the standard's cube lies in the
// working space.
void Iso9283Planner::ChooseCube() {
  if (o_.cube) {
    plan_.cube = *o_.cube;
  } else {
    const double edge = iso::LargestCubeEdge(
        centre_, [this](const iso::TestCube& cube) { return Reachable(cube); },
        iso::kMinCubeEdgeMm, 4000.0, 1.0);
    if (edge <= 0.0) {
      throw InputError({"--centre", 0, 0, ""},
                       fmt::format("--auto: not even a {:g} mm cube around {} mm is within the "
                                   "reach of model {} with this tool orientation",
                                   iso::kMinCubeEdgeMm, Mm(centre_), model_.name));
    }
    plan_.cube = {centre_, std::floor(edge / 10.0) * 10.0};
  }
  for (const auto& c : iso::CubeCorners(plan_.cube)) {
    if (const auto s = inverse_->Solve(c, q_centre_, centre_); !s.status.ok()) {
      spdlog::warn(
          "iso9283 plan: corner {} mm of the cube is not within the model's reach ({}): "
          "the standard's cube lies in the working space",
          Mm(c), s.status.message);
    }
  }
}

// --compensated: the joints at which the active signature (its map included) puts the
// target, from the nominal joints.
Eigen::VectorXd Iso9283Planner::Compensated(const Eigen::Vector3d& target,
                                            const Eigen::VectorXd& nominal,
                                            const std::string& what) const {
  const auto s =
      calibration::SolveJoints(model_, Eigen::Isometry3d::Identity(), signature_->signature.params,
                               target, nominal, {}, signature_->signature.map.get());
  if (!s.status.ok()) {
    throw InputError({"--compensated", 0, 0, ""},
                     fmt::format("{} {} mm: the calibrated robot cannot reach it ({})", what,
                                 Mm(target), s.status.message));
  }
  return s.joints_rad;
}

// P1…P5: nominal joints by the inverse, then (with --compensated) the signature's.
void Iso9283Planner::PlanTestPoints() {
  for (const auto& p : iso::TestPoints(plan_.cube)) {
    Iso9283PlannedPoint planned;
    planned.name = p.name;
    planned.target_mm = p.position_mm;
    const auto s =
        p.name == "P1" ? centre_solution_ : inverse_->Solve(p.position_mm, q_centre_, centre_);
    if (!s.status.ok()) {
      throw InputError({where_, 0, 0, ""},
                       fmt::format("test point {} at {} mm cannot be reached by model {}: {}",
                                   p.name, Mm(p.position_mm), model_.name, s.status.message));
    }
    planned.nominal_joints_rad = planned.joints_rad = s.joints_rad;
    if (o_.compensated) {
      planned.joints_rad = Compensated(p.position_mm, s.joints_rad, "test point " + p.name);
      planned.compensation_mm =
          (kin_.Position(Eigen::Isometry3d::Identity(), zero_, planned.joints_rad.data()) -
           p.position_mm)
              .norm();
    }
    plan_.points.push_back(std::move(planned));
  }
  if (o_.compensated) plan_.signature_version = signature_->signature.version;
}

// The multi-directional test's via points: `approach_mm` from each point on its +x, +y and
// +z side, reached by the inverse from the point's own joints.
void Iso9283Planner::PlanViaPoints() {
  via_joints_.resize(plan_.points.size());
  via_targets_.resize(plan_.points.size());
  if (!o_.multi_directional) return;
  for (size_t i = 0; i < plan_.points.size(); ++i) {
    for (int k = 0; k < 3; ++k) {
      const Eigen::Vector3d via = plan_.points[i].target_mm + o_.approach_mm * iso::ApproachSide(k);
      const auto s =
          inverse_->Solve(via, plan_.points[i].nominal_joints_rad, plan_.points[i].target_mm);
      if (!s.status.ok()) {
        throw InputError(
            {"--approach-mm", 0, 0, ""},
            fmt::format("the via point of {} on its +{} side, {} mm, cannot be "
                        "reached: {}",
                        plan_.points[i].name, iso::ApproachName(k), Mm(via), s.status.message));
      }
      via_targets_[i][k] = via;
      via_joints_[i][k] =
          o_.compensated ? Compensated(via, s.joints_rad, "via point") : s.joints_rad;
    }
  }
}

// The cycles in the standard's order of points (P1 P5 P4 P3 P2); in the multi-directional
// test each point three times, each after its via point on one side.
void Iso9283Planner::PlanCycles() {
  for (int c = 1; c <= o_.cycles; ++c) {
    for (int index : iso::kCycleOrder) {
      const auto& p = plan_.points[index];
      const std::string label = p.name + "-" + CycleLabel(c, o_.cycles);
      if (!o_.multi_directional) {
        plan_.rows.push_back({label, p.name, c, "", p.target_mm, p.joints_rad, std::nullopt, ""});
        continue;
      }
      for (int k = 0; k < 3; ++k) {
        const std::string side = iso::ApproachName(k);
        plan_.rows.push_back({label + "-" + side + "-via", "", 0, "", via_targets_[index][k],
                              via_joints_[index][k], std::nullopt, ""});
        plan_.rows.push_back(
            {label + "-" + side, p.name, c, side, p.target_mm, p.joints_rad, std::nullopt, ""});
      }
    }
  }
}

// The path test: each path's vertices by the inverse, each from the joints of the vertex
// before (one branch along the path, as the controller's linear moves follow it), then (with
// --compensated) the signature's; every cycle the vertices in order, the first a joint move,
// the others linear moves at the path speed.
void Iso9283Planner::PlanPaths() {
  if (!(o_.path_speed_mm_s > 0.0 && o_.path_speed_mm_s <= acquisition::kMostLinearSpeedMmS))
    throw InputError({"--speed", 0, 0, ""}, "expected a path speed above 0 mm/s");
  const iso::TestPaths paths = iso::BuildTestPaths(plan_.cube);
  for (const std::string& name : o_.paths) {
    const bool circle = name == "circle-large" || name == "circle-small";
    const std::vector<Eigen::Vector3d>* polyline = name == "line"           ? &paths.line_mm
                                                   : name == "rectangle"    ? &paths.rectangle_mm
                                                   : name == "circle-large" ? &paths.large_circle_mm
                                                   : name == "circle-small" ? &paths.small_circle_mm
                                                                            : nullptr;
    if (!polyline) {
      throw InputError({"--path", 0, 0, ""},
                       fmt::format("unknown path {} (expected line, rectangle, circle-large or "
                                   "circle-small)",
                                   Quoted(name)));
    }
    // A circle's rows: its start, then via its quarter points to its half and back to its
    // start (two circular moves); 360 segments from BuildTestPaths.
    std::vector<Eigen::Vector3d> circle_rows;
    if (circle) {
      for (size_t k : {0, 90, 180, 270, 360}) circle_rows.push_back((*polyline)[k]);
    }
    const std::vector<Eigen::Vector3d>* vertices = circle ? &circle_rows : polyline;
    for (const auto& [done, ignored] : plan_.paths) {
      if (done == name) throw InputError({"--path", 0, 0, ""}, "path " + name + " given twice");
    }
    std::vector<Eigen::VectorXd> joints;
    Eigen::VectorXd q = q_centre_;
    Eigen::Vector3d from = centre_;
    for (const Eigen::Vector3d& v : *vertices) {
      const auto solved = inverse_->Solve(v, q, from);
      if (!solved.status.ok()) {
        throw InputError({where_, 0, 0, ""},
                         fmt::format("the {} path's vertex {} mm cannot be reached by model {}: {}",
                                     name, Mm(v), model_.name, solved.status.message));
      }
      q = solved.joints_rad;
      from = v;
      joints.push_back(o_.compensated ? Compensated(v, q, "the " + name + " path's vertex") : q);
    }
    for (int c = 1; c <= o_.cycles; ++c) {
      for (size_t k = 0; k < vertices->size(); ++k) {
        Iso9283PlanRow row;
        row.pose = fmt::format("{}-{}-v{}", name, CycleLabel(c, o_.cycles), k + 1);
        row.target_mm = (*vertices)[k];
        row.joints_rad = joints[k];
        if (k > 0) row.speed_mm_s = o_.path_speed_mm_s;
        if (circle && k > 0) row.motion = k % 2 == 1 ? "via" : "circular";
        plan_.rows.push_back(std::move(row));
      }
    }
    plan_.paths.emplace_back(name, *polyline);
  }
}

// The plan file's comment: the robot, the cube, the measuring plane, the cycles and how
// the joints were found.
std::string Iso9283Planner::Conditions() const {
  const Eigen::Vector3d abc = iso::AbcFromRotation(plan_.tool_rotation) / kRadPerDeg;
  return fmt::format(
      "ISO 9283 test cube of robot {} (model {}): centre {} mm, edge {:.1f} mm\n"
      "measuring plane C1-C2-C7-C8; P2, P3, P4, P5 at 10 % of the diagonal from C1, C2, C7, C8\n"
      "{}; tool orientation a {:.4f}, b {:.4f}, c {:.4f} deg\n"
      "joints: {}; targets x_mm, y_mm, z_mm in the robot frame",
      robot_, model_.name, Mm(plan_.cube.centre_mm), plan_.cube.edge_mm,
      !o_.paths.empty()
          ? fmt::format("path test: {} cycles of {} at {:g} mm/s (linear moves; measure it with "
                        "capture --on-the-move)",
                        o_.cycles, fmt::join(o_.paths, ", "), o_.path_speed_mm_s)
          : fmt::format("{} cycles in the order P1 P5 P4 P3 P2{}", o_.cycles,
      o_.multi_directional
          ? fmt::format(", each point approached from its +x, +y and +z side ({:g} mm via points)",
                        o_.approach_mm)
          : std::string()),
      abc.x(), abc.y(), abc.z(),
      o_.compensated
          ? fmt::format("compensated with arm signature version {}", plan_.signature_version)
          : std::string("the nominal model's inverse"));
}

}  // namespace

Iso9283Plan MakeIso9283Plan(const calibration::RobotModel& model, const std::string& robot,
                            const Iso9283PlanOptions& o, const workflows::ActiveSignature* signature) {
  return Iso9283Planner(model, robot, o, signature).Make();
}

std::string FormatIso9283PlanSummary(const Iso9283Plan& plan, const std::string& out_path) {
  std::string out = plan.conditions + "\n";
  for (const auto& p : plan.points) {
    out +=
        fmt::format("  {}  {} mm   joints {} deg", p.name, Mm(p.target_mm), Degrees(p.joints_rad));
    if (plan.signature_version > 0)
      out += fmt::format("   (compensation {:.3f} mm)", p.compensation_mm);
    out += "\n";
  }
  for (const auto& [name, vertices] : plan.paths) {
    double length = 0.0;
    for (size_t k = 1; k < vertices.size(); ++k) length += (vertices[k] - vertices[k - 1]).norm();
    out += fmt::format("  path {}: {} vertices, {:.1f} mm from {} mm\n", name, vertices.size(),
                       length, Mm(vertices.front()));
  }
  for (const auto& pair : iso::kDistancePairs) {
    if (!plan.paths.empty()) break;  // the pose test's distances
    out += fmt::format("  distance {}-{}: {:.3f} mm\n", plan.points[pair.from].name,
                       plan.points[pair.to].name,
                       (plan.points[pair.from].target_mm - plan.points[pair.to].target_mm).norm());
  }
  out += fmt::format(
      "{} configurations -> {} ({})\n", plan.rows.size(), out_path,
      plan.signature_version > 0
          ? fmt::format("compensated with arm signature version {}", plan.signature_version)
          : std::string("nominal joints"));
  return out;
}

// ---- The figures ----

Iso9283Evaluation EvaluateIso9283(std::vector<iso::PointData> points, bool align,
                                  const Iso9283Frame& frame) {
  Iso9283Evaluation e;
  e.frame = frame;
  if (align) {
    std::vector<Eigen::Vector3d> attained, commanded;
    for (const auto& p : points) {
      if (p.samples.empty()) continue;
      Eigen::Vector3d sum = Eigen::Vector3d::Zero();
      for (const auto& s : p.samples) sum += s.position_mm;
      attained.push_back(sum / static_cast<double>(p.samples.size()));
      commanded.push_back(p.commanded_mm);
    }
    const auto fit = iso::AlignRigidly(attained, commanded);
    if (!fit) {
      throw InputError({"--align", 0, 0, ""},
                       fmt::format("a rigid best fit needs three or more test points not on one "
                                   "line (got {})",
                                   attained.size()));
    }
    for (auto& p : points) iso::TransformSamples(p, fit->commanded_from_attained);
    e.frame.method = "rigid best fit";
    e.frame.commanded_from_attained = fit->commanded_from_attained;
    e.frame.fit = fit;
    e.frame.detail = fmt::format(
        "rigid best fit of the {} barycentres onto the commanded positions (rms {:.4f} mm): it "
        "absorbs the rigid part of the pose error",
        attained.size(), fit->rms_mm);
  }
  for (const auto& p : points) {
    if (p.samples.empty()) {
      e.notes.push_back("point " + p.name + " was never attained: left out");
      continue;
    }
    e.data.push_back(p);
    e.points.push_back(iso::EvaluatePoint(p));
    std::vector<Eigen::Vector3d> x;
    for (const auto& s : p.samples) x.push_back(s.position_mm);
    e.rp_intervals.push_back(iso::BootstrapRpInterval(x));
  }
  for (const auto& pair : iso::kDistancePairs) {
    const std::string a = fmt::format("P{}", pair.from + 1), b = fmt::format("P{}", pair.to + 1);
    const auto ia =
        std::find_if(points.begin(), points.end(), [&](auto& p) { return p.name == a; });
    const auto ib =
        std::find_if(points.begin(), points.end(), [&](auto& p) { return p.name == b; });
    if (ia == points.end() || ib == points.end()) continue;
    if (auto d = iso::EvaluateDistance(*ia, *ib)) e.distances.push_back(std::move(*d));
  }
  return e;
}

Iso9283Evaluation EvaluateIso9283Files(const std::string& commanded_csv,
                                       const std::string& attained_csv, bool align) {
  const auto commanded = iso9283::ReadCommandedCsv(commanded_csv);
  const auto attained = iso9283::ReadAttainedCsv(attained_csv);
  std::vector<iso::PointData> points;
  std::map<std::string, size_t> index;
  for (const auto& c : commanded) {
    index[c.point] = points.size();
    points.push_back({c.point, c.position_mm, c.orientation_rad, {}});
  }
  std::map<std::string, int> approaches;  // name → 1, 2, … by first appearance
  for (const auto& a : attained) {
    const auto it = index.find(a.point);
    if (it == index.end()) {
      throw InputError(
          {attained_csv, a.line, 0, ""},
          "point " + Quoted(a.point) + " is not in the commanded poses " + commanded_csv);
    }
    int approach = 0;
    if (!a.approach.empty()) {
      approach =
          approaches.emplace(a.approach, static_cast<int>(approaches.size()) + 1).first->second;
    }
    points[it->second].samples.push_back({a.cycle, approach, a.position_mm, a.orientation_rad});
  }
  Iso9283Evaluation e = EvaluateIso9283(std::move(points), align);
  return e;
}

namespace {

nlohmann::json Vec(const Eigen::Vector3d& v, double scale = 1.0) {
  return {v.x() * scale, v.y() * scale, v.z() * scale};
}
nlohmann::json NumberOrNull(double v) {
  return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json();
}

}  // namespace

nlohmann::json Iso9283Json(const Iso9283Evaluation& e) {
  nlohmann::json points = nlohmann::json::array();
  const double deg = 1.0 / kRadPerDeg;
  for (size_t i = 0; i < e.points.size(); ++i) {
    const auto& f = e.points[i];
    nlohmann::json p = {{"point", f.name},
                        {"n", f.n},
                        {"commanded_mm", Vec(f.commanded_mm)},
                        {"barycentre_mm", Vec(f.barycentre_mm)},
                        {"AP_mm", f.ap_mm},
                        {"APx_mm", f.ap_xyz_mm.x()},
                        {"APy_mm", f.ap_xyz_mm.y()},
                        {"APz_mm", f.ap_xyz_mm.z()},
                        {"RP_mm", NumberOrNull(f.rp_mm)},
                        {"l_mean_mm", NumberOrNull(f.mean_l_mm)},
                        {"S_l_mm", NumberOrNull(f.s_l_mm)}};
    const auto& interval = e.rp_intervals[i];
    p["RP_interval_mm"] = interval ? nlohmann::json{interval->lo, interval->hi} : nlohmann::json();
    if (f.ap_abc_rad) {
      p["APa_deg"] = f.ap_abc_rad->x() * deg;
      p["APb_deg"] = f.ap_abc_rad->y() * deg;
      p["APc_deg"] = f.ap_abc_rad->z() * deg;
    }
    if (f.rp_abc_rad) {
      p["RPa_deg"] = f.rp_abc_rad->x() * deg;
      p["RPb_deg"] = f.rp_abc_rad->y() * deg;
      p["RPc_deg"] = f.rp_abc_rad->z() * deg;
    }
    if (f.vap_mm) {
      p["vAP_mm"] = *f.vap_mm;
      p["approaches"] = f.approaches;
    }
    if (f.vap_abc_rad) {
      p["vAPa_deg"] = f.vap_abc_rad->x() * deg;
      p["vAPb_deg"] = f.vap_abc_rad->y() * deg;
      p["vAPc_deg"] = f.vap_abc_rad->z() * deg;
    }
    points.push_back(std::move(p));
  }
  nlohmann::json out = {{"points", points}};
  nlohmann::json distances = nlohmann::json::array();
  for (const auto& d : e.distances) {
    distances.push_back({{"from", d.from},
                         {"to", d.to},
                         {"n", d.n},
                         {"commanded_mm", d.commanded_mm},
                         {"mean_mm", d.mean_mm},
                         {"AD_mm", d.ad_mm},
                         {"RD_mm", NumberOrNull(d.rd_mm)},
                         {"S_D_mm", NumberOrNull(d.s_d_mm)}});
  }
  if (!distances.empty()) {
    out["distance"] = distances.front();
    out["distances"] = distances;
  }
  const Eigen::Isometry3d& t = e.frame.commanded_from_attained;
  nlohmann::json rotation = nlohmann::json::array();
  for (int r = 0; r < 3; ++r)
    rotation.push_back({t.linear()(r, 0), t.linear()(r, 1), t.linear()(r, 2)});
  nlohmann::json alignment = {{"method", e.frame.method},
                              {"detail", e.frame.detail},
                              {"rotation", rotation},
                              {"rotation_deg", Eigen::AngleAxisd(t.linear()).angle() * deg},
                              {"translation_mm", Vec(t.translation())}};
  if (e.frame.fit) {
    alignment["rms_mm"] = e.frame.fit->rms_mm;
    alignment["residuals_mm"] = e.frame.fit->residual_mm;
  }
  out["alignment"] = alignment;
  if (!e.notes.empty()) out["notes"] = e.notes;
  return out;
}

std::string FormatIso9283Figures(const Iso9283Evaluation& e) {
  std::string out;
  const bool oriented = std::any_of(e.points.begin(), e.points.end(),
                                    [](const auto& f) { return f.rp_abc_rad.has_value(); });
  if (e.points.size() <= 20) {
    out += fmt::format("{:<8}{:>5}{:>10}{:>10}{:>10}{:>10}{:>10}{:>22}{}\n", "point", "n", "AP mm",
                       "APx", "APy", "APz", "RP mm", "RP 95 % bootstrap",
                       oriented ? "   RPa RPb RPc deg" : "");
    for (size_t i = 0; i < e.points.size(); ++i) {
      const auto& f = e.points[i];
      const auto& iv = e.rp_intervals[i];
      out += fmt::format("{:<8}{:>5}{:>10.4f}{:>10.4f}{:>10.4f}{:>10.4f}{:>10}{:>22}", f.name, f.n,
                         f.ap_mm, f.ap_xyz_mm.x(), f.ap_xyz_mm.y(), f.ap_xyz_mm.z(),
                         std::isfinite(f.rp_mm) ? fmt::format("{:.4f}", f.rp_mm) : "-",
                         iv ? fmt::format("{:.4f} - {:.4f}", iv->lo, iv->hi) : "-");
      if (f.rp_abc_rad) {
        out += fmt::format("   {:.4f} {:.4f} {:.4f}", f.rp_abc_rad->x() / kRadPerDeg,
                           f.rp_abc_rad->y() / kRadPerDeg, f.rp_abc_rad->z() / kRadPerDeg);
      }
      if (f.vap_mm) out += fmt::format("   vAP {:.4f} mm", *f.vap_mm);
      out += "\n";
    }
  } else {
    std::vector<double> ap;
    for (const auto& f : e.points) ap.push_back(f.ap_mm);
    std::sort(ap.begin(), ap.end());
    double sum = 0.0;
    for (double v : ap) sum += v;
    out += fmt::format(
        "{} points: AP mean {:.4f} mm, median {:.4f} mm, 95 % {:.4f} mm, max {:.4f} mm (every "
        "point in --json)\n",
        ap.size(), sum / ap.size(), ap[(ap.size() - 1) / 2],
        ap[std::min(ap.size() - 1, static_cast<size_t>(std::ceil(0.95 * ap.size())) - 1)],
        ap.back());
  }
  for (const auto& d : e.distances) {
    out += fmt::format("distance {}-{}: n {}, commanded {:.4f} mm, AD {:+.4f} mm, RD {}\n", d.from,
                       d.to, d.n, d.commanded_mm, d.ad_mm,
                       std::isfinite(d.rd_mm) ? fmt::format("{:.4f} mm", d.rd_mm) : "-");
  }
  out += "frame: " + (e.frame.detail.empty() ? e.frame.method : e.frame.detail) + "\n";
  for (const auto& n : e.notes) out += "note: " + n + "\n";
  return out;
}

void ParseIso9283Limit(const std::string& text, Iso9283Limits& limits) {
  const size_t eq = text.find('=');
  const std::string key = text.substr(0, eq);
  std::optional<double>* slot = key == "AP"   ? &limits.ap_mm
                                : key == "RP" ? &limits.rp_mm
                                : key == "AD" ? &limits.ad_mm
                                : key == "RD" ? &limits.rd_mm
                                              : nullptr;
  double value = NAN;
  if (eq != std::string::npos && slot) {
    const std::string number = text.substr(eq + 1);
    size_t used = 0;
    try {
      value = std::stod(number, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used != number.size() || number.empty()) value = NAN;
  }
  if (!slot || !std::isfinite(value) || value <= 0.0 || value > 1e4) {
    throw InputError(fmt::format(
        "--limit: '{}': expected KEY=MM with KEY one of AP, RP, AD, RD and MM a length in mm "
        "above 0 (as the data sheet or the customer states it: --limit RP=0.04)",
        text));
  }
  *slot = value;
}

Iso9283Verdict JudgeIso9283(const Iso9283Evaluation& e, const Iso9283Limits& limits) {
  Iso9283Verdict v;
  auto check = [&](const char* figure, const std::string& where, double value, double limit) {
    // NaN (the figure needs more cycles than the test has) is not within any limit.
    v.checks.push_back({figure, where, value, limit, std::isfinite(value) && value <= limit});
  };
  for (const auto& p : e.points) {
    if (limits.ap_mm) check("AP", p.name, p.ap_mm, *limits.ap_mm);
    if (limits.rp_mm) check("RP", p.name, p.rp_mm, *limits.rp_mm);
  }
  for (const auto& d : e.distances) {
    const std::string where = d.from + "-" + d.to;
    if (limits.ad_mm) check("AD", where, std::abs(d.ad_mm), *limits.ad_mm);
    if (limits.rd_mm) check("RD", where, d.rd_mm, *limits.rd_mm);
  }
  std::string failed;
  for (const auto& c : v.checks) {
    if (c.pass) continue;
    v.pass = false;
    failed += fmt::format("{}{} at {} {} > {:.3f} mm", failed.empty() ? "" : "; ", c.figure,
                          c.where,
                          std::isfinite(c.value_mm) ? fmt::format("{:.3f} mm", c.value_mm)
                                                    : std::string("not measured"),
                          c.limit_mm);
  }
  if (v.checks.empty()) {
    v.pass = false;
    v.summary = "FAIL: no figure of this test to judge against the stated limits";
  } else if (v.pass) {
    v.summary = fmt::format("PASS: all {} figures within the stated limits", v.checks.size());
  } else {
    v.summary = "FAIL: " + failed;
  }
  if (!limits.source.empty()) v.summary += " (limits: " + limits.source + ")";
  return v;
}

nlohmann::json Iso9283VerdictJson(const Iso9283Verdict& v, const Iso9283Limits& limits) {
  nlohmann::json stated = {{"source", limits.source}};
  if (limits.ap_mm) stated["AP_mm"] = *limits.ap_mm;
  if (limits.rp_mm) stated["RP_mm"] = *limits.rp_mm;
  if (limits.ad_mm) stated["AD_mm"] = *limits.ad_mm;
  if (limits.rd_mm) stated["RD_mm"] = *limits.rd_mm;
  nlohmann::json checks = nlohmann::json::array();
  for (const auto& c : v.checks) {
    checks.push_back({{"figure", c.figure},
                      {"where", c.where},
                      {"value_mm", std::isfinite(c.value_mm) ? nlohmann::json(c.value_mm)
                                                             : nlohmann::json(nullptr)},
                      {"limit_mm", c.limit_mm},
                      {"pass", c.pass}});
  }
  return {{"limits", stated}, {"pass", v.pass}, {"summary", v.summary}, {"checks", checks}};
}

}  // namespace armsig::iso9283
