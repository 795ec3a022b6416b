// Capture sessions against simulators on real pseudo-terminals.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <future>
#include <map>
#include <set>
#include <nlohmann/json.hpp>
#include <random>
#include <thread>

#include "acquisition/lab.h"
#include "acquisition/session.h"
#include "workflows/reduce.h"
#include "calibration/synthetic.h"
#include "core/error.h"
#include "core/units.h"
#include "db/database.h"
#include "db/observations.h"
#include "db/push.h"
#include "db/store.h"
#include "instruments/geocom_device.h"
#include "io/atomic_file.h"
#include "io/network_files.h"
#include "reduction/intersection.h"
#include "reduction/observation.h"
#include "reduction/point_flags.h"
#include "simulation/fault_matrix.h"
#include "simulation/geocom_simulator.h"
#include "simulation/simulator.h"
#include "simulation/val_simulator.h"
#include "support/stores.h"
#include "test_support.h"

namespace armsig::acquisition {

using namespace std::chrono_literals;

namespace {

// Three theodolites (GeoCOM) and a Kawasaki AS controller around a PUMA 760 with the
// paper's errors; the lab YAML gives the true station poses as the oriented ones.
class VirtualLabFixture : public ::testing::Test {
 protected:
  void Start(std::array<int, 3> latency_ms = {10, 10, 10}) {
    lab_ = std::make_unique<simulation::VirtualLab>(
        testing::Puma(), calibration::PaperTable3Parameters(), Eigen::Isometry3d::Identity(), 3);
    std::vector<reduction::Station> stations;
    for (int s = 0; s < 3; ++s) {
      simulation::VirtualStation st;
      st.pose.id = "T" + std::to_string(s + 1);
      const double a = 0.3 + 2.1 * s;
      st.pose.position_mm = {3500 * std::cos(a), 3500 * std::sin(a), 500.0 + 100 * s};
      // Clustered: the three stations 4 mm apart, 3.5 m away: every pair of rays meets
      // at less than 0.1° (the intersection's "nearly parallel" limit is 0.2°).
      if (clustered_) st.pose.position_mm = {3500.0, 4.0 * s, 500.0};
      st.pose.azimuth_rad = 1.0 + s;
      st.pose.world_from_station = reduction::LevelledRotation(st.pose.azimuth_rad);
      st.sigma_angle_rad = 0.5 * armsig::kRadPerArcsec;
      lab_->AddStation(st);
      reduction::Station oriented;
      oriented.pose = st.pose;
      stations.push_back(oriented);
      simulation::SimulatorOptions o;
      o.angle_latency = std::chrono::milliseconds(latency_ms[s]);
      o.motion_latency = 5ms;
      sims_.push_back(std::make_unique<simulation::GeoComSimulator>(
          *lab_, s, dir_.File("T" + std::to_string(s + 1)), o, "TDRA6000", 358120 + s));
      sims_.back()->Start();
    }
    simulation::SimulatorOptions o;
    o.angle_latency = 2ms;
    o.motion_latency = 5ms;
    robot_ = std::make_unique<simulation::ValSimulator>(
        *lab_, dir_.File("robot"), simulation::ValSimulator::Layout::kKawasakiAs, o);
    robot_->Start();
    testing::WriteText(dir_.File("stations.yaml"), io::FormatStationsYaml(stations, "truth"));
    std::string yaml = "robot:\n  model: '" + testing::SourcePath("models/puma760.yaml") +
                       "'\n  controller: {protocol: as, port: '" + robot_->path() +
                       "', can_move: true}\ninstruments:\n";
    for (int s = 0; s < 3; ++s) {
      yaml += "  - {station: T" + std::to_string(s + 1) + ", protocol: geocom, port: '" +
              sims_[s]->path() + "', sigma_hz_arcsec: 0.5, sigma_v_arcsec: 0.5}\n";
    }
    yaml +=
        "stations: stations.yaml\ntolerances: {max_miss_mm: 0.1, settle_ms: 0, timeout_ms: 300, "
        "fault_retries: 2, fault_retry_delay_ms: 200}\n";
    testing::WriteText(dir_.File("lab.yaml"), yaml);
  }

  // The store: a file, or (OnServer) a database on the tests' PostgreSQL server.
  std::string Db() const { return store_.empty() ? dir_.File("lab.db") : store_; }
  void OnServer() { store_ = testing::NewStore(db::Backend::kPostgres, dir_, "capture"); }
  bool StoreMade() const {
    if (store_.empty()) return std::filesystem::exists(Db());
    try {
      db::Database db(Db(), db::OpenMode::kMustExist);
      return true;
    } catch (const InputError&) {
      return false;
    }
  }

  std::string store_;

  // kill -9 of the capture process at `kills` random moments or more, then --resume each
  // time; then the session is finished and checked.
  void KillNineThenResume(int kills);

  bool clustered_ = false;
  testing::TempDir dir_;
  std::unique_ptr<simulation::VirtualLab> lab_;
  std::vector<std::unique_ptr<simulation::GeoComSimulator>> sims_;
  std::unique_ptr<simulation::ValSimulator> robot_;
};

int Count(db::Database& db, const std::string& sql) {
  return static_cast<int>(db.connection().QueryInt(sql));
}
std::string Text(db::Database& db, const std::string& sql) {
  auto q = db.connection().Prepare(sql);
  return q->Step() ? q->Text(0) : std::string();
}

// The command after "resume with: " in a log, "" when there is none.
std::string ResumeHint(const std::string& log) {
  const std::string marker = "resume with: ";
  const size_t at = log.rfind(marker);
  if (at == std::string::npos) return "";
  const size_t end = log.find('\n', at);
  return log.substr(at + marker.size(), end == std::string::npos ? end : end - at - marker.size());
}

}  // namespace

// A whole session through the capture command; every reduced point where the true robot
// put its target. On a server store too (capture on a cell machine, store in the plant).
TEST_F(VirtualLabFixture, FullSessionStoresEveryConfigurationOnceAndReducesTheTruth) {
  Start();
  const auto r = testing::RunArmsig("--db '" + Db() + "' capture --lab '" + dir_.File("lab.yaml") +
                                    "' --plan auto:30 --robot puma");
  ASSERT_EQ(r.exit_code, 0) << r.err << r.out;
  EXPECT_NE(r.out.find("30 of 30 configurations stored"), std::string::npos) << r.out;
  db::Database db(Db());
  EXPECT_EQ(Count(db, "SELECT count(*) FROM poses WHERE status = 'measured'"), 30);
  EXPECT_EQ(Count(db, "SELECT count(*) FROM observations"), 90);
  EXPECT_EQ(Count(db, "SELECT count(*) FROM points WHERE x_mm IS NOT NULL"), 30);
  EXPECT_EQ(Text(db, "SELECT state FROM sessions"), "completed");
  // Every reduced point is where the true robot put its target.
  auto q = db.connection().Prepare(
      "SELECT p.joints_json, pt.x_mm, pt.y_mm, pt.z_mm FROM poses p JOIN points pt "
      "ON pt.pose_id = p.id");
  calibration::Kinematics kin(lab_->model());
  int checked = 0;
  while (q->Step()) {
    const auto joints = nlohmann::json::parse(q->Text(0)).get<std::vector<double>>();
    const Eigen::Vector3d truth =
        kin.Position(lab_->world_from_base(), lab_->true_params(), joints.data());
    const Eigen::Vector3d measured(q->Double(1), q->Double(2), q->Double(3));
    EXPECT_LT((measured - truth).norm(), 0.06);  // 0.5″ at 3.5 m: ~0.01 mm per ray
    ++checked;
  }
  EXPECT_EQ(checked, 30);
}

TEST_F(VirtualLabFixture, FullSessionOnAServerStore) {
  OnServer();
  Start();
  const auto r = testing::RunArmsig("--db '" + Db() + "' capture --lab '" + dir_.File("lab.yaml") +
                                    "' --plan auto:30 --robot puma");
  ASSERT_EQ(r.exit_code, 0) << r.err << r.out;
  db::Database db(Db(), db::OpenMode::kMustExist);
  EXPECT_EQ(Count(db, "SELECT count(*) FROM poses WHERE status = 'measured'"), 30);
  EXPECT_EQ(Count(db, "SELECT count(*) FROM observations"), 90);
  EXPECT_EQ(Text(db, "SELECT state FROM sessions"), "completed");
  auto q = db.connection().Prepare(
      "SELECT p.joints_json, pt.x_mm, pt.y_mm, pt.z_mm FROM poses p JOIN points pt "
      "ON pt.pose_id = p.id");
  calibration::Kinematics kin(lab_->model());
  int checked = 0;
  while (q->Step()) {
    const auto joints = nlohmann::json::parse(q->Text(0)).get<std::vector<double>>();
    const Eigen::Vector3d truth =
        kin.Position(lab_->world_from_base(), lab_->true_params(), joints.data());
    EXPECT_LT((Eigen::Vector3d(q->Double(1), q->Double(2), q->Double(3)) - truth).norm(), 0.06);
    ++checked;
  }
  EXPECT_EQ(checked, 30);
}

// Triggering every instrument at once costs the slowest one, not their sum.
TEST_F(VirtualLabFixture, ConcurrentTriggeringCostsTheSlowestInstrument) {
  // Delays long against scheduling noise on a loaded 2-core CI machine: the test asserts
  // overlap (the cycle is far below the sum), not speed; overhead is measured in bench/.
  Start({100, 150, 200});
  // Sequential reference through the same drivers.
  double sequential_ms = 0;
  {
    std::vector<std::unique_ptr<instruments::GeoComDevice>> devices;
    for (auto& s : sims_) {
      instruments::SerialSettings port;
      port.path = s->path();
      devices.push_back(
          std::make_unique<instruments::GeoComDevice>(instruments::MakeSerialTransport(port)));
      devices.back()->Face();
    }
    const auto t0 = std::chrono::steady_clock::now();
    for (int k = 0; k < 3; ++k)
      for (auto& d : devices) d->MeasureAngles();
    sequential_ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count() /
        3;
  }
  const io::LabConfig lab = io::LoadLab(dir_.File("lab.yaml"));
  db::Database db(Db());
  Plan plan = WellSpreadPlan(lab.model, 6, 300, 1);
  const int64_t session = CreateSession(db, lab, "puma", plan);
  auto devices = OpenInstruments(lab);
  auto controller = OpenController(lab);
  const auto s = RunCapture(db, lab, session, devices, *controller, {});
  ASSERT_TRUE(s.completed);
  EXPECT_GT(sequential_ms, 440.0);                  // 100 + 150 + 200
  EXPECT_LT(s.mean_cycle_ms, 0.7 * sequential_ms);  // ≈ 200 + overhead, far below 450
  EXPECT_GT(s.mean_cycle_ms, 190.0);                // never faster than the slowest
}

// A reading keeps its own record on the way to the database: the time its instrument's
// answer arrived (not the time it was stored), the instrument's warning with valid data,
// and the instrument as it identified itself (the instruments table).
TEST_F(VirtualLabFixture, AReadingIsStoredWithItsTimeItsWarningAndItsInstrument) {
  Start();
  io::LabConfig lab = io::LoadLab(dir_.File("lab.yaml"));
  lab.tolerances.readings = 2;  // two rounds: each instrument answers twice, 10 ms apart
  db::Database db(Db());
  const Plan plan = WellSpreadPlan(lab.model, 4, 300, 1);
  const int64_t session = CreateSession(db, lab, "puma", plan);
  auto devices = OpenInstruments(lab);
  auto controller = OpenController(lab);
  std::vector<instruments::DeviceInfo> identities;
  for (auto& d : devices) identities.push_back(d->Identify());
  CaptureOptions options;
  options.identities = identities;
  // Station T2 warns with every measurement (GeoCOM 1284: data valid, accuracy not
  // guaranteed) from now on.
  sims_[1]->InjectAlways({simulation::Fault::kWarningCode, 1284});
  const std::string before = db::MeasuredAt(std::chrono::system_clock::now());
  const auto s = RunCapture(db, lab, session, devices, *controller, options);
  ASSERT_TRUE(s.completed);
  const auto rows = db::LoadObservations(db, session);
  ASSERT_EQ(rows.size(), 24u);
  std::map<std::string, std::set<int64_t>> instruments_of_station;
  // The seconds of the day of a stored time (2026-11-27T13:04:14.123Z).
  const auto seconds_of = [](const std::string& t) {
    return std::stod(t.substr(11, 2)) * 3600 + std::stod(t.substr(14, 2)) * 60 +
           std::stod(t.substr(17, 6));
  };
  std::map<std::pair<int64_t, std::string>, std::vector<double>> answers;
  for (const auto& r : rows) {
    ASSERT_TRUE(r.measured_at.has_value());
    EXPECT_GE(*r.measured_at, before);
    answers[{*r.pose_id, r.station}].push_back(seconds_of(*r.measured_at));
    ASSERT_TRUE(r.instrument_id.has_value());
    instruments_of_station[r.station].insert(*r.instrument_id);
    if (r.station == "T2") {
      EXPECT_EQ(r.return_code, 1284);
      EXPECT_NE(r.note.find("TMC_ACCURACY_GUARANTEE"), std::string::npos) << r.note;
    } else {
      EXPECT_EQ(r.return_code, 0);
      EXPECT_TRUE(r.note.empty()) << r.note;
    }
  }
  // An instrument's two answers to one configuration are its latency apart (at least
  // 10 ms, the simulated instrument's), where the rows were stored at once in one
  // transaction: the stored times are the instruments'.
  for (const auto& [key, times] : answers) {
    ASSERT_EQ(times.size(), 2u);
    EXPECT_GE(std::abs(times[1] - times[0]), 0.009) << key.second;
  }
  // Each reading was received before its configuration's pose was stored, and the
  // configurations one after another.
  auto q = db.connection().Prepare(
      "SELECT max(o.measured_at) <= p.captured_at, min(o.measured_at) FROM observations o JOIN "
      "poses p ON p.id = o.pose_id GROUP BY p.id ORDER BY p.seq");
  std::string previous;
  while (q->Step()) {
    EXPECT_EQ(q->Int(0), 1);
    EXPECT_GT(q->Text(1), previous);
    previous = q->Text(1);
  }
  // One instrument per station, as it said it was: the serial number it gave.
  ASSERT_EQ(instruments_of_station.size(), 3u);
  for (size_t i = 0; i < 3; ++i) {
    const std::string station = lab.instruments[i].station;
    ASSERT_EQ(instruments_of_station[station].size(), 1u) << station;
    auto row = db.connection().Prepare(
        "SELECT name, kind, protocol, serial_number, port FROM instruments WHERE id = ?");
    row->Bind(1, *instruments_of_station[station].begin());
    ASSERT_TRUE(row->Step());
    EXPECT_EQ(row->Text(1), "theodolite");
    EXPECT_EQ(row->Text(2), "geocom");
    EXPECT_EQ(row->Text(3), identities[i].serial);
    EXPECT_FALSE(identities[i].serial.empty());
    EXPECT_NE(row->Text(0).find(identities[i].serial), std::string::npos) << row->Text(0);
    EXPECT_EQ(row->Text(4), lab.instruments[i].port);
  }
  // A second run of the same instruments finds them: no new rows.
  EXPECT_EQ(Count(db, "SELECT count(*) FROM instruments"), 3);
}

// An instrument that answers 3 s before the configuration is stored (the slowest of the
// three takes that long): its readings keep their own time, not the insert's, and their
// time, warning and instrument go on with `db push`.
TEST_F(VirtualLabFixture, AReadingStoredSecondsAfterItsAnswerKeepsItsTimeThroughPush) {
  Start({10, 10, 3000});
  io::LabConfig lab = io::LoadLab(dir_.File("lab.yaml"));
  lab.policy.timeout = 10s;  // T3 answers after 3 s
  int64_t session = 0;
  {
    db::Database db(Db());
    session = CreateSession(db, lab, "puma", WellSpreadPlan(lab.model, 2, 300, 1));
    auto devices = OpenInstruments(lab);
    auto controller = OpenController(lab);
    CaptureOptions options;
    for (auto& d : devices) options.identities.push_back(d->Identify());
    sims_[0]->InjectOnce({simulation::Fault::kWarningCode, 1283});
    ASSERT_TRUE(RunCapture(db, lab, session, devices, *controller, options).completed);
  }
  const std::string pushed = dir_.File("central.db");
  {
    db::Database source(Db(), db::OpenMode::kMustExist);
    db::Database target(pushed);
    db::Push(source.connection(), target.connection(), {Db(), nullptr});
  }
  for (const std::string& path : {Db(), pushed}) {
    db::Database db(path, db::OpenMode::kMustExist);
    auto q = db.connection().Prepare(
        "SELECT (julianday(p.captured_at) - julianday(o.measured_at)) * 86400, o.note, i.name "
        "FROM observations o JOIN poses p ON p.id = o.pose_id JOIN stations s ON "
        "s.id = o.station_id LEFT JOIN instruments i ON i.id = o.instrument_id "
        "WHERE s.code = 'T1' ORDER BY p.seq");
    int rows = 0;
    while (q->Step()) {
      EXPECT_GT(q->Double(0), 2.5) << path;  // answered ~3 s before the pose was stored
      EXPECT_LT(q->Double(0), 60.0) << path;
      if (rows == 0) {
        EXPECT_NE(q->Text(1).find("TMC_NO_FULL_CORRECTION"), std::string::npos) << q->Text(1);
      }
      EXPECT_EQ(q->Text(2), "TDRA6000 358120") << path;
      ++rows;
    }
    EXPECT_EQ(rows, 2) << path;
  }
}

void VirtualLabFixture::KillNineThenResume(int kills_wanted) {
  Start({12, 12, 12});
  std::mt19937 rng(20261122);
  std::uniform_int_distribution<int> delay(20, 120);
  const std::string binary = ARMSIG_BINARY;
  int kills = 0;
  for (int round = 0; round < 60 && kills < kills_wanted + 2; ++round) {
    bool have_session = false;
    if (StoreMade()) {
      db::Database db(Db());
      have_session = Count(db, "SELECT count(*) FROM sessions") > 0;
    }
    std::vector<std::string> args = {binary,    "--db",  Db(),
                                     "capture", "--lab", dir_.File("lab.yaml")};
    if (have_session) {
      args.insert(args.end(), {"--resume", "1"});
    } else {
      args.insert(args.end(), {"--plan", "auto:100", "--robot", "puma"});
    }
    const pid_t child = testing::SpawnQuietly(args);
    ASSERT_GE(child, 0);
    if (!have_session) {
      // Planning takes a moment; start killing once the session exists.
      int ended = 0;
      testing::WaitForChildOr(child, &ended, [&] {
        if (!StoreMade()) return false;
        db::Database db(Db());
        return Count(db, "SELECT count(*) FROM sessions") > 0;
      });
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(delay(rng)));
    int status = 0;
    if (::waitpid(child, &status, WNOHANG) == 0) {
      ::kill(child, SIGKILL);
      ::waitpid(child, &status, 0);
      ++kills;
    } else if (WIFEXITED(status) && WEXITSTATUS(status) == 0) {
      db::Database db(Db());
      if (Text(db, "SELECT state FROM sessions WHERE id = 1") == "completed")
        break;
    }
  }
  EXPECT_GE(kills, kills_wanted);
  // Finish the session.
  const auto last = testing::RunArmsig("--db '" + Db() + "' capture --lab '" +
                                       dir_.File("lab.yaml") + "' --resume 1");
  ASSERT_EQ(last.exit_code, 0) << last.err;
  db::Database db(Db());
  if (store_.empty()) {
    EXPECT_EQ(Text(db, "PRAGMA integrity_check"), "ok");
  }
  EXPECT_EQ(Text(db, "SELECT state FROM sessions WHERE id = 1"),
            "completed");
  EXPECT_EQ(Count(db, "SELECT count(*) FROM poses WHERE session_id = 1"), 100);
  EXPECT_EQ(Count(db, "SELECT count(DISTINCT seq) FROM poses WHERE session_id = 1"), 100);
  EXPECT_EQ(Count(db, "SELECT max(seq) FROM poses WHERE session_id = 1"), 99);
  // Exactly three rays and one point per configuration: nothing half-written, nothing twice.
  EXPECT_EQ(Count(db,
                  "SELECT count(*) FROM (SELECT pose_id, count(*) c FROM observations GROUP BY "
                  "pose_id) per_pose WHERE c != 3"),
            0);
  EXPECT_EQ(Count(db, "SELECT count(*) FROM observations"), 300);
  EXPECT_EQ(Count(db, "SELECT count(*) FROM points WHERE session_id = 1"), 100);
}

// kill -9 of the capture process at 20+ random moments, then --resume each time: every
// committed configuration is present exactly once and the session completes.
TEST_F(VirtualLabFixture, KillNineAtRandomMomentsThenResume) { KillNineThenResume(20); }

// The same with the store on the server: the killed process's transaction is rolled back
// by the server when its connection drops.
TEST_F(VirtualLabFixture, KillNineAtRandomMomentsThenResumeOnAServerStore) {
  OnServer();
  KillNineThenResume(8);
}

TEST_F(VirtualLabFixture, InstrumentFaultPausesThenResumes) {
  Start();
  const io::LabConfig lab = io::LoadLab(dir_.File("lab.yaml"));
  db::Database db(Db());
  const int64_t session = CreateSession(db, lab, "puma", WellSpreadPlan(lab.model, 8, 300, 2));
  auto devices = OpenInstruments(lab);
  auto controller = OpenController(lab);
  // A transient error is retried and the configuration measured.
  sims_[1]->InjectOnce({simulation::Fault::kErrorCode, 8710});
  // Then T2 loses its target for good on the configuration after: 3 attempts fail.
  CaptureOptions options;
  int progress = 0;
  options.progress = [&](const Progress&) {
    if (++progress == 3)
      for (int k = 0; k < 3; ++k) sims_[1]->InjectOnce({simulation::Fault::kErrorCode, 8710});
  };
  const auto paused = RunCapture(db, lab, session, devices, *controller, options);
  EXPECT_TRUE(paused.paused);
  EXPECT_NE(paused.pause_reason.find("AUT_NO_TARGET"), std::string::npos) << paused.pause_reason;
  EXPECT_EQ(paused.measured, 3);
  EXPECT_EQ(Text(db, "SELECT state FROM sessions"), "paused");
  // Fixed: resume from the configuration that failed.
  const auto resumed = RunCapture(db, lab, session, devices, *controller, {});
  EXPECT_TRUE(resumed.completed);
  EXPECT_EQ(resumed.already, 3);
  EXPECT_EQ(resumed.measured, 5);
  EXPECT_EQ(Count(db, "SELECT count(*) FROM poses"), 8);
}

TEST_F(VirtualLabFixture, SkipOnFaultRecordsTheConfigurationAsSkipped) {
  Start();
  const io::LabConfig lab = io::LoadLab(dir_.File("lab.yaml"));
  db::Database db(Db());
  const int64_t session = CreateSession(db, lab, "puma", WellSpreadPlan(lab.model, 5, 300, 3));
  auto devices = OpenInstruments(lab);
  auto controller = OpenController(lab);
  for (int k = 0; k < 3; ++k) sims_[0]->InjectOnce({simulation::Fault::kErrorCode, 1292});
  CaptureOptions options;
  options.skip_on_fault = true;
  const auto s = RunCapture(db, lab, session, devices, *controller, options);
  EXPECT_TRUE(s.completed);
  EXPECT_EQ(s.skipped, 1);
  EXPECT_EQ(s.measured, 4);
  EXPECT_EQ(
      Count(db, "SELECT count(*) FROM poses WHERE status = 'skipped' AND joints_json IS NULL"), 1);
  EXPECT_EQ(Count(db, "SELECT count(*) FROM observations"), 12);  // none from the skipped one
}

// A robot that stops short of where it was sent (a fence, a limit, the pendant's hold):
// the joints read back are not the commanded ones. Once, the configuration is moved
// again and measured; for good, the session pauses naming the joint, storing nothing of
// a configuration the robot did not reach.
TEST_F(VirtualLabFixture, ARobotThatStopsShortIsAFaultNamingTheJoint) {
  Start();
  const io::LabConfig lab = io::LoadLab(dir_.File("lab.yaml"));
  db::Database db(Db());
  const int64_t session = CreateSession(db, lab, "puma", WellSpreadPlan(lab.model, 6, 300, 4));
  auto devices = OpenInstruments(lab);
  auto controller = OpenController(lab);
  robot_->InjectOnce({simulation::Fault::kStopShort, 0});  // the first move
  CaptureOptions options;
  int progress = 0;
  options.progress = [&](const Progress&) {
    if (++progress == 2) robot_->InjectAlways({simulation::Fault::kStopShort, 0});
  };
  const auto s = RunCapture(db, lab, session, devices, *controller, options);
  EXPECT_TRUE(s.paused);
  EXPECT_EQ(s.measured, 2);
  EXPECT_NE(s.pause_reason.find("joint 2"), std::string::npos) << s.pause_reason;
  EXPECT_NE(s.pause_reason.find("not where the plan put it"), std::string::npos)
      << s.pause_reason;
  // What was stored is where the robot was sent.
  const auto poses = db::LoadSessionPoses(db, session);
  ASSERT_EQ(poses.size(), 2u);
  const Plan plan = PlanFromJson(db::LoadSession(db, session)->plan_json);
  for (const auto& p : poses) {
    bool found = false;
    // Within the controller's printed resolution (0.001°), far from the 2° it stopped short.
    for (const auto& c : plan) found |= (c.joints_rad - p.joints_rad).cwiseAbs().maxCoeff() < 1e-4;
    EXPECT_TRUE(found) << p.joints_rad.transpose();
  }
  robot_->ClearFaults();
  const auto resumed = RunCapture(db, lab, session, devices, *controller, {});
  EXPECT_TRUE(resumed.completed);
  EXPECT_EQ(resumed.measured, 4);
}

// A controller armsig cannot move and an operator who does not move the robot (no terminal
// to ask on, or an absent-minded one): the second configuration reads where the first was
// measured. It is a fault naming both, not a copy of the first stored under the second's
// name; the session pauses with one configuration, and goes on once the robot moves.
TEST_F(VirtualLabFixture, AnUnmovedRobotIsAFaultNotASecondConfiguration) {
  Start();
  std::string yaml = testing::ReadText(dir_.File("lab.yaml"));
  const auto at = yaml.find("can_move: true");
  ASSERT_NE(at, std::string::npos);
  yaml.replace(at, 14, "can_move: false");
  testing::WriteText(dir_.File("lab.yaml"), yaml);
  const io::LabConfig lab = io::LoadLab(dir_.File("lab.yaml"));
  db::Database db(Db());
  const Plan plan = WellSpreadPlan(lab.model, 3, 300, 5);
  const int64_t session = CreateSession(db, lab, "puma", plan);
  auto devices = OpenInstruments(lab);
  auto controller = OpenController(lab);
  ASSERT_FALSE(controller->CanMove());
  lab_->SetJoints(plan[0].joints_rad);
  CaptureOptions options;
  int asked = 0;
  options.prompt_move = [&](const PlannedConfiguration&) { ++asked; };  // and nothing moves
  const auto s = RunCapture(db, lab, session, devices, *controller, options);
  EXPECT_TRUE(s.paused);
  EXPECT_EQ(s.measured, 1);
  EXPECT_NE(s.pause_reason.find("has not moved since configuration " + plan[0].label),
            std::string::npos)
      << s.pause_reason;
  EXPECT_EQ(db::LoadSessionPoses(db, session).size(), 1u);
  // The operator moves it this time: the session goes on and completes.
  options.prompt_move = [&](const PlannedConfiguration& c) { lab_->SetJoints(c.joints_rad); };
  const auto resumed = RunCapture(db, lab, session, devices, *controller, options);
  EXPECT_TRUE(resumed.completed);
  EXPECT_EQ(resumed.measured, 2);
}

// Two captures on the same lab at once: the second is refused before it makes a session
// or sends a byte, naming the device and the process that holds it; the first finishes.
TEST_F(VirtualLabFixture, ASecondCaptureOnTheSameDevicesIsRefused) {
  Start({15, 15, 15});
  const std::string binary = ARMSIG_BINARY;
  const pid_t first = testing::SpawnQuietly({binary, "--db", Db(), "capture", "--lab",
                                    dir_.File("lab.yaml"), "--plan", "auto:40", "--robot",
                                    "puma"});
  ASSERT_GE(first, 0);
  int ended = 0;
  ASSERT_TRUE(testing::WaitForChildOr(first, &ended, [&] {
    if (!std::filesystem::exists(Db())) return false;
    db::Database db(Db());
    return Count(db, "SELECT count(*) FROM poses") >= 2;
  })) << "the first capture ended before it stored two configurations";
  const auto second = testing::RunArmsig("--db '" + dir_.File("other.db") + "' capture --lab '" +
                                         dir_.File("lab.yaml") + "' --plan auto:5 --robot puma");
  EXPECT_EQ(second.exit_code, 1) << second.err;
  EXPECT_NE(second.err.find("is in use by another armsig process"), std::string::npos)
      << second.err;
  EXPECT_NE(second.err.find("pid " + std::to_string(first)), std::string::npos) << second.err;
  EXPECT_FALSE(std::filesystem::exists(dir_.File("other.db")));  // nothing made
  int status = 0;
  ::waitpid(first, &status, 0);
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 0);
  db::Database db(Db());
  EXPECT_EQ(Count(db, "SELECT count(*) FROM poses"), 40);
  // The claims went with the process: the next capture runs.
  const auto next = testing::RunArmsig("--db '" + Db() + "' capture --lab '" +
                                       dir_.File("lab.yaml") + "' --plan auto:3 --robot puma");
  EXPECT_EQ(next.exit_code, 0) << next.err;
}

// A robot name a typo away from a registered one is that robot mistyped: refused, naming the
// robot meant, nothing stored; registered first with `robot add`, the new name captures.
TEST_F(VirtualLabFixture, ARobotNameATypoAwayFromARegisteredOneIsRefused) {
  Start();
  const std::string lab = dir_.File("lab.yaml");
  ASSERT_EQ(testing::RunArmsig("--db '" + Db() + "' capture --lab '" + lab +
                               "' --plan auto:3 --robot puma")
                .exit_code,
            0);
  const auto typo = testing::RunArmsig("--db '" + Db() + "' capture --lab '" + lab +
                                       "' --plan auto:3 --robot pumaa");
  EXPECT_EQ(typo.exit_code, 2) << typo.err;
  EXPECT_NE(typo.err.find("no robot 'pumaa'"), std::string::npos) << typo.err;
  EXPECT_NE(typo.err.find("did you mean 'puma'?"), std::string::npos) << typo.err;
  {
    db::Database db(Db());
    EXPECT_EQ(Count(db, "SELECT count(*) FROM robots"), 1);
    EXPECT_EQ(Count(db, "SELECT count(*) FROM sessions"), 1);
  }
  ASSERT_EQ(testing::RunArmsig("--db '" + Db() + "' robot add pumaa --model '" +
                               testing::SourcePath("models/puma760.yaml") + "'")
                .exit_code,
            0);
  const auto added = testing::RunArmsig("--db '" + Db() + "' capture --lab '" + lab +
                                        "' --plan auto:3 --robot pumaa");
  EXPECT_EQ(added.exit_code, 0) << added.err;
}

// An instrument that is not there (switched off, a wrong port) is named before anything
// is made: no database, no empty paused session; so is a silent robot controller.
TEST_F(VirtualLabFixture, AnInstrumentThatDoesNotAnswerIsNamedBeforeASessionIsMade) {
  Start();
  std::string yaml = testing::ReadText(dir_.File("lab.yaml"));
  const std::string t2 = sims_[1]->path();
  yaml.replace(yaml.find(t2), t2.size(), dir_.File("no-such-port"));
  testing::WriteText(dir_.File("off.yaml"), yaml);
  const auto r = testing::RunArmsig("--db '" + Db() + "' capture --lab '" + dir_.File("off.yaml") +
                                    "' --plan auto:5 --robot puma");
  EXPECT_EQ(r.exit_code, 1) << r.err;
  EXPECT_NE(r.err.find("station T2: the instrument does not answer"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("nothing was stored"), std::string::npos) << r.err;
  EXPECT_FALSE(StoreMade());
  // The controller silent (every request dropped): named, nothing made.
  robot_->InjectAlways({simulation::Fault::kDropReply, 0});
  const auto silent = testing::RunArmsig("--db '" + Db() + "' capture --lab '" +
                                         dir_.File("lab.yaml") + "' --plan auto:5 --robot puma");
  EXPECT_EQ(silent.exit_code, 1) << silent.err;
  EXPECT_NE(silent.err.find("the robot controller does not answer"), std::string::npos)
      << silent.err;
  EXPECT_FALSE(StoreMade());
  robot_->ClearFaults();
  const auto works = testing::RunArmsig("--db '" + Db() + "' capture --lab '" +
                                        dir_.File("lab.yaml") + "' --plan auto:3 --robot puma");
  EXPECT_EQ(works.exit_code, 0) << works.err;
  EXPECT_NE(works.err.find("capture: station T1: "), std::string::npos) << works.err;
}

TEST_F(VirtualLabFixture, PortThatVanishesAndReturnsMidSession) {
  Start();
  const io::LabConfig lab = io::LoadLab(dir_.File("lab.yaml"));
  db::Database db(Db());
  const int64_t session = CreateSession(db, lab, "puma", WellSpreadPlan(lab.model, 10, 300, 4));
  auto devices = OpenInstruments(lab);
  auto controller = OpenController(lab);
  CaptureOptions options;
  std::future<void> outage;
  int progress = 0;
  options.progress = [&](const Progress&) {
    if (++progress == 4) {
      outage = std::async(std::launch::async, [&] {
        sims_[2]->Disappear();  // the USB adapter is pulled …
        std::this_thread::sleep_for(250ms);
        sims_[2]->Reappear();  // … and plugged back in
      });
    }
  };
  const auto s = RunCapture(db, lab, session, devices, *controller, options);
  outage.wait();
  EXPECT_TRUE(s.completed) << s.pause_reason;
  EXPECT_EQ(s.measured, 10);
  EXPECT_EQ(Count(db, "SELECT count(*) FROM observations"), 30);
}

// Ctrl-C stops between configurations: the session is paused with every finished
// configuration stored, and --resume completes it.
TEST_F(VirtualLabFixture, CtrlCStopsCleanlyAndResumeCompletes) {
  Start({15, 15, 15});
  const std::string binary = ARMSIG_BINARY;
  std::vector<std::string> args = {
      binary,   "--db",    Db(),      "capture", "--lab", dir_.File("lab.yaml"),
      "--plan", "auto:60", "--robot", "puma"};
  const pid_t child = testing::SpawnQuietly(args);
  ASSERT_GE(child, 0);
  // Interrupt once some configurations are stored (an event, however slow the machine). The
  // store is only ever opened as one that exists (a plain open of the file the capture is
  // still creating would make the schema itself), and a capture that ends early is said at
  // once, not after the three minutes of waiting it once took on a loaded machine.
  int ended = 0;
  ASSERT_TRUE(testing::WaitForChildOr(child, &ended, [&] {
    try {
      db::Database db(Db(), db::OpenMode::kMustExist);
      return Count(db, "SELECT count(*) FROM poses") >= 5;
    } catch (const InputError&) {
      return false;  // not made yet
    }
  })) << "the capture ended (status " << ended << ") before it stored 5 configurations";
  ::kill(child, SIGINT);
  int status = 0;
  ::waitpid(child, &status, 0);
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 130);  // stopped by a signal, as every command
  {
    db::Database db(Db());
    EXPECT_EQ(Text(db, "SELECT state FROM sessions"), "paused");
    const int stored = Count(db, "SELECT count(*) FROM poses");
    EXPECT_GE(stored, 5);
    EXPECT_LT(stored, 60);
    EXPECT_EQ(Count(db, "SELECT count(*) FROM observations"), 3 * stored);
  }
  const auto r = testing::RunArmsig("--db '" + Db() + "' capture --lab '" + dir_.File("lab.yaml") +
                                    "' --resume 1");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  db::Database db(Db());
  EXPECT_EQ(Count(db, "SELECT count(*) FROM poses"), 60);
  EXPECT_EQ(Text(db, "SELECT state FROM sessions"), "completed");
}

// Ctrl-C at moments defined by what the capture has done, never by the clock: right after
// the start (before the session exists, while devices answer), just after the session row
// appears, and once a configuration is stored, each with a random extra delay. The session
// is never left running, and the resume command printed, run as printed from another
// directory, completes it. A slow or loaded machine only makes the test slower.
TEST_F(VirtualLabFixture, CtrlCAtRandomMomentsLeavesAResumableSession) {
  Start({8, 8, 8});
  std::mt19937 rng(20261123);
  std::uniform_int_distribution<int> delay(0, 20);
  const std::string binary = ARMSIG_BINARY;
  int waited_sessions = 0, sessions = 0, paused = 0;
  for (int round = 0; round < 6; ++round) {
    const std::string db = dir_.File("ctrl-c-" + std::to_string(round) + ".db");
    const pid_t child = testing::Spawn({binary, "--db", db, "capture", "--lab", dir_.File("lab.yaml"),
                               "--plan", "auto:12", "--robot", "puma"},
                              dir_.File("out"), dir_.File("err"));
    ASSERT_GE(child, 0);
    auto count = [&](const char* sql) {
      if (!std::filesystem::exists(db)) return 0;
      db::Database database(db);
      return Count(database, sql);
    };
    int status = 0;
    bool running = true;
    const int moment = round % 3;  // 0: at once, 1: the session row, 2: a stored configuration
    if (moment == 1) {
      running = testing::WaitForChildOr(
          child, &status, [&] { return count("SELECT count(*) FROM sessions") > 0; });
    } else if (moment == 2) {
      running = testing::WaitForChildOr(
          child, &status, [&] { return count("SELECT count(*) FROM poses") > 0; });
    }
    ASSERT_TRUE(running || moment == 0) << "the capture ended before the moment\n"
                                        << testing::ReadText(dir_.File("err"));
    if (running) {
      std::this_thread::sleep_for(std::chrono::milliseconds(delay(rng)));
      ::kill(child, SIGINT);
      ::waitpid(child, &status, 0);
    }
    if (moment != 0) ++waited_sessions;
    const std::string err = testing::ReadText(dir_.File("err"));
    if (!std::filesystem::exists(db)) continue;  // stopped before the database was opened
    db::Database database(db);
    if (Count(database, "SELECT count(*) FROM sessions") == 0) continue;
    ++sessions;
    const std::string state =
        Text(database, "SELECT state FROM sessions WHERE id = 1");
    ASSERT_TRUE(state == "paused" || state == "completed") << state << "\n" << err;
    if (state == "completed") continue;
    ++paused;
    EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 130) << err;
    const std::string hint = ResumeHint(err);
    ASSERT_EQ(hint.rfind("armsig --db ", 0), 0u) << err;
    const auto r = testing::RunArmsig(hint.substr(std::string("armsig ").size()), "/");
    ASSERT_EQ(r.exit_code, 0) << hint << "\n" << r.err;
    EXPECT_EQ(Text(database, "SELECT state FROM sessions WHERE id = 1"),
              "completed");
    EXPECT_EQ(Count(database, "SELECT count(*) FROM poses WHERE session_id = 1"), 12);
  }
  // Every round that waited for the session has one; a Ctrl-C at most 20 ms after the
  // session row or the first stored configuration of twelve finds it unfinished.
  EXPECT_GE(sessions, waited_sessions);
  EXPECT_GE(paused, waited_sessions / 2) << "of " << sessions << " sessions";
}

// A lab file whose robot model differs from the registered robot's (the upper arm edited
// from 650 to 650.3 mm) is refused before anything is stored, naming the differing value;
// the registered robot's own model file is accepted.
TEST_F(VirtualLabFixture, ALabModelThatDiffersFromTheRegisteredRobotIsRefused) {
  Start();
  const std::string db = "--db '" + Db() + "' ";
  const auto first = testing::RunArmsig(db + "capture --lab '" + dir_.File("lab.yaml") +
                                        "' --plan auto:3 --robot puma");
  ASSERT_EQ(first.exit_code, 0) << first.err;
  std::string model = testing::ReadText(testing::SourcePath("models/puma760.yaml"));
  const std::string link = "[[1,0,0,650]";
  ASSERT_NE(model.find(link), std::string::npos);
  model.replace(model.find(link), link.size(), "[[1,0,0,650.3]");
  testing::WriteText(dir_.File("edited.yaml"), model);
  std::string lab = testing::ReadText(dir_.File("lab.yaml"));
  const std::string shipped = testing::SourcePath("models/puma760.yaml");
  lab.replace(lab.find(shipped), shipped.size(), dir_.File("edited.yaml"));
  testing::WriteText(dir_.File("edited-lab.yaml"), lab);
  const auto edited = testing::RunArmsig(db + "capture --lab '" + dir_.File("edited-lab.yaml") +
                                         "' --plan auto:3 --robot puma");
  EXPECT_EQ(edited.exit_code, 2) << edited.err;
  EXPECT_NE(edited.err.find("differs from robot 'puma' as registered"), std::string::npos)
      << edited.err;
  EXPECT_NE(edited.err.find("650.3 mm against 650 mm"), std::string::npos) << edited.err;
  db::Database database(Db());
  EXPECT_EQ(Count(database, "SELECT count(*) FROM sessions"), 1);
}

// Every ray nearly parallel: no point can be intersected. Each configuration is counted
// failed and named, no miss distance is invented, and the exit code is 1, with
// --skip-on-fault too (nothing usable was captured).
TEST_F(VirtualLabFixture, ParallelRaysAreFailedNamedAndExitOne) {
  clustered_ = true;
  Start();
  const auto r = testing::RunArmsig("--db '" + Db() + "' capture --lab '" + dir_.File("lab.yaml") +
                                    "' --plan auto:4 --robot puma");
  EXPECT_EQ(r.exit_code, 1) << r.err << r.out;
  EXPECT_NE(r.out.find("4 of 4 configurations stored (4 now, 0 before): 0 usable, 0 flagged, 4 "
                       "failed, 0 skipped"),
            std::string::npos)
      << r.out;
  for (const char* label : {"C1 (parallel_rays", "C2 (parallel_rays", "C4 (parallel_rays"})
    EXPECT_NE(r.out.find(label), std::string::npos) << label << "\n" << r.out;
  EXPECT_EQ(r.out.find("0.0000"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("no usable point"), std::string::npos) << r.out;
  EXPECT_NE(r.err.find("no usable configuration"), std::string::npos) << r.err;
  const auto skip = testing::RunArmsig("--db '" + dir_.File("skip.db") + "' capture --lab '" +
                                       dir_.File("lab.yaml") + "' --plan auto:4 --robot puma " +
                                       "--skip-on-fault");
  EXPECT_EQ(skip.exit_code, 1) << skip.out;
  db::Database db(Db());
  EXPECT_EQ(Text(db, "SELECT state FROM sessions"), "completed");
  EXPECT_EQ(Count(db, "SELECT count(*) FROM points WHERE flags LIKE '%parallel_rays%'"), 4);
}

// Points beyond the lab's tolerances after re-measuring are stored flagged, counted
// apart from the usable ones (whose miss distances alone make the mean and max), named,
// and make the exit code 1 unless --skip-on-fault accepts them.
TEST_F(VirtualLabFixture, FlaggedConfigurationsAreNamedAndExitOneUnlessAccepted) {
  Start();
  std::string yaml = testing::ReadText(dir_.File("lab.yaml"));
  // 0.5″ noise at 3.5 m misses by micrometres: 10 nm flags every point.
  yaml.replace(yaml.find("max_miss_mm: 0.1"), 16, "max_miss_mm: 0.00001, max_remeasure: 1");
  testing::WriteText(dir_.File("tight.yaml"), yaml);
  const io::LabConfig lab = io::LoadLab(dir_.File("lab.yaml"));
  for (const bool accept : {false, true}) {
    const std::string path = dir_.File(accept ? "accept.db" : "refuse.db");
    {
      // The first three configurations with the lab's own tolerances, then a stop.
      db::Database db(path);
      const int64_t session = CreateSession(db, lab, "puma", WellSpreadPlan(lab.model, 6, 300, 7));
      auto devices = OpenInstruments(lab);
      auto controller = OpenController(lab);
      std::atomic<bool> stop{false};
      CaptureOptions options;
      options.stop = &stop;
      int progress = 0;
      options.progress = [&](const Progress&) { stop = ++progress == 3; };
      const auto first = RunCapture(db, lab, session, devices, *controller, options);
      ASSERT_TRUE(first.stopped);
      ASSERT_EQ(first.usable, 3);
      ASSERT_TRUE(first.mean_miss_mm.has_value());
      EXPECT_LT(*first.max_miss_mm, 0.1);
    }
    // The rest with tolerances no point meets.
    const auto r =
        testing::RunArmsig("--db '" + path + "' capture --lab '" + dir_.File("tight.yaml") +
                           "' --resume 1" + (accept ? " --skip-on-fault" : ""));
    EXPECT_EQ(r.exit_code, accept ? 0 : 1) << r.err << r.out;
    EXPECT_NE(r.out.find("6 of 6 configurations stored (3 now, 3 before): 0 usable, 3 flagged, 0 "
                         "failed, 0 skipped; 3 re-measured"),
              std::string::npos)
        << r.out;
    EXPECT_NE(r.out.find("flagged (beyond tolerances): C4 (miss_exceeded"), std::string::npos)
        << r.out;
    for (const char* label : {", C5 (miss_exceeded", ", C6 (miss_exceeded"})
      EXPECT_NE(r.out.find(label), std::string::npos) << label << "\n" << r.out;
    EXPECT_NE(r.out.find("no usable point in this run"), std::string::npos) << r.out;
    if (!accept) {
      EXPECT_NE(r.err.find("0 failed and 3 flagged"), std::string::npos) << r.err;
    }
  }
}

// Two-face sets: every configuration read in face I, the telescopes turned, read in face
// II, turned back; both faces are stored and intersect to the same point.
TEST_F(VirtualLabFixture, TwoFaceSetsStoreBothFaces) {
  Start();
  std::string yaml = testing::ReadText(dir_.File("lab.yaml"));
  yaml.replace(yaml.find("settle_ms: 0"), 12, "settle_ms: 0, two_face: true");
  testing::WriteText(dir_.File("lab2.yaml"), yaml);
  const io::LabConfig lab = io::LoadLab(dir_.File("lab2.yaml"));
  ASSERT_TRUE(lab.tolerances.two_face);
  db::Database db(Db());
  const int64_t session = CreateSession(db, lab, "puma", WellSpreadPlan(lab.model, 4, 300, 5));
  auto devices = OpenInstruments(lab);
  auto controller = OpenController(lab);
  const auto s = RunCapture(db, lab, session, devices, *controller, {});
  ASSERT_TRUE(s.completed) << s.pause_reason;
  EXPECT_EQ(Count(db, "SELECT count(*) FROM observations WHERE face = 1"), 12);
  EXPECT_EQ(Count(db, "SELECT count(*) FROM observations WHERE face = 2"), 12);
  EXPECT_EQ(Count(db, "SELECT count(*) FROM points WHERE rays = 6 AND x_mm IS NOT NULL"), 4);
  EXPECT_LT(s.max_miss_mm, 0.1);
  for (int k = 0; k < 3; ++k) EXPECT_EQ(lab_->Face(k), 1);  // turned back to face I
}

// Capture flags points against the lab's tolerances; `reduce` replaces the session's
// points from the stored rays and must keep every capture flag it cannot derive again.
TEST_F(VirtualLabFixture, ReduceAfterCaptureKeepsEveryCaptureFlag) {
  Start();
  std::string yaml = testing::ReadText(dir_.File("lab.yaml"));
  // 0.5″ noise at 3.5 m gives misses and repeat spreads of micrometres: tolerances of
  // 10 nm flag every point; no re-measuring.
  yaml.replace(yaml.find("max_miss_mm: 0.1"), 16,
               "max_miss_mm: 0.00001, max_repeat_mm: 0.00001, readings: 2, max_remeasure: 0");
  testing::WriteText(dir_.File("lab2.yaml"), yaml);
  const io::LabConfig lab = io::LoadLab(dir_.File("lab2.yaml"));
  ASSERT_EQ(lab.tolerances.readings, 2);
  db::Database db(Db());
  const int64_t session = CreateSession(db, lab, "puma", WellSpreadPlan(lab.model, 4, 300, 5));
  auto devices = OpenInstruments(lab);
  auto controller = OpenController(lab);
  const auto s = RunCapture(db, lab, session, devices, *controller, {});
  ASSERT_TRUE(s.completed) << s.pause_reason;

  auto flags_by_pose = [&] {
    std::map<int64_t, reduction::PointFlags> out;
    for (const auto& p : db::LoadPoints(db, session)) {
      const auto flags = reduction::ParsePointFlags(p.flags);
      EXPECT_TRUE(flags.has_value()) << p.flags;
      if (p.pose_id && flags) out[*p.pose_id] = *flags;
    }
    return out;
  };
  const auto captured = flags_by_pose();
  ASSERT_EQ(captured.size(), 4u);
  for (const auto& [pose, flags] : captured) {
    EXPECT_TRUE(flags.Has(reduction::PointFlag::kMissExceeded)) << ToString(flags);
    EXPECT_TRUE(flags.Has(reduction::PointFlag::kRepeatExceeded)) << ToString(flags);
  }

  // As `armsig reduce` runs today: no tolerances, so nothing is re-derived, all is kept.
  const auto reduced = workflows::ReduceSession(db, session, reduction::PointOptions{});
  EXPECT_EQ(reduced.reduced, 4);
  const auto after = flags_by_pose();
  ASSERT_EQ(after.size(), captured.size());
  for (const auto& [pose, flags] : captured) {
    ASSERT_TRUE(after.count(pose));
    for (auto flag : {reduction::PointFlag::kMissExceeded, reduction::PointFlag::kRepeatExceeded,
                      reduction::PointFlag::kBlunderRejected}) {
      if (flags.Has(flag)) {
        EXPECT_TRUE(after.at(pose).Has(flag)) << ToString(after.at(pose));
      }
    }
  }

  // With the lab's miss tolerance the miss check is made again (and still fails); with a
  // generous one it passes, and only repeat_exceeded, which the stored rays cannot show,
  // is kept.
  // `armsig reduce` takes the checks from the lab file stored with the session.
  const reduction::PointChecks stored = workflows::SessionChecks(db, session);
  ASSERT_TRUE(stored.max_miss_mm && stored.max_repeat_mm);
  EXPECT_EQ(*stored.max_miss_mm, lab.tolerances.max_miss_mm);
  EXPECT_EQ(*stored.max_repeat_mm, lab.tolerances.max_repeat_mm);
  reduction::PointOptions strict;
  strict.checks = stored;
  workflows::ReduceSession(db, session, strict);
  for (const auto& [pose, flags] : flags_by_pose()) {
    EXPECT_TRUE(flags.Has(reduction::PointFlag::kMissExceeded)) << ToString(flags);
    EXPECT_TRUE(flags.Has(reduction::PointFlag::kRepeatExceeded)) << ToString(flags);
  }
  reduction::PointOptions generous;
  generous.checks.max_miss_mm = 1.0;
  workflows::ReduceSession(db, session, generous);
  for (const auto& [pose, flags] : flags_by_pose()) {
    EXPECT_FALSE(flags.Has(reduction::PointFlag::kMissExceeded)) << ToString(flags);
    EXPECT_TRUE(flags.Has(reduction::PointFlag::kRepeatExceeded)) << ToString(flags);
  }
}

TEST(Lab, MalformedLabFileNamesLineAndColumn) {
  testing::TempDir dir;
  testing::WriteText(dir.File("lab.yaml"),
                     "robot:\n  model: '" + testing::SourcePath("models/puma760.yaml") +
                         "'\n  controller: {protocol: fanuc, port: /dev/null}\ninstruments: []\n");
  try {
    io::LoadLab(dir.File("lab.yaml"));
    FAIL();
  } catch (const armsig::InputError& e) {
    EXPECT_EQ(e.where().line, 3);
    EXPECT_NE(std::string(e.what()).find("expected val, as, counter, ur, abb or kuka"),
              std::string::npos);
  }
}

// The demo runs the whole chain; with all 43 parameters its validation error is at the
// simulated noise floor, and geometric-only leaves a clearly larger error.
TEST(Demo, RunsEndToEndAndReachesTheNoiseFloor) {
  testing::TempDir dir;
  const auto r = testing::RunArmsig("--db '" + dir.File("demo.db") + "' demo --json '" +
                                    dir.File("demo.json") + "'");
  ASSERT_EQ(r.exit_code, 0) << r.err << r.out;
  const auto j = nlohmann::json::parse(testing::ReadText(dir.File("demo.json")));
  EXPECT_EQ(j["session"]["poses"], 200);
  ASSERT_EQ(j["stages"].size(), 3u);
  EXPECT_EQ(j["stages"][0]["params"], "geometric");
  EXPECT_EQ(j["stages"][0]["rank"], 25);
  EXPECT_EQ(j["stages"][1]["rank"], 27);
  EXPECT_EQ(j["stages"][2]["rank"], 29);
  const double floor = j["session"]["noise_floor_mm"];
  const double all = j["stages"][2]["validation"]["mean_mm"];
  const double geometric = j["stages"][0]["validation"]["mean_mm"];
  EXPECT_GT(j["stages"][2]["nominal"]["mean_mm"].get<double>(), 3.0);
  EXPECT_LT(all, 1.6 * floor);  // validation points carry their own noise too
  EXPECT_GT(geometric, 10.0 * all);
  db::Database db(dir.File("demo.db"));
  EXPECT_EQ(db.sql().execAndGet("SELECT count(*) FROM calibrations WHERE active = 1").getInt(), 1);
}

// A theodolite that floods its port (unrelated lines, an endless line, binary garbage)
// while the session runs: without Ctrl-C the session pauses by itself once the
// configuration's tries are spent (each device call ends by its deadline), naming the
// instrument and the code; nothing of that configuration is stored.
TEST_F(VirtualLabFixture, FloodingInstrumentPausesTheSessionByItsDeadlines) {
  Start();  // timeout_ms 300, fault_retries 2, fault_retry_delay_ms 200
  const io::LabConfig lab = io::LoadLab(dir_.File("lab.yaml"));
  for (const auto fault : {simulation::Fault::kFloodLines, simulation::Fault::kEndlessLine,
                           simulation::Fault::kFloodBytes}) {
    const std::string path = dir_.File("flood-" + simulation::FaultName(fault) + ".db");
    db::Database db(path);
    const int64_t session = CreateSession(db, lab, "puma", WellSpreadPlan(lab.model, 6, 300, 5));
    auto devices = OpenInstruments(lab);
    auto controller = OpenController(lab);
    CaptureOptions options;
    int progress = 0;
    std::chrono::steady_clock::time_point flood_start;
    options.progress = [&](const Progress&) {
      if (++progress == 2) {
        sims_[1]->InjectAlways({fault, 0});
        flood_start = std::chrono::steady_clock::now();
      }
    };
    const auto s = RunCapture(db, lab, session, devices, *controller, options);
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - flood_start).count();
    sims_[1]->ClearFaults();
    EXPECT_TRUE(s.paused) << simulation::FaultName(fault);
    EXPECT_EQ(s.measured, 2);
    EXPECT_NE(s.pause_reason.find(sims_[1]->path()), std::string::npos) << s.pause_reason;
    EXPECT_GT(sims_[1]->flood_bytes(), 0);
    // Three tries of 300 ms deadlines and two 200 ms delays (plus a move and the other
    // instruments): about 1.3 s; minutes before the deadline covered the whole exchange.
    EXPECT_LT(seconds, 4.0) << simulation::FaultName(fault) << ": " << s.pause_reason;
    std::cout << simulation::FaultName(fault) << ": paused " << seconds << " s after the flood began\n";
    EXPECT_EQ(Count(db, "SELECT count(*) FROM poses"), 2);
    EXPECT_EQ(Count(db, "SELECT count(*) FROM observations"), 6);
    EXPECT_EQ(Text(db, "SELECT state FROM sessions"), "paused");
  }
}

// The stop flag raised during a flood (5 s deadlines): the device calls in flight are
// interrupted and the session pauses within a fraction of a second, not after the
// deadlines and fault retries; the configuration being measured is not stored.
TEST_F(VirtualLabFixture, StopDuringAFloodPausesWithinAFractionOfTheDeadline) {
  Start();
  std::string yaml = testing::ReadText(dir_.File("lab.yaml"));
  yaml.replace(yaml.find("timeout_ms: 300"), 15, "timeout_ms: 5000");
  testing::WriteText(dir_.File("slow.yaml"), yaml);
  const io::LabConfig lab = io::LoadLab(dir_.File("slow.yaml"));
  ASSERT_EQ(lab.policy.timeout, 5000ms);
  db::Database db(Db());
  const int64_t session = CreateSession(db, lab, "puma", WellSpreadPlan(lab.model, 6, 300, 6));
  auto devices = OpenInstruments(lab);
  auto controller = OpenController(lab);
  std::atomic<bool> stop{false};
  std::chrono::steady_clock::time_point raised;
  std::thread ctrl_c;
  CaptureOptions options;
  options.stop = &stop;
  int progress = 0;
  options.progress = [&](const Progress&) {
    if (++progress != 2) return;
    // Unrelated lines without pause: each call would read them until its deadline.
    sims_[0]->InjectAlways({simulation::Fault::kFloodLines, 0});
    sims_[2]->InjectAlways({simulation::Fault::kFloodLines, 0});
    ctrl_c = std::thread([&] {
      std::this_thread::sleep_for(400ms);  // the next configuration is in the flood
      raised = std::chrono::steady_clock::now();
      stop = true;
    });
  };
  const auto s = RunCapture(db, lab, session, devices, *controller, options);
  const auto returned = std::chrono::steady_clock::now();
  ASSERT_TRUE(ctrl_c.joinable());
  ctrl_c.join();
  const auto took = returned - raised;
  for (auto& sim : sims_) sim->ClearFaults();
  EXPECT_TRUE(s.stopped);
  EXPECT_FALSE(s.paused) << s.pause_reason;  // a stop, not an instrument fault
  EXPECT_EQ(s.measured, 2);
  EXPECT_GT(sims_[0]->flood_bytes(), 0);
  EXPECT_LT(took, 1500ms);  // 10 ms interrupt polls; far below one 5 s deadline
  std::cout << "stopped "
            << std::chrono::duration_cast<std::chrono::milliseconds>(took).count()
            << " ms after the stop flag\n";
  EXPECT_EQ(Text(db, "SELECT state FROM sessions"), "paused");
  EXPECT_EQ(Count(db, "SELECT count(*) FROM poses"), 2);
  EXPECT_EQ(Count(db, "SELECT count(*) FROM observations"), 6);
  // Resumed on a quiet line, the session completes.
  const auto resumed = RunCapture(db, lab, session, devices, *controller, {});
  EXPECT_TRUE(resumed.completed) << resumed.pause_reason;
  EXPECT_EQ(Count(db, "SELECT count(*) FROM poses"), 6);
}

// The same through `armsig capture` and a real SIGINT: the process exits 130 with the
// session paused within a fraction of a second of Ctrl-C while a theodolite floods.
TEST_F(VirtualLabFixture, CtrlCDuringAFloodEndsTheCaptureAtOnce) {
  Start({15, 15, 15});
  std::string yaml = testing::ReadText(dir_.File("lab.yaml"));
  yaml.replace(yaml.find("timeout_ms: 300"), 15, "timeout_ms: 5000");
  testing::WriteText(dir_.File("slow.yaml"), yaml);
  const pid_t child = testing::Spawn({ARMSIG_BINARY, "--db", Db(), "capture", "--lab", dir_.File("slow.yaml"),
                             "--plan", "auto:40", "--robot", "puma"},
                            dir_.File("out"), dir_.File("err"));
  ASSERT_GE(child, 0);
  int ended = 0;
  ASSERT_TRUE(testing::WaitForChildOr(child, &ended, [&] {
    if (!std::filesystem::exists(Db())) return false;
    db::Database db(Db());
    return Count(db, "SELECT count(*) FROM poses") >= 2;
  })) << testing::ReadText(dir_.File("err"));
  sims_[1]->InjectAlways({simulation::Fault::kFloodLines, 0});
  std::this_thread::sleep_for(500ms);  // the capture is reading the flood now
  const auto raised = std::chrono::steady_clock::now();
  ::kill(child, SIGINT);
  int status = 0;
  ::waitpid(child, &status, 0);
  const auto took = std::chrono::steady_clock::now() - raised;
  sims_[1]->ClearFaults();
  const std::string err = testing::ReadText(dir_.File("err"));
  ASSERT_TRUE(WIFEXITED(status)) << err;
  EXPECT_EQ(WEXITSTATUS(status), 130) << err;
  EXPECT_LT(took, 2000ms) << err;
  std::cout << "exited " << std::chrono::duration_cast<std::chrono::milliseconds>(took).count()
            << " ms after SIGINT\n";
  EXPECT_GT(sims_[1]->flood_bytes(), 0);
  db::Database db(Db());
  EXPECT_EQ(Text(db, "SELECT state FROM sessions"), "paused");
  EXPECT_EQ(Count(db, "SELECT count(*) FROM observations"),
            3 * Count(db, "SELECT count(*) FROM poses"));
}

}  // namespace armsig::acquisition

