#include "acquisition/station_reading.h"

#include <fmt/format.h>

#include <cmath>

#include "acquisition/observation_rows.h"
#include "core/units.h"

namespace armsig::acquisition {

bool UsableSigmas(const std::optional<instruments::ReadingSigmas>& s) {
  return s && std::isfinite(s->hz_rad) && std::isfinite(s->v_rad) &&
         std::isfinite(s->distance_mm) && s->hz_rad > 0.0 && s->v_rad > 0.0 && s->distance_mm > 0.0;
}

reduction::Observation TargetObservation(const StationReading& r, const io::InstrumentConfig& c) {
  reduction::Observation o;
  o.point = "target";
  o.station = c.station;
  o.reading = r.reading.angles;
  o.distance_mm = r.reading.distance_mm;
  o.sigma_hz_rad = c.sigma_hz_arcsec * kRadPerArcsec;
  o.sigma_v_rad = c.sigma_v_arcsec * kRadPerArcsec;
  o.sigma_distance_mm = c.sigma_distance_mm;
  if (UsableSigmas(r.reading.sigma)) {
    o.sigma_hz_rad = r.reading.sigma->hz_rad;
    o.sigma_v_rad = r.reading.sigma->v_rad;
    o.sigma_distance_mm = r.reading.sigma->distance_mm;
  }
  return o;
}

db::ObservationRow StoredReading(const StationReading& r, const io::InstrumentConfig& c,
                                 int64_t pose, int64_t instrument_id) {
  db::ObservationRow row = ObservationRowOf(TargetObservation(r, c), pose, r.reading.return_code);
  if (const auto& air = r.reading.environment) {
    row.temperature_c = air->temperature_c;
    row.pressure_hpa = air->pressure_hpa;
    row.humidity_percent = air->humidity_percent;
  }
  if (r.reading.time.time_since_epoch().count() > 0) {
    row.measured_at = db::MeasuredAt(r.reading.time);
  }
  row.note = r.reading.note;
  row.instrument_id = instrument_id;
  return row;
}

db::InstrumentRow InstrumentRowOf(const io::InstrumentConfig& c,
                                  const instruments::DeviceInfo& who) {
  db::InstrumentRow row;
  const bool tracker = c.protocol == io::InstrumentProtocol::kEmScon;
  row.protocol = io::NameOf(c.protocol);
  row.port = c.Where();
  row.kind = tracker ? "laser_tracker" : c.distance ? "total_station" : "theodolite";
  row.serial_number = who.serial;
  row.firmware = who.firmware;
  const std::string model = who.name.empty() ? row.protocol : who.name;
  row.name = who.serial.empty() ? fmt::format("{} at {}", model, row.port)
                                : fmt::format("{} {}", model, who.serial);
  // A laser tracker's readings carry their own sigmas, which take the place of a-priori ones.
  if (!tracker) {
    row.sigma_hz_arcsec = c.sigma_hz_arcsec;
    row.sigma_v_arcsec = c.sigma_v_arcsec;
    if (c.distance) row.sigma_distance_mm = c.sigma_distance_mm;
  }
  return row;
}

}  // namespace armsig::acquisition
