#include "programs/controller.h"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <set>
#include <stdexcept>
#include <vector>

#include "calibration/pose_solver.h"
#include "core/units.h"

namespace armsig::programs {

namespace {

// The frame before each joint's rotation (its axis z, its origin on the axis) and the last
// link frame, at the joints.
struct Chain {
  std::vector<Eigen::Isometry3d> before;
  Eigen::Isometry3d last = Eigen::Isometry3d::Identity();
};

Chain ChainAt(const calibration::RobotModel& model, const Eigen::VectorXd& q) {
  Chain c;
  c.before.reserve(static_cast<std::size_t>(model.num_joints()));
  Eigen::Isometry3d t = model.base.value_or(Eigen::Isometry3d::Identity());
  for (int i = 0; i < model.num_joints(); ++i) {
    if (i > 0) t = t * model.links[static_cast<std::size_t>(i - 1)];
    c.before.push_back(t);
    t = t * calibration::JointRotation(q(i));
  }
  c.last = t;
  return c;
}

// The wrist centre: the point nearest both joint 4's and joint 6's axes (where a spherical
// wrist's axes meet); joint 5's origin when they are parallel or the arm has fewer joints.
Eigen::Vector3d WristCentre(const Chain& c) {
  const int n = static_cast<int>(c.before.size());
  if (n < 6) return c.before[static_cast<std::size_t>(std::max(0, n - 2))].translation();
  const Eigen::Vector3d p = c.before[3].translation(), u = c.before[3].linear().col(2);
  const Eigen::Vector3d r = c.before[5].translation(), v = c.before[5].linear().col(2);
  const double b = u.dot(v), d = u.dot(p - r), e = v.dot(p - r), den = 1 - b * b;
  if (den < 1e-9) return c.before[4].translation();
  const double s = (b * e - d) / den, t = (e - b * d) / den;
  return 0.5 * ((p + s * u) + (r + t * v));
}

// Across joint 2's axis, which side of the line from joint 2 through joint 3 the wrist
// centre lies: zero with the arm stretched or folded.
double ElbowSide(const Chain& c, const Eigen::Vector3d& w) {
  const Eigen::Vector3d o2 = c.before[1].translation(), o3 = c.before[2].translation();
  return c.before[1].linear().col(2).dot((o3 - o2).cross(w - o3));
}

double StretchedAngle(const calibration::RobotModel& model) {
  if (model.num_joints() < 3) return 0.0;
  Eigen::VectorXd q = Eigen::VectorXd::Zero(model.num_joints());
  auto side = [&](double q3) {
    q(2) = q3;
    const Chain c = ChainAt(model, q);
    return ElbowSide(c, WristCentre(c));
  };
  auto reach = [&](double q3) {
    q(2) = q3;
    const Chain c = ChainAt(model, q);
    return (WristCentre(c) - c.before[1].translation()).norm();
  };
  double best = 0.0, best_reach = -1.0;
  const int steps = 720;
  for (int k = 0; k < steps; ++k) {
    double a = -kPi + 2 * kPi * k / steps, b = a + 2 * kPi / steps;
    double fa = side(a), fb = side(b);
    if ((fa < 0) == (fb < 0)) continue;
    for (int it = 0; it < 60; ++it) {  // bisection to the zero
      const double m = 0.5 * (a + b), fm = side(m);
      if ((fm < 0) == (fa < 0)) a = m, fa = fm;
      else b = m;
    }
    const double root = 0.5 * (a + b);
    if (reach(root) > best_reach) {
      best_reach = reach(root);
      best = root;
    }
  }
  return best;
}

Eigen::Vector3d FrontDirection(const calibration::RobotModel& model) {
  const Eigen::VectorXd q = Eigen::VectorXd::Zero(model.num_joints());
  const Chain c = ChainAt(model, q);
  Eigen::Vector3d w = c.before[0].inverse() * WristCentre(c);  // in the frame turning with joint 1
  w.z() = 0;
  return w.norm() > 1e-9 ? Eigen::Vector3d(w.normalized()) : Eigen::Vector3d::UnitX();
}

calibration::RobotModel ControllerChain(calibration::RobotModel model) {
  model.base = Eigen::Isometry3d::Identity();
  model.nongeometric.clear();  // a controller knows no non-geometric terms
  model.tool_mm.setZero();
  // Nor where a calibration target sits on the flange: its nominal flange has no turn.
  model.tool_mounting = calibration::ToolMounting::kFitted;
  model.turn_lever_mm.reset();
  return model;
}

int Quadrant(double rad) { return static_cast<int>(std::floor(rad / (kPi / 2) + 1e-12)); }

}  // namespace

const char* ToString(ControllerKind kind) {
  switch (kind) {
    case ControllerKind::kUniversalRobots:
      return "Universal Robots";
    case ControllerKind::kKuka:
      return "KUKA";
    case ControllerKind::kAbb:
      return "ABB";
    case ControllerKind::kGeneric:
      break;
  }
  return "generic";
}

ControllerModel NominalController(const calibration::RobotModel& model, ControllerKind kind,
                                  std::string description) {
  ControllerModel c;
  c.kind = kind;
  c.model = ControllerChain(model);
  c.flange = model.flange;
  c.description = std::move(description);
  c.stretched_q3_rad = StretchedAngle(c.model);
  c.front = FrontDirection(c.model);
  return c;
}

ControllerModel UrController(const UrKinematics& k) {
  // T_i = Rz(θ_i + q_i)·Tz(d_i)·Tx(a_i)·Rx(α_i): the joint turns Rz(q_i) first, so
  // N(i+1) = Rz(θ_i)·Tz(d_i)·Tx(a_i)·Rx(α_i) (after joint i) and the last row is the flange.
  auto row = [&](int i) {
    Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
    t.rotate(Eigen::AngleAxisd(k.theta[static_cast<std::size_t>(i)], Eigen::Vector3d::UnitZ()));
    t.translate(Eigen::Vector3d(0, 0, 1000.0 * k.d[static_cast<std::size_t>(i)]));
    t.translate(Eigen::Vector3d(1000.0 * k.a[static_cast<std::size_t>(i)], 0, 0));
    t.rotate(Eigen::AngleAxisd(k.alpha[static_cast<std::size_t>(i)], Eigen::Vector3d::UnitX()));
    return t;
  };
  calibration::RobotModel model;
  model.name = "ur-controller";
  for (int i = 0; i < 5; ++i) model.links.push_back(row(i));
  model.joint_min_rad.assign(6, -2 * kPi);
  model.joint_max_rad.assign(6, 2 * kPi);
  ControllerModel c;
  c.kind = ControllerKind::kUniversalRobots;
  c.model = ControllerChain(model);
  c.flange = row(5);
  c.description = "the UR's own kinematics (KinematicsInfo) from " + k.source;
  c.stretched_q3_rad = StretchedAngle(c.model);
  c.front = FrontDirection(c.model);
  return c;
}

Eigen::Isometry3d FlangePose(const ControllerModel& c, const Eigen::VectorXd& q) {
  return ChainAt(c.model, q).last * c.flange;
}

Eigen::Isometry3d TcpPose(const ControllerModel& c, const Eigen::VectorXd& q, const Eigen::Isometry3d& tool) {
  return FlangePose(c, q) * tool;
}

ArmConfiguration ConfigurationOf(const ControllerModel& c, const Eigen::VectorXd& q) {
  ArmConfiguration a;
  const int n = static_cast<int>(q.size());
  const Chain chain = ChainAt(c.model, q);
  const Eigen::Vector3d w = WristCentre(chain);
  const Eigen::Isometry3d turning = chain.before[0] * calibration::JointRotation(q(0));
  Eigen::Vector3d local = turning.inverse() * w;
  local.z() = 0;
  a.overhead = local.dot(c.front) < 0;
  const double past = n >= 3 ? WrapPi(q(2) - c.stretched_q3_rad) : 0.0;
  a.elbow = past >= 0;
  a.wrist = n >= 5 && q(4) <= 0;
  a.kuka_status = (a.overhead ? 1 : 0) | (a.elbow ? 2 : 0) | (a.wrist ? 4 : 0);
  for (int i = 0; i < std::min(n, 6); ++i) a.kuka_turn |= q(i) < 0 ? (1 << i) : 0;
  const double home = WrapPi(-c.stretched_q3_rad);
  const bool backward = n >= 3 && (past >= 0) != (home >= 0);
  a.abb_cf = {Quadrant(q(0)), n >= 4 ? Quadrant(q(3)) : 0, n >= 6 ? Quadrant(q(5)) : 0,
              4 * (a.overhead ? 1 : 0) + 2 * (backward ? 1 : 0) + (n >= 5 && q(4) < 0 ? 1 : 0)};
  return a;
}

bool Matches(const StatedConfiguration& s, const ArmConfiguration& a) {
  if (s.kuka_status && (*s.kuka_status & 7) != a.kuka_status) return false;
  if (s.kuka_turn && (*s.kuka_turn & 63) != a.kuka_turn) return false;
  if (s.abb_cf && *s.abb_cf != a.abb_cf) return false;
  return true;
}

std::string Describe(const StatedConfiguration& s) {
  std::string out;
  if (s.kuka_status) out += fmt::format("S {}", *s.kuka_status);
  if (s.kuka_turn) out += fmt::format("{}T {}", out.empty() ? "" : " ", *s.kuka_turn);
  if (s.abb_cf)
    out += fmt::format("cf [{},{},{},{}]", (*s.abb_cf)[0], (*s.abb_cf)[1], (*s.abb_cf)[2], (*s.abb_cf)[3]);
  return out;
}

namespace {

// Seeds over the configurations for a TCP at `x`: joint 1 facing the target or away, the
// upper arm at several angles, the elbow on either side of stretched, the wrist flipped or not.
std::vector<Eigen::VectorXd> ConfigurationSeeds(const ControllerModel& c,
                                               const Eigen::Vector3d& x) {
  const int n = c.num_joints();
  std::vector<Eigen::VectorXd> seeds;
  const Eigen::VectorXd zero_q = Eigen::VectorXd::Zero(n);
  const Chain home = ChainAt(c.model, zero_q);
  const Eigen::Vector3d w0 = WristCentre(home);
  const double axis_sign = home.before[0].linear().col(2).z() >= 0 ? 1.0 : -1.0;
  const double facing = axis_sign * (std::atan2(x.y(), x.x()) - std::atan2(w0.y(), w0.x()));
  for (double q1 : {facing, facing + kPi}) {
    for (double q2 : {-2.2, -1.6, -1.0, -0.3, 0.4, 1.0}) {
      for (double side : {1.0, -1.0}) {
        for (double q5 : {0.9, -0.9}) {
          Eigen::VectorXd seed = Eigen::VectorXd::Zero(n);
          seed(0) = WrapPi(q1);
          if (n >= 2) seed(1) = q2;
          if (n >= 3) seed(2) = c.stretched_q3_rad + side * 1.0;
          if (n >= 5) seed(4) = q5;
          seeds.push_back(seed);
        }
      }
    }
  }
  return seeds;
}

}  // namespace

InverseSolution ControllerInverse(const ControllerModel& c, const InverseRequest& request) {
  const int n = c.num_joints();
  const Eigen::Isometry3d flange_tcp = c.flange * request.tool;
  calibration::RobotModel model = calibration::AtPoint(c.model, flange_tcp.translation());
  const Eigen::Matrix3d last_rotation = request.tcp.linear() * flange_tcp.linear().transpose();
  const Eigen::VectorXd zero = Eigen::VectorXd::Zero(model.num_parameters());
  calibration::JointSolveOptions options;
  options.tolerance_mm = 1e-9;  // the controller's joints to the numbers' last digit
  options.max_iterations = 200;
  const bool limits = static_cast<int>(model.joint_min_rad.size()) == n &&
                      static_cast<int>(model.joint_max_rad.size()) == n;
  auto within = [&](const auto& q) {
    for (int i = 0; i < n && limits; ++i)
      if (q(i) < model.joint_min_rad[static_cast<std::size_t>(i)] - 1e-9 ||
          q(i) > model.joint_max_rad[static_cast<std::size_t>(i)] + 1e-9)
        return false;
    return true;
  };
  // The solutions as found (each once, on a grid of 1 µrad), and on demand every variant of
  // one: each joint turned by whole turns its limits allow. A UR10's joints turn ±2π, so a
  // solution has up to 3⁶ variants: storing them all, and flipping and comparing each,
  // made the 632 goals of the real series D take minutes under the sanitizers.
  using Small = Eigen::Matrix<double, Eigen::Dynamic, 1, 0, 8, 1>;
  if (n > 8) throw std::invalid_argument("ControllerInverse: more than 8 joints");
  std::vector<Small> variants;  // one buffer for every call: up to 3⁶ of them
  variants.reserve(729);
  auto for_each_variant = [&](const Eigen::VectorXd& q, const auto& visit) {
    variants.clear();
    variants.emplace_back(q);
    for (int i = 0; i < n; ++i) {
      const std::size_t before = variants.size();
      for (std::size_t k = 0; k < before; ++k) {
        for (int turn : {-2, -1, 1, 2}) {
          Small w = variants[k];
          w(i) += turn * 2 * kPi;
          if (limits && w(i) >= model.joint_min_rad[static_cast<std::size_t>(i)] - 1e-9 &&
              w(i) <= model.joint_max_rad[static_cast<std::size_t>(i)] + 1e-9)
            variants.push_back(w);
        }
      }
    }
    for (const auto& v : variants) {
      if (within(v)) visit(v);
    }
  };
  std::vector<Eigen::VectorXd> found;
  std::set<std::array<long long, 8>> known;
  auto add = [&](const Eigen::VectorXd& q) {
    std::array<long long, 8> key{};
    for (int i = 0; i < n; ++i) key[static_cast<std::size_t>(i)] = std::llround(q(i) * 1e6);
    if (!known.insert(key).second) return;
    bool usable = false;
    for_each_variant(q, [&](const Small&) { usable = true; });
    if (usable) found.push_back(q);
  };
  auto solve = [&](const Eigen::VectorXd& seed) {
    const auto s = calibration::SolvePose(model, Eigen::Isometry3d::Identity(), zero,
                                          request.tcp.translation(), last_rotation, seed, options);
    if (s.status.code == SolveCode::kOk || s.status.code == SolveCode::kOutOfRange) {
      Eigen::VectorXd q = s.joints_rad;
      for (int i = 0; i < n; ++i) {  // into the limits by whole turns, when it fits
        if (!limits) break;
        while (q(i) > model.joint_max_rad[static_cast<std::size_t>(i)] + 1e-9) q(i) -= 2 * kPi;
        while (q(i) < model.joint_min_rad[static_cast<std::size_t>(i)] - 1e-9) q(i) += 2 * kPi;
      }
      add(q);
    }
  };
  // A program that states no configuration (URScript) matches every variant: its arm
  // configuration is not worked out for each of up to 3⁶ variants of every solution.
  const bool stated = request.stated.kuka_status || request.stated.kuka_turn || request.stated.abb_cf;
  Eigen::VectorXd candidate(n);  // one buffer for every variant compared
  auto pick = [&]() -> std::optional<Eigen::VectorXd> {
    std::optional<Eigen::VectorXd> best;
    double best_distance = INFINITY;
    for (const auto& base : found) {
      for_each_variant(base, [&](const Small& v) {
        candidate = v;
        if (stated && !Matches(request.stated, ConfigurationOf(c, candidate))) return;
        const double d = request.near_rad ? (candidate - *request.near_rad).norm() : candidate.norm();
        if (d < best_distance) {
          best_distance = d;
          best = candidate;
        }
      });
    }
    return best;
  };
  InverseSolution out;
  // The solution where the controller's start leads, and every other: the nearest is picked
  // among all of them (a UR's get_inverse_kin returns the solution nearest qnear, not the one
  // a descent from qnear reaches: from a stretched elbow, as at all joints zero, a descent
  // may go to either side).
  if (request.near_rad && request.near_rad->size() == n) {
    solve(*request.near_rad);
    // Another branch lies across the stretched elbow (joint 3 mirrored about it) or the
    // straight wrist (joint 5 mirrored about 0 or π), or behind joint 1: a solution nearer
    // qnear than half of its distance to each of those boundaries is the nearest of all
    // (with a margin of two for arms whose branches are not exact mirrors).
    if (auto q = pick(); q && n == 6) {
      const double elbow = std::abs(std::remainder((*q)(2) - c.stretched_q3_rad, 2 * kPi));
      const double wrist = std::abs(std::remainder((*q)(4), kPi));
      if ((*q - *request.near_rad).norm() < 0.5 * std::min({elbow, wrist, kPi / 2})) {
        out.joints_rad = q;
        out.reachable = true;
        return out;
      }
    }
  }
  for (const Eigen::VectorXd& seed : ConfigurationSeeds(c, request.tcp.translation()))
    solve(seed);
  // Each solution's wrist flipped (joint 4 and 6 a half turn on, joint 5 mirrored): the
  // other wrist configuration of the same arm position, found from there at once.
  if (n == 6) {
    const std::vector<Eigen::VectorXd> arms = found;
    for (const auto& q : arms) {
      Eigen::VectorXd flipped = q;
      flipped(3) = WrapPi(q(3) + kPi);
      flipped(4) = -q(4);
      flipped(5) = WrapPi(q(5) + kPi);
      solve(flipped);
    }
  }
  out.reachable = !found.empty();
  out.joints_rad = pick();
  if (!out.joints_rad) {
    if (found.empty()) {
      out.why = "no joints within the limits put the TCP there: out of reach";
    } else {
      std::string others;
      for (std::size_t k = 0; k < found.size() && k < 4; ++k) {
        const ArmConfiguration a = ConfigurationOf(c, found[k]);
        StatedConfiguration s;
        if (request.stated.abb_cf) s.abb_cf = a.abb_cf;
        else s.kuka_status = a.kuka_status, s.kuka_turn = a.kuka_turn;
        others += (others.empty() ? "" : ", ") + Describe(s);
      }
      out.why = fmt::format("no solution in the configuration it states ({}); its solutions: {}",
                            Describe(request.stated), others);
    }
  }
  return out;
}

}  // namespace armsig::programs
