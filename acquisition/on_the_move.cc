#include "acquisition/on_the_move.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <functional>
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

std::vector<SweepSpan> Segments(size_t waypoints, int per_segment) {
  std::vector<SweepSpan> out;
  const auto step = static_cast<size_t>(std::max(1, per_segment));
  for (size_t first = 0; first + 1 < waypoints; first += step) {
    out.push_back({static_cast<int>(out.size()), first, std::min(first + step, waypoints - 1)});
  }
  return out;
}

}  // namespace

std::vector<SweepSpan> PathSegments(const Plan& plan) {
  std::vector<SweepSpan> out;
  size_t first = 0;
  for (size_t k = 1; k <= plan.size(); ++k) {
    const bool linear = k < plan.size() && plan[k].linear_speed_mm_s;
    const bool same = linear && (k == first + 1 ||
                                 plan[k].linear_speed_mm_s == plan[k - 1].linear_speed_mm_s);
    if (same) continue;
    if (k - 1 > first) out.push_back({static_cast<int>(out.size()), first, k - 1});
    first = linear ? k - 1 : k;
  }
  return out;
}

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

namespace {

// The streams of a session's stored segments, ready to pair: the joint packages and the
// tracker's points (world frame) in time order, the rows the points came from, the events.
struct LoadedStreams {
  calibration::JointStream joints;
  calibration::PointStream points;
  db::SessionStreams raw;
  std::vector<const db::StreamPointRow*> point_rows;  // into raw.points, as `points`
};

// The clock and the model the pairing used (the fitted one, or nominal).
struct ClockFit {
  calibration::ClockMap clock;
  ClockEstimate estimate;
  Eigen::VectorXd params;
  Eigen::Isometry3d base = Eigen::Isometry3d::Identity();
};

// One sweep capture (RunSweepCapture): set up, the segments, then the clock and the pairing.
class SweepRun {
 public:
  SweepRun(db::Database& db, const io::LabConfig& lab, int64_t session,
           std::vector<std::unique_ptr<instruments::DistanceInstrument>>& devices,
           instruments::RobotController& controller, const CaptureOptions& options)
      : db_(db), lab_(lab), session_(session), devices_(devices), controller_(controller),
        options_(options), sweep_(options.sweep.value_or(SweepOptions{})) {
    summary_.session = session;
    summary_.single_ray = true;
  }

  CaptureSummary Run() {
    if (!SetUp()) return Done();
    SweepSegments();
    figures_.refused_records = tracker_->continuous_refused();
    if (summary_.stopped || summary_.paused) return Done();
    const LoadedStreams streams = LoadStreams();
    if (streams.joints.size() < 2 || streams.points.size() < 20) {
      Pause(fmt::format("the sweep gave {} joint packages and {} tracker points: too few to pair",
                        streams.joints.size(), streams.points.size()));
      return Done();
    }
    const std::optional<ClockFit> fit = EstimateClock(streams);
    if (!fit) return Done();
    StorePairs(streams, *fit);
    return Done();
  }

 private:
  CaptureSummary Done() {
    summary_.seconds = std::chrono::duration<double>(Clock::now() - started_).count();
    summary_.sweep = figures_;
    return summary_;
  }
  void Pause(const std::string& why) {
    summary_.paused = true;
    summary_.pause_reason = why;
    db::SetSessionState(db_, session_, db::SessionState::kPaused);
  }
  void Stop() {
    summary_.stopped = true;
    db::SetSessionState(db_, session_, db::SessionState::kPaused);
  }

  bool SetUp();
  void SweepSegments();
  // Sweeps one segment into `rows` (the devices' work; throws what they throw).
  void SweepSegment(const SweepSpan& seg, db::StreamSegment& rows);
  void Stored(const SweepSpan& seg, const db::StreamSegment& rows);
  LoadedStreams LoadStreams() const;
  // nullopt when no clock lines the streams up (the session is paused, saying why).
  std::optional<ClockFit> EstimateClock(const LoadedStreams& s);
  void StorePairs(const LoadedStreams& s, const ClockFit& fit);

  db::Database& db_;
  const io::LabConfig& lab_;
  const int64_t session_;
  std::vector<std::unique_ptr<instruments::DistanceInstrument>>& devices_;
  instruments::RobotController& controller_;
  const CaptureOptions& options_;
  const SweepOptions sweep_;
  const Clock::time_point started_ = Clock::now();
  SweepSummary figures_;
  CaptureSummary summary_;
  instruments::EmsconDevice* tracker_ = nullptr;
  std::string station_code_;
  const reduction::Station* station_ = nullptr;
  Plan plan_;
  std::vector<SweepSpan> segments_;
  bool path_ = false;  // an ISO 9283 path plan (linear moves)
};

// One laser tracker, a controller that streams its joints, the plan; who the controller is.
// False when stopped while the controller was asked.
bool SweepRun::SetUp() {
  size_t tracker_index = 0;
  for (size_t i = 0; i < devices_.size(); ++i) {
    if (auto* e = dynamic_cast<instruments::EmsconDevice*>(devices_[i].get())) {
      if (tracker_) {
        throw InputError({lab_.source, 0, 0, "instruments"},
                         "measuring on the move pairs one laser tracker with the joints; this "
                         "lab has several");
      }
      tracker_ = e;
      tracker_index = i;
    }
  }
  if (!tracker_) {
    throw InputError({lab_.source, 0, 0, "instruments"},
                     "measuring on the move needs a laser tracker (protocol: emscon) measuring "
                     "continuously; this lab has none");
  }
  if (!controller_.StreamsJoints() || !controller_.CanMove()) {
    throw InputError({lab_.source, 0, 0, "robot"},
                     "measuring on the move needs a controller armsig moves that streams its "
                     "joints (protocol: ur, can_move: true)");
  }
  station_code_ = lab_.instruments[tracker_index].station;
  for (const auto& s : lab_.stations) {
    if (s.pose.id == station_code_) station_ = &s;
  }
  if (!station_) {
    throw InputError({lab_.source, 0, 0, "stations"}, "no oriented station " + station_code_);
  }
  const auto row = db::LoadSession(db_, session_);
  if (!row) throw InputError({db_.path(), 0, 0, ""}, "no session " + std::to_string(session_));
  plan_ = PlanFromJson(row->plan_json, {db_.path(), "sessions", session_, "plan_json"});
  if (plan_.size() < 2) {
    throw InputError({db_.path(), 0, 0, ""},
                     fmt::format("session {}: a sweep needs at least two configurations", session_));
  }
  db::SetSessionOwner(db_, session_, ThisProcess());
  db::SetSessionState(db_, session_, db::SessionState::kRunning);
  // Who the controller is, checked against the lab and the store and kept with the session,
  // as a stationary session does (another arm is refused before anything moves).
  try {
    const ControllerFacts facts = AskController(controller_);
    if (facts.identity) {
      CheckControllerFacts(db_, lab_, row->robot, session_, facts);
      summary_.controller = facts.Describe();
      db::WriteTransaction tx(db_);
      if (!db::SessionController(db_, session_)) db::SetSessionController(db_, session_, facts.Record());
      if (const auto robot_id = db::FindRobot(db_, row->robot))
        db::RecordRobotController(db_, *robot_id, facts.Record());
      tx.commit();
    }
  } catch (...) {
    db::SetSessionState(db_, session_, db::SessionState::kPaused);
    if (!Stopping(options_)) throw;
    summary_.stopped = true;
    return false;
  }
  // How far the target reaches from the first joint (the speed's lever).
  double reach_mm = 0.0;
  calibration::Kinematics kin(lab_.model);
  const Eigen::VectorXd zero = Eigen::VectorXd::Zero(lab_.model.num_parameters());
  for (const auto& c : plan_) {
    reach_mm = std::max(
        reach_mm, kin.Position(Eigen::Isometry3d::Identity(), zero, c.joints_rad.data()).norm());
  }
  figures_.speed_rad_s = sweep_.speed_rad_s > 0.0
                             ? sweep_.speed_rad_s
                             : SweepSpeed(2.0 * TrackerSigmaMm(2000.0), kClockBudgetS, reach_mm);
  path_ = HasLinearMoves(plan_);
  for (const auto& c : plan_) {
    if (c.linear_speed_mm_s) figures_.path_speed_mm_s = std::max(figures_.path_speed_mm_s, *c.linear_speed_mm_s);
  }
  segments_ = path_ ? PathSegments(plan_) : Segments(plan_.size(), sweep_.waypoints_per_segment);
  return true;
}

// Every segment not stored yet, each in one transaction; Ctrl-C or a fault stops between
// segments (the one in flight is swept again by a resume).
void SweepRun::SweepSegments() {
  const std::set<int> stored = db::StoredStreamSegments(db_, session_);
  figures_.segments = static_cast<int>(segments_.size());
  figures_.segments_before = static_cast<int>(stored.size());
  summary_.total = figures_.segments;
  summary_.already = figures_.segments_before;
  const InterruptScope interrupts(devices_, controller_, options_.stop);
  for (const SweepSpan& seg : segments_) {
    if (stored.count(seg.index)) continue;
    if (Stopping(options_)) return Stop();
    db::StreamSegment rows;
    rows.segment = seg.index;
    try {
      SweepSegment(seg, rows);
    } catch (const std::exception& e) {
      try {
        tracker_->StopContinuous();
      } catch (const std::exception&) {
      }
      if (Stopping(options_)) return Stop();
      return Pause(fmt::format("segment {} of {} (configurations {} to {}): {}", seg.index + 1,
                               segments_.size(), plan_[seg.first].label, plan_[seg.last].label,
                               e.what()));
    }
    Stored(seg, rows);
  }
}

// The arm to the segment's first waypoint, the tracker measuring continuously on a thread of
// its own while the controller sweeps through the rest and streams its joints.
void SweepRun::SweepSegment(const SweepSpan& seg, db::StreamSegment& rows) {
  std::mutex tracker_rows;
  std::exception_ptr tracker_failed;
  std::atomic<bool> done{false};
  controller_.MoveTo(plan_[seg.first].joints_rad);
  tracker_->StartContinuous(
      {path_ ? sweep_.path_tracker_separation_ms : sweep_.tracker_separation_ms, std::nullopt});
  const std::function<void(const instruments::ContinuousRecord&)> keep =
      [&](const instruments::ContinuousRecord& r) {
        std::lock_guard lock(tracker_rows);
        rows.points.push_back({station_code_, r.tracker_time_s, r.angles.hz_rad, r.angles.v_rad,
                               r.distance_mm, r.status});
      };
  std::thread reader([&] {
    try {
      tracker_->ReadContinuous(
          instruments::Clock::now() + std::chrono::hours(2), done, keep,
          [&](const instruments::ContinuousEvent& e) {
            std::lock_guard lock(tracker_rows);
            rows.events.push_back({station_code_, e.after_tracker_time_s, e.status, e.what});
          });
    } catch (...) {
      tracker_failed = std::current_exception();
    }
  });
  std::vector<Eigen::VectorXd> waypoints;
  for (size_t k = seg.first + 1; k <= seg.last; ++k) waypoints.push_back(plan_[k].joints_rad);
  try {
    instruments::SweepMotion motion;
    motion.speed_rad_s = figures_.speed_rad_s;
    motion.acceleration_rad_s2 = sweep_.acceleration_rad_s2;
    if (const auto& v = plan_[seg.last].linear_speed_mm_s) {
      motion.linear_speed_mm_s = *v;
      motion.linear_acceleration_mm_s2 = sweep_.linear_acceleration_mm_s2;
      motion.circular = plan_[seg.first + 1].via;  // a circle: (via, target) pairs
    }
    controller_.Sweep(waypoints, motion, [&](const instruments::JointSample& s) {
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
  // The records a reader behind the tracker has not read yet (the arm's last moments) are kept.
  tracker_->StopContinuous(keep);
}

// A swept segment's rows in one transaction, its figures and the progress.
void SweepRun::Stored(const SweepSpan& seg, const db::StreamSegment& rows) {
  if (rows.joints.size() >= 2)
    figures_.robot_time_s += rows.joints.back().t_s - rows.joints.front().t_s;
  figures_.joint_packages += static_cast<int>(rows.joints.size());
  figures_.tracker_records += static_cast<int>(rows.points.size());
  for (const auto& e : rows.events) {
    figures_.beam_breaks.push_back(fmt::format("station {}, segment {}, after tracker time {:.3f} s: {}",
                                               station_code_, seg.index + 1, e.t_s, e.what));
    spdlog::warn("capture: station {}: {} (segment {}); the stream goes on", station_code_, e.what,
                 seg.index + 1);
  }
  db::WriteTransaction tx(db_);
  db::InsertStreamSegment(db_, session_, rows);
  tx.commit();
  ++summary_.measured;
  if (!options_.progress) return;
  Progress p;
  p.done = summary_.already + summary_.measured;
  p.total = summary_.total;
  p.label = fmt::format("segment {} ({} points)", seg.index + 1, rows.points.size());
  p.elapsed_s = std::chrono::duration<double>(Clock::now() - started_).count();
  p.eta_s = p.done > summary_.already ? p.elapsed_s / (p.done - summary_.already) * (p.total - p.done)
                                      : 0.0;
  options_.progress(p);
}

// Every stored segment's rows (this run's and earlier runs'), in time order; the beam breaks
// of all of them named in the figures.
LoadedStreams SweepRun::LoadStreams() const {
  LoadedStreams s;
  s.raw = db::LoadSessionStreams(db_, session_);
  std::vector<size_t> order(s.raw.joints.size());
  std::iota(order.begin(), order.end(), size_t{0});
  std::stable_sort(order.begin(), order.end(),
                   [&](size_t a, size_t b) { return s.raw.joints[a].t_s < s.raw.joints[b].t_s; });
  for (size_t i : order) {
    s.joints.t_s.push_back(s.raw.joints[i].t_s);
    s.joints.q_rad.push_back(s.raw.joints[i].q_rad);
    s.joints.qd_rad_s.push_back(s.raw.joints[i].qd_rad_s);
  }
  for (const auto& p : s.raw.points) {
    if (p.station == station_code_) s.point_rows.push_back(&p);
  }
  std::stable_sort(s.point_rows.begin(), s.point_rows.end(),
                   [](const auto* a, const auto* b) { return a->t_s < b->t_s; });
  for (const auto* p : s.point_rows) {
    const Eigen::Vector3d in_station =
        instruments::emscon::PointFromSpherical({p->hz_rad, p->v_rad, p->distance_mm});
    s.points.t_s.push_back(p->t_s);
    s.points.point_mm.push_back(station_->pose.position_mm +
                                station_->pose.world_from_station * in_station);
  }
  return s;
}

std::optional<ClockFit> SweepRun::EstimateClock(const LoadedStreams& s) {
  figures_.beam_breaks.clear();  // every run's, from the store
  for (const auto& e : s.raw.events) {
    figures_.beam_breaks.push_back(
        fmt::format("station {}, after tracker time {:.3f} s: {}", e.station, e.t_s, e.what));
  }
  const calibration::RobotModel& model = lab_.model;
  ClockFit fit;
  fit.params = Eigen::VectorXd::Zero(model.num_parameters());
  // A path's points lie in one plane of the work space: no model of their own to fit, so
  // they are paired with the robot's active arm signature (else the nominal model).
  if (path_ && options_.prediction_params && options_.prediction_params->size() == fit.params.size())
    fit.params = *options_.prediction_params;
  if (sweep_.assumed_offset_ms) {
    fit.clock.offset_s = *sweep_.assumed_offset_ms * 1e-3;
    fit.clock.reference_s = s.points.t_s.front();
    fit.estimate.assumed = true;
  } else {
    calibration::ClockMap guess;
    guess.offset_s = s.points.t_s.front() - s.joints.t_s.front();
    const auto coarse = calibration::CoarseClock(model, fit.params, s.joints, s.points, guess, sweep_.clock);
    if (!coarse) {
      // Tell a stream too sparse to interpolate from streams that never met.
      std::vector<double> steps;
      for (size_t i = 1; i < s.joints.size(); ++i) steps.push_back(s.joints.t_s[i] - s.joints.t_s[i - 1]);
      std::nth_element(steps.begin(), steps.begin() + steps.size() / 2, steps.end());
      const double median = steps[steps.size() / 2];
      Pause(median > sweep_.clock.max_gap_s
                ? fmt::format("the joint stream's packages are {:.1f} ms apart (median): too far "
                              "to interpolate the joints at the tracker's instants (at most {:.0f} "
                              "ms); raise the controller's stream frequency",
                              median * 1e3, sweep_.clock.max_gap_s * 1e3)
                : std::string("the tracker's and the controller's streams do not overlap in time: "
                              "no clock offset lines their speeds up (was the tracker measuring "
                              "the robot?)"));
      return std::nullopt;
    }
    fit.clock = calibration::RefineClock(model, fit.params, s.joints, s.points, *coarse, fit.base, sweep_.clock);
    // The nominal model's errors bias the clock: fit the model to the points the clock pairs,
    // refine the clock with it, and again.
    calibration::EstimationOptions fit_options;
    fit_options.parameters = calibration::ParseParameterSpec(model, "geometric");
    calibration::PairingOptions loose = sweep_.pairing;
    loose.max_sync_sigma_mm = std::numeric_limits<double>::infinity();
    for (int round = 0; round < (path_ ? 0 : sweep_.clock_rounds); ++round) {
      const auto paired =
          calibration::PairStreams(model, fit.params, fit.base, s.joints, s.points, fit.clock, loose);
      std::vector<MeasuredPose> poses;
      const size_t stride = std::max<size_t>(1, paired.points.size() / 600);
      for (size_t k = 0; k < paired.points.size(); k += stride) {
        const auto& p = paired.points[k];
        poses.push_back({"m" + std::to_string(k), p.q_rad, p.point_mm, 0});
      }
      if (poses.size() < 30) break;
      const auto estimated = calibration::Estimate(model, poses, fit_options);
      if (!estimated.usable()) break;
      fit.params = estimated.params;
      fit.clock = calibration::RefineClock(model, fit.params, s.joints, s.points, fit.clock, fit.base,
                                           sweep_.clock);
      spdlog::debug("capture: clock round {}: offset {:.4f} ms, drift {:.2f} ppm, σ0 {:.4f} mm",
                    round + 1, fit.clock.offset_s * 1e3, fit.clock.drift * 1e6, fit.clock.sigma0_mm);
    }
    fit.estimate.sigma0_mm = fit.clock.sigma0_mm;
  }
  fit.estimate.offset_ms = fit.clock.offset_s * 1e3;
  fit.estimate.drift_ppm = fit.clock.drift * 1e6;
  fit.estimate.sigma_ms = fit.clock.SigmaAt(fit.clock.reference_s) * 1e3;
  figures_.clock = fit.estimate;
  return fit;
}

// The paired points as configurations (pose, observation, reduced point with its clock
// share), the clock with the session, the session completed: one transaction.
void SweepRun::StorePairs(const LoadedStreams& s, const ClockFit& fit) {
  const calibration::Pairing paired = calibration::PairStreams(
      lab_.model, fit.params, fit.base, s.joints, s.points, fit.clock, sweep_.pairing);
  figures_.paired = static_cast<int>(paired.points.size());
  figures_.left_accelerating = paired.accelerating;
  figures_.left_gaps = paired.gaps;
  figures_.left_outside = paired.outside;
  figures_.left_uncertain = paired.uncertain;
  for (const auto& p : paired.points) {
    figures_.mean_sync_sigma_mm += p.sync_sigma_mm / std::max<size_t>(1, paired.points.size());
    figures_.max_sync_sigma_mm = std::max(figures_.max_sync_sigma_mm, p.sync_sigma_mm);
  }
  db::WriteTransaction tx(db_);
  const reduction::InstrumentDefaults defaults;
  std::vector<db::ObservationRow> observations;
  std::vector<db::PointRow> point_rows;
  int seq = 0;
  for (const auto& p : paired.points) {
    const db::StreamPointRow& raw = *s.point_rows[p.index];
    const int64_t pose = db::InsertPose(db_, session_, seq, fmt::format("M{}", seq + 1), p.q_rad,
                                        "measured", 1, p.controller_time_s);
    ++seq;
    db::ObservationRow o;
    o.pose_id = pose;
    o.point = "target";
    o.station = station_code_;
    o.reading = {raw.hz_rad, raw.v_rad, 1};
    o.distance_mm = raw.distance_mm;
    const double sigma = TrackerSigmaMm(raw.distance_mm);
    const double sin_v = std::max(1e-6, std::sin(raw.v_rad));
    o.sigma_hz_rad = sigma / (raw.distance_mm * sin_v);
    o.sigma_v_rad = sigma / raw.distance_mm;
    o.sigma_distance_mm = sigma;
    o.note = fmt::format("on the move: tracker time {:.6f} s", raw.t_s);
    reduction::RayGroup group;
    group.rays.push_back(reduction::RayOf(ObservationOf(o), *station_, defaults));
    const reduction::ReducedPoint reduced = reduction::IntersectPoint(group);
    db::PointRow row = PointRowOf(pose, "target", 1, reduced.result, reduced.result.flags);
    row.sync_sigma_mm = p.sync_sigma_mm;
    row.covariance_mm2 += p.sync_sigma_mm * p.sync_sigma_mm * Eigen::Matrix3d::Identity();
    observations.push_back(std::move(o));
    point_rows.push_back(std::move(row));
  }
  db::InsertObservations(db_, session_, observations);
  for (const auto& r : point_rows) db::InsertPoint(db_, session_, r);
  const ClockEstimate& e = fit.estimate;
  const nlohmann::json sync = {{"mode", "on_the_move"},
                               {"paired", true},
                               {"offset_ms", e.offset_ms},
                               {"drift_ppm", e.drift_ppm},
                               {"sigma_ms", e.sigma_ms},
                               {"sigma0_mm", e.sigma0_mm},
                               {"assumed", e.assumed},
                               {"points", figures_.paired},
                               {"left_accelerating", figures_.left_accelerating},
                               {"left_gaps", figures_.left_gaps},
                               {"left_outside", figures_.left_outside},
                               {"left_uncertain", figures_.left_uncertain},
                               {"beam_breaks", s.raw.events.size()},
                               {"speed_rad_s", figures_.speed_rad_s}};
  db::SetSessionSync(db_, session_, JsonText(sync));
  db::SetSessionState(db_, session_, db::SessionState::kCompleted);
  tx.commit();
  summary_.completed = true;
  summary_.measured = summary_.usable = figures_.paired;
}

}  // namespace

CaptureSummary RunSweepCapture(
    db::Database& db, const io::LabConfig& lab, int64_t session,
    std::vector<std::unique_ptr<instruments::DistanceInstrument>>& devices,
    instruments::RobotController& controller, const CaptureOptions& options) {
  return SweepRun(db, lab, session, devices, controller, options).Run();
}

}  // namespace armsig::acquisition
