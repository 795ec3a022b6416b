#include "acquisition/on_the_move.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <mutex>
#include <nlohmann/json.hpp>
#include <numeric>
#include <thread>

#include "acquisition/controller_record.h"
#include "acquisition/observation_rows.h"
#include "acquisition/session_owner.h"
#include "calibration/estimation.h"
#include "core/error.h"
#include "core/text.h"
#include "db/controllers.h"
#include "db/observations.h"
#include "db/robots.h"
#include "db/sessions.h"
#include "db/streams.h"
#include "instruments/emscon_codec.h"
#include "instruments/emscon_device.h"
#include "reduction/intersection.h"

namespace armsig::acquisition {

namespace {

using Clock = std::chrono::steady_clock;

// The tracker's one-sigma error per coordinate at `distance_mm`: half the maximum
// permissible error U_xyz = 15 µm + 6 µm/m of an AT9xx-class tracker, as its continuous
// records state none.
double TrackerSigmaMm(double distance_mm) { return 0.5 * (0.015 + 6e-6 * distance_mm); }

// What the clock's uncertainty is expected to be once estimated: the budget SweepSpeed keeps
// the sweep under (a few tens of microseconds from a few thousand points at a few hundred
// mm/s; the estimate reports its own).
constexpr double kClockBudgetS = 5e-5;

bool Stopping(const CaptureOptions& o) { return o.stop && o.stop->load(); }

struct Segment {
  int index = 0;
  size_t first = 0, last = 0;  // waypoints, inclusive
};

std::vector<Segment> Segments(size_t waypoints, int per_segment) {
  std::vector<Segment> out;
  const auto step = static_cast<size_t>(std::max(1, per_segment));
  for (size_t first = 0; first + 1 < waypoints; first += step) {
    out.push_back({static_cast<int>(out.size()), first, std::min(first + step, waypoints - 1)});
  }
  return out;
}

}  // namespace

double SweepSpeed(double noise_mm, double clock_sigma_s, double reach_mm) {
  const double v_mm_s = noise_mm / std::max(clock_sigma_s, 1e-9);
  return std::clamp(v_mm_s / std::max(reach_mm, 1.0), 0.05, 1.05);
}

void CheckOnTheMoveLab(const io::LabConfig& lab) {
  const auto trackers = std::count_if(lab.instruments.begin(), lab.instruments.end(), [](const auto& i) {
    return i.protocol == io::InstrumentProtocol::kEmScon;
  });
  if (trackers != 1) {
    throw InputError({lab.source, 0, 0, "instruments"},
                     fmt::format("--on-the-move pairs one laser tracker (protocol: emscon) with the "
                                 "joints; this lab has {}",
                                 trackers));
  }
  if (lab.controller.protocol != io::ControllerProtocol::kUr || !lab.controller.can_move) {
    throw InputError({lab.source, 0, 0, "robot"},
                     "--on-the-move needs a controller that streams its joints and that armsig "
                     "moves: robot.controller {protocol: ur, host: …, can_move: true}");
  }
}

Plan SweepOrder(const Plan& plan) {
  Plan out;
  if (plan.empty()) return out;
  std::vector<char> used(plan.size(), 0);
  size_t at = 0;
  used[0] = 1;
  out.push_back(plan[0]);
  for (size_t n = 1; n < plan.size(); ++n) {
    size_t best = plan.size();
    double nearest = std::numeric_limits<double>::infinity();
    for (size_t k = 0; k < plan.size(); ++k) {
      if (used[k]) continue;
      const double turn = (plan[k].joints_rad - plan[at].joints_rad).cwiseAbs().maxCoeff();
      if (turn < nearest) {
        nearest = turn;
        best = k;
      }
    }
    used[best] = 1;
    at = best;
    out.push_back(plan[best]);
  }
  return out;
}

bool IsOnTheMoveSession(db::Database& db, int64_t session) {
  return db::SessionSync(db, session).has_value();
}

void MarkOnTheMove(db::Database& db, int64_t session) {
  db::SetSessionSync(db, session, R"({"mode":"on_the_move","paired":false})");
}

CaptureSummary RunSweepCapture(
    db::Database& db, const io::LabConfig& lab, int64_t session,
    std::vector<std::unique_ptr<instruments::DistanceInstrument>>& devices,
    instruments::RobotController& controller, const CaptureOptions& options) {
  const SweepOptions sweep = options.sweep.value_or(SweepOptions{});
  SweepSummary figures;
  CaptureSummary summary;
  summary.session = session;
  summary.single_ray = true;
  const auto started = Clock::now();
  // One laser tracker and a controller that streams its joints.
  instruments::EmsconDevice* tracker = nullptr;
  size_t tracker_index = 0;
  for (size_t i = 0; i < devices.size(); ++i) {
    if (auto* e = dynamic_cast<instruments::EmsconDevice*>(devices[i].get())) {
      if (tracker) {
        throw InputError({lab.source, 0, 0, "instruments"},
                         "measuring on the move pairs one laser tracker with the joints; this "
                         "lab has several");
      }
      tracker = e;
      tracker_index = i;
    }
  }
  if (!tracker) {
    throw InputError({lab.source, 0, 0, "instruments"},
                     "measuring on the move needs a laser tracker (protocol: emscon) measuring "
                     "continuously; this lab has none");
  }
  if (!controller.StreamsJoints() || !controller.CanMove()) {
    throw InputError({lab.source, 0, 0, "robot"},
                     "measuring on the move needs a controller armsig moves that streams its "
                     "joints (protocol: ur, can_move: true)");
  }
  const std::string station_code = lab.instruments[tracker_index].station;
  const reduction::Station* station = nullptr;
  for (const auto& s : lab.stations) {
    if (s.pose.id == station_code) station = &s;
  }
  if (!station) {
    throw InputError({lab.source, 0, 0, "stations"}, "no oriented station " + station_code);
  }
  const auto row = db::LoadSession(db, session);
  if (!row) throw InputError({db.path(), 0, 0, ""}, "no session " + std::to_string(session));
  const Plan plan = PlanFromJson(row->plan_json, {db.path(), "sessions", session, "plan_json"});
  if (plan.size() < 2) {
    throw InputError({db.path(), 0, 0, ""},
                     fmt::format("session {}: a sweep needs at least two configurations", session));
  }
  db::SetSessionOwner(db, session, ThisProcess());
  db::SetSessionState(db, session, db::SessionState::kRunning);
  // Who the controller is, checked against the lab and the store and kept with the session,
  // as a stationary session does (another arm is refused before anything moves).
  try {
    const ControllerFacts facts = AskController(controller);
    if (facts.identity) {
      CheckControllerFacts(db, lab, row->robot, session, facts);
      summary.controller = facts.Describe();
      db::WriteTransaction tx(db);
      if (!db::SessionController(db, session)) db::SetSessionController(db, session, facts.Record());
      if (const auto robot_id = db::FindRobot(db, row->robot))
        db::RecordRobotController(db, *robot_id, facts.Record());
      tx.commit();
    }
  } catch (...) {
    db::SetSessionState(db, session, db::SessionState::kPaused);
    if (Stopping(options)) {
      summary.stopped = true;
      return summary;
    }
    throw;
  }
  // How far the target reaches from the first joint (the speed's lever).
  double reach_mm = 0.0;
  {
    calibration::Kinematics kin(lab.model);
    const Eigen::VectorXd zero = Eigen::VectorXd::Zero(lab.model.num_parameters());
    for (const auto& c : plan) {
      reach_mm = std::max(
          reach_mm, kin.Position(Eigen::Isometry3d::Identity(), zero, c.joints_rad.data()).norm());
    }
  }
  figures.speed_rad_s = sweep.speed_rad_s > 0.0
                            ? sweep.speed_rad_s
                            : SweepSpeed(2.0 * TrackerSigmaMm(2000.0), kClockBudgetS, reach_mm);
  const std::vector<Segment> segments = Segments(plan.size(), sweep.waypoints_per_segment);
  const std::set<int> stored = db::StoredStreamSegments(db, session);
  figures.segments = static_cast<int>(segments.size());
  figures.segments_before = static_cast<int>(stored.size());
  summary.total = figures.segments;
  summary.already = figures.segments_before;
  const auto pause = [&](const std::string& why) {
    summary.paused = true;
    summary.pause_reason = why;
    db::SetSessionState(db, session, db::SessionState::kPaused);
  };
  {
    const InterruptScope interrupts(devices, controller, options.stop);
    for (const Segment& seg : segments) {
      if (stored.count(seg.index)) continue;
      if (Stopping(options)) {
        summary.stopped = true;
        db::SetSessionState(db, session, db::SessionState::kPaused);
        break;
      }
      db::StreamSegment rows;
      rows.segment = seg.index;
      std::mutex tracker_rows;
      std::exception_ptr tracker_failed;
      std::atomic<bool> done{false};
      try {
        controller.MoveTo(plan[seg.first].joints_rad);
        tracker->StartContinuous({sweep.tracker_separation_ms, std::nullopt});
        std::thread reader([&] {
          try {
            tracker->ReadContinuous(
                instruments::Clock::now() + std::chrono::hours(2), done,
                [&](const instruments::ContinuousRecord& r) {
                  std::lock_guard lock(tracker_rows);
                  rows.points.push_back({station_code, r.tracker_time_s, r.angles.hz_rad,
                                         r.angles.v_rad, r.distance_mm, r.status});
                },
                [&](const instruments::ContinuousEvent& e) {
                  std::lock_guard lock(tracker_rows);
                  rows.events.push_back({station_code, e.after_tracker_time_s, e.status, e.what});
                });
          } catch (...) {
            tracker_failed = std::current_exception();
          }
        });
        std::vector<Eigen::VectorXd> waypoints;
        for (size_t k = seg.first + 1; k <= seg.last; ++k) waypoints.push_back(plan[k].joints_rad);
        try {
          controller.Sweep(waypoints, figures.speed_rad_s, sweep.acceleration_rad_s2,
                           [&](const instruments::JointSample& s) {
                             rows.joints.push_back({s.controller_time_s, s.q_rad, s.qd_rad_s});
                           });
        } catch (...) {
          done = true;
          reader.join();
          throw;
        }
        done = true;
        reader.join();
        if (tracker_failed) std::rethrow_exception(tracker_failed);
        tracker->StopContinuous();
      } catch (const std::exception& e) {
        // Nothing of this segment is stored: a resume sweeps it again.
        try {
          tracker->StopContinuous();
        } catch (const std::exception&) {
        }
        if (Stopping(options)) {
          summary.stopped = true;
          db::SetSessionState(db, session, db::SessionState::kPaused);
          break;
        }
        pause(fmt::format("segment {} of {} (configurations {} to {}): {}", seg.index + 1,
                          segments.size(), plan[seg.first].label, plan[seg.last].label, e.what()));
        break;
      }
      if (rows.joints.size() >= 2)
        figures.robot_time_s += rows.joints.back().t_s - rows.joints.front().t_s;
      figures.joint_packages += static_cast<int>(rows.joints.size());
      figures.tracker_records += static_cast<int>(rows.points.size());
      for (const auto& e : rows.events) {
        figures.beam_breaks.push_back(
            fmt::format("station {}, segment {}, after tracker time {:.3f} s: {}", station_code,
                        seg.index + 1, e.t_s, e.what));
        spdlog::warn("capture: station {}: {} (segment {}); the stream goes on", station_code,
                     e.what, seg.index + 1);
      }
      {
        db::WriteTransaction tx(db);
        db::InsertStreamSegment(db, session, rows);
        tx.commit();
      }
      ++summary.measured;
      if (options.progress) {
        Progress p;
        p.done = summary.already + summary.measured;
        p.total = summary.total;
        p.label = fmt::format("segment {} ({} points)", seg.index + 1, rows.points.size());
        p.elapsed_s = std::chrono::duration<double>(Clock::now() - started).count();
        p.eta_s = p.done > summary.already
                      ? p.elapsed_s / (p.done - summary.already) * (p.total - p.done)
                      : 0.0;
        options.progress(p);
      }
    }
  }
  figures.refused_records = tracker->continuous_refused();
  summary.seconds = std::chrono::duration<double>(Clock::now() - started).count();
  if (summary.stopped || summary.paused) {
    summary.sweep = figures;
    return summary;
  }

  // --- Every segment stored: the clock, then the pairing -----------------------------------
  const db::SessionStreams streams = db::LoadSessionStreams(db, session);
  calibration::JointStream joints;
  {
    std::vector<size_t> order(streams.joints.size());
    std::iota(order.begin(), order.end(), size_t{0});
    std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) {
      return streams.joints[a].t_s < streams.joints[b].t_s;
    });
    for (size_t i : order) {
      joints.t_s.push_back(streams.joints[i].t_s);
      joints.q_rad.push_back(streams.joints[i].q_rad);
      joints.qd_rad_s.push_back(streams.joints[i].qd_rad_s);
    }
  }
  calibration::PointStream points;
  std::vector<const db::StreamPointRow*> point_rows;
  for (const auto& p : streams.points) {
    if (p.station == station_code) point_rows.push_back(&p);
  }
  std::stable_sort(point_rows.begin(), point_rows.end(),
                   [](const auto* a, const auto* b) { return a->t_s < b->t_s; });
  for (const auto* p : point_rows) {
    const Eigen::Vector3d in_station = instruments::emscon::PointFromSpherical(
        {p->hz_rad, p->v_rad, p->distance_mm});
    points.t_s.push_back(p->t_s);
    points.point_mm.push_back(station->pose.position_mm + station->pose.world_from_station * in_station);
  }
  figures.beam_breaks.clear();  // every run's, from the store
  for (const auto& e : streams.events) {
    figures.beam_breaks.push_back(
        fmt::format("station {}, after tracker time {:.3f} s: {}", e.station, e.t_s, e.what));
  }
  if (joints.size() < 2 || points.size() < 20) {
    pause(fmt::format("the sweep gave {} joint packages and {} tracker points: too few to pair",
                      joints.size(), points.size()));
    summary.sweep = figures;
    return summary;
  }
  const calibration::RobotModel& model = lab.model;
  Eigen::VectorXd params = Eigen::VectorXd::Zero(model.num_parameters());
  Eigen::Isometry3d base = Eigen::Isometry3d::Identity();
  calibration::ClockMap clock;
  ClockEstimate estimate;
  if (sweep.assumed_offset_ms) {
    clock.offset_s = *sweep.assumed_offset_ms * 1e-3;
    clock.reference_s = points.t_s.front();
    estimate.assumed = true;
  } else {
    calibration::ClockMap guess;
    guess.offset_s = points.t_s.front() - joints.t_s.front();
    const auto coarse = calibration::CoarseClock(model, params, joints, points, guess, sweep.clock);
    if (!coarse) {
      // Tell a stream too sparse to interpolate from streams that never met.
      std::vector<double> steps;
      for (size_t i = 1; i < joints.size(); ++i) steps.push_back(joints.t_s[i] - joints.t_s[i - 1]);
      std::nth_element(steps.begin(), steps.begin() + steps.size() / 2, steps.end());
      const double median = steps[steps.size() / 2];
      pause(median > sweep.clock.max_gap_s
                ? fmt::format("the joint stream's packages are {:.1f} ms apart (median): too far "
                              "to interpolate the joints at the tracker's instants (at most {:.0f} "
                              "ms); raise the controller's stream frequency",
                              median * 1e3, sweep.clock.max_gap_s * 1e3)
                : std::string("the tracker's and the controller's streams do not overlap in time: "
                              "no clock offset lines their speeds up (was the tracker measuring "
                              "the robot?)"));
      summary.sweep = figures;
      return summary;
    }
    clock = calibration::RefineClock(model, params, joints, points, *coarse, base, sweep.clock);
    // The nominal model's errors bias the clock: fit the model to the points the clock pairs,
    // refine the clock with it, and again.
    calibration::EstimationOptions fit_options;
    fit_options.parameters = calibration::ParseParameterSpec(model, "geometric");
    calibration::PairingOptions loose = sweep.pairing;
    loose.max_sync_sigma_mm = std::numeric_limits<double>::infinity();
    for (int round = 0; round < sweep.clock_rounds; ++round) {
      const auto paired = calibration::PairStreams(model, params, base, joints, points, clock, loose);
      std::vector<MeasuredPose> poses;
      const size_t stride = std::max<size_t>(1, paired.points.size() / 600);
      for (size_t k = 0; k < paired.points.size(); k += stride) {
        const auto& p = paired.points[k];
        poses.push_back({"m" + std::to_string(k), p.q_rad, p.point_mm, 0});
      }
      if (poses.size() < 30) break;
      const auto fit = calibration::Estimate(model, poses, fit_options);
      if (!fit.usable()) break;
      params = fit.params;
      clock = calibration::RefineClock(model, params, joints, points, clock, base, sweep.clock);
      spdlog::debug("capture: clock round {}: offset {:.4f} ms, drift {:.2f} ppm, σ0 {:.4f} mm",
                    round + 1, clock.offset_s * 1e3, clock.drift * 1e6, clock.sigma0_mm);
    }
    estimate.sigma0_mm = clock.sigma0_mm;
  }
  estimate.offset_ms = clock.offset_s * 1e3;
  estimate.drift_ppm = clock.drift * 1e6;
  estimate.sigma_ms = clock.SigmaAt(clock.reference_s) * 1e3;
  figures.clock = estimate;
  const calibration::Pairing paired =
      calibration::PairStreams(model, params, base, joints, points, clock, sweep.pairing);
  figures.paired = static_cast<int>(paired.points.size());
  figures.left_accelerating = paired.accelerating;
  figures.left_gaps = paired.gaps;
  figures.left_outside = paired.outside;
  figures.left_uncertain = paired.uncertain;
  for (const auto& p : paired.points) {
    figures.mean_sync_sigma_mm += p.sync_sigma_mm / std::max<size_t>(1, paired.points.size());
    figures.max_sync_sigma_mm = std::max(figures.max_sync_sigma_mm, p.sync_sigma_mm);
  }

  // --- The paired points as configurations, in one transaction ------------------------------
  {
    db::WriteTransaction tx(db);
    const reduction::InstrumentDefaults defaults;
    std::vector<db::ObservationRow> observations;
    std::vector<db::PointRow> point_rows_out;
    int seq = 0;
    for (const auto& p : paired.points) {
      const db::StreamPointRow& raw = *point_rows[p.index];
      const int64_t pose = db::InsertPose(db, session, seq, fmt::format("M{}", seq + 1), p.q_rad,
                                          "measured", 1, p.controller_time_s);
      ++seq;
      db::ObservationRow o;
      o.pose_id = pose;
      o.point = "target";
      o.station = station_code;
      o.reading = {raw.hz_rad, raw.v_rad, 1};
      o.distance_mm = raw.distance_mm;
      const double sigma = TrackerSigmaMm(raw.distance_mm);
      const double sin_v = std::max(1e-6, std::sin(raw.v_rad));
      o.sigma_hz_rad = sigma / (raw.distance_mm * sin_v);
      o.sigma_v_rad = sigma / raw.distance_mm;
      o.sigma_distance_mm = sigma;
      o.note = fmt::format("on the move: tracker time {:.6f} s", raw.t_s);
      reduction::RayGroup group;
      group.rays.push_back(reduction::RayOf(ObservationOf(o), *station, defaults));
      const reduction::ReducedPoint reduced = reduction::IntersectPoint(group);
      db::PointRow row = PointRowOf(pose, "target", 1, reduced.result, reduced.result.flags);
      row.sync_sigma_mm = p.sync_sigma_mm;
      row.covariance_mm2 += p.sync_sigma_mm * p.sync_sigma_mm * Eigen::Matrix3d::Identity();
      observations.push_back(std::move(o));
      point_rows_out.push_back(std::move(row));
    }
    db::InsertObservations(db, session, observations);
    for (const auto& r : point_rows_out) db::InsertPoint(db, session, r);
    nlohmann::json sync = {{"mode", "on_the_move"},
                           {"paired", true},
                           {"offset_ms", estimate.offset_ms},
                           {"drift_ppm", estimate.drift_ppm},
                           {"sigma_ms", estimate.sigma_ms},
                           {"sigma0_mm", estimate.sigma0_mm},
                           {"assumed", estimate.assumed},
                           {"points", figures.paired},
                           {"left_accelerating", figures.left_accelerating},
                           {"left_gaps", figures.left_gaps},
                           {"left_outside", figures.left_outside},
                           {"left_uncertain", figures.left_uncertain},
                           {"beam_breaks", streams.events.size()},
                           {"speed_rad_s", figures.speed_rad_s}};
    db::SetSessionSync(db, session, JsonText(sync));
    db::SetSessionState(db, session, db::SessionState::kCompleted);
    tx.commit();
  }
  summary.completed = true;
  summary.measured = summary.usable = figures.paired;
  summary.seconds = std::chrono::duration<double>(Clock::now() - started).count();
  summary.sweep = figures;
  return summary;
}

}  // namespace armsig::acquisition
