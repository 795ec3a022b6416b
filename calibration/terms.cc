#include "calibration/terms.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "calibration/identifiability.h"

namespace armsig::calibration {

std::optional<TermFamily> TermFamilyFromName(std::string_view name) {
  if (name == "compliance") return TermFamily::kCompliance;
  if (name == "harmonics") return TermFamily::kHarmonics;
  return std::nullopt;
}

const char* TermFamilyName(TermFamily family) {
  switch (family) {
    case TermFamily::kModel:
      return "model";
    case TermFamily::kCompliance:
      return "compliance";
    case TermFamily::kHarmonics:
      return "harmonics";
  }
  return "?";
}

namespace {

// Relative size below which a quantity computed from ~metre-sized geometry is rounding.
constexpr double kRounding = 1e-9;
// Deterministic configurations over the joint limits on which the checks are decided.
constexpr int kCheckConfigurations = 64;

// Does joint i move the target at all? From the nominal joint Jacobian over spread
// configurations, against the largest joint's lever.
std::vector<bool> JointsThatMoveTheTarget(const RobotModel& model,
                                          const std::vector<Eigen::VectorXd>& configurations) {
  const int n = model.num_joints();
  RobotModel bare = model;
  bare.nongeometric.clear();
  Kinematics kin(bare);
  const Eigen::VectorXd zero = Eigen::VectorXd::Zero(bare.num_parameters());
  Eigen::VectorXd lever = Eigen::VectorXd::Zero(n);
  for (const auto& q : configurations) {
    kin.Position(Eigen::Isometry3d::Identity(), zero, q.data());
    lever += kin.JointJacobian().colwise().squaredNorm().transpose();
  }
  std::vector<bool> moves(n);
  for (int i = 0; i < n; ++i)
    moves[i] = std::sqrt(lever(i)) > kRounding * std::sqrt(lever.maxCoeff());
  return moves;
}

std::string JointName(int joint) { return std::to_string(joint + 1); }

std::vector<NongeometricTerm> Compliance(const RobotModel& model,
                                         const std::vector<Eigen::VectorXd>& configurations,
                                         const std::vector<bool>& moves) {
  const int n = model.num_joints();
  const int count = static_cast<int>(configurations.size());
  // Torque of a unit mass at every frame origin and the target, about every joint axis,
  // over the configurations; and the lever |p − o| to judge what is rounding.
  RobotModel probe = model;
  probe.nongeometric.clear();
  for (int i = 0; i < n; ++i) {
    for (int j = i + 1; j <= n; ++j) {
      NongeometricTerm t;
      t.joint = i;
      t.basis = NongeometricTerm::Basis::kGravityTorque;
      t.mass_at = j;
      probe.nongeometric.push_back(t);
    }
  }
  const int terms = static_cast<int>(probe.nongeometric.size());
  Eigen::MatrixXd torque(count, terms);
  Eigen::VectorXd lever = Eigen::VectorXd::Zero(terms);
  NominalFrames frames;
  std::vector<double> values(terms);
  for (int c = 0; c < count; ++c) {
    EvaluateTerms(probe, configurations[c].data(), values.data(), frames);
    for (int k = 0; k < terms; ++k) {
      torque(c, k) = values[k];
      const auto& t = probe.nongeometric[k];
      const Eigen::Vector3d& p = t.mass_at < n ? frames.origin[t.mass_at] : frames.target;
      lever(k) = std::max(lever(k), (p - frames.origin[t.joint]).norm() / 1000.0);
    }
  }
  std::vector<NongeometricTerm> out;
  for (int k = 0; k < terms; ++k) {
    NongeometricTerm t = probe.nongeometric[k];
    if (!moves[t.joint]) continue;
    const Eigen::VectorXd f = torque.col(k);
    // Identically zero: a vertical axis, or the mass on the joint's own axis.
    if (f.cwiseAbs().maxCoeff() <= kRounding * std::max(lever(k), 1e-3)) continue;
    // The same function of the angles as an earlier mass on this joint (up to a factor):
    // one coefficient could not be told from the other.
    bool duplicate = false;
    for (int e = 0; e < k && !duplicate; ++e) {
      const auto& earlier = probe.nongeometric[e];
      if (earlier.joint != t.joint) continue;
      const Eigen::VectorXd g = torque.col(e);
      if (g.norm() == 0.0) continue;
      const double cosine = std::abs(f.dot(g)) / (f.norm() * g.norm());
      duplicate = cosine > 1.0 - 1e-12;
    }
    if (duplicate) continue;
    t.name = "k" + JointName(t.joint) + "_" + JointName(t.mass_at);
    t.family = TermFamily::kCompliance;
    out.push_back(std::move(t));
  }
  return out;
}

std::vector<NongeometricTerm> Harmonics(const RobotModel& model, const std::vector<bool>& moves) {
  std::vector<NongeometricTerm> out;
  for (int i = 0; i < model.num_joints(); ++i) {
    if (!moves[i]) continue;
    for (int order : {1, 2}) {
      for (auto basis : {NongeometricTerm::Basis::kSin, NongeometricTerm::Basis::kCos}) {
        NongeometricTerm t;
        t.joint = i;
        t.basis = basis;
        t.of = {i};
        t.order = order;
        t.family = TermFamily::kHarmonics;
        t.name = "e" + JointName(i) + (basis == NongeometricTerm::Basis::kSin ? "_s" : "_c") +
                 std::to_string(order);
        out.push_back(std::move(t));
      }
    }
  }
  return out;
}

}  // namespace

std::vector<NongeometricTerm> GenerateTerms(const RobotModel& model, TermFamily family) {
  const auto configurations = SpreadConfigurations(model, kCheckConfigurations);
  const std::vector<bool> moves = JointsThatMoveTheTarget(model, configurations);
  switch (family) {
    case TermFamily::kCompliance:
      return Compliance(model, configurations, moves);
    case TermFamily::kHarmonics:
      return Harmonics(model, moves);
    case TermFamily::kModel:
      break;
  }
  throw std::invalid_argument("the model's own terms are not generated");
}

RobotModel WithGeneratedTerms(const RobotModel& model, const std::vector<TermFamily>& families) {
  RobotModel out = model;
  for (TermFamily family : families) {
    const bool present = std::any_of(out.nongeometric.begin(), out.nongeometric.end(),
                                     [&](const NongeometricTerm& t) { return t.family == family; });
    if (present) continue;
    for (NongeometricTerm& term : GenerateTerms(model, family)) {
      if (out.IndexOf(term.name) >= 0) {
        throw std::invalid_argument("generated " + std::string(TermFamilyName(family)) + " term '" +
                                    term.name + "' has the name of another parameter of the model");
      }
      out.nongeometric.push_back(std::move(term));
    }
  }
  return out;
}

std::vector<TermFamily> FamiliesNamedIn(const std::string& spec) {
  std::vector<TermFamily> out;
  size_t start = 0;
  while (start <= spec.size()) {
    size_t end = spec.find(',', start);
    if (end == std::string::npos) end = spec.size();
    std::string token = spec.substr(start, end - start);
    token.erase(0, token.find_first_not_of(" \t"));
    token.erase(token.find_last_not_of(" \t") + 1);
    if (const auto family = TermFamilyFromName(token);
        family && std::find(out.begin(), out.end(), *family) == out.end()) {
      out.push_back(*family);
    }
    start = end + 1;
  }
  return out;
}

}  // namespace armsig::calibration
