// The adjustment of the orientation made blunder-proof: the robust start, the gross
// mistakes set aside, then least-squares adjustments repeated by data snooping
// (reduction/data_snooping.h) until no observation fails or what fails cannot be decided.
// Internal to Orient.
#pragma once

#include <optional>

#include "reduction/adjustment_statistics.h"
#include "reduction/orientation.h"
#include "reduction/orientation_bundle.h"
#include "reduction/orientation_network.h"

namespace armsig::reduction {

// One adjustment with its statistics.
struct Adjustment {
  Bundle bundle;
  BundleSolve solve;
  Linearisation lin;
  ResidualStatistics statistics;
  int dof() const { return static_cast<int>(bundle.rows.size()) - static_cast<int>(lin.q.rows()); }
};

// The last adjustment, its removals and undecided observations in `result`; nullopt when an
// adjustment fails (result.status says why, with a refusal for a singular network).
// `unknowns` start at the initial values and end at the solution.
std::optional<Adjustment> AdjustWithSnooping(const OrientationProblem& problem,
                                             const IndexedNetwork& network,
                                             const OrientationOptions& options,
                                             BundleUnknowns& unknowns, OrientationResult& result);

}  // namespace armsig::reduction
