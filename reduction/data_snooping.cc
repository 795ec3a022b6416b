#include "reduction/data_snooping.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <boost/math/distributions/normal.hpp>
#include <cmath>
#include <optional>
#include <set>
#include <stdexcept>

namespace armsig::reduction {

namespace {

// x with P(Z > x) = p for a standard normal Z.
double UpperQuantile(double p) {
  return boost::math::quantile(boost::math::complement(boost::math::normal(), p));
}

SnoopLevels LevelsOf(const DataSnooping& policy, int tests) {
  SnoopLevels levels;
  levels.tests = std::max(1, tests);
  if (policy.critical_w) {
    levels.critical_w = levels.pair_critical_w = *policy.critical_w;
    levels.alpha0 = std::erfc(levels.critical_w / std::sqrt(2.0));
  } else {
    levels.pair_critical_w = UpperQuantile(policy.alpha / 2.0);
    // Šidák: n independent tests at α0 keep the adjustment's level, 1 − (1 − α0)^n = α.
    levels.alpha0 = -std::expm1(std::log1p(-policy.alpha) / levels.tests);
    levels.critical_w = UpperQuantile(levels.alpha0 / 2.0);
  }
  levels.delta0 = levels.critical_w + UpperQuantile(1.0 - policy.beta0);
  return levels;
}

// Whether removing j instead of i would explain i's failure as well: i passes once j is
// gone, and |w_i| is not significantly larger than |w_j| (reduction/data_snooping.h).
bool Twins(const SnoopCandidate& i, const SnoopCandidate& j, double rho, double k) {
  rho = std::clamp(rho, -1.0, 1.0);
  if (std::abs(rho) < kNearlyTheSameTest) return false;
  const double tolerance = 1e-9 * std::abs(i.w);  // rounding when |ρ| = 1
  const bool explained = std::abs(i.w - rho * j.w) <= k * std::sqrt(1.0 - rho * rho) + tolerance;
  const bool not_larger =
      std::abs(i.w) - std::abs(j.w) <= k * std::sqrt(2.0 * (1.0 - std::abs(rho))) + tolerance;
  return explained && not_larger;
}

// The undecided candidate whose removal would let candidate c pass, if any: c|u ≤ k1.
std::optional<int> EchoOf(std::span<const SnoopCandidate> candidates, int c,
                          const std::vector<SnoopUndecided>& undecided, const SnoopLevels& levels,
                          const TestCorrelation& correlation) {
  for (const SnoopUndecided& u : undecided) {
    if (candidates[u.candidate].group == candidates[c].group) continue;
    const double rho = std::clamp(correlation(u.candidate, c), -1.0, 1.0);
    const double w_c = candidates[c].w, w_u = candidates[u.candidate].w;
    if (std::abs(w_c - rho * w_u) <=
        levels.pair_critical_w * std::sqrt(1.0 - rho * rho) + 1e-9 * std::abs(w_c))
      return u.candidate;
  }
  return std::nullopt;
}

}  // namespace

SnoopLevels DataSnooping::Levels(int tests) const {
  // The defaults' levels are tabulated for the small adjustments of the intersection, which
  // asks for them for every point (a quantile costs ~0.2 µs, a point ~0.7 µs).
  constexpr int kTabulated = 3 * 64;
  const bool defaults = alpha == DataSnooping{}.alpha && beta0 == DataSnooping{}.beta0;
  if (defaults && !critical_w && tests >= 1 && tests <= kTabulated) {
    static const std::vector<SnoopLevels> table = [] {
      std::vector<SnoopLevels> t(kTabulated + 1);
      for (int n = 1; n <= kTabulated; ++n) t[n] = LevelsOf(DataSnooping{}, n);
      return t;
    }();
    return table[tests];
  }
  return LevelsOf(*this, tests);
}

void DataSnooping::Check() const {
  if (!(alpha > 0 && alpha < 1)) throw std::invalid_argument("alpha must lie in (0, 1)");
  if (!(beta0 > 0 && beta0 < 1)) throw std::invalid_argument("beta0 must lie in (0, 1)");
  if (critical_w && !(*critical_w > 0 && std::isfinite(*critical_w)))
    throw std::invalid_argument("critical_w must be > 0");
  if (!(min_redundancy >= 0 && min_redundancy < 1))
    throw std::invalid_argument("min_redundancy must lie in [0, 1)");
}

std::string Explain(Undecided why) {
  switch (why) {
    case Undecided::kRejectionOff:
      return "not removed (rejection off)";
    case Undecided::kNoRedundancyLeft:
      return "not removed: without it the adjustment would have no redundancy left";
    case Undecided::kBarelyChecked:
      return "not removed: the other observations barely check it (redundancy number near 0), "
             "without it what it determines would be left unchecked";
    case Undecided::kEcho:
      return "not removed: its failure may be an echo of one that could not be decided";
    case Undecided::kRemovalLimit:
      return "not removed: the limit on removals is reached (so many failing observations "
             "point to wrong sigmas, a systematic error or mixed-up point names, not blunders)";
  }
  return {};
}

std::optional<Undecided> WhyNotRemovable(std::span<const SnoopCandidate> candidates,
                                     const std::set<int>& groups, int dof,
                                     const DataSnooping& policy,
                                     const TestCorrelation& correlation) {
  std::vector<int> rows;
  std::set<int> counted;
  int removes = 0;
  for (int c = 0; c < static_cast<int>(candidates.size()); ++c) {
    if (!groups.count(candidates[c].group)) continue;
    rows.push_back(c);
    if (counted.insert(candidates[c].group).second) removes += candidates[c].removes;
  }
  if (dof - removes < 1) return Undecided::kNoRedundancyLeft;
  const int n = static_cast<int>(rows.size());
  Eigen::MatrixXd block(n, n);
  for (int a = 0; a < n; ++a) {
    const double ra = std::max(0.0, candidates[rows[a]].redundancy);
    block(a, a) = ra;
    for (int b = 0; b < a; ++b) {
      const double rb = std::max(0.0, candidates[rows[b]].redundancy);
      block(a, b) = block(b, a) = correlation(rows[a], rows[b]) * std::sqrt(ra * rb);
    }
  }
  const double smallest =
      n == 1 ? block(0, 0)
             : Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(block, Eigen::EigenvaluesOnly)
                   .eigenvalues()(0);
  if (!(smallest >= policy.min_redundancy)) return Undecided::kBarelyChecked;
  return std::nullopt;
}

SnoopDecision DecideRejection(std::span<const SnoopCandidate> candidates, int dof,
                              const DataSnooping& policy, const SnoopLevels& levels,
                              const TestCorrelation& correlation) {
  SnoopDecision d;
  std::vector<int> failing;
  for (int i = 0; i < static_cast<int>(candidates.size()); ++i) {
    if (!candidates[i].kept && std::abs(candidates[i].w) > levels.critical_w) failing.push_back(i);
  }
  std::stable_sort(failing.begin(), failing.end(), [&](int a, int b) {
    return std::abs(candidates[a].w) > std::abs(candidates[b].w);
  });
  if (!failing.empty() && !policy.reject) {
    d.undecided.push_back({failing[0], Undecided::kRejectionOff, {}});
    return d;
  }
  for (int i : failing) {
    const SnoopCandidate& worst = candidates[i];
    if (auto echo = EchoOf(candidates, i, d.undecided, levels, correlation)) {
      d.undecided.push_back({i, Undecided::kEcho, {*echo}});
      continue;
    }
    std::vector<int> twins;
    std::set<int> groups = {worst.group};
    for (int j = 0; j < static_cast<int>(candidates.size()); ++j) {
      const SnoopCandidate& other = candidates[j];
      if (other.group == worst.group || other.kept) continue;
      if (Twins(worst, other, correlation(i, j), levels.pair_critical_w)) {
        twins.push_back(j);
        groups.insert(other.group);
      }
    }
    if (auto why = WhyNotRemovable(candidates, groups, dof, policy, correlation)) {
      d.undecided.push_back({i, *why, twins});
      continue;
    }
    d.remove.push_back(i);
    d.remove.insert(d.remove.end(), twins.begin(), twins.end());
    return d;
  }
  return d;
}

}  // namespace armsig::reduction
