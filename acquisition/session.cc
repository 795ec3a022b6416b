#include "acquisition/session.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <future>
#include <set>
#include <thread>

#include "acquisition/records.h"
#include "acquisition/session_owner.h"
#include "core/error.h"
#include "core/units.h"
#include "db/store.h"
#include "reduction/intersection.h"
#include "reduction/point_flags.h"

namespace armsig::acquisition {

using Clock = std::chrono::steady_clock;

int64_t CreateSession(db::Database& db, const LabConfig& lab, const std::string& robot,
                      const Plan& plan) {
  db::WriteTransaction tx(db);
  const int64_t robot_id = db::EnsureRobot(db, robot, lab.model.name, lab.model_yaml);
  const int64_t session = db::CreateSession(db, robot_id, lab.text, PlanToJson(plan), "running",
                                            "capture from " + lab.source);
  db::SetSessionOwner(db, session, ThisProcess());  // running: in this process
  for (const auto& s : lab.stations) {
    db::StationSetupRow row = StationSetupRowOf(s, "lab");
    for (const auto& c : lab.instruments) {
      if (c.station == s.pose.id) {
        row.sigma_hz_rad = c.sigma_hz_arcsec * kRadPerArcsec;
        row.sigma_v_rad = c.sigma_v_arcsec * kRadPerArcsec;
      }
    }
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

// Ctrl-C: the flag was raised while a configuration was being measured.
struct StopRequested {};

// Hands the stop flag to every device for the duration of a capture, so that a device
// call in flight (a flooding port, a long move) ends within a few milliseconds.
class InterruptScope {
 public:
  InterruptScope(std::vector<std::unique_ptr<instruments::DistanceInstrument>>& devices,
                 instruments::RobotController& controller, const std::atomic<bool>* stop)
      : devices_(devices), controller_(controller) {
    if (!stop) return;
    for (auto& d : devices_) d->SetInterrupt(stop);
    controller_.SetInterrupt(stop);
  }
  ~InterruptScope() {
    for (auto& d : devices_) d->SetInterrupt(nullptr);
    controller_.SetInterrupt(nullptr);
  }
  InterruptScope(const InterruptScope&) = delete;
  InterruptScope& operator=(const InterruptScope&) = delete;

 private:
  std::vector<std::unique_ptr<instruments::DistanceInstrument>>& devices_;
  instruments::RobotController& controller_;
};

struct Measurement {
  Eigen::VectorXd joints;
  std::vector<StationReading> readings;  // every reading of every instrument (faces, repeats)
  reduction::ReducedPoint point;         // its flags carry the tolerance checks
  double device_ms = 0.0;                // slowest device call of the parallel round(s)
};

// A reading of the capture's target as an observation, with its instrument's sigmas.
reduction::Observation ObservationOf(const StationReading& r, const InstrumentConfig& c) {
  reduction::Observation o;
  o.point = "target";
  o.station = c.station;
  o.reading = r.reading.angles;
  o.distance_mm = r.reading.distance_mm;
  o.sigma_hz_rad = c.sigma_hz_arcsec * kRadPerArcsec;
  o.sigma_v_rad = c.sigma_v_arcsec * kRadPerArcsec;
  o.sigma_distance_mm = c.sigma_distance_mm;
  return o;
}

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
  db::SetSessionOwner(db, session, ThisProcess());
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

  const InterruptScope interrupts(devices, controller, options.stop);
  const auto stopping = [&] { return options.stop && options.stop->load(); };
  // Between device calls: a raised stop flag ends the configuration.
  const auto check_stop = [&] {
    if (stopping()) throw StopRequested{};
  };
  // A wait that a raised stop flag cuts short.
  const auto sleep_unless_stopped = [&](int ms) {
    const auto end = Clock::now() + std::chrono::milliseconds(ms);
    for (auto now = Clock::now(); now < end; now = Clock::now()) {
      check_stop();
      std::this_thread::sleep_for(
          std::min<Clock::duration>(end - now, std::chrono::milliseconds(10)));
    }
    check_stop();
  };

  const auto start = Clock::now();
  double miss_sum = 0.0, max_miss = 0.0;  // over usable points
  int miss_count = 0;
  double cycle_sum = 0.0, overhead_sum = 0.0;
  int cycles = 0;

  // One parallel round: joints (optional) and every instrument at once.
  auto round = [&](bool with_joints, Measurement& m) {
    check_stop();
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

  // The point's checks are the lab's tolerances.
  reduction::PointOptions point_options;
  point_options.checks.max_miss_mm = lab.tolerances.max_miss_mm;
  point_options.checks.max_repeat_mm = lab.tolerances.max_repeat_mm;
  auto rays_of = [&](const std::vector<StationReading>& readings) {
    std::vector<reduction::Ray> rays;
    for (const auto& r : readings) {
      rays.push_back(reduction::RayOf(ObservationOf(r, lab.instruments[r.instrument]),
                                      *station_of[r.instrument], reduction::InstrumentDefaults{}));
    }
    return rays;
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
    bool stopped = false;
    for (int fault_try = 0; fault_try <= lab.tolerances.fault_retries && !accepted && !stopped;
         ++fault_try) {
      try {
        if (fault_try > 0) sleep_unless_stopped(lab.tolerances.fault_retry_delay_ms);
        check_stop();
        if (controller.CanMove())
          controller.MoveTo(target.joints_rad);
        else if (options.prompt_move)
          options.prompt_move(target);
        sleep_unless_stopped(lab.tolerances.settle_ms);
        for (int measure = 0; measure <= lab.tolerances.max_remeasure; ++measure) {
          ++attempts;
          const auto cycle_start = Clock::now();
          Measurement m;
          round(true, m);
          reduction::RayGroup group;  // every ray, and each repeated round's rays
          group.repeats.push_back(rays_of(m.readings));
          for (int k = 1; k < lab.tolerances.readings; ++k) {
            Measurement again;
            round(false, again);
            group.repeats.push_back(rays_of(again.readings));
            m.readings.insert(m.readings.end(), again.readings.begin(), again.readings.end());
            m.device_ms += again.device_ms;
          }
          if (lab.tolerances.two_face) {
            check_stop();
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
          group.rays = rays_of(m.readings);
          reduction::IntersectPoint(group, point_options, m.point);
          const double cycle_ms =
              std::chrono::duration<double, std::milli>(Clock::now() - cycle_start).count();
          cycle_sum += cycle_ms;
          overhead_sum += std::max(0.0, cycle_ms - m.device_ms);
          ++cycles;
          if (m.point.accepted() || measure == lab.tolerances.max_remeasure) {
            accepted = std::move(m);
            break;
          }
          ++summary.remeasured;
        }
      } catch (const StopRequested&) {
        stopped = true;
      } catch (const std::exception& e) {
        // A device call the stop flag interrupted (or that failed while it was raised)
        // is no fault of the configuration: the session stops.
        if (stopping()) {
          stopped = true;
        } else {
          fault = e.what();
        }
      }
    }

    if (stopped && !accepted) {
      // Nothing of this configuration is stored: --resume measures it again.
      summary.stopped = true;
      db::SetSessionState(db, session, "paused");
      break;
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
    db::WriteTransaction tx(db);
    if (!accepted) {
      db::InsertPose(db, session, seq, target.label, std::nullopt, "skipped", attempts);
      tx.commit();
      spdlog::debug("capture: {} skipped after {} attempt(s): {}", target.label, attempts, fault);
      ++summary.skipped;
      summary.skipped_configurations.push_back({target.label, fault});
    } else {
      const Measurement& m = *accepted;
      const int64_t pose =
          db::InsertPose(db, session, seq, target.label, m.joints, "measured", attempts);
      std::vector<db::ObservationRow> rows;
      for (const auto& r : m.readings) {
        rows.push_back(ObservationRowOf(ObservationOf(r, lab.instruments[r.instrument]), pose,
                                        r.reading.return_code));
      }
      db::InsertObservations(db, session, rows);
      const reduction::IntersectionResult& result = m.point.result;
      const db::PointRow point =
          PointRowOf(pose, "target", static_cast<int>(m.readings.size()), result, result.flags);
      // Append this configuration's point (other sessions' points are untouched).
      db::InsertPoint(db, session, point);
      tx.commit();
      ++summary.measured;
      const std::string flags = ToString(result.flags);
      spdlog::debug("capture: {} stored: {} readings, {} attempt(s), point {}{}, miss {:.4f} mm",
                    target.label, m.readings.size(), attempts,
                    result.status.ok() ? "intersected" : "not intersected",
                    flags.empty() ? "" : " [" + flags + "]", result.max_miss_mm);
      for (const auto& r : m.readings) {
        spdlog::trace("capture: {} {}: Hz {:.8f} V {:.8f} rad{} code {}", target.label,
                      lab.instruments[r.instrument].station, r.reading.angles.hz_rad,
                      r.reading.angles.v_rad,
                      r.reading.distance_mm ? fmt::format(" d {:.4f} mm", *r.reading.distance_mm)
                                            : std::string(),
                      r.reading.return_code);
      }
      if (m.point.accepted()) {
        ++summary.usable;
        miss_sum += result.max_miss_mm;
        ++miss_count;
        max_miss = std::max(max_miss, result.max_miss_mm);
      } else if (result.status.ok()) {
        ++summary.flagged;  // intersected, but beyond the tolerances after re-measuring
        summary.flagged_configurations.push_back({target.label, ToString(result.flags)});
      } else {
        ++summary.failed;  // no point: the readings are kept, the point is not usable
        summary.failed_configurations.push_back(
            {target.label, ToString(result.flags) + ": " + result.status.message});
      }
    }
    if (options.progress) {
      Progress p;
      p.done = summary.already + summary.measured + summary.skipped;
      p.total = summary.total;
      p.skipped = summary.skipped;
      p.flagged = summary.flagged;
      p.failed = summary.failed;
      p.remeasured = summary.remeasured;
      p.label = target.label;
      p.last_miss_mm = accepted && accepted->point.accepted()
                           ? std::optional(accepted->point.result.max_miss_mm)
                           : std::nullopt;
      if (miss_count > 0) {
        p.mean_miss_mm = miss_sum / miss_count;
        p.max_miss_mm = max_miss;
      }
      p.elapsed_s = std::chrono::duration<double>(Clock::now() - start).count();
      const int this_run = summary.measured + summary.skipped;
      p.eta_s = this_run ? p.elapsed_s / this_run * (p.total - p.done) : 0.0;
      options.progress(p);
    }
  }
  summary.seconds = std::chrono::duration<double>(Clock::now() - start).count();
  if (miss_count) {
    summary.mean_miss_mm = miss_sum / miss_count;
    summary.max_miss_mm = max_miss;
  }
  summary.mean_cycle_ms = cycles ? cycle_sum / cycles : 0.0;
  summary.mean_overhead_ms = cycles ? overhead_sum / cycles : 0.0;
  if (!summary.paused && !summary.stopped) {
    summary.completed = true;
    db::SetSessionState(db, session, "completed");
  }
  return summary;
}

}  // namespace armsig::acquisition
