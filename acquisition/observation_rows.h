// The one place where reduction's values become database rows and back: observations,
// station set-ups and reduced points, as capture, `reduce` and `import observations`
// store and read them.
#pragma once

#include <optional>
#include <string>

#include "db/observations.h"
#include "reduction/intersection.h"
#include "reduction/observation.h"

namespace armsig::acquisition {

db::ObservationRow ObservationRowOf(const reduction::Observation& o, std::optional<int64_t> pose_id,
                                    int return_code = 0);
reduction::Observation ObservationOf(const db::ObservationRow& row);

// `method`: how the set-up was obtained ("lab", "file", "orient").
db::StationSetupRow StationSetupRowOf(const reduction::Station& station, const std::string& method);
reduction::Station StationOf(const db::StationSetupRow& row);

// A reduced point's row: position, covariance, σ0 (when there is redundancy) and miss
// only when the solve succeeded; flags always.
db::PointRow PointRowOf(std::optional<int64_t> pose_id, const std::string& point, int rays,
                        const reduction::IntersectionResult& result, reduction::PointFlags flags);

}  // namespace armsig::acquisition
