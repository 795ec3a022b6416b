#include "acquisition/session.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <boost/asio/post.hpp>
#include <boost/asio/thread_pool.hpp>
#include <chrono>
#include <cmath>
#include <functional>
#include <future>
#include <map>
#include <set>
#include <thread>

#include "acquisition/beam_pointing.h"
#include "acquisition/records.h"
#include "acquisition/session_owner.h"
#include "core/error.h"
#include "core/text.h"
#include "io/model_yaml.h"
#include "core/units.h"
#include "db/store.h"
#include "reduction/intersection.h"
#include "reduction/point_flags.h"
#include "reduction/polar_checks.h"

namespace armsig::acquisition {

using Clock = std::chrono::steady_clock;

int64_t CreateSession(db::Database& db, const LabConfig& lab, const std::string& robot,
                      const Plan& plan) {
  db::WriteTransaction tx(db);
  if (const auto registered = db::FindRobot(db, robot)) {
    // The robot is what was registered: a lab file naming another model (an edited link
    // length, another robot's file) would store measurements of one arm under another.
    const auto model = io::ParseRobotModel(db::RobotModelYaml(db, *registered),
                                           "model of robot " + robot);
    const auto differences = calibration::ModelDifferences(lab.model, model);
    if (!differences.empty()) {
      std::string list;
      for (const auto& d : differences) list += (list.empty() ? "" : "; ") + d;
      throw InputError({lab.robot_model_path, 0, 0, ""},
                       fmt::format("the lab's robot model differs from robot {} as registered "
                                   "({} against the registered): {}; correct the lab file's "
                                   "model, or register the changed arm under a new name "
                                   "(armsig robot add NAME --model FILE)",
                                   Quoted(robot), lab.robot_model_path, list));
    }
  }
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
  int round = 0;  // which round of readings (repeat or face) it came from
};

// Ctrl-C: the flag was raised while a configuration was being measured.
struct StopRequested {};

struct Measurement {
  Eigen::VectorXd joints;
  std::vector<StationReading> readings;  // every reading of every instrument (faces, repeats)
  reduction::ReducedPoint point;         // its flags carry the tolerance checks
  double device_ms = 0.0;                // slowest device call of each parallel step, summed
};

bool UsableSigmas(const std::optional<instruments::ReadingSigmas>& s) {
  return s && std::isfinite(s->hz_rad) && std::isfinite(s->v_rad) &&
         std::isfinite(s->distance_mm) && s->hz_rad > 0.0 && s->v_rad > 0.0 && s->distance_mm > 0.0;
}

// A reading of the capture's target as an observation: with the sigmas the instrument
// stated with it (a laser tracker), else its configured ones.
reduction::Observation ObservationOf(const StationReading& r, const InstrumentConfig& c) {
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

// A tracker searches at the distance the prediction gives, else at its last reading's,
// else at this (a typical robot cell: the tracker a few metres from the robot).
constexpr double kDefaultSearchDistanceMm = 3000.0;

double MsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
      .count();
}

// The threads of a capture's parallel steps (every instrument and the joints at once),
// started once for the session: a step starts no thread, and its first task runs on the
// calling thread, so one tracker alone is measured without any hand-over between threads.
class Crew {
 public:
  explicit Crew(size_t threads) : pool_(std::max<size_t>(threads, 1)) {}
  ~Crew() { pool_.join(); }
  Crew(const Crew&) = delete;
  Crew& operator=(const Crew&) = delete;

  template <typename F>
  auto Spawn(F f) -> std::future<decltype(f())> {
    auto task = std::make_shared<std::packaged_task<decltype(f())()>>(std::move(f));
    auto future = task->get_future();
    boost::asio::post(pool_, [task] { (*task)(); });
    return future;
  }

  // Runs every task at once, the first here, and waits for all of them (they may hold
  // references into the caller's frame); their results in order, else the first failure
  // in task order.
  template <typename T>
  std::vector<T> Together(std::vector<std::function<T()>>& tasks) {
    std::vector<std::future<T>> others;
    for (size_t i = 1; i < tasks.size(); ++i) others.push_back(Spawn(tasks[i]));
    std::vector<std::optional<T>> results(tasks.size());
    std::exception_ptr failure;
    if (!tasks.empty()) {
      try {
        results[0] = tasks[0]();
      } catch (...) {
        failure = std::current_exception();
      }
    }
    for (size_t i = 1; i < tasks.size(); ++i) {
      try {
        results[i] = others[i - 1].get();
      } catch (...) {
        if (!failure) failure = std::current_exception();
      }
    }
    if (failure) std::rethrow_exception(failure);
    std::vector<T> out;
    for (auto& r : results) out.push_back(std::move(*r));
    return out;
  }

 private:
  boost::asio::thread_pool pool_;
};

}  // namespace

CaptureSummary RunCapture(db::Database& db, const LabConfig& lab, int64_t session,
                          std::vector<std::unique_ptr<instruments::DistanceInstrument>>& devices,
                          instruments::RobotController& controller, const CaptureOptions& options) {
  CaptureSummary summary;
  summary.session = session;
  const auto row = db::LoadSession(db, session);
  if (!row) throw InputError({db.path(), 0, 0, ""}, "no session " + std::to_string(session));
  const Plan plan = PlanFromJson(row->plan_json, {db.path(), "sessions", session, "plan_json"});
  summary.total = static_cast<int>(plan.size());
  summary.single_ray = devices.size() == 1;
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

  // Laser trackers point their beams at the predicted target before measuring.
  std::vector<instruments::BeamSteering*> beams(devices.size(), nullptr);
  bool any_beam = false;
  for (size_t i = 0; i < devices.size(); ++i) {
    beams[i] = dynamic_cast<instruments::BeamSteering*>(devices[i].get());
    any_beam |= beams[i] != nullptr;
  }
  // The robot base fitted to the measured points: laser trackers point their beams
  // through it, and every session checks by it that the points follow the robot.
  TargetPredictor predictor(
      lab.model,
      options.prediction_params.value_or(Eigen::VectorXd::Zero(lab.model.num_parameters())),
      lab.robot_base);
  // A resumed session starts from the points it has (the base is known at once).
  for (const auto& p : db::LoadSessionPoses(db, session)) {
    predictor.Add(p.joints_rad, p.target_in_world);
  }
  if (any_beam) {
    spdlog::info("capture: laser tracker beams point through {}{}", predictor.Describe(),
                 options.prediction_params ? " and the robot's active arm signature"
                                           : " and the nominal model");
  }
  // Points that do not follow the robot: the session stops before measuring more of them
  // and is discarded (what is stored stays, unused), naming what it found.
  const auto pause_unless_following = [&](const std::string& where) {
    const auto problem = predictor.FollowProblem(lab.tolerances.max_base_fit_rms_mm);
    if (!problem) return false;
    summary.paused = summary.discarded = true;
    summary.pause_reason = where + ": " + *problem;
    db::WriteTransaction tx(db);
    db::DiscardSession(db, session, "set-up check: " + summary.pause_reason);
    tx.commit();
    return true;
  };
  const bool stored_points_wrong =
      pause_unless_following(fmt::format("the {} stored points of this session", predictor.points()));
  std::vector<std::optional<double>> expected_distance(devices.size());  // this configuration
  std::vector<double> last_distance(devices.size(), 0.0);
  std::atomic<int> searches{0}, operator_pointed{0};

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
  double cycle_sum = 0.0, overhead_sum = 0.0, store_sum = 0.0;
  int cycles = 0, stores = 0;

  // A tracker's reading: where its beam points; when the reflector is not there, a search
  // around the beam (FindReflector), then the operator.
  auto measure = [&](size_t i, const PlannedConfiguration& target) {
    auto& device = *devices[i];
    auto read = [&] {
      return lab.instruments[i].distance ? device.MeasureDistanceAndAngles()
                                         : device.MeasureAngles();
    };
    instruments::BeamSteering* beam = beams[i];
    if (!beam) return read();
    const std::string& station = lab.instruments[i].station;
    try {
      return read();
    } catch (const instruments::InstrumentError& e) {
      if (!beam->ReflectorLost(e.code()) || stopping()) throw;
      spdlog::debug("capture: {} {}: no reflector in the beam ({}); searching", target.label,
                    station, e.what());
    }
    ++searches;
    const double around = expected_distance[i].value_or(
        last_distance[i] > 0.0 ? last_distance[i] : kDefaultSearchDistanceMm);
    try {
      beam->FindReflector(around);
      return read();
    } catch (const instruments::InstrumentError& e) {
      if (!beam->ReflectorLost(e.code()) || stopping() || !options.prompt_reflector) throw;
      spdlog::info(
          "capture: {} {}: the reflector was not found around the beam ({}); asking the "
          "operator to point the beam at it",
          target.label, station, e.what());
    }
    ++operator_pointed;
    options.prompt_reflector(station, target);
    check_stop();
    return read();
  };

  // A robot armsig moved must be where it was sent: the joints read back within the lab's
  // max_joint_error_deg of the commanded ones, else the configuration faults (retried).
  const double max_joint_error_rad = lab.tolerances.max_joint_error_deg * kPi / 180.0;
  auto check_joints = [&](const PlannedConfiguration& target, const Eigen::VectorXd& read) {
    if (read.size() != target.joints_rad.size()) return;
    Eigen::Index worst = 0;
    const double error = (read - target.joints_rad).cwiseAbs().maxCoeff(&worst);
    if (!(error > max_joint_error_rad)) return;
    throw std::runtime_error(fmt::format(
        "the controller reads joint {} at {:.4f} deg, commanded {:.4f} deg ({:.4f} deg off, "
        "more than the lab's max_joint_error_deg {}): the robot is not where the plan put it "
        "(another program drives it, or it stopped at a limit or a safety fence)",
        worst + 1, read(worst) * 180.0 / kPi, target.joints_rad(worst) * 180.0 / kPi,
        error * 180.0 / kPi, lab.tolerances.max_joint_error_deg));
  };

  // One parallel round: joints (optional) and every instrument at once.
  Crew crew(devices.size());
  auto round = [&](bool with_joints, Measurement& m, const PlannedConfiguration& target,
                   int round_index) {
    check_stop();
    using Timed = std::pair<instruments::Reading, double>;
    std::vector<std::function<Timed()>> reads;
    for (size_t i = 0; i < devices.size(); ++i) {
      reads.push_back([&, i] {
        const auto a = Clock::now();
        auto r = measure(i, target);
        return std::make_pair(r, MsSince(a));
      });
    }
    std::future<Eigen::VectorXd> joints;
    if (with_joints) joints = crew.Spawn([&] { return controller.ReadJointsRad(); });
    std::exception_ptr failure;
    std::vector<Timed> done_reads;
    try {
      done_reads = crew.Together(reads);
    } catch (...) {
      failure = std::current_exception();
    }
    if (with_joints) {
      try {
        m.joints = joints.get();
      } catch (...) {
        if (!failure) failure = std::current_exception();
      }
    }
    if (failure) std::rethrow_exception(failure);
    double slowest = 0.0;
    for (size_t i = 0; i < done_reads.size(); ++i) {
      m.readings.push_back({done_reads[i].first, static_cast<int>(i), round_index});
      slowest = std::max(slowest, done_reads[i].second);
    }
    m.device_ms += slowest;
  };

  // Every tracker's beam at the target the model predicts for this configuration; returns
  // the device time (the slowest GoPosition, and the joint reading it needed).
  auto point_beams = [&](const PlannedConfiguration& target) {
    std::fill(expected_distance.begin(), expected_distance.end(), std::nullopt);
    if (!any_beam) return 0.0;
    const auto a = Clock::now();
    double device_ms = 0.0;
    Eigen::VectorXd q = target.joints_rad;
    if (!controller.CanMove()) {  // the operator moved it: where it is, not where it was asked
      q = controller.ReadJointsRad();
      device_ms += MsSince(a);
    }
    const auto predicted = predictor.Predict(q);
    if (!predicted) return device_ms;
    std::vector<std::function<double()>> moves;
    for (size_t i = 0; i < devices.size(); ++i) {
      if (!beams[i]) continue;
      const auto& pose = station_of[i]->pose;
      const Eigen::Vector3d in_instrument =
          pose.world_from_station.transpose() * (*predicted - pose.position_mm);
      expected_distance[i] = in_instrument.norm();
      moves.push_back([&, i, in_instrument] {
        const auto t = Clock::now();
        beams[i]->GoPosition(in_instrument);
        return MsSince(t);
      });
      ++summary.beam_predicted;
    }
    double slowest = 0.0;
    for (const double ms : crew.Together(moves)) slowest = std::max(slowest, ms);
    return device_ms + slowest;
  };

  // The point's checks are the lab's tolerances.
  reduction::PointOptions point_options;
  point_options.checks.max_miss_mm = lab.tolerances.max_miss_mm;
  point_options.checks.max_repeat_mm = lab.tolerances.max_repeat_mm;
  // The fixed-mm repeat check is the theodolites' (two of them intersect a point per
  // round); a laser tracker's repeated readings are checked against the sigmas it states
  // (tracker_checks), which at 10 m exceed any fixed 0.05 mm.
  int angle_only = 0;
  for (size_t i = 0; i < devices.size(); ++i) angle_only += beams[i] ? 0 : 1;
  // angles_only: the theodolites' rays only (the fixed-mm repeat check's).
  auto rays_of = [&](const std::vector<StationReading>& readings, bool angles_only = false) {
    std::vector<reduction::Ray> rays;
    for (const auto& r : readings) {
      if (angles_only && beams[r.instrument]) continue;
      rays.push_back(reduction::RayOf(ObservationOf(r, lab.instruments[r.instrument]),
                                      *station_of[r.instrument], reduction::InstrumentDefaults{}));
    }
    return rays;
  };
  // A tracker's readings against the sigmas it stated: each one's largest sigma, and its
  // repeated readings (same face) against each other.
  auto tracker_checks = [&](Measurement& m) {
    if (!any_beam || !m.point.result.status.ok()) return;
    std::map<std::pair<int, int>, std::vector<std::pair<Eigen::Vector3d, Eigen::Matrix3d>>> seen;
    bool sigma_exceeded = false, repeat_exceeded = false;
    for (const auto& r : m.readings) {
      if (!beams[r.instrument] || !UsableSigmas(r.reading.sigma) || !r.reading.distance_mm)
        continue;
      const auto& s = *r.reading.sigma;
      const Eigen::Matrix3d c = reduction::PolarCovariance(r.reading.angles, *r.reading.distance_mm,
                                                           {s.hz_rad, s.v_rad, s.distance_mm});
      const double sigma = reduction::LargestSigmaMm(c);
      if (sigma > lab.tolerances.max_sigma_mm) {
        sigma_exceeded = true;
        spdlog::debug("capture: {}: a reading states sigma {:.4f} mm > {} mm",
                      lab.instruments[r.instrument].station, sigma, lab.tolerances.max_sigma_mm);
      }
      const Eigen::Vector3d p = reduction::PolarPoint(r.reading.angles, *r.reading.distance_mm);
      for (const auto& [q, cq] : seen[{r.instrument, r.reading.angles.face}]) {
        const double k = reduction::NormalisedDisagreement(p, c, q, cq);
        if (k > lab.tolerances.max_repeat_sigma) {
          repeat_exceeded = true;
          spdlog::debug("capture: {}: repeated readings {:.4f} mm apart, {:.1f} sigma",
                        lab.instruments[r.instrument].station, (p - q).norm(), k);
        }
      }
      seen[{r.instrument, r.reading.angles.face}].push_back({p, c});
    }
    if (sigma_exceeded) m.point.result.flags.Set(reduction::PointFlag::kSigmaExceeded);
    if (repeat_exceeded) m.point.result.flags.Set(reduction::PointFlag::kRepeatExceeded);
  };
  auto turn_faces = [&] {
    check_stop();
    const auto a = Clock::now();
    std::vector<std::function<int()>> turns;
    for (auto& d : devices)
      turns.push_back([&d] {
        d->ChangeFace();
        return 0;
      });
    crew.Together(turns);
    return MsSince(a);
  };

  for (int seq = 0; seq < static_cast<int>(plan.size()) && !stored_points_wrong; ++seq) {
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
        auto cycle_start = Clock::now();
        const double pointing_ms = point_beams(target);
        for (int measure_try = 0; measure_try <= lab.tolerances.max_remeasure; ++measure_try) {
          ++attempts;
          if (measure_try > 0) cycle_start = Clock::now();
          Measurement m;
          if (measure_try == 0) m.device_ms = pointing_ms;
          round(true, m, target, 0);
          if (controller.CanMove()) check_joints(target, m.joints);
          reduction::RayGroup group;  // every ray, and each repeated round's rays
          if (angle_only >= 2) group.repeats.push_back(rays_of(m.readings, true));
          for (int k = 1; k < lab.tolerances.readings; ++k) {
            Measurement again;
            round(false, again, target, k);
            if (angle_only >= 2) group.repeats.push_back(rays_of(again.readings, true));
            m.readings.insert(m.readings.end(), again.readings.begin(), again.readings.end());
            m.device_ms += again.device_ms;
          }
          if (lab.tolerances.two_face) {
            m.device_ms += turn_faces();
            Measurement face2;
            round(false, face2, target, lab.tolerances.readings);
            m.readings.insert(m.readings.end(), face2.readings.begin(), face2.readings.end());
            m.device_ms += face2.device_ms;
            m.device_ms += turn_faces();
          }
          group.rays = rays_of(m.readings);
          reduction::IntersectPoint(group, point_options, m.point);
          tracker_checks(m);
          const double cycle_ms = MsSince(cycle_start);
          cycle_sum += cycle_ms;
          overhead_sum += std::max(0.0, cycle_ms - m.device_ms);
          ++cycles;
          if (m.point.accepted() || measure_try == lab.tolerances.max_remeasure) {
            accepted = std::move(m);
            break;
          }
          ++summary.remeasured;
          spdlog::info("capture: {}: measuring again ({} of {}): {}", target.label,
                       measure_try + 1, lab.tolerances.max_remeasure,
                       m.point.result.status.ok()
                           ? ToString(m.point.result.flags)
                           : ToString(m.point.result.flags) + " " + m.point.result.status.message);
        }
      } catch (const instruments::ConventionMismatch&) {
        throw;  // no reading of that tracker can be used: the capture ends here
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
      summary.paused = true;
      summary.pause_reason = "configuration " + target.label + " (" + std::to_string(seq + 1) +
                             " of " + std::to_string(plan.size()) + "): " + fault;
      db::SetSessionState(db, session, "paused");
      break;
    }
    bool not_following = false;  // this configuration's point showed it
    const auto store_start = Clock::now();
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
        db::ObservationRow o = ObservationRowOf(ObservationOf(r, lab.instruments[r.instrument]),
                                                pose, r.reading.return_code);
        if (const auto& air = r.reading.environment) {
          o.temperature_c = air->temperature_c;
          o.pressure_hpa = air->pressure_hpa;
          o.humidity_percent = air->humidity_percent;
        }
        rows.push_back(std::move(o));
      }
      db::InsertObservations(db, session, rows);
      const reduction::IntersectionResult& result = m.point.result;
      const db::PointRow point =
          PointRowOf(pose, "target", static_cast<int>(m.readings.size()), result, result.flags);
      // Append this configuration's point (other sessions' points are untouched).
      db::InsertPoint(db, session, point);
      tx.commit();
      store_sum += MsSince(store_start);
      ++stores;
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
        if (r.reading.distance_mm) last_distance[r.instrument] = *r.reading.distance_mm;
      }
      if (result.status.ok() && m.point.accepted()) {
        const bool had_fit = predictor.fitted();
        predictor.Add(m.joints, result.position_mm);
        if (any_beam && !had_fit && predictor.fitted()) {
          spdlog::info("capture: robot base {}; the tracker beams point by prediction from now on",
                       predictor.Describe().substr(5));
        }
        not_following = pause_unless_following(
            fmt::format("configuration {} ({} of {})", target.label, seq + 1, plan.size()));
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
    if (not_following) break;
  }
  summary.seconds = std::chrono::duration<double>(Clock::now() - start).count();
  if (miss_count) {
    summary.mean_miss_mm = miss_sum / miss_count;
    summary.max_miss_mm = max_miss;
  }
  summary.mean_cycle_ms = cycles ? cycle_sum / cycles : 0.0;
  summary.mean_overhead_ms = cycles ? overhead_sum / cycles : 0.0;
  summary.mean_store_ms = stores ? store_sum / stores : 0.0;
  summary.beam_searches = searches.load();
  summary.beam_operator = operator_pointed.load();
  if (any_beam) summary.beam_base = predictor.Describe();
  if (!summary.paused && !summary.stopped) {
    summary.completed = true;
    db::SetSessionState(db, session, "completed");
  }
  return summary;
}

}  // namespace armsig::acquisition
