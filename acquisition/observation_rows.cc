#include "acquisition/observation_rows.h"

#include <limits>

namespace armsig::acquisition {

namespace {

// The fields an observation and its row share, named alike: one list for both directions.
template <typename From, typename To>
void CopyObservation(const From& from, To& to) {
  to.point = from.point;
  to.station = from.station;
  to.reading = from.reading;
  to.distance_mm = from.distance_mm;
  to.sigma_hz_rad = from.sigma_hz_rad;
  to.sigma_v_rad = from.sigma_v_rad;
  to.sigma_distance_mm = from.sigma_distance_mm;
}

}  // namespace

db::ObservationRow ObservationRowOf(const reduction::Observation& o, std::optional<int64_t> pose_id,
                                    int return_code) {
  db::ObservationRow row;
  row.pose_id = pose_id;
  CopyObservation(o, row);
  row.return_code = return_code;
  return row;
}

reduction::Observation ObservationOf(const db::ObservationRow& row) {
  reduction::Observation o;
  CopyObservation(row, o);
  return o;
}

db::StationSetupRow StationSetupRowOf(const reduction::Station& station,
                                      const std::string& method) {
  db::StationSetupRow row;
  row.station = station.pose.id;
  row.pose = station.pose;
  row.sigma_position_mm = station.sigma_position_mm;
  row.sigma_azimuth_rad = station.sigma_azimuth_rad;
  row.sigma_hz_rad = station.sigma_hz_rad;
  row.sigma_v_rad = station.sigma_v_rad;
  // How the station was oriented, when the stations file says (armsig orient writes it).
  row.method = station.orientation_method.empty() ? method : station.orientation_method;
  row.sigma0 = station.orientation_sigma0;
  row.dof = station.orientation_dof;
  return row;
}

reduction::Station StationOf(const db::StationSetupRow& row) {
  reduction::Station station;
  station.pose = row.pose;
  station.sigma_hz_rad = row.sigma_hz_rad;
  station.sigma_v_rad = row.sigma_v_rad;
  station.sigma_position_mm = row.sigma_position_mm;
  station.sigma_azimuth_rad = row.sigma_azimuth_rad;
  if (row.sigma0) {
    station.orientation_sigma0 = row.sigma0;
    station.orientation_dof = row.dof;
    station.orientation_method = row.method;
  }
  return station;
}

db::PointRow PointRowOf(std::optional<int64_t> pose_id, const std::string& point, int rays,
                        const reduction::IntersectionResult& result, reduction::PointFlags flags) {
  db::PointRow row;
  row.pose_id = pose_id;
  row.point = point;
  row.rays = rays;
  row.flags = reduction::ToString(flags);
  if (result.status.ok()) {
    row.position_mm = result.position_mm;
    row.covariance_mm2 = result.covariance_mm2;
    row.rejected_rays = result.rejected;
    row.sigma0 = result.dof > 0 ? result.sigma0 : std::numeric_limits<double>::quiet_NaN();
    row.miss_mm = result.max_miss_mm;
  }
  return row;
}

}  // namespace armsig::acquisition
