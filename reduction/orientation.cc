#include "reduction/orientation.h"

#include <ceres/rotation.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "core/units.h"
#include "reduction/adjustment_statistics.h"
#include "reduction/observation.h"
#include "reduction/orientation_bundle.h"
#include "reduction/orientation_initial.h"
#include "reduction/orientation_network.h"

namespace armsig::reduction {

void OrientationOptions::Check() const {
  if (max_iterations < 1) throw std::invalid_argument("max_iterations must be ≥ 1");
  snooping.Check();
  if (!(max_removed_fraction >= 0 && max_removed_fraction <= 1))
    throw std::invalid_argument("max_removed_fraction must lie in [0, 1]");
}

const char* KindName(ResidualReport::Kind kind) {
  static const char* kNames[] = {"Hz", "V", "distance", "scale bar", "control"};
  return kNames[static_cast<int>(kind)];
}

namespace {

using Kind = ResidualReport::Kind;

// The network cannot be solved: status kDegenerate naming every refusal.
OrientationResult& Refused(OrientationResult& result) {
  std::string why;
  for (const auto& r : result.refusals) why += (why.empty() ? "" : "; ") + r;
  result.status = {SolveCode::kDegenerate, why};
  return result;
}

// Approximate values the adjustment can start from: finite, and no station on a point it
// sights (a direction to itself has no derivative; it would fail at the first step).
void RefuseUnusableStart(const IndexedNetwork& network, const InitialValues& initial,
                         std::vector<std::string>& refusals) {
  constexpr double kCoincidentMm = 1e-6;
  const std::vector<StationState>& st = initial.stations;
  for (size_t i = 0; i < st.size(); ++i) {
    if (!st[i].position.allFinite() || !std::isfinite(st[i].azimuth) ||
        !st[i].angle_axis.allFinite()) {
      refusals.push_back("station " + network.station_ids[i] +
                         ": no finite approximate pose from its rays");
    }
  }
  for (const auto& o : network.obs) {
    const Eigen::Vector3d* target = nullptr;
    if (o.target_station >= 0) {
      target = &st[o.target_station].position;
    } else if (auto it = initial.points.find(o.point); it != initial.points.end()) {
      target = &it->second;
    }
    if (target &&
        (!target->allFinite() || (*target - st[o.station].position).norm() <= kCoincidentMm)) {
      refusals.push_back("station " + network.station_ids[o.station] + " and " +
                         (o.target_station >= 0 ? "station " : "point ") + o.point +
                         " get the same approximate position: the observations do not place "
                         "them apart (repeated or contradictory sightings?)");
      return;
    }
  }
}

// One adjustment with its statistics.
struct Adjustment {
  Bundle bundle;
  BundleSolve solve;
  Linearisation lin;
  ResidualStatistics statistics;
  int dof() const { return static_cast<int>(bundle.rows.size()) - static_cast<int>(lin.q.rows()); }
};

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

// The robust start, the gross mistakes set aside, data snooping on the rest, and the
// set-aside ones confirmed by their own test (one that passes is put back and the
// snooping repeated).
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

// Free network: the covariance S-transformed to the inner-constraint datum.
void ToFreeDatum(const OrientationProblem& problem, const IndexedNetwork& network,
                 const BundleUnknowns& u, Linearisation& lin, OrientationResult& result) {
  using DatumKind = DatumBlock::Kind;
  std::vector<DatumBlock> all;
  for (size_t i = 0; i < u.station_pos.size(); ++i) {
    const std::string& id = network.station_ids[i];
    all.push_back({u.station_pos[i].data(), 3, DatumKind::kPosition, id});
    all.push_back({u.station_rot[i].data(), u.levelled[i] ? 1 : 3,
                   u.levelled[i] ? DatumKind::kAzimuth : DatumKind::kAngleAxis, id});
  }
  for (size_t k = 0; k < u.point_ids.size(); ++k)
    all.push_back({u.point_pos[k].data(), 3, DatumKind::kPosition, u.point_ids[k]});
  const int count = InnerConstraintCovariance(all, problem.datum_points, lin.q, lin.column_of);
  if (count >= 2) {
    result.datum += "; covariance by inner constraints over " +
                    (problem.datum_points.empty() ? std::string("all points and stations")
                                                  : std::to_string(count) + " datum points");
  }
}

// Stations and points back in the input frame, with their precisions; the status says
// whether every estimate is finite and the last adjustment converged.
void Results(const IndexedNetwork& network, const BundleUnknowns& u, const Adjustment& a,
             OrientationResult& result) {
  const Eigen::MatrixXd& q = a.lin.q;
  for (size_t i = 0; i < u.station_pos.size(); ++i) {
    Station s = network.station_info[i];
    s.pose.levelled = u.levelled[i];
    s.pose.position_mm = u.station_pos[i] + u.offset;
    if (u.levelled[i]) {
      s.pose.azimuth_rad = WrapTwoPi(u.station_rot[i](0));
      s.pose.world_from_station = LevelledRotation(s.pose.azimuth_rad);
    } else {
      double r[9];
      ceres::AngleAxisToRotationMatrix(u.station_rot[i].data(), ceres::ColumnMajorAdapter3x3(r));
      s.pose.world_from_station = Eigen::Map<Eigen::Matrix3d>(r);
    }
    if (auto it = a.lin.column_of.find(u.station_pos[i].data()); it != a.lin.column_of.end()) {
      for (int k = 0; k < 3; ++k) s.sigma_position_mm(k) = std::sqrt(q(it->second + k, it->second + k));
    }
    if (auto it = a.lin.column_of.find(u.station_rot[i].data()); it != a.lin.column_of.end()) {
      if (u.levelled[i])
        s.sigma_azimuth_rad = std::sqrt(q(it->second, it->second));
      else
        for (int k = 0; k < 3; ++k)
          s.sigma_rotation_rad(k) = std::sqrt(q(it->second + k, it->second + k));
    }
    result.stations.push_back(s);
  }
  for (size_t k = 0; k < u.point_ids.size(); ++k) {
    PointEstimate p;
    p.id = u.point_ids[k];
    p.position_mm = u.point_pos[k] + u.offset;
    p.rays = static_cast<int>(network.rays_of_point.at(p.id).size());
    p.control = network.control.count(p.id) > 0;
    if (auto it = a.lin.column_of.find(u.point_pos[k].data()); it != a.lin.column_of.end())
      p.covariance_mm2 = q.block<3, 3>(it->second, it->second);
    result.points.push_back(p);
  }
  // A solve with any non-finite estimate never reports ok.
  bool finite = std::isfinite(result.sigma0);
  for (const auto& s : result.stations) {
    finite = finite && s.pose.position_mm.allFinite() && s.pose.world_from_station.allFinite() &&
             s.sigma_position_mm.allFinite() && std::isfinite(s.sigma_azimuth_rad) &&
             s.sigma_rotation_rad.allFinite();
  }
  for (const auto& p : result.points)
    finite = finite && p.position_mm.allFinite() && p.covariance_mm2.allFinite();
  if (!finite) {
    result.status = {SolveCode::kNonFinite, "an estimate or its precision is not finite"};
  } else if (!a.solve.converged) {
    result.status = {SolveCode::kNotConverged,
                     "not converged after " + std::to_string(result.iterations) + " iterations"};
  }
}

}  // namespace

// The procedure: index the problem and refuse what cannot be solved, initial values
// (orientation_initial.cc), the adjustment (orientation_bundle.cc) repeated by data
// snooping, the statistics (adjustment_statistics.cc), the free-network covariance when
// asked, and the results in the input frame.
OrientationResult Orient(const OrientationProblem& problem, const OrientationOptions& options) {
  options.Check();
  OrientationResult result;
  const IndexedNetwork network = IndexNetwork(problem, result.refusals);
  RefuseUnsolvable(problem, network, result.refusals);
  if (!result.refusals.empty()) return Refused(result);

  const std::optional<InitialValues> initial =
      FindInitialValues(problem, network, result.refusals);
  if (!initial) return Refused(result);
  RefuseUnusableStart(network, *initial, result.refusals);
  if (!result.refusals.empty()) return Refused(result);
  BundleUnknowns unknowns = UnknownsFrom(network, *initial, result.excluded_points);

  std::optional<Adjustment> adjusted =
      AdjustWithSnooping(problem, network, options, unknowns, result);
  if (!adjusted) return result;
  Adjustment& a = *adjusted;
  result.observations = static_cast<int>(a.bundle.rows.size());
  result.unknowns = static_cast<int>(a.lin.q.rows());
  result.dof = a.dof();
  double vtpv = 0.0;
  for (double r : a.lin.residuals) vtpv += r * r;
  result.sigma0 = result.dof > 0 ? std::sqrt(vtpv / result.dof) : 0.0;
  result.residuals = a.statistics.residuals;
  result.groups = a.statistics.groups;
  for (auto& r : result.removed) {
    r.error = ObservedMinusPredicted(problem, network, unknowns, {r.kind, r.observation});
  }
  if (problem.free_datum && !network.use_control) ToFreeDatum(problem, network, unknowns, a.lin, result);
  Results(network, unknowns, a, result);
  return result;
}

}  // namespace armsig::reduction
