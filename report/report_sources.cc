#include "report/report_sources.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <map>
#include <nlohmann/json.hpp>

#include "acquisition/lab.h"
#include "calibration/identifiability.h"
#include "core/error.h"
#include "db/calibrations.h"
#include "db/report_queries.h"
#include "report/report_statistics.h"
#include "workflows/signature.h"

namespace armsig::report {

std::vector<ReportHistoryPoint> ReportHistoryOf(db::Database& db, int64_t robot_id) {
  std::vector<ReportHistoryPoint> out;
  const auto activations = db::ActivationHistory(db, robot_id);
  for (const auto& h : db::CalibrationHistory(db, robot_id)) {
    ReportHistoryPoint point{h.version, h.created_at, h.validation_mean_mm, h.params_spec,
                             h.active};
    const auto drift =
        nlohmann::json::parse(h.drift_json.empty() ? "null" : h.drift_json, nullptr, false);
    point.drift = drift.is_object() && drift.contains("flag") && drift["flag"].is_boolean() &&
                  drift["flag"].get<bool>();
    for (const auto& a : activations) {
      if (a.version == h.version) point.activations.push_back({a.activated_at, a.activated_by});
    }
    out.push_back(std::move(point));
  }
  return out;
}

ReportDrift ReportDriftOf(db::Database& db, const calibration::RobotModel& model, int64_t robot_id,
                          double tolerance_mm) {
  ReportDrift out;
  out.tolerance_mm = tolerance_mm;
  const auto spread = calibration::SpreadConfigurations(model, kReportDriftConfigurations);
  out.configurations = static_cast<int>(spread.size());
  const auto history = db::CalibrationHistory(db, robot_id);
  std::map<int, const db::StoredCalibration*> by_version;
  for (const auto& c : history) by_version[c.version] = &c;
  const db::StoredCalibration* previous = nullptr;
  for (const auto& c : history) {
    // Against the set its drift decision named (the one active before it), else the
    // version before it.
    const auto decision =
        nlohmann::json::parse(c.drift_json.empty() ? "null" : c.drift_json, nullptr, false);
    const db::StoredCalibration* against = previous;
    if (decision.is_object() && decision.contains("against") &&
        decision["against"].is_number_integer()) {
      const auto it = by_version.find(decision["against"].get<int>());
      if (it != by_version.end()) against = it->second;
    }
    previous = &c;
    if (!against) continue;
    try {
      ReportDriftPoint point =
          DriftPointOf(model, FittedSetOf(model, workflows::SignatureOf(model, *against), *against),
                       FittedSetOf(model, workflows::SignatureOf(model, c), c), spread);
      point.version = c.version;
      point.against = against->version;
      point.drift = decision.is_object() && decision.contains("flag") &&
                    decision["flag"].is_boolean() && decision["flag"].get<bool>();
      out.points.push_back(point);
    } catch (const InputError& e) {
      // A set of another model (the robot's model file changed): not comparable.
      spdlog::debug("report: version {} against {} not compared: {}", c.version, against->version,
                    e.what());
    }
  }
  return out;
}

namespace {
// The sessions with their fitted and validated pose counts: dates, the instruments of
// their stored lab files and of the instruments table, their stations' latest set-ups.
ReportSources LoadSessionSources(db::Database& db,
                                 const std::map<int64_t, std::pair<int, int>>& counts);
}  // namespace

ReportSources LoadReportSources(db::Database& db, const workflows::CalibrationRun& run) {
  // Pose ids are "<session>:<label>" (db::LoadRobotPoses).
  std::map<int64_t, std::pair<int, int>> counts;  // session → fitted, validated
  auto count = [&](const std::vector<std::string>& ids, bool fit) {
    for (const auto& id : ids) {
      const auto colon = id.find(':');
      if (colon == std::string::npos || colon == 0) continue;
      int64_t session = 0;
      try {
        session = std::stoll(id.substr(0, colon));
      } catch (const std::exception&) {
        continue;  // not a stored pose id
      }
      (fit ? counts[session].first : counts[session].second)++;
    }
  };
  count(run.fit_pose_ids, true);
  count(run.validation_pose_ids, false);
  return LoadSessionSources(db, counts);
}

ReportSources LoadReportSources(db::Database& db, const std::vector<int64_t>& session_ids) {
  std::map<int64_t, std::pair<int, int>> counts;
  for (int64_t id : session_ids) counts[id] = {0, 0};
  return LoadSessionSources(db, counts);
}

namespace {

ReportSources LoadSessionSources(db::Database& db,
                                 const std::map<int64_t, std::pair<int, int>>& counts) {
  ReportSources out;
  std::vector<int64_t> ids;
  for (const auto& [id, c] : counts) ids.push_back(id);

  std::map<std::pair<std::string, std::string>, std::vector<int64_t>> instruments;
  for (const auto& s : db::LoadReportSessions(db, ids)) {
    const auto [fitted, validated] = counts.at(s.id);
    out.sessions.push_back(
        {s.id, s.started_at, s.finished_at, db::ToString(s.state), s.note, fitted, validated});
    // Each instrument once: what the lab file said of a station (protocol, port, sigmas) and
    // what the instrument said of itself when it stood there (name, serial, firmware) are
    // one line, "station LT1: AT960 391234".
    std::map<std::string, std::string> by_station;  // the lab file's, by station code
    if (!s.lab_yaml.empty()) {
      try {
        const auto lab = io::StoredLabSettings(s.lab_yaml, s.id, db.path());
        for (const auto& i : lab ? lab->instruments : std::vector<io::InstrumentConfig>{}) {
          std::string d = io::NameOf(i.protocol) + (i.tcp ? " over " + i.tcp->Text() : " on " + i.port);
          if (i.protocol == io::InstrumentProtocol::kEmScon) {
            // A laser tracker's readings carry their own sigmas, which take the place of
            // any a-priori ones.
            d += fmt::format(", laser tracker, stationary mode {} ms; sigmas: each reading's own",
                             i.measurement_time_ms);
          } else {
            d += fmt::format(", sigma hz {:g}\" v {:g}\"", i.sigma_hz_arcsec, i.sigma_v_arcsec);
            if (i.distance) d += fmt::format(", distances (sigma {:g} mm)", i.sigma_distance_mm);
          }
          by_station[i.station] = d;
        }
      } catch (const InputError& e) {
        spdlog::warn("report: session {}: its stored lab file cannot be read: {}", s.id, e.what());
        instruments[{"session " + std::to_string(s.id), "lab file unreadable"}].push_back(s.id);
      }
    }
    for (const auto& i : db::SessionInstruments(db, s.id)) {
      std::string d;
      for (const auto& station : i.stations) {
        const auto lab = by_station.find(station);
        if (lab == by_station.end() || !d.empty()) continue;
        d = lab->second;
        by_station.erase(lab);
      }
      const bool from_lab = !d.empty();
      if (!from_lab) d = i.kind + ", " + i.protocol;
      if (!i.serial_number.empty()) d += ", serial " + i.serial_number;
      if (!i.firmware.empty()) d += ", firmware " + i.firmware;
      if (!from_lab && i.sigma_hz_arcsec && i.sigma_v_arcsec)
        d += fmt::format(", sigma hz {:g}\" v {:g}\"", *i.sigma_hz_arcsec, *i.sigma_v_arcsec);
      if (!from_lab && i.sigma_distance_mm)
        d += fmt::format(", sigma distance {:g} mm", *i.sigma_distance_mm);
      std::string label;
      for (const auto& station : i.stations) label += (label.empty() ? "station " : ", ") + station;
      label += (label.empty() ? "" : ": ") + i.name;
      instruments[{label, d}].push_back(s.id);
    }
    for (const auto& [station, d] : by_station) {  // stations the session never read from
      instruments[{"station " + station, d}].push_back(s.id);
    }
    for (const auto& [station, setup] : db::LatestStationSetups(db, s.id)) {
      out.setups.push_back({s.id, station, setup.sigma0, setup.dof, setup.method});
    }
  }
  for (const auto& [key, sessions] : instruments) {
    out.instruments.push_back({key.first, key.second, sessions});
  }
  return out;
}

}  // namespace

}  // namespace armsig::report
