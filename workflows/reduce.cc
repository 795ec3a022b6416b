#include "core/wording.h"
#include "workflows/reduce.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <limits>
#include <map>
#include <optional>
#include <utility>

#include "acquisition/lab.h"
#include "acquisition/observation_rows.h"
#include "core/error.h"
#include "core/plausibility.h"
#include "core/text.h"
#include "db/store.h"
#include "io/csv.h"
#include "io/network_files.h"
#include "workflows/hint.h"

namespace armsig::workflows {

reduction::PointChecks SessionChecks(db::Database& database, int64_t session_id) {
  reduction::PointChecks checks;
  const auto session = db::LoadSession(database, session_id);
  if (!session) return checks;
  const auto lab = io::StoredLabSettings(session->lab_yaml, session_id, database.path());
  if (!lab) return checks;
  checks.max_miss_mm = lab->tolerances.max_miss_mm;
  checks.max_repeat_mm = lab->tolerances.max_repeat_mm;
  return checks;
}

namespace {

// The points a reduction of the session's stored readings gives, read inside the caller's
// transaction (a snapshot or the write transaction); `points` empty with `observations` 0: a
// session of measured points, nothing to replace.
struct Reduction {
  ReduceSummary summary;
  std::vector<db::PointRow> points;
  bool replace = false;
};

Reduction Reduce(db::Database& database, int64_t session_id,
                 const reduction::PointOptions& options) {
  Reduction out;
  ReduceSummary& summary = out.summary;
  summary.session = session_id;
  std::map<std::string, reduction::Station> stations;
  for (const auto& [code, setup] : db::LatestStationSetups(database, session_id))
    stations.emplace(code, acquisition::StationOf(setup));
  const auto observations = db::LoadObservations(database, session_id);
  summary.observations = static_cast<int64_t>(observations.size());
  // A session of measured points without readings (imported poses, a tracker's point table):
  // nothing to reduce, and its points are its measurements; replacing them with none would
  // lose them.
  if (observations.empty()) {
    summary.kept_points = db::LoadPoints(database, session_id).size();
    return out;
  }
  // The flags stored with the points this reduction replaces, by (pose, point).
  std::map<std::pair<std::optional<int64_t>, std::string>, reduction::PointFlags> stored;
  // And a paired point's clock share (measuring on the move), which no reading holds.
  std::map<std::pair<std::optional<int64_t>, std::string>, double> sync_sigma;
  for (const auto& p : db::LoadPoints(database, session_id)) {
    if (p.sync_sigma_mm) sync_sigma[{p.pose_id, p.point}] = *p.sync_sigma_mm;
    if (const auto flags = reduction::ParsePointFlags(p.flags)) {
      stored[{p.pose_id, p.point}] = *flags;
    } else {
      spdlog::warn("session {}: point {} has unknown stored flags '{}'; they are not kept",
                   session_id, p.point, p.flags);
    }
  }
  const reduction::InstrumentDefaults defaults;
  std::vector<db::PointRow>& points = out.points;
  out.replace = true;
  reduction::RayGroup group;
  reduction::ReducedPoint reduced;
  size_t begin = 0;
  while (begin < observations.size()) {
    size_t end = begin;
    const auto& first = observations[begin];
    while (end < observations.size() && observations[end].pose_id == first.pose_id &&
           observations[end].point == first.point) {
      ++end;
    }
    if (stations.count(first.point)) {  // a mutual pointing at a station: not a target
      begin = end;
      continue;
    }
    group.rays.clear();
    for (size_t k = begin; k < end; ++k) {
      const auto& o = observations[k];
      auto it = stations.find(o.station);
      if (it == stations.end()) {
        throw InputError({"session " + std::to_string(session_id), 0, 0, ""},
                         "station " + o.station + " has no set-up (orient it first)");
      }
      group.rays.push_back(reduction::RayOf(acquisition::ObservationOf(o), it->second, defaults));
    }
    reduction::IntersectPoint(group, options, reduced);
    const reduction::IntersectionResult& result = reduced.result;
    reduction::PointFlags flags = result.flags;
    if (auto it = stored.find({first.pose_id, first.point}); it != stored.end())
      flags |= reduction::CarriedOverFlags(it->second, options.checks);
    db::PointRow row = acquisition::PointRowOf(first.pose_id, first.point,
                                               static_cast<int>(group.rays.size()), result, flags);
    if (auto it = sync_sigma.find({first.pose_id, first.point}); it != sync_sigma.end()) {
      row.sync_sigma_mm = it->second;
      row.covariance_mm2 += it->second * it->second * Eigen::Matrix3d::Identity();
    }
    if (result.status.ok()) {
      ++summary.reduced;
      summary.rejected_rays += result.rejected;
    } else {
      ++summary.failed;
    }
    points.push_back(std::move(row));
    begin = end;
  }
  return out;
}

}  // namespace

ReduceSummary ReduceSession(db::Database& database, int64_t session_id,
                            const reduction::PointOptions& options) {
  // The points replaced must be exactly those of the observations read (none lost to a
  // configuration a capture stores meanwhile, none from half a configuration). The reduction
  // is computed on a snapshot, without the store's write lock, and written only if the
  // session's rows are still those it read: a capture storing configurations is kept waiting
  // the length of the write, not of the computation (SQLite's waiting writer polls, and a
  // lock held for the computation again and again could keep it out past its timeout).
  constexpr int kOptimisticTries = 3;
  for (int attempt = 0; attempt < kOptimisticTries; ++attempt) {
    db::SessionRowsMark read_mark;
    Reduction reduced;
    {
      db::ReadSnapshot snapshot(database);
      read_mark = db::MarkSessionRows(database, session_id);
      reduced = Reduce(database, session_id, options);
      snapshot.commit();
    }
    db::WriteTransaction tx(database);
    db::LockSessionForWrite(database, session_id);
    if (!(db::MarkSessionRows(database, session_id) == read_mark)) continue;  // rolled back
    if (reduced.replace) db::ReplacePoints(database, session_id, reduced.points);
    tx.commit();
    return reduced.summary;
  }
  // Rows keep coming faster than the reduction computes: reduce under the lock, the capture
  // waiting this once.
  db::WriteTransaction tx(database);
  db::LockSessionForWrite(database, session_id);
  Reduction reduced = Reduce(database, session_id, options);
  if (reduced.replace) db::ReplacePoints(database, session_id, reduced.points);
  tx.commit();
  return reduced.summary;
}

std::string ImportNote(const std::string& file) {
  // The file name is input: shown, never obeyed (a newline in it would be one in the note),
  // and cut to a note's length.
  return std::string(TruncateUtf8("imported from " + Printable(file), plausible::kMaxNoteLength));
}

ImportObservationsResult ImportObservations(db::Database& database,
                                            const ImportObservationsOptions& options) {
  const auto stations = io::ReadStationsYaml(options.stations);
  // The optional pose column groups rows into robot configurations.
  std::vector<std::string> pose_labels;
  const auto observations = io::ReadObservationsCsv(options.file, &pose_labels, options.progress);
  const bool pose_column = !pose_labels.empty();
  std::map<std::string, const reduction::Station*> by_id;
  for (const auto& s : stations) by_id[s.pose.id] = &s;
  for (const auto& o : observations) {
    if (!by_id.count(o.station)) {
      throw InputError({options.file, o.source_line, o.source_station_column, "station"},
                       "station " + Quoted(o.station) + " is not in " + options.stations +
                           " (expected one of its stations)");
    }
  }
  ImportObservationsResult result;
  db::WriteTransaction tx(database);
  const int64_t robot = db::EnsureRobot(database, options.robot, "", "");
  result.session =
      db::CreateSession(database, robot, "", "", db::SessionState::kCompleted,
                        options.note.empty() ? ImportNote(options.file) : options.note);
  for (const auto& s : stations) {
    db::InsertStationSetup(database, result.session, acquisition::StationSetupRowOf(s, "file"));
  }
  std::map<std::string, int64_t> pose_ids;
  std::vector<db::ObservationRow> rows;
  rows.reserve(observations.size());
  for (size_t k = 0; k < observations.size(); ++k) {
    const auto& o = observations[k];
    std::optional<int64_t> pose_id;
    if (pose_column) {
      const std::string& label = pose_labels[k];
      auto it = pose_ids.find(label);
      if (it == pose_ids.end()) {
        const int seq = static_cast<int>(pose_ids.size());
        it = pose_ids
                 .emplace(label, db::InsertPose(database, result.session, seq, label, std::nullopt,
                                                "measured", 1))
                 .first;
      }
      pose_id = it->second;
    }
    rows.push_back(acquisition::ObservationRowOf(o, pose_id));
  }
  db::InsertObservations(database, result.session, rows);
  tx.commit();
  result.observations = rows.size();
  result.stations = stations.size();
  result.poses = pose_ids.size();
  return result;
}

std::vector<ReduceSummary> ReduceSessions(db::Database& database, int64_t session,
                                          bool reject_blunders) {
  std::vector<int64_t> sessions;
  if (session > 0) {
    if (!db::SessionExists(database, session)) {
      throw InputError({database.path(), 0, 0, ""},
                       fmt::format("no session {} in the database ({} lists them)", session,
                                   Hint(database.path(), {"sessions"})));
    }
    sessions.push_back(session);
  } else {
    sessions = db::SessionIds(database);
  }
  std::vector<ReduceSummary> out;
  for (int64_t id : sessions) {
    reduction::PointOptions options;
    options.intersection.snooping.reject = reject_blunders;
    options.checks = SessionChecks(database, id);
    out.push_back(ReduceSession(database, id, options));
    spdlog::debug("reduce: session {}: {} points reduced, {} not", id, out.back().reduced,
                  out.back().failed);
  }
  return out;
}

std::string FormatReduceSummaries(const std::vector<ReduceSummary>& summaries,
                                  const std::string& db_path) {
  if (summaries.empty()) return "no sessions in " + Printable(db_path) + "\n";
  std::string text;
  for (const auto& s : summaries) {
    if (s.observations == 0) {
      text +=
          fmt::format("session {}: no observations to reduce; its {} measured points are kept\n",
                      s.session, s.kept_points);
      continue;
    }
    text += fmt::format("session {}: {} -> {} reduced, {} not ({} rejected as blunders)\n",
                        s.session, Count(s.observations, "observation"),
                        Count(s.reduced, "point"), s.failed, Count(s.rejected_rays, "ray"));
  }
  return text;
}

}  // namespace armsig::workflows
