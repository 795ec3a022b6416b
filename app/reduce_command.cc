// armsig reduce [--session ID]: batch reduction of stored raw observations into reduced
// points, one transaction per session, idempotent (a rerun replaces the points).
// armsig import observations OBS.csv --stations STATIONS.yaml: a file into a new session.
#include "app/reduce_command.h"

#include <fmt/format.h>

#include <iostream>
#include <map>

#include "app/command.h"
#include "core/error.h"
#include "db/database.h"
#include "db/store.h"
#include "io/csv.h"
#include "io/network_io.h"
#include "reduction/intersection.h"

namespace armsig::app {

ReduceSummary ReduceSession(db::Database& database, int64_t session_id,
                            const reduction::IntersectionOptions& options) {
  ReduceSummary summary;
  summary.session = session_id;
  const auto setups = db::LatestStationSetups(database, session_id);
  const auto observations = db::LoadObservations(database, session_id);
  summary.observations = static_cast<int64_t>(observations.size());
  reduction::InstrumentDefaults defaults;
  std::vector<db::PointRow> points;
  std::vector<reduction::Ray> rays;
  reduction::IntersectionResult result;
  size_t begin = 0;
  while (begin < observations.size()) {
    size_t end = begin;
    const auto& first = observations[begin];
    while (end < observations.size() && observations[end].pose_id == first.pose_id &&
           observations[end].point == first.point) {
      ++end;
    }
    if (setups.count(first.point)) {  // a mutual pointing at a station: not a target
      begin = end;
      continue;
    }
    rays.clear();
    for (size_t k = begin; k < end; ++k) {
      const auto& o = observations[k];
      auto it = setups.find(o.station);
      if (it == setups.end()) {
        throw InputError({"session " + std::to_string(session_id), 0, 0, ""},
                         "station " + o.station + " has no set-up (orient it first)");
      }
      reduction::Observation obs;
      obs.sigma_hz_rad = o.sigma_hz_rad;
      obs.sigma_v_rad = o.sigma_v_rad;
      obs.sigma_distance_mm = o.sigma_distance_mm;
      reduction::Station station;
      station.sigma_hz_rad = it->second.sigma_hz_rad;
      station.sigma_v_rad = it->second.sigma_v_rad;
      const auto sigma = reduction::SigmasOf(obs, &station, defaults);
      reduction::Ray ray;
      ray.station_mm = it->second.pose.position_mm;
      ray.world_from_station = it->second.pose.world_from_station;
      ray.reading = o.reading;
      ray.distance_mm = o.distance_mm ? *o.distance_mm : std::numeric_limits<double>::quiet_NaN();
      ray.sigma_hz_rad = sigma.hz_rad;
      ray.sigma_v_rad = sigma.v_rad;
      ray.sigma_distance_mm = sigma.distance_mm;
      rays.push_back(ray);
    }
    reduction::Intersect(rays, options, result);
    db::PointRow row;
    row.pose_id = first.pose_id;
    row.point = first.point;
    row.rays = static_cast<int>(rays.size());
    if (result.status == reduction::IntersectionStatus::kOk) {
      row.position_mm = result.position_mm;
      row.covariance_mm2 = result.covariance_mm2;
      row.rejected_rays = result.rejected;
      row.sigma0 = result.dof > 0 ? result.sigma0 : std::numeric_limits<double>::quiet_NaN();
      row.miss_mm = result.max_miss_mm;
      row.flags = result.rejected ? "blunder_rejected"
                                  : (result.blunder_suspected ? "blunder_suspected" : "");
      ++summary.reduced;
      summary.rejected_rays += result.rejected;
    } else {
      row.flags = reduction::ToString(result.status);
      ++summary.failed;
    }
    points.push_back(std::move(row));
    begin = end;
  }
  SQLite::Transaction tx(database.sql());
  db::ReplacePoints(database, session_id, points);
  tx.commit();
  return summary;
}

struct ReduceOptions {
  int64_t session = 0;  // 0 = every session
  bool no_reject = false;
};

int RunReduce(const ReduceOptions& options, const GlobalOptions& global) {
  db::Database database(global.DbPath());
  std::vector<int64_t> sessions;
  if (options.session > 0) {
    if (!db::SessionExists(database, options.session)) {
      throw InputError({database.path(), 0, 0, ""},
                       "no session " + std::to_string(options.session) + " in the database");
    }
    sessions.push_back(options.session);
  } else {
    sessions = db::SessionIds(database);
  }
  reduction::IntersectionOptions intersection;
  intersection.reject_blunders = !options.no_reject;
  for (int64_t id : sessions) {
    const auto s = ReduceSession(database, id, intersection);
    std::cout << fmt::format(
        "session {}: {} observations -> {} points reduced, {} not ({} rays "
        "rejected as blunders)\n",
        id, s.observations, s.reduced, s.failed, s.rejected_rays);
  }
  if (sessions.empty()) std::cout << "no sessions in " << database.path() << "\n";
  return kOk;
}

struct ImportObservationsOptions {
  std::string file, stations, robot = "unassigned", note;
};

int RunImportObservations(const ImportObservationsOptions& options, const GlobalOptions& global) {
  const auto stations = io::ReadStationsYaml(options.stations);
  const auto observations = io::ReadObservationsCsv(options.file);
  // Optional pose column groups rows into robot configurations.
  const io::CsvTable table = io::ReadCsvFile(options.file);
  const auto pose_column = table.FindColumn("pose");
  std::map<std::string, const reduction::Station*> by_id;
  for (const auto& s : stations) by_id[s.pose.id] = &s;
  for (const auto& o : observations) {
    if (!by_id.count(o.station)) {
      throw InputError({options.file, o.source_line, 0, "station"},
                       "station '" + o.station + "' is not in " + options.stations);
    }
  }
  db::Database database(global.DbPath());
  SQLite::Transaction tx(database.sql());
  const int64_t robot = db::EnsureRobot(database, options.robot, "", "");
  const int64_t session =
      db::CreateSession(database, robot, "", "", "completed",
                        options.note.empty() ? "imported from " + options.file : options.note);
  for (const auto& s : stations) {
    db::StationSetupRow row;
    row.station = s.pose.id;
    row.pose = s.pose;
    row.sigma_position_mm = s.sigma_position_mm;
    row.sigma_azimuth_rad = s.sigma_azimuth_rad;
    row.sigma_hz_rad = s.sigma_hz_rad;
    row.sigma_v_rad = s.sigma_v_rad;
    row.method = "file";
    db::InsertStationSetup(database, session, row);
  }
  std::map<std::string, int64_t> pose_ids;
  std::vector<db::ObservationRow> rows;
  rows.reserve(observations.size());
  for (size_t k = 0; k < observations.size(); ++k) {
    const auto& o = observations[k];
    db::ObservationRow r;
    if (pose_column) {
      const std::string& label = table.Text(table.rows()[k], *pose_column);
      auto it = pose_ids.find(label);
      if (it == pose_ids.end()) {
        it =
            pose_ids
                .emplace(label, db::InsertPose(database, session, static_cast<int>(pose_ids.size()),
                                               label, std::nullopt, "measured", 1))
                .first;
      }
      r.pose_id = it->second;
    }
    r.point = o.point;
    r.station = o.station;
    r.reading = o.reading;
    r.distance_mm = o.distance_mm;
    r.sigma_hz_rad = o.sigma_hz_rad;
    r.sigma_v_rad = o.sigma_v_rad;
    r.sigma_distance_mm = o.sigma_distance_mm;
    rows.push_back(r);
  }
  db::InsertObservations(database, session, rows);
  tx.commit();
  std::cout << fmt::format("session {}: {} observations, {} stations, {} poses imported into {}\n",
                           session, rows.size(), stations.size(), pose_ids.size(), database.path());
  return kOk;
}

void SetupReduceCommand(CLI::App& parent, const GlobalOptions& global, Runner& run) {
  auto o = std::make_shared<ReduceOptions>();
  auto* sub = parent.add_subcommand(
      "reduce", "Reduce stored raw observations into points (per session, idempotent)");
  sub->add_option("--session", o->session, "Session id (default: every session)");
  sub->add_flag("--no-reject", o->no_reject, "Report blunders but keep every ray");
  sub->callback([&run, &global, o] { run = [&global, o] { return RunReduce(*o, global); }; });
}

void SetupImportObservations(CLI::App& import, const GlobalOptions& global, Runner& run) {
  auto o = std::make_shared<ImportObservationsOptions>();
  auto* sub = import.add_subcommand(
      "observations",
      "Angle observations CSV (optional 'pose' column) into a new session, with "
      "the stations' set-ups");
  sub->add_option("file", o->file, "Observations CSV")->required();
  sub->add_option("--stations", o->stations, "Stations YAML")->required();
  sub->add_option("--robot", o->robot, "Robot name")->capture_default_str();
  sub->add_option("--note", o->note, "Session note");
  sub->callback(
      [&run, &global, o] { run = [&global, o] { return RunImportObservations(*o, global); }; });
}

}  // namespace armsig::app
