#include "acquisition/session.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <functional>
#include <future>
#include <map>
#include <set>
#include <thread>

#include "acquisition/beam_pointing.h"
#include "acquisition/controller_record.h"
#include "acquisition/crew.h"
#include "acquisition/observation_rows.h"
#include "acquisition/session_owner.h"
#include "acquisition/station_reading.h"
#include "core/error.h"
#include "core/text.h"
#include "core/units.h"
#include "db/store.h"
#include "io/model_yaml.h"
#include "reduction/intersection.h"
#include "reduction/point_flags.h"
#include "reduction/polar_checks.h"

namespace armsig::acquisition {

using Clock = std::chrono::steady_clock;

int64_t CreateSession(db::Database& db, const io::LabConfig& lab, const std::string& robot,
                      const Plan& plan) {
  db::WriteTransaction tx(db);
  if (const auto registered = db::FindRobotInUse(db, robot)) {  // a removed one: refused
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
  } else {
    // A new name registers the lab's robot; one a typo away from a registered robot is that
    // robot mistyped (`--robot pumaa` would start a second history of the same arm).
    std::vector<std::string> names;
    for (const auto& r : db::ListRobots(db)) names.push_back(r.name);
    if (const auto nearest = NearestKey(robot, names)) {
      throw InputError({"--robot", 0, 0, ""},
                       fmt::format("no robot {} in {} (did you mean {}? a new robot with a name "
                                   "this close is registered first: armsig robot add {} --model "
                                   "{}); nothing was stored",
                                   Quoted(robot), db.path(), Quoted(*nearest), robot,
                                   lab.robot_model_path));
    }
  }
  const int64_t robot_id = db::EnsureRobot(db, robot, lab.model.name, lab.model_yaml);
  const int64_t session = db::CreateSession(db, robot_id, lab.text, PlanToJson(plan), db::SessionState::kRunning,
                                            "capture from " + lab.source);
  db::SetSessionOwner(db, session, ThisProcess());  // running: in this process
  // A plan that says where every target is meant to be is an ISO 9283 test (`iso9283 plan`):
  // measured to judge the robot, never calibration data unless asked.
  const bool test = !plan.empty() && std::all_of(plan.begin(), plan.end(), [](const auto& c) {
    return c.target_mm.has_value();
  });
  if (test) db::SetSessionKind(db, session, db::SessionKind::kTest);
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

// Ctrl-C: the flag was raised while a configuration was being measured.
struct StopRequested {};

struct Measurement {
  Eigen::VectorXd joints;
  std::optional<double> controller_time_s;  // the controller's stamp of `joints`, when it has one
  std::vector<StationReading> readings;  // every reading of every instrument (faces, repeats)
  reduction::ReducedPoint point;         // its flags carry the tolerance checks
  double device_ms = 0.0;                // slowest device call of each parallel step, summed
};

// A streaming controller's joints read before and after the instruments may differ by this
// much and the arm still count as standing (0.001°: 0.02 mm at a metre, below any
// instrument's noise; a standing arm's encoders repeat within a few microradians).
constexpr double kStillToleranceRad = 2e-5;

// A tracker searches at the distance the prediction gives, else at its last reading's,
// else at this (a typical robot cell: the tracker a few metres from the robot).
constexpr double kDefaultSearchDistanceMm = 3000.0;

double MsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
      .count();
}

}  // namespace

namespace {

using Devices = std::vector<std::unique_ptr<instruments::DistanceInstrument>>;

// One run of a capture session, step by step: set up (the plan, what is stored, the
// stations, the beams, the robot base from the points already measured), then for every
// configuration not stored: move, settle, point the beams, measure in parallel rounds
// (repeats, faces), intersect and check on the spot, re-measure, retry faults, store in one
// transaction, check that the points follow the robot, report progress.
class CaptureRun {
 public:
  CaptureRun(db::Database& db, const io::LabConfig& lab, int64_t session, Devices& devices,
             instruments::RobotController& controller, const CaptureOptions& options);
  CaptureSummary Run();

 private:
  // What one configuration came to: a measurement kept (usable or not), or a fault, or a
  // stop before anything was kept.
  struct Outcome {
    std::optional<Measurement> accepted;
    int attempts = 0;
    std::string fault;
    bool stopped = false;
    // The fault is the controller's state (an emergency stop, local mode, …): the session
    // pauses, never skips the configuration (no arm can be measured until it is dealt with).
    bool controller_fault = false;
  };

  void SetUp();
  void IdentifyController(const std::string& robot);
  bool WaitOut(const instruments::ControllerError& stop, const PlannedConfiguration& target);
  void ConfirmStill(const Measurement& m) const;
  instruments::DeviceInfo Identity(size_t i) const;
  bool PauseUnlessFollowing(const std::string& where);
  bool Stopping() const { return options_.stop && options_.stop->load(); }
  void CheckStop() const {
    if (Stopping()) throw StopRequested{};
  }
  void SleepUnlessStopped(int ms) const;
  instruments::Reading Measure(size_t i, const PlannedConfiguration& target);
  instruments::InstrumentError NobodyToPointTheBeam(const instruments::InstrumentError& e) const;
  void CheckJoints(const PlannedConfiguration& target, const Eigen::VectorXd& read) const;
  void CheckMoved(const PlannedConfiguration& target, const Eigen::VectorXd& read) const;
  // The joints and label of the last configuration this run measured (CheckMoved).
  std::optional<Eigen::VectorXd> previous_joints_;
  std::string previous_label_;
  void Round(bool with_joints, Measurement& m, const PlannedConfiguration& target,
             int round_index);
  double PointBeams(const PlannedConfiguration& target);
  double TurnFaces();
  std::vector<reduction::Ray> RaysOf(const std::vector<StationReading>& readings,
                                     bool angles_only = false) const;
  void TrackerChecks(Measurement& m) const;
  Measurement MeasureOnce(const PlannedConfiguration& target, double pointing_ms,
                          std::chrono::steady_clock::time_point cycle_start);
  Outcome MeasureConfiguration(const PlannedConfiguration& target);
  bool Store(int seq, const PlannedConfiguration& target, const Outcome& outcome);
  void StoreMeasurement(int seq, const PlannedConfiguration& target, const Outcome& outcome);
  void Count(const PlannedConfiguration& target, const Measurement& m);
  void ReportProgress(const PlannedConfiguration& target, const Outcome& outcome);
  CaptureSummary Finish();

  db::Database& db_;
  const io::LabConfig& lab_;
  const int64_t session_;
  Devices& devices_;
  instruments::RobotController& controller_;
  const CaptureOptions& options_;
  CaptureSummary summary_;
  Plan plan_;
  std::set<int> done_;
  std::vector<const reduction::Station*> station_of_;
  std::vector<int64_t> instrument_ids_;  // the instruments table's row of each device
  // Laser trackers point their beams at the predicted target before measuring.
  std::vector<instruments::BeamSteering*> beams_;
  bool any_beam_ = false;
  int angle_only_ = 0;  // instruments that measure angles only (theodolites)
  // The robot base fitted to the measured points: laser trackers point their beams
  // through it, and every session checks by it that the points follow the robot.
  TargetPredictor predictor_;
  std::vector<std::optional<double>> expected_distance_;  // this configuration
  std::vector<double> last_distance_;
  std::atomic<int> searches_{0}, operator_pointed_{0};
  Crew crew_;
  reduction::PointOptions point_options_;
  const double max_joint_error_rad_;
  Clock::time_point start_;
  double miss_sum_ = 0.0, max_miss_ = 0.0;  // over usable points
  int miss_count_ = 0;
  double cycle_sum_ = 0.0, overhead_sum_ = 0.0, store_sum_ = 0.0;
  int cycles_ = 0, stores_ = 0;
};

CaptureRun::CaptureRun(db::Database& db, const io::LabConfig& lab, int64_t session,
                       Devices& devices, instruments::RobotController& controller,
                       const CaptureOptions& options)
    : db_(db),
      lab_(lab),
      session_(session),
      devices_(devices),
      controller_(controller),
      options_(options),
      station_of_(devices.size(), nullptr),
      beams_(devices.size(), nullptr),
      predictor_(
          lab.model,
          options.prediction_params.value_or(Eigen::VectorXd::Zero(lab.model.num_parameters())),
          lab.robot_base),
      expected_distance_(devices.size()),
      last_distance_(devices.size(), 0.0),
      crew_(devices.size()),
      max_joint_error_rad_(lab.tolerances.max_joint_error_deg * kPi / 180.0) {
  summary_.session = session;
  // The point's checks are the lab's tolerances. The fixed-mm repeat check is the
  // theodolites' (two of them intersect a point per round); a laser tracker's repeated
  // readings are checked against the sigmas it states (TrackerChecks), which at 10 m
  // exceed any fixed 0.05 mm.
  point_options_.checks.max_miss_mm = lab.tolerances.max_miss_mm;
  point_options_.checks.max_repeat_mm = lab.tolerances.max_repeat_mm;
}

void CaptureRun::SetUp() {
  const auto row = db::LoadSession(db_, session_);
  if (!row) throw InputError({db_.path(), 0, 0, ""}, "no session " + std::to_string(session_));
  plan_ = PlanFromJson(row->plan_json, {db_.path(), "sessions", session_, "plan_json"});
  summary_.total = static_cast<int>(plan_.size());
  summary_.single_ray = devices_.size() == 1;
  IdentifyController(row->robot);
  const auto stored = db::StoredSeqs(db_, session_);
  done_ = std::set<int>(stored.begin(), stored.end());
  summary_.already = static_cast<int>(done_.size());
  db::SetSessionOwner(db_, session_, ThisProcess());
  db::SetSessionState(db_, session_, db::SessionState::kRunning);
  for (size_t i = 0; i < devices_.size(); ++i) {
    for (const auto& s : lab_.stations) {
      if (s.pose.id == lab_.instruments[i].station) station_of_[i] = &s;
    }
    if (!station_of_[i]) {
      throw InputError({lab_.source, 0, 0, "stations"},
                       "no oriented station " + lab_.instruments[i].station);
    }
    beams_[i] = dynamic_cast<instruments::BeamSteering*>(devices_[i].get());
    any_beam_ |= beams_[i] != nullptr;
    angle_only_ += beams_[i] ? 0 : 1;
    instrument_ids_.push_back(
        db::EnsureInstrument(db_, InstrumentRowOf(lab_.instruments[i], Identity(i))));
  }
  // A resumed session starts from the points it has (the base is known at once).
  for (const auto& p : db::LoadSessionPoses(db_, session_)) {
    predictor_.Add(p.joints_rad, p.target_in_world);
  }
  if (any_beam_) {
    spdlog::info("capture: laser tracker beams point through {}{}", predictor_.Describe(),
                 options_.prediction_params ? " and the robot's active arm signature"
                                            : " and the nominal model");
  }
}

// The controller says who it is before anything is measured: another arm than the lab's
// robot, the robot as registered or the session's is refused (nothing stored); what it says
// is kept with the session (when it has none yet) and the robot.
void CaptureRun::IdentifyController(const std::string& robot) {
  const ControllerFacts facts = AskController(controller_);
  if (!facts.identity) return;
  CheckControllerFacts(db_, lab_, robot, session_, facts);
  summary_.controller = facts.Describe();
  spdlog::info("capture: robot controller {}", summary_.controller);
  db::WriteTransaction tx(db_);
  if (!db::SessionController(db_, session_)) db::SetSessionController(db_, session_, facts.Record());
  if (const auto robot_id = db::FindRobot(db_, robot))
    db::RecordRobotController(db_, *robot_id, facts.Record());
  tx.commit();
}

// A stop the session waits out (a protective stop): says so, has it cleared from here when
// the operator asks for it, and waits until the controller takes moves again. Returns false
// when stopped meanwhile (Ctrl-C); throws the controller's error when the wait ends by
// max_controller_wait_s or the controller turns to a state that is not waited out (an
// emergency stop pressed meanwhile).
bool CaptureRun::WaitOut(const instruments::ControllerError& stop,
                         const PlannedConfiguration& target) {
  const auto start = Clock::now();
  ++summary_.controller_waits;
  spdlog::warn("capture: {}: {}: the session waits until it is cleared", target.label, stop.what());
  if (options_.progress) {
    Progress p;
    p.done = summary_.already + summary_.measured + summary_.skipped;
    p.total = summary_.total;
    p.label = target.label;
    p.waiting = std::string(instruments::KindName(stop.kind())) + ": " + stop.action();
    options_.progress(p);
  }
  bool clear_here = options_.controller_fault && options_.controller_fault(stop);
  for (;;) {
    if (Stopping()) return false;
    try {
      if (clear_here) {
        controller_.ClearProtectiveStop();
        clear_here = false;
      }
      controller_.CheckReady();
      const double waited = std::chrono::duration<double>(Clock::now() - start).count();
      summary_.controller_wait_s += waited;
      spdlog::info("capture: {}: {} cleared after {:.1f} s; moving to it again", target.label,
                   instruments::KindName(stop.kind()), waited);
      return true;
    } catch (const instruments::ControllerError& e) {
      if (!e.WaitedOut()) throw;
      spdlog::debug("capture: {}: still waiting: {}", target.label, e.what());
    }
    const double waited = std::chrono::duration<double>(Clock::now() - start).count();
    if (options_.max_controller_wait_s > 0 && waited > options_.max_controller_wait_s) {
      summary_.controller_wait_s += waited;
      throw instruments::ControllerError(
          stop.kind(), controller_.name(),
          fmt::format("not cleared after {:.0f} s of waiting", waited), stop.action());
    }
    try {
      SleepUnlessStopped(100);
    } catch (const StopRequested&) {
      return false;
    }
  }
}

// A controller that streams its joints is read again after the instruments: a reading whose
// arm moved in between is never stored (ControllerError kArmMoving, the configuration faults
// and is measured again).
void CaptureRun::ConfirmStill(const Measurement& m) const {
  if (!controller_.StreamsJoints()) return;
  const instruments::StampedJoints after = controller_.ReadStampedJoints();
  if (after.joints_rad.size() != m.joints.size()) return;
  Eigen::Index worst = 0;
  const double moved = (after.joints_rad - m.joints).cwiseAbs().maxCoeff(&worst);
  if (!(moved > kStillToleranceRad)) return;
  throw instruments::ControllerError(
      instruments::ControllerError::Kind::kArmMoving, controller_.name(),
      fmt::format("joint {} moved by {:.6f} deg while the instruments measured", worst + 1,
                  moved * 180.0 / kPi),
      "nothing else may move the arm during a capture (another program, the pendant, freedrive)");
}

// What instrument `i` said it is when it was probed before the run (CaptureOptions); one
// not probed is named by its protocol and port. Not asked here: a run's requests are its
// measurements.
instruments::DeviceInfo CaptureRun::Identity(size_t i) const {
  return i < options_.identities.size() ? options_.identities[i] : instruments::DeviceInfo{};
}

// Points that do not follow the robot: the session stops before measuring more of them
// and is discarded (what is stored stays, unused), naming what it found.
bool CaptureRun::PauseUnlessFollowing(const std::string& where) {
  const auto problem = predictor_.FollowProblem(lab_.tolerances.max_base_fit_rms_mm);
  if (!problem) return false;
  summary_.paused = summary_.discarded = true;
  summary_.pause_reason = where + ": " + *problem;
  db::WriteTransaction tx(db_);
  db::DiscardSession(db_, session_, "set-up check: " + summary_.pause_reason);
  tx.commit();
  return true;
}

// A wait that a raised stop flag cuts short.
void CaptureRun::SleepUnlessStopped(int ms) const {
  const auto end = Clock::now() + std::chrono::milliseconds(ms);
  for (auto now = Clock::now(); now < end; now = Clock::now()) {
    CheckStop();
    std::this_thread::sleep_for(std::min<Clock::duration>(end - now, std::chrono::milliseconds(10)));
  }
  CheckStop();
}

// A tracker's reading: where its beam points; when the reflector is not there, a search
// around the beam (FindReflector), then the operator.
instruments::Reading CaptureRun::Measure(size_t i, const PlannedConfiguration& target) {
  auto& device = *devices_[i];
  auto read = [&] {
    return lab_.instruments[i].distance ? device.MeasureDistanceAndAngles()
                                        : device.MeasureAngles();
  };
  instruments::BeamSteering* beam = beams_[i];
  if (!beam) return read();
  const std::string& station = lab_.instruments[i].station;
  try {
    return read();
  } catch (const instruments::InstrumentError& e) {
    if (!beam->ReflectorLost(e.code()) || Stopping()) throw;
    spdlog::debug("capture: {} {}: no reflector in the beam ({}); searching", target.label,
                  station, e.what());
  }
  ++searches_;
  const double around = expected_distance_[i].value_or(
      last_distance_[i] > 0.0 ? last_distance_[i] : kDefaultSearchDistanceMm);
  try {
    beam->FindReflector(around);
    return read();
  } catch (const instruments::InstrumentError& e) {
    if (!beam->ReflectorLost(e.code()) || Stopping()) throw;
    if (!options_.prompt_reflector) throw NobodyToPointTheBeam(e);
    spdlog::info(
        "capture: {} {}: the reflector was not found around the beam ({}); asking the "
        "operator to point the beam at it",
        target.label, station, e.what());
  }
  ++operator_pointed_;
  options_.prompt_reflector(station, target);
  CheckStop();
  return read();
}

// The reflector is not in the beam, a search did not find it, and no one can point the beam
// here (capture is not on a terminal): what lets the tracker find the target by itself.
instruments::InstrumentError CaptureRun::NobodyToPointTheBeam(
    const instruments::InstrumentError& e) const {
  std::string message = e.what();
  if (message.starts_with(e.device() + ": ")) message.erase(0, e.device().size() + 2);
  if (!predictor_.base()) {
    message +=
        "; no one can point the beam (capture is not on a terminal) and the robot's base is not "
        "known yet: give the lab file `robot: base:` (the robot base in the tracker's frame, a "
        "4x4 matrix in mm) so that the tracker points at the predicted target from the first "
        "configuration on, or run capture on a terminal to point the beam by hand";
  } else {
    message += fmt::format(
        "; the beam pointed where the model puts the target through the robot's base ({}) and "
        "no one can point it by hand here (not a terminal): is the reflector on the robot, and "
        "the lab file's `robot: base:` right?",
        predictor_.Describe());
  }
  return instruments::InstrumentError(e.device(), e.code(), message);
}

// A robot armsig moved must be where it was sent: the joints read back within the lab's
// max_joint_error_deg of the commanded ones, else the configuration faults (retried).
void CaptureRun::CheckJoints(const PlannedConfiguration& target,
                             const Eigen::VectorXd& read) const {
  if (read.size() != target.joints_rad.size()) return;
  Eigen::Index worst = 0;
  const double error = (read - target.joints_rad).cwiseAbs().maxCoeff(&worst);
  if (!(error > max_joint_error_rad_)) return;
  throw std::runtime_error(fmt::format(
      "the controller reads joint {} at {:.4f} deg, commanded {:.4f} deg ({:.4f} deg off, "
      "more than the lab's max_joint_error_deg {}): the robot is not where the plan put it "
      "(another program drives it, or it stopped at a limit or a safety fence)",
      worst + 1, read(worst) * 180.0 / kPi, target.joints_rad(worst) * 180.0 / kPi,
      error * 180.0 / kPi, lab_.tolerances.max_joint_error_deg));
}

// The operator moves the robot (a controller armsig cannot command): a configuration read
// where the previous one was measured is that one again, not the plan's next, and would be
// stored as a copy of it (an unmoved robot gives one configuration, whatever the plan says).
// A fault of the configuration: retried after the delay, then the session pauses.
void CaptureRun::CheckMoved(const PlannedConfiguration& target, const Eigen::VectorXd& read) const {
  if (!previous_joints_ || previous_joints_->size() != read.size()) return;
  constexpr double kStillRad = 1e-4;  // 0.006°: far below any move between configurations
  if ((read - *previous_joints_).cwiseAbs().maxCoeff() > kStillRad) return;
  throw std::runtime_error(fmt::format(
      "the robot has not moved since configuration {} was measured (every joint within {:.4f} "
      "deg of it): move it to configuration {} (without a terminal to ask on, the lab's own "
      "program must move it between readings)",
      previous_label_, kStillRad * 180.0 / kPi, target.label));
}

// One parallel round: the joints (optional) and every instrument at once.
void CaptureRun::Round(bool with_joints, Measurement& m, const PlannedConfiguration& target,
                       int round_index) {
  CheckStop();
  using Timed = std::pair<instruments::Reading, double>;
  std::vector<std::function<Timed()>> reads;
  for (size_t i = 0; i < devices_.size(); ++i) {
    reads.push_back([&, i] {
      const auto a = Clock::now();
      auto r = Measure(i, target);
      return std::make_pair(r, MsSince(a));
    });
  }
  std::future<instruments::StampedJoints> joints;
  if (with_joints) joints = crew_.Spawn([&] { return controller_.ReadStampedJoints(); });
  std::exception_ptr failure;
  std::vector<Timed> done_reads;
  try {
    done_reads = crew_.Together(reads);
  } catch (...) {
    failure = std::current_exception();
  }
  if (with_joints) {
    try {
      const instruments::StampedJoints stamped = joints.get();
      m.joints = stamped.joints_rad;
      m.controller_time_s = stamped.controller_time_s;
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
}

// Every tracker's beam at the target the model predicts for this configuration; returns
// the device time (the slowest GoPosition, and the joint reading it needed).
double CaptureRun::PointBeams(const PlannedConfiguration& target) {
  std::fill(expected_distance_.begin(), expected_distance_.end(), std::nullopt);
  if (!any_beam_) return 0.0;
  const auto a = Clock::now();
  double device_ms = 0.0;
  Eigen::VectorXd q = target.joints_rad;
  if (!controller_.CanMove()) {  // the operator moved it: where it is, not where it was asked
    q = controller_.ReadJointsRad();
    device_ms += MsSince(a);
  }
  const auto predicted = predictor_.Predict(q);
  if (!predicted) return device_ms;
  std::vector<std::function<double()>> moves;
  for (size_t i = 0; i < devices_.size(); ++i) {
    if (!beams_[i]) continue;
    const auto& pose = station_of_[i]->pose;
    const Eigen::Vector3d in_instrument =
        pose.world_from_station.transpose() * (*predicted - pose.position_mm);
    expected_distance_[i] = in_instrument.norm();
    moves.push_back([&, i, in_instrument] {
      const auto t = Clock::now();
      beams_[i]->GoPosition(in_instrument);
      return MsSince(t);
    });
    ++summary_.beam_predicted;
  }
  double slowest = 0.0;
  for (const double ms : crew_.Together(moves)) slowest = std::max(slowest, ms);
  return device_ms + slowest;
}

double CaptureRun::TurnFaces() {
  CheckStop();
  const auto a = Clock::now();
  std::vector<std::function<int()>> turns;
  for (auto& d : devices_) {
    turns.push_back([&d] {
      d->ChangeFace();
      return 0;
    });
  }
  crew_.Together(turns);
  return MsSince(a);
}

// The readings' rays; angles_only: the theodolites' (the fixed-mm repeat check's).
std::vector<reduction::Ray> CaptureRun::RaysOf(const std::vector<StationReading>& readings,
                                               bool angles_only) const {
  std::vector<reduction::Ray> rays;
  for (const auto& r : readings) {
    if (angles_only && beams_[r.instrument]) continue;
    rays.push_back(reduction::RayOf(TargetObservation(r, lab_.instruments[r.instrument]),
                                    *station_of_[r.instrument], reduction::InstrumentDefaults{}));
  }
  return rays;
}

// A tracker's readings against the sigmas it stated: each one's largest sigma, and its
// repeated readings (same face) against each other.
void CaptureRun::TrackerChecks(Measurement& m) const {
  if (!any_beam_ || !m.point.result.status.ok()) return;
  std::map<std::pair<int, int>, std::vector<std::pair<Eigen::Vector3d, Eigen::Matrix3d>>> seen;
  bool sigma_exceeded = false, repeat_exceeded = false;
  for (const auto& r : m.readings) {
    if (!beams_[r.instrument] || !UsableSigmas(r.reading.sigma) || !r.reading.distance_mm)
      continue;
    const auto& s = *r.reading.sigma;
    const Eigen::Matrix3d c = reduction::PolarCovariance(r.reading.angles, *r.reading.distance_mm,
                                                         {s.hz_rad, s.v_rad, s.distance_mm});
    const double sigma = reduction::LargestSigmaMm(c);
    if (sigma > lab_.tolerances.max_sigma_mm) {
      sigma_exceeded = true;
      spdlog::debug("capture: {}: a reading states sigma {:.4f} mm > {} mm",
                    lab_.instruments[r.instrument].station, sigma, lab_.tolerances.max_sigma_mm);
    }
    const Eigen::Vector3d p = reduction::PolarPoint(r.reading.angles, *r.reading.distance_mm);
    for (const auto& [q, cq] : seen[{r.instrument, r.reading.angles.face}]) {
      const double k = reduction::NormalisedDisagreement(p, c, q, cq);
      if (k > lab_.tolerances.max_repeat_sigma) {
        repeat_exceeded = true;
        spdlog::debug("capture: {}: repeated readings {:.4f} mm apart, {:.1f} sigma",
                      lab_.instruments[r.instrument].station, (p - q).norm(), k);
      }
    }
    seen[{r.instrument, r.reading.angles.face}].push_back({p, c});
  }
  if (sigma_exceeded) m.point.result.flags.Set(reduction::PointFlag::kSigmaExceeded);
  if (repeat_exceeded) m.point.result.flags.Set(reduction::PointFlag::kRepeatExceeded);
}

// Every reading of one measurement of the configuration (the rounds of repeats, both faces
// when the lab wants them), intersected and checked on the spot.
Measurement CaptureRun::MeasureOnce(const PlannedConfiguration& target, double pointing_ms,
                                    Clock::time_point cycle_start) {
  Measurement m;
  m.device_ms = pointing_ms;
  Round(true, m, target, 0);
  ConfirmStill(m);
  if (controller_.CanMove())
    CheckJoints(target, m.joints);
  else
    CheckMoved(target, m.joints);
  reduction::RayGroup group;  // every ray, and each repeated round's rays
  if (angle_only_ >= 2) group.repeats.push_back(RaysOf(m.readings, true));
  for (int k = 1; k < lab_.tolerances.readings; ++k) {
    Measurement again;
    Round(false, again, target, k);
    if (angle_only_ >= 2) group.repeats.push_back(RaysOf(again.readings, true));
    m.readings.insert(m.readings.end(), again.readings.begin(), again.readings.end());
    m.device_ms += again.device_ms;
  }
  if (lab_.tolerances.two_face) {
    m.device_ms += TurnFaces();
    Measurement face2;
    Round(false, face2, target, lab_.tolerances.readings);
    m.readings.insert(m.readings.end(), face2.readings.begin(), face2.readings.end());
    m.device_ms += face2.device_ms;
    m.device_ms += TurnFaces();
  }
  group.rays = RaysOf(m.readings);
  reduction::IntersectPoint(group, point_options_, m.point);
  TrackerChecks(m);
  const double cycle_ms = MsSince(cycle_start);
  cycle_sum_ += cycle_ms;
  overhead_sum_ += std::max(0.0, cycle_ms - m.device_ms);
  ++cycles_;
  return m;
}

// Move, settle, point, measure — again while the point is beyond the tolerances (up to
// max_remeasure), and from the start after a fault (up to fault_retries).
CaptureRun::Outcome CaptureRun::MeasureConfiguration(const PlannedConfiguration& target) {
  Outcome out;
  for (int fault_try = 0;
       fault_try <= lab_.tolerances.fault_retries && !out.accepted && !out.stopped; ++fault_try) {
    try {
      if (fault_try > 0) SleepUnlessStopped(lab_.tolerances.fault_retry_delay_ms);
      CheckStop();
      if (controller_.CanMove())
        controller_.MoveTo(target.joints_rad);
      else if (options_.prompt_move)
        options_.prompt_move(target);
      SleepUnlessStopped(lab_.tolerances.settle_ms);
      auto cycle_start = Clock::now();
      const double pointing_ms = PointBeams(target);
      for (int measure_try = 0; measure_try <= lab_.tolerances.max_remeasure; ++measure_try) {
        ++out.attempts;
        if (measure_try > 0) cycle_start = Clock::now();
        Measurement m = MeasureOnce(target, measure_try == 0 ? pointing_ms : 0.0, cycle_start);
        if (m.point.accepted() || measure_try == lab_.tolerances.max_remeasure) {
          previous_joints_ = m.joints;
          previous_label_ = target.label;
          out.accepted = std::move(m);
          break;
        }
        ++summary_.remeasured;
        spdlog::info("capture: {}: measuring again ({} of {}): {}", target.label, measure_try + 1,
                     lab_.tolerances.max_remeasure,
                     m.point.result.status.ok()
                         ? ToString(m.point.result.flags)
                         : ToString(m.point.result.flags) + " " + m.point.result.status.message);
      }
    } catch (const instruments::ConventionMismatch&) {
      throw;  // no reading of that tracker can be used: the capture ends here
    } catch (const StopRequested&) {
      out.stopped = true;
    } catch (const instruments::ControllerError& e) {
      if (Stopping()) {
        out.stopped = true;
      } else if (e.WaitedOut()) {
        // Waited out, then this configuration again from its move: the stop is no fault of
        // it and does not count against fault_retries. Nothing measured before it is kept.
        try {
          if (!WaitOut(e, target)) out.stopped = true;
          --fault_try;
        } catch (const instruments::ControllerError& other) {
          out.fault = other.what();
          out.controller_fault = true;
          break;
        }
      } else {
        out.fault = e.what();
        out.controller_fault = true;
        // A moving arm or a lost connection may pass: retried as any fault. The rest waits
        // for the operator: the session pauses at once.
        if (e.kind() == instruments::ControllerError::Kind::kArmMoving) ++summary_.moving_refused;
        if (e.kind() != instruments::ControllerError::Kind::kArmMoving &&
            e.kind() != instruments::ControllerError::Kind::kConnectionLost)
          break;
      }
    } catch (const std::exception& e) {
      // A device call the stop flag interrupted (or that failed while it was raised) is no
      // fault of the configuration: the session stops.
      if (Stopping())
        out.stopped = true;
      else
        out.fault = e.what();
    }
  }
  return out;
}

// The configuration's joints, raw readings and reduced point in one transaction; then the
// check that the points follow the robot. Returns true when they do not (the session
// stops).
bool CaptureRun::Store(int seq, const PlannedConfiguration& target, const Outcome& outcome) {
  if (!outcome.accepted) {
    db::WriteTransaction tx(db_);
    db::InsertPose(db_, session_, seq, target.label, std::nullopt, "skipped", outcome.attempts);
    tx.commit();
    spdlog::debug("capture: {} skipped after {} attempt(s): {}", target.label, outcome.attempts,
                  outcome.fault);
    ++summary_.skipped;
    summary_.skipped_configurations.push_back({target.label, outcome.fault});
    return false;
  }
  StoreMeasurement(seq, target, outcome);
  const Measurement& m = *outcome.accepted;
  const reduction::IntersectionResult& result = m.point.result;
  bool not_following = false;
  if (result.status.ok() && m.point.accepted()) {
    const bool had_fit = predictor_.fitted();
    predictor_.Add(m.joints, result.position_mm);
    if (any_beam_ && !had_fit && predictor_.fitted()) {
      spdlog::info("capture: robot base {}; the tracker beams point by prediction from now on",
                   predictor_.Describe().substr(5));
    }
    not_following = PauseUnlessFollowing(
        fmt::format("configuration {} ({} of {})", target.label, seq + 1, plan_.size()));
  }
  Count(target, m);
  return not_following;
}

void CaptureRun::StoreMeasurement(int seq, const PlannedConfiguration& target,
                                  const Outcome& outcome) {
  const Measurement& m = *outcome.accepted;
  const auto store_start = Clock::now();
  db::WriteTransaction tx(db_);
  const int64_t pose = db::InsertPose(db_, session_, seq, target.label, m.joints, "measured",
                                      outcome.attempts, m.controller_time_s);
  std::vector<db::ObservationRow> rows;
  for (const auto& r : m.readings) {
    rows.push_back(StoredReading(r, lab_.instruments[r.instrument], pose,
                                 instrument_ids_[static_cast<size_t>(r.instrument)]));
  }
  db::InsertObservations(db_, session_, rows);
  const reduction::IntersectionResult& result = m.point.result;
  // Append this configuration's point (other sessions' points are untouched).
  db::InsertPoint(db_, session_,
                  PointRowOf(pose, "target", static_cast<int>(m.readings.size()), result,
                             result.flags));
  tx.commit();
  store_sum_ += MsSince(store_start);
  ++stores_;
  ++summary_.measured;
  const std::string flags = ToString(result.flags);
  spdlog::debug("capture: {} stored: {} readings, {} attempt(s), point {}{}, miss {:.4f} mm",
                target.label, m.readings.size(), outcome.attempts,
                result.status.ok() ? "intersected" : "not intersected",
                flags.empty() ? "" : " [" + flags + "]", result.max_miss_mm);
  for (const auto& r : m.readings) {
    spdlog::trace("capture: {} {}: Hz {:.8f} V {:.8f} rad{} code {}", target.label,
                  lab_.instruments[r.instrument].station, r.reading.angles.hz_rad,
                  r.reading.angles.v_rad,
                  r.reading.distance_mm ? fmt::format(" d {:.4f} mm", *r.reading.distance_mm)
                                        : std::string(),
                  r.reading.return_code);
    if (r.reading.distance_mm) last_distance_[r.instrument] = *r.reading.distance_mm;
  }
}

// A measured configuration is usable, flagged (beyond the tolerances after re-measuring)
// or failed (no point).
void CaptureRun::Count(const PlannedConfiguration& target, const Measurement& m) {
  const reduction::IntersectionResult& result = m.point.result;
  if (m.point.accepted()) {
    ++summary_.usable;
    miss_sum_ += result.max_miss_mm;
    ++miss_count_;
    max_miss_ = std::max(max_miss_, result.max_miss_mm);
  } else if (result.status.ok()) {
    ++summary_.flagged;
    summary_.flagged_configurations.push_back({target.label, ToString(result.flags)});
  } else {
    ++summary_.failed;  // the readings are kept, the point is not usable
    summary_.failed_configurations.push_back(
        {target.label, ToString(result.flags) + ": " + result.status.message});
  }
}

void CaptureRun::ReportProgress(const PlannedConfiguration& target, const Outcome& outcome) {
  if (!options_.progress) return;
  Progress p;
  p.done = summary_.already + summary_.measured + summary_.skipped;
  p.total = summary_.total;
  p.skipped = summary_.skipped;
  p.flagged = summary_.flagged;
  p.failed = summary_.failed;
  p.remeasured = summary_.remeasured;
  p.label = target.label;
  p.last_miss_mm = outcome.accepted && outcome.accepted->point.accepted()
                       ? std::optional(outcome.accepted->point.result.max_miss_mm)
                       : std::nullopt;
  if (miss_count_ > 0) {
    p.mean_miss_mm = miss_sum_ / miss_count_;
    p.max_miss_mm = max_miss_;
  }
  p.elapsed_s = std::chrono::duration<double>(Clock::now() - start_).count();
  const int this_run = summary_.measured + summary_.skipped;
  p.eta_s = this_run ? p.elapsed_s / this_run * (p.total - p.done) : 0.0;
  options_.progress(p);
}

CaptureSummary CaptureRun::Finish() {
  summary_.seconds = std::chrono::duration<double>(Clock::now() - start_).count();
  if (miss_count_) {
    summary_.mean_miss_mm = miss_sum_ / miss_count_;
    summary_.max_miss_mm = max_miss_;
  }
  summary_.mean_cycle_ms = cycles_ ? cycle_sum_ / cycles_ : 0.0;
  summary_.mean_overhead_ms = cycles_ ? overhead_sum_ / cycles_ : 0.0;
  summary_.mean_store_ms = stores_ ? store_sum_ / stores_ : 0.0;
  summary_.beam_searches = searches_.load();
  summary_.beam_operator = operator_pointed_.load();
  if (any_beam_) summary_.beam_base = predictor_.Describe();
  if (!summary_.paused && !summary_.stopped) {
    summary_.completed = true;
    db::SetSessionState(db_, session_, db::SessionState::kCompleted);
  }
  return summary_;
}

CaptureSummary CaptureRun::Run() {
  const InterruptScope interrupts(devices_, controller_, options_.stop);
  try {
    SetUp();
  } catch (const std::exception&) {
    // Ctrl-C while the controller was asked who it is: stopped before the first
    // configuration, the session paused as at any other stop.
    if (!Stopping()) throw;
    summary_.stopped = true;
    db::SetSessionState(db_, session_, db::SessionState::kPaused);
    return Finish();
  }
  const bool stored_points_wrong = PauseUnlessFollowing(
      fmt::format("the {} stored points of this session", predictor_.points()));
  start_ = Clock::now();
  for (int seq = 0; seq < static_cast<int>(plan_.size()) && !stored_points_wrong; ++seq) {
    if (done_.count(seq)) continue;
    if (Stopping()) {
      summary_.stopped = true;
      db::SetSessionState(db_, session_, db::SessionState::kPaused);
      break;
    }
    const PlannedConfiguration& target = plan_[seq];
    const Outcome outcome = MeasureConfiguration(target);
    if (outcome.stopped && !outcome.accepted) {
      // Nothing of this configuration is stored: --resume measures it again.
      summary_.stopped = true;
      db::SetSessionState(db_, session_, db::SessionState::kPaused);
      break;
    }
    if (!outcome.accepted && (!options_.skip_on_fault || outcome.controller_fault)) {
      summary_.paused = true;
      summary_.pause_reason = "configuration " + target.label + " (" + std::to_string(seq + 1) +
                              " of " + std::to_string(plan_.size()) + "): " + outcome.fault;
      db::SetSessionState(db_, session_, db::SessionState::kPaused);
      break;
    }
    const bool not_following = Store(seq, target, outcome);
    ReportProgress(target, outcome);
    if (not_following) break;
  }
  return Finish();
}

}  // namespace

CaptureSummary RunCapture(db::Database& db, const io::LabConfig& lab, int64_t session,
                          Devices& devices, instruments::RobotController& controller,
                          const CaptureOptions& options) {
  return CaptureRun(db, lab, session, devices, controller, options).Run();
}

}  // namespace armsig::acquisition
