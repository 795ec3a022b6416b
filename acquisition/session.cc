#include "acquisition/session.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <future>
#include <set>
#include <thread>

#include "core/error.h"
#include "core/units.h"
#include "db/store.h"
#include "reduction/intersection.h"

namespace armsig::acquisition {

using Clock = std::chrono::steady_clock;

int64_t CreateSession(db::Database& db, const LabConfig& lab, const std::string& robot,
                      const Plan& plan) {
  SQLite::Transaction tx(db.sql());
  const int64_t robot_id = db::EnsureRobot(db, robot, lab.model.name, lab.model_yaml);
  const int64_t session = db::CreateSession(db, robot_id, lab.text, PlanToJson(plan), "running",
                                            "capture from " + lab.source);
  for (const auto& s : lab.stations) {
    db::StationSetupRow row;
    row.station = s.pose.id;
    row.pose = s.pose;
    row.sigma_position_mm = s.sigma_position_mm;
    row.sigma_azimuth_rad = s.sigma_azimuth_rad;
    for (const auto& c : lab.instruments) {
      if (c.station == s.pose.id) {
        row.sigma_hz_rad = c.sigma_hz_arcsec * kRadPerArcsec;
        row.sigma_v_rad = c.sigma_v_arcsec * kRadPerArcsec;
      }
    }
    row.method = "lab";
    db::InsertStationSetup(db, session, row);
  }
  tx.commit();
  return session;
}

namespace {

struct StationReading {
  instruments::Reading reading;
  int instrument = 0;
};

struct Measurement {
  Eigen::VectorXd joints;
  std::vector<StationReading> readings;  // every reading of every instrument (faces, repeats)
  reduction::IntersectionResult point;
  double repeat_mm = 0.0;
  double device_ms = 0.0;  // slowest device call of the parallel round(s)
};

}  // namespace

CaptureSummary RunCapture(db::Database& db, const LabConfig& lab, int64_t session,
                          std::vector<std::unique_ptr<instruments::DistanceInstrument>>& devices,
                          instruments::RobotController& controller, const CaptureOptions& options) {
  CaptureSummary summary;
  summary.session = session;
  const auto row = db::LoadSession(db, session);
  if (!row) throw InputError({db.path(), 0, 0, ""}, "no session " + std::to_string(session));
  const Plan plan = PlanFromJson(row->plan_json);
  summary.total = static_cast<int>(plan.size());
  const auto stored = db::StoredSeqs(db, session);
  const std::set<int> done(stored.begin(), stored.end());
  summary.already = static_cast<int>(done.size());
  db::SetSessionState(db, session, "running");

  // Stations by instrument.
  std::vector<const reduction::Station*> station_of(devices.size(), nullptr);
  for (size_t i = 0; i < devices.size(); ++i) {
    for (const auto& s : lab.stations) {
      if (s.pose.id == lab.instruments[i].station) station_of[i] = &s;
    }
    if (!station_of[i])
      throw InputError({lab.source, 0, 0, "stations"},
                       "no oriented station " + lab.instruments[i].station);
  }

  const auto start = Clock::now();
  double miss_sum = 0.0;
  int miss_count = 0;
  double cycle_sum = 0.0, overhead_sum = 0.0;
  int cycles = 0;

  // One parallel round: joints (optional) and every instrument at once.
  auto round = [&](bool with_joints, Measurement& m) {
    std::future<Eigen::VectorXd> joints;
    std::vector<std::future<std::pair<instruments::Reading, double>>> futures;
    auto timed = [](auto&& f) {
      const auto a = Clock::now();
      auto r = f();
      return std::make_pair(r, std::chrono::duration<double, std::milli>(Clock::now() - a).count());
    };
    if (with_joints)
      joints = std::async(std::launch::async, [&] { return controller.ReadJointsRad(); });
    for (size_t i = 0; i < devices.size(); ++i) {
      futures.push_back(std::async(std::launch::async, [&, i] {
        return timed([&] {
          return lab.instruments[i].distance ? devices[i]->MeasureDistanceAndAngles()
                                             : devices[i]->MeasureAngles();
        });
      }));
    }
    std::exception_ptr failure;
    double slowest = 0.0;
    for (size_t i = 0; i < futures.size(); ++i) {
      try {
        auto [reading, ms] = futures[i].get();
        m.readings.push_back({reading, static_cast<int>(i)});
        slowest = std::max(slowest, ms);
      } catch (...) {
        if (!failure) failure = std::current_exception();
      }
    }
    if (with_joints) {
      try {
        m.joints = joints.get();
      } catch (...) {
        if (!failure) failure = std::current_exception();
      }
    }
    if (failure) std::rethrow_exception(failure);
    m.device_ms += slowest;
  };

  auto intersect = [&](const std::vector<StationReading>& readings) {
    std::vector<reduction::Ray> rays;
    for (const auto& r : readings) {
      const auto& c = lab.instruments[r.instrument];
      reduction::Ray ray;
      ray.station_mm = station_of[r.instrument]->pose.position_mm;
      ray.world_from_station = station_of[r.instrument]->pose.world_from_station;
      ray.reading = r.reading.angles;
      ray.distance_mm = r.reading.distance_mm ? *r.reading.distance_mm : NAN;
      ray.sigma_hz_rad = c.sigma_hz_arcsec * kRadPerArcsec;
      ray.sigma_v_rad = c.sigma_v_arcsec * kRadPerArcsec;
      ray.sigma_distance_mm = c.sigma_distance_mm;
      rays.push_back(ray);
    }
    return reduction::Intersect(rays);
  };

  for (int seq = 0; seq < static_cast<int>(plan.size()); ++seq) {
    if (done.count(seq)) continue;
    if (options.stop && options.stop->load()) {
      summary.stopped = true;
      db::SetSessionState(db, session, "paused");
      break;
    }
    const PlannedConfiguration& target = plan[seq];
    std::optional<Measurement> accepted;
    int attempts = 0;
    std::string fault;
    for (int fault_try = 0; fault_try <= lab.tolerances.fault_retries && !accepted; ++fault_try) {
      if (fault_try > 0)
        std::this_thread::sleep_for(std::chrono::milliseconds(lab.tolerances.fault_retry_delay_ms));
      try {
        if (controller.CanMove())
          controller.MoveTo(target.joints_rad);
        else if (options.prompt_move)
          options.prompt_move(target);
        std::this_thread::sleep_for(std::chrono::milliseconds(lab.tolerances.settle_ms));
        for (int measure = 0; measure <= lab.tolerances.max_remeasure; ++measure) {
          ++attempts;
          const auto cycle_start = Clock::now();
          Measurement m;
          round(true, m);
          std::vector<Eigen::Vector3d> repeats;
          {
            repeats.push_back(intersect(m.readings).position_mm);
            for (int k = 1; k < lab.tolerances.readings; ++k) {
              Measurement again;
              round(false, again);
              repeats.push_back(intersect(again.readings).position_mm);
              m.readings.insert(m.readings.end(), again.readings.begin(), again.readings.end());
              m.device_ms += again.device_ms;
            }
          }
          if (lab.tolerances.two_face) {
            std::vector<std::future<void>> turns;
            for (auto& d : devices)
              turns.push_back(std::async(std::launch::async, [&d] { d->ChangeFace(); }));
            for (auto& t : turns) t.get();
            Measurement face2;
            round(false, face2);
            m.readings.insert(m.readings.end(), face2.readings.begin(), face2.readings.end());
            m.device_ms += face2.device_ms;
            turns.clear();
            for (auto& d : devices)
              turns.push_back(std::async(std::launch::async, [&d] { d->ChangeFace(); }));
            for (auto& t : turns) t.get();
          }
          m.point = intersect(m.readings);
          for (size_t a = 0; a < repeats.size(); ++a)
            for (size_t b = a + 1; b < repeats.size(); ++b)
              m.repeat_mm = std::max(m.repeat_mm, (repeats[a] - repeats[b]).norm());
          const double cycle_ms =
              std::chrono::duration<double, std::milli>(Clock::now() - cycle_start).count();
          cycle_sum += cycle_ms;
          overhead_sum += std::max(0.0, cycle_ms - m.device_ms);
          ++cycles;
          const bool good = m.point.status == reduction::IntersectionStatus::kOk &&
                            m.point.max_miss_mm <= lab.tolerances.max_miss_mm &&
                            m.repeat_mm <= lab.tolerances.max_repeat_mm;
          if (good || measure == lab.tolerances.max_remeasure) {
            accepted = std::move(m);
            break;
          }
          ++summary.remeasured;
        }
      } catch (const std::exception& e) {
        fault = e.what();
      }
    }

    if (!accepted && !options.skip_on_fault) {
      {
        summary.paused = true;
        summary.pause_reason = "configuration " + target.label + " (" + std::to_string(seq + 1) +
                               " of " + std::to_string(plan.size()) + "): " + fault;
        db::SetSessionState(db, session, "paused");
        break;
      }
    }
    SQLite::Transaction tx(db.sql());
    if (!accepted) {
      db::InsertPose(db, session, seq, target.label, std::nullopt, "skipped", attempts);
      tx.commit();
      ++summary.skipped;
    } else {
      const Measurement& m = *accepted;
      const int64_t pose =
          db::InsertPose(db, session, seq, target.label, m.joints, "measured", attempts);
      std::vector<db::ObservationRow> rows;
      for (const auto& r : m.readings) {
        db::ObservationRow o;
        o.pose_id = pose;
        o.point = "target";
        o.station = lab.instruments[r.instrument].station;
        o.reading = r.reading.angles;
        o.distance_mm = r.reading.distance_mm;
        o.sigma_hz_rad = lab.instruments[r.instrument].sigma_hz_arcsec * kRadPerArcsec;
        o.sigma_v_rad = lab.instruments[r.instrument].sigma_v_arcsec * kRadPerArcsec;
        o.sigma_distance_mm = lab.instruments[r.instrument].sigma_distance_mm;
        o.return_code = r.reading.return_code;
        rows.push_back(o);
      }
      db::InsertObservations(db, session, rows);
      db::PointRow point;
      point.pose_id = pose;
      point.point = "target";
      point.rays = static_cast<int>(m.readings.size());
      if (m.point.status == reduction::IntersectionStatus::kOk) {
        point.position_mm = m.point.position_mm;
        point.covariance_mm2 = m.point.covariance_mm2;
        point.rejected_rays = m.point.rejected;
        point.sigma0 = m.point.dof > 0 ? m.point.sigma0 : NAN;
        point.miss_mm = m.point.max_miss_mm;
        std::string flags;
        if (m.point.max_miss_mm > lab.tolerances.max_miss_mm) flags += "miss_exceeded ";
        if (m.repeat_mm > lab.tolerances.max_repeat_mm) flags += "repeat_exceeded ";
        if (m.point.rejected) flags += "blunder_rejected ";
        point.flags = flags;
        miss_sum += m.point.max_miss_mm;
        ++miss_count;
        summary.max_miss_mm = std::max(summary.max_miss_mm, m.point.max_miss_mm);
      } else {
        point.flags = reduction::ToString(m.point.status);
      }
      // Append this configuration's point (other sessions' points are untouched).
      db::InsertPoint(db, session, point);
      tx.commit();
      ++summary.measured;
    }
    if (options.progress) {
      Progress p;
      p.done = summary.already + summary.measured + summary.skipped;
      p.total = summary.total;
      p.skipped = summary.skipped;
      p.remeasured = summary.remeasured;
      p.label = target.label;
      p.last_miss_mm = accepted ? accepted->point.max_miss_mm : NAN;
      p.mean_miss_mm = miss_count ? miss_sum / miss_count : 0.0;
      p.max_miss_mm = summary.max_miss_mm;
      p.elapsed_s = std::chrono::duration<double>(Clock::now() - start).count();
      const int this_run = summary.measured + summary.skipped;
      p.eta_s = this_run ? p.elapsed_s / this_run * (p.total - p.done) : 0.0;
      options.progress(p);
    }
  }
  summary.seconds = std::chrono::duration<double>(Clock::now() - start).count();
  summary.mean_miss_mm = miss_count ? miss_sum / miss_count : 0.0;
  summary.mean_cycle_ms = cycles ? cycle_sum / cycles : 0.0;
  summary.mean_overhead_ms = cycles ? overhead_sum / cycles : 0.0;
  if (!summary.paused && !summary.stopped) {
    summary.completed = true;
    db::SetSessionState(db, session, "completed");
  }
  return summary;
}

}  // namespace armsig::acquisition
