// Baarda's data snooping: the one blunder policy of every adjustment in armsig, the station
// orientation (`orient`, a laser tracker's set-up, the demo) and the intersection of target
// points (`triangulate`, `reduce`, capture's checks).
//
// Each observation's standardised residual w_i = v_i / (σ_i √r_i) (r_i its redundancy
// number) is tested two-sided; the observation with the largest |w| beyond the critical
// value k is removed and the adjustment repeated, until no observation fails.
//
// The significance level α is the adjustment's: the probability that snooping removes a
// good observation from an adjustment without blunders. Each of its n tests is made at
// α0 = 1 − (1 − α)^(1/n) (Šidák), k = Φ⁻¹(1 − α0/2): with α = 0.1 %, one test alone has
// k = 3.29 (Baarda's α0 = 0.1 %), the 6 tests of a three-ray point k = 3.76, K06's 359
// k = 4.69. A per-test α0 of 0.1 % would remove a good observation from a network of 400
// in one adjustment out of three. δ0 = k + Φ⁻¹(β0) is the non-centrality a blunder must
// reach to be found with probability β0 (the power, 80 %): the minimal detectable bias is
// MDB_i = σ_i δ0 / √r_i.
//
// What cannot be decided is said, never guessed. Which of two observations is wrong is a
// question about two named tests, asked at the level of one test, k1 = Φ⁻¹(1 − α/2)
// (3.29 at α = 0.1 %):
// - Another observation j may explain the data as well (its twin): the two tests are nearly
//   the same (|ρ_ij| ≥ 0.9, ρ_ij = Qvv_ij / √(Qvv_ii Qvv_jj) their correlation), with j
//   removed instead the worst would pass, w_i|j = (w_i − ρ_ij w_j) / √(1 − ρ_ij²) ≤ k1 (the
//   worst's standardised residual once j is removed), and |w_i| exceeds |w_j| by less than
//   k1 standard deviations of their difference, √(2 (1 − |ρ_ij|)). One of them is wrong and
//   the data cannot say which: all of them are removed, and named together. Equal |w| in a
//   pair (|ρ| = 1) is the extreme case. Below |ρ| = 0.9 removing the worst leaves at least
//   44 % (√(1 − 0.9²)) of the other's test its own: an echo of the worst clears, a second
//   blunder stays and is removed next.
// - Nothing is removed when that would leave the adjustment without redundancy (degrees of
//   freedom < 1) or when the others barely check it: the smallest eigenvalue of the Qvv
//   block of it and its twins (for one observation its redundancy number r_i) below
//   min_redundancy; its w then rests on a tiny part of its error, and without it what it
//   determines would be left unchecked. It is reported, and the next failing observation
//   is examined, unless that one's failure could be an echo of it (w_c|u ≤ k1): then it
//   stays too.
#pragma once

#include <functional>
#include <optional>
#include <set>
#include <span>
#include <string>
#include <vector>

namespace armsig::reduction {

// The levels of the tests of one adjustment.
struct SnoopLevels {
  int tests = 0;
  double alpha0 = 0.0;      // of each test
  double critical_w = 0.0;  // k, of each test among `tests`
  double pair_critical_w = 0.0;  // k1, of one test alone: for which of two is wrong
  double delta0 = 0.0;           // for the minimal detectable biases
};

struct DataSnooping {
  bool reject = true;   // false: test and report, remove nothing
  double alpha = 1e-3;  // the adjustment's significance level (see above)
  double beta0 = 0.80;  // the power of each test
  // Instead of alpha: the critical value of every test, whatever their number.
  std::optional<double> critical_w;
  // Below this redundancy number an observation is barely checked by the others (its MDB
  // beyond 32 δ0 σ): it is tested but never removed.
  double min_redundancy = 1e-3;

  SnoopLevels Levels(int tests) const;
  void Check() const;
};

// Two tests correlated beyond this (|ρ|) are nearly the same test (see above).
inline constexpr double kNearlyTheSameTest = 0.9;

// One tested observation.
struct SnoopCandidate {
  double w = 0.0;
  double redundancy = 0.0;
  int group = 0;      // candidates removed together (the Hz, V, distance of one ray)
  int removes = 1;    // observations its removal takes out (its group's size)
  bool kept = false;  // forced in by the user: tested, never removed
};

// Why a failing candidate is not removed.
enum class Undecided {
  kRejectionOff,      // testing only (--no-reject)
  kNoRedundancyLeft,  // removing it (and its twins) leaves no degree of freedom
  kBarelyChecked,     // the others barely check it (and its twins): redundancy near 0
  kEcho,              // its failure may be that of an undecided one (its twin)
  kRemovalLimit       // the adjustment's limit on removals is reached (orientation)
};

struct SnoopUndecided {
  int candidate = -1;
  Undecided why = Undecided::kRejectionOff;
  std::vector<int> twins;  // the candidates it cannot be told from
};

struct SnoopDecision {
  // To remove now: the failing candidate with the largest |w| that can be decided, then the
  // candidates it cannot be told from (one of them is wrong, the data cannot say which).
  // Empty: nothing to remove.
  std::vector<int> remove;
  // Failing candidates with a larger |w| that cannot be removed, and why.
  std::vector<SnoopUndecided> undecided;
};

// What an undecided outcome means, in words for a report.
std::string Explain(Undecided why);

// The correlation ρ_ij = Qvv_ij / √(Qvv_ii Qvv_jj) of two candidates' tests.
using TestCorrelation = std::function<double(int, int)>;

// Why the candidates of `groups` cannot be removed together, if they cannot: no degree of
// freedom left, or the smallest eigenvalue of their Qvv block (how much the others check
// them together) below policy.min_redundancy.
std::optional<Undecided> WhyNotRemovable(std::span<const SnoopCandidate> candidates,
                                         const std::set<int>& groups, int dof,
                                         const DataSnooping& policy,
                                         const TestCorrelation& correlation);

// The decision for the next removal among `candidates` of an adjustment with `dof`
// degrees of freedom, tested at `levels` (policy.Levels(candidates.size())); `correlation`
// is called only when a candidate fails the test.
SnoopDecision DecideRejection(std::span<const SnoopCandidate> candidates, int dof,
                              const DataSnooping& policy, const SnoopLevels& levels,
                              const TestCorrelation& correlation);

}  // namespace armsig::reduction
