#include "reduction/orientation_snooping.h"

#include <Eigen/SparseCore>
#include <algorithm>
#include <cmath>
#include <map>
#include <set>

#include "core/units.h"
#include "reduction/data_snooping.h"

namespace armsig::reduction {

namespace {

using Kind = ResidualReport::Kind;


// Whether the user forced the observation of `row` in (--keep).
bool Kept(const ResidualRow& row, const KeptObservations& keep) {
  switch (row.kind) {
    case Kind::kScaleBar:
      return keep.scale_bars.count(row.source) > 0;
    case Kind::kControl:
      return keep.control.count(row.source) > 0;
    default:
      return keep.observations.count(row.source) > 0;
  }
}

// The tests of one adjustment as data snooping sees them: a weighted control point's three
// coordinates are one candidate group, every other row its own; kept ones are flagged.
class Tests {
 public:
  Tests(const Adjustment& a, const KeptObservations& keep)
      : a_(a), j_(a.lin.jacobian), candidates(a.bundle.rows.size()) {
    const std::vector<ResidualRow>& rows = a.bundle.rows;
    for (size_t r = 0; r < rows.size(); ++r) {
      SnoopCandidate& c = candidates[r];
      c.w = a.statistics.residuals[r].w;
      c.redundancy = a.statistics.residuals[r].redundancy;
      const bool control = rows[r].kind == Kind::kControl;
      c.group = control ? static_cast<int>(rows.size()) + rows[r].source : static_cast<int>(r);
      c.removes = control ? 3 : 1;
      c.kept = Kept(rows[r], keep);
    }
  }
  Tests(const Tests&) = delete;
  Tests& operator=(const Tests&) = delete;

  // ρ_ij = Qvv_ij / √(r_i r_j) with Qvv = I − A Q Aᵀ (whitened): Qvv_ij = −a_i Q a_jᵀ.
  double Correlation(int i, int k) {
    auto it = qa_.find(i);
    if (it == qa_.end()) it = qa_.emplace(i, a_.lin.q * Eigen::VectorXd(j_.row(i).transpose())).first;
    double aqa = 0.0;
    for (Eigen::SparseMatrix<double, Eigen::RowMajor>::InnerIterator e(j_, k); e; ++e)
      aqa += e.value() * it->second(e.col());
    const double scale = std::sqrt(candidates[i].redundancy * candidates[k].redundancy);
    return scale > 0 ? -aqa / scale : 0.0;
  }
  TestCorrelation Function() {
    return [this](int i, int k) { return Correlation(i, k); };
  }

 private:
  const Adjustment& a_;
  const Eigen::SparseMatrix<double, Eigen::RowMajor> j_;
  std::map<int, Eigen::VectorXd> qa_;  // Q a_iᵀ of the candidates examined

 public:
  std::vector<SnoopCandidate> candidates;
};

// The data-snooping decision on one adjustment (reduction/data_snooping.h).
SnoopDecision DecideOn(const Adjustment& a, const OrientationOptions& options,
                       const SnoopLevels& levels) {
  bool fails = false;  // the usual case, no failing test, without the correlations' set-up
  for (const auto& r : a.statistics.residuals) fails |= std::abs(r.w) > levels.critical_w;
  if (!fails) return {};
  Tests tests(a, options.keep);
  return DecideRejection(tests.candidates, a.dof(), options.snooping, levels, tests.Function());
}

RemovedObservation RemovalOf(const OrientationProblem& problem, const ResidualRow& row,
                             const ResidualReport& tested, int round) {
  RemovedObservation r;
  r.kind = row.kind;
  r.observation = row.source;
  r.label = row.label;
  r.w = tested.w;
  r.redundancy = tested.redundancy;
  r.sigma = row.sigma;
  r.round = round;
  if (row.kind == Kind::kScaleBar || row.kind == Kind::kControl) {
    r.point = row.label;
  } else {
    r.station = problem.observations[row.source].station;
    r.point = problem.observations[row.source].point;
    r.line = problem.observations[row.source].source_line;
  }
  return r;
}

// Whether a reading misses the initial values by more than kStartOutlierRad (a distance by
// more than that fraction of itself): a blunder the start left in.
bool SomeReadingMisses(const OrientationProblem& problem, const IndexedNetwork& network,
                       BundleUnknowns& unknowns) {
  for (const auto& o : network.obs) {
    for (Kind kind : {Kind::kHz, Kind::kV}) {
      const double e = ObservedMinusPredicted(problem, network, unknowns, {kind, o.source});
      if (!(std::abs(e) * kRadPerArcsec <= kStartOutlierRad)) return true;
    }
    if (o.distance) {
      const double e = ObservedMinusPredicted(problem, network, unknowns, {Kind::kDistance, o.source});
      if (!(std::abs(e) <= kStartOutlierRad * *o.distance)) return true;
    }
  }
  return false;
}

// The robust start: one adjustment from the initial values with Cauchy's loss at the
// critical value of one test (reduction/data_snooping.h), where a blunder's pull fades with
// its size, so that the least-squares adjustments start near the network without it
// (a least-squares step from rough values with a 100-gon reading in them can end anywhere).
// A robust adjustment that fails leaves the initial values.
void RobustStart(const OrientationProblem& problem, const IndexedNetwork& network,
                 const OrientationOptions& options, BundleUnknowns& unknowns) {
  const BundleUnknowns initial = unknowns;
  Bundle robust = BuildBundle(problem, network, unknowns, {},
                              options.snooping.Levels(1).pair_critical_w);
  constexpr double kStartTolerance = 1e-8;  // the least-squares adjustments go to 1e-14
  if (!SolveBundle(robust, unknowns, options.max_iterations, kStartTolerance).failure.empty()) {
    robust.problem.reset();  // it points into `unknowns`
    unknowns = initial;
  }
}

// One least-squares adjustment without the `removed` observations, with its statistics;
// nullopt when it fails (result.status says why, with a refusal for a singular network).
std::optional<Adjustment> Adjust(const OrientationProblem& problem, const IndexedNetwork& network,
                                 const OrientationOptions& options, BundleUnknowns& unknowns,
                                 const std::set<ObservationKey>& removed,
                                 OrientationResult& result) {
  Adjustment a;
  a.bundle = BuildBundle(problem, network, unknowns, removed);
  a.solve = SolveBundle(a.bundle, unknowns, options.max_iterations);
  result.iterations += a.solve.iterations;
  ++result.adjustments;
  result.datum = a.bundle.datum;
  if (!a.solve.failure.empty()) {
    result.status = {SolveCode::kNonFinite, a.solve.failure};
    return std::nullopt;
  }
  SolveStatus failure;
  std::optional<Linearisation> lin = Linearise(a.bundle, unknowns, network, a.solve, failure);
  if (!lin) {
    if (failure.code == SolveCode::kDegenerate) result.refusals.push_back(failure.message);
    result.status = failure;
    return std::nullopt;
  }
  a.lin = std::move(*lin);
  result.levels = options.snooping.Levels(static_cast<int>(a.bundle.rows.size()));
  a.statistics = ResidualStatisticsOf(a.lin.jacobian, a.lin.residuals, a.lin.q, a.bundle.rows,
                                      result.levels.delta0);
  return a;
}

// Records a decision: what fails and stays (result.undecided), what goes (result.removed and
// `removed`). Returns whether anything was removed.
bool Apply(const OrientationProblem& problem, const Adjustment& a, const SnoopDecision& d,
           int round, int limit, std::set<ObservationKey>& removed, OrientationResult& result) {
  const std::vector<ResidualReport>& tested = a.statistics.residuals;
  result.undecided.clear();
  for (const auto& u : d.undecided) {
    UndecidedBlunder b{tested[u.candidate], u.why, {}};
    for (int t : u.twins) b.twins.push_back(tested[t]);
    result.undecided.push_back(b);
  }
  if (d.remove.empty()) return false;
  std::set<ObservationKey> now;
  for (int c : d.remove) now.insert({a.bundle.rows[c].kind, a.bundle.rows[c].source});
  if (static_cast<int>(removed.size() + now.size()) > limit) {
    result.removal_limit_reached = true;
    UndecidedBlunder b{tested[d.remove[0]], Undecided::kRemovalLimit, {}};
    for (size_t t = 1; t < d.remove.size(); ++t) b.twins.push_back(tested[d.remove[t]]);
    result.undecided.push_back(b);
    return false;
  }
  for (int c : d.remove) {
    const ResidualRow& row = a.bundle.rows[c];
    if (!removed.insert({row.kind, row.source}).second) continue;  // a control point's rows
    RemovedObservation r = RemovalOf(problem, row, tested[c], round);
    for (int t : d.remove) {
      const ResidualRow& other = a.bundle.rows[t];
      if (other.kind != row.kind || other.source != row.source)
        r.twins.push_back(std::string(KindName(other.kind)) + " " + other.label);
    }
    result.removed.push_back(r);
  }
  return true;
}

// Adjusts, tests every observation and removes the worst blunder, again and again, until
// none fails or what fails cannot be decided (reduction/data_snooping.h). The last
// adjustment is returned; nullopt when one fails.
std::optional<Adjustment> SnoopRounds(const OrientationProblem& problem,
                                      const IndexedNetwork& network,
                                      const OrientationOptions& options, BundleUnknowns& unknowns,
                                      std::set<ObservationKey> removed, OrientationResult& result) {
  int limit = 0;
  for (int round = 1;; ++round) {
    std::optional<Adjustment> a = Adjust(problem, network, options, unknowns, removed, result);
    if (!a) return a;
    if (round == 1) {
      limit = static_cast<int>(removed.size()) +
              std::max(1, static_cast<int>(options.max_removed_fraction *
                                           static_cast<double>(a->bundle.rows.size())));
    }
    if (!a->solve.converged) return a;  // residuals of no solution are not tested
    const SnoopDecision d = DecideOn(*a, options, result.levels);
    if (!Apply(problem, *a, d, round, limit, removed, result)) return a;
  }
}

// Readings the robust start misses by more than a tenth of a radian (6.4 gon), and lengths
// by more than a tenth of themselves: not errors of measurement but mistakes (a misread
// digit, a confused face, a wrong point), beyond what a least-squares adjustment, linear in
// its corrections, can weigh. They are set aside before it (kept ones excepted) with the
// tests they are nearly the same as (|ρ| ≥ kNearlyTheSameTest at the robust solution), for
// the robust start cannot tell them apart either: the innocent ones pass their own test
// afterwards and are put back (ConfirmGross). A mistake that cannot be set aside without
// leaving the network unchecked (reduction/data_snooping.h) stays in, and is said.
struct GrossMistakes {
  std::set<ObservationKey> aside;
  struct Stuck {
    ObservationKey key;
    Undecided why;
    std::vector<ObservationKey> twins;
  };
  std::vector<Stuck> stuck;  // found, but not to be set aside
};
GrossMistakes GrossAtRobustStart(const OrientationProblem& problem,
                                            const IndexedNetwork& network,
                                            const OrientationOptions& options,
                                            BundleUnknowns& unknowns) {
  constexpr double kGross = 0.1;
  std::vector<std::pair<double, ObservationKey>> gross;  // by how far beyond the bound
  auto check = [&](Kind kind, int index, double bound) {
    const double e = ObservedMinusPredicted(problem, network, unknowns, {kind, index});
    if (std::abs(e) > bound) gross.push_back({std::abs(e) / bound, {kind, index}});
  };
  for (const auto& o : network.obs) {
    if (options.keep.observations.count(o.source)) continue;
    check(Kind::kHz, o.source, kGross / kRadPerArcsec);
    check(Kind::kV, o.source, kGross / kRadPerArcsec);
    if (o.distance) check(Kind::kDistance, o.source, kGross * *o.distance);
  }
  for (size_t b = 0; b < problem.scale_bars.size(); ++b) {
    if (options.keep.scale_bars.count(static_cast<int>(b))) continue;
    check(Kind::kScaleBar, static_cast<int>(b), kGross * problem.scale_bars[b].length_mm);
  }
  if (gross.empty()) return {};
  std::sort(gross.begin(), gross.end(), [](const auto& x, const auto& y) { return x.first > y.first; });
  // The least-squares network linearised at the robust solution: its tests' correlations.
  Adjustment a;
  a.bundle = BuildBundle(problem, network, unknowns, {});
  a.solve.converged = true;
  SolveStatus failure;
  std::optional<Linearisation> lin = Linearise(a.bundle, unknowns, network, a.solve, failure);
  if (!lin) return {};  // the least-squares adjustment will say why
  a.lin = std::move(*lin);
  a.statistics =
      ResidualStatisticsOf(a.lin.jacobian, a.lin.residuals, a.lin.q, a.bundle.rows, 0.0);
  Tests tests(a, options.keep);
  std::map<ObservationKey, int> row_of;
  for (size_t r = 0; r < a.bundle.rows.size(); ++r)
    row_of.emplace(ObservationKey{a.bundle.rows[r].kind, a.bundle.rows[r].source}, static_cast<int>(r));
  GrossMistakes found;
  std::set<ObservationKey>& aside = found.aside;
  for (const auto& [beyond, key] : gross) {
    auto it = row_of.find(key);
    if (it == row_of.end() || aside.count(key)) continue;
    const int g = it->second;
    std::set<int> groups = {tests.candidates[g].group};
    for (int j = 0; j < static_cast<int>(tests.candidates.size()); ++j) {
      if (j != g && !tests.candidates[j].kept &&
          std::abs(tests.Correlation(g, j)) >= kNearlyTheSameTest)
        groups.insert(tests.candidates[j].group);
    }
    std::vector<ObservationKey> set;
    for (size_t r = 0; r < a.bundle.rows.size(); ++r) {
      if (groups.count(tests.candidates[r].group))
        set.push_back({a.bundle.rows[r].kind, a.bundle.rows[r].source});
    }
    if (auto why = WhyNotRemovable(tests.candidates, groups, a.dof(), options.snooping,
                                   tests.Function())) {
      std::erase(set, key);
      found.stuck.push_back({key, *why, set});
      continue;
    }
    aside.insert(set.begin(), set.end());
  }
  return found;
}

// Each set-aside observation tested from the final adjustment without it (its predicted
// residual: the w it would have there); those that pass are returned, to be put back.
std::set<ObservationKey> ConfirmGross(const OrientationProblem& problem,
                                      const IndexedNetwork& network, BundleUnknowns& unknowns,
                                      const Adjustment& a, const std::set<ObservationKey>& gross,
                                      OrientationResult& result) {
  std::set<ObservationKey> passed;
  std::vector<RemovedObservation> confirmed;
  for (const ObservationKey& key : gross) {
    const std::optional<PredictedTest> test =
        PredictedTestOf(problem, network, unknowns, a.lin, key);
    if (test && !(std::abs(test->w) > result.levels.critical_w)) {
      passed.insert(key);
      continue;
    }
    ResidualRow row{key.kind, key.index, "", 0.0, ""};
    const ObservationKey k = key;
    for (const auto& o : network.obs) {
      if (o.source == k.index && k.kind != Kind::kScaleBar)
        row.label = network.station_ids[o.station] + "->" + o.point;
    }
    if (key.kind == Kind::kScaleBar) {
      row.label = problem.scale_bars[key.index].from + ":" + problem.scale_bars[key.index].to;
    }
    ResidualReport tested;
    tested.w = test ? test->w : std::nan("");
    tested.redundancy = test ? test->redundancy : std::nan("");
    confirmed.push_back(RemovalOf(problem, row, tested, 0));
  }
  result.removed.insert(result.removed.begin(), confirmed.begin(), confirmed.end());
  return passed;
}

// Mistakes the robust start found but could not set aside, and snooping did not remove
// either: said, with what they cannot be told from (a least-squares adjustment with them is
// far outside its linear range). When the adjustment failed, its status names them.
void SayStuckMistakes(const OrientationProblem& problem, const GrossMistakes& gross,
                      const std::optional<Adjustment>& a, OrientationResult& result) {
  std::string named;
  auto report_of = [&](const ObservationKey& key) -> const ResidualReport* {
    for (size_t r = 0; a && r < a->bundle.rows.size(); ++r)
      if (a->bundle.rows[r].kind == key.kind && a->bundle.rows[r].source == key.index)
        return &a->statistics.residuals[r];
    return nullptr;  // removed, or no adjustment
  };
  for (const auto& stuck : gross.stuck) {
    named += std::string(named.empty() ? "" : "; ") + KindName(stuck.key.kind) + " " +
             (stuck.key.kind == Kind::kScaleBar
                  ? problem.scale_bars[stuck.key.index].from + ":" +
                        problem.scale_bars[stuck.key.index].to
                  : problem.observations[stuck.key.index].station + "->" +
                        problem.observations[stuck.key.index].point);
    const ResidualReport* self = report_of(stuck.key);
    if (!self || !(std::abs(self->w) > result.levels.critical_w)) continue;
    bool said = false;
    for (const auto& u : result.undecided)
      said |= u.observation.kind == self->kind && u.observation.observation == self->observation;
    if (said) continue;
    UndecidedBlunder b{*self, stuck.why, {}};
    for (const auto& twin : stuck.twins)
      if (const ResidualReport* t = report_of(twin)) b.twins.push_back(*t);
    result.undecided.push_back(b);
  }
  if (!a && !named.empty()) {
    result.refusals.clear();  // not a datum defect: the mistakes carry the adjustment away
    result.status = {SolveCode::kNotConverged,
                     "the adjustment fails with mistakes in it that cannot be told from other "
                     "readings (" + named + "): correct or remove them"};
  }
}

}  // namespace

// The robust start, the gross mistakes set aside, data snooping on the rest, and the
// set-aside ones confirmed by their own test (one that passes is put back and the
// snooping repeated).
std::optional<Adjustment> AdjustWithSnooping(const OrientationProblem& problem,
                                             const IndexedNetwork& network,
                                             const OrientationOptions& options,
                                             BundleUnknowns& unknowns, OrientationResult& result) {
  GrossMistakes gross;
  // Testing only: one least-squares adjustment, as it was. Initial values that every reading
  // fits within kStartOutlierRad need no robust start either.
  if (options.snooping.reject && SomeReadingMisses(problem, network, unknowns)) {
    RobustStart(problem, network, options, unknowns);
    gross = GrossAtRobustStart(problem, network, options, unknowns);
  }
  const BundleUnknowns start = unknowns;
  const size_t refusals = result.refusals.size();
  std::set<ObservationKey>& aside = gross.aside;
  for (int attempt = 0;; ++attempt) {
    result.removed.clear();
    result.undecided.clear();
    result.removal_limit_reached = false;
    result.status = {};
    result.refusals.resize(refusals);
    std::optional<Adjustment> a = SnoopRounds(problem, network, options, unknowns, aside, result);
    std::set<ObservationKey> put_back;
    if (a) put_back = ConfirmGross(problem, network, unknowns, *a, aside, result);
    if ((a && put_back.empty()) || (!a && aside.empty()) || attempt > 8) {
      SayStuckMistakes(problem, gross, a, result);
      return a;
    }
    // Without them the network is singular, or one is no blunder: adjust with it again.
    a.reset();  // its problem points into `unknowns`
    unknowns = start;
    if (put_back.empty()) aside.clear();
    for (const auto& key : put_back) aside.erase(key);
  }
}

}  // namespace armsig::reduction
