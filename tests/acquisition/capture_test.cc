// Capture sessions against simulators on real pseudo-terminals.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <future>
#include <nlohmann/json.hpp>
#include <random>
#include <thread>

#include "acquisition/lab.h"
#include "acquisition/session.h"
#include "calibration/simulation.h"
#include "core/error.h"
#include "core/units.h"
#include "db/database.h"
#include "db/store.h"
#include "instruments/geocom_device.h"
#include "io/atomic_file.h"
#include "io/network_io.h"
#include "reduction/observation.h"
#include "simulation/simulators.h"
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
          *lab_, s, dir_.File("T" + std::to_string(s + 1)), o));
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

  std::string Db() const { return dir_.File("lab.db"); }

  testing::TempDir dir_;
  std::unique_ptr<simulation::VirtualLab> lab_;
  std::vector<std::unique_ptr<simulation::GeoComSimulator>> sims_;
  std::unique_ptr<simulation::ValSimulator> robot_;
};

int Count(db::Database& db, const std::string& sql) { return db.sql().execAndGet(sql).getInt(); }

// Starts args[0] with args, output to /dev/null; returns its pid (−1 on failure).
pid_t SpawnQuietly(std::vector<std::string> args) {
  const pid_t child = ::fork();
  if (child == 0) {
    std::vector<char*> argv;
    for (auto& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    const int null = ::open("/dev/null", O_WRONLY);
    ::dup2(null, 1);
    ::dup2(null, 2);
    ::execv(argv[0], argv.data());
    _exit(127);
  }
  return child;
}

}  // namespace

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
  EXPECT_EQ(db.sql().execAndGet("SELECT state FROM sessions").getString(), "completed");
  // Every reduced point is where the true robot put its target.
  SQLite::Statement q(db.sql(),
                      "SELECT p.joints_json, pt.x_mm, pt.y_mm, pt.z_mm FROM poses p JOIN points pt "
                      "ON pt.pose_id = p.id");
  calibration::Kinematics kin(lab_->model());
  while (q.executeStep()) {
    const auto joints =
        nlohmann::json::parse(q.getColumn(0).getString()).get<std::vector<double>>();
    const Eigen::Vector3d truth =
        kin.Position(lab_->world_from_base(), lab_->true_params(), joints.data());
    const Eigen::Vector3d measured(q.getColumn(1).getDouble(), q.getColumn(2).getDouble(),
                                   q.getColumn(3).getDouble());
    EXPECT_LT((measured - truth).norm(), 0.06);  // 0.5″ at 3.5 m: ~0.01 mm per ray
  }
}

// Triggering every instrument at once costs the slowest one, not their sum.
TEST_F(VirtualLabFixture, ConcurrentTriggeringCostsTheSlowestInstrument) {
  Start({60, 90, 120});
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
  const LabConfig lab = LoadLab(dir_.File("lab.yaml"));
  db::Database db(Db());
  Plan plan = WellSpreadPlan(lab.model, 6, 300, 1);
  const int64_t session = CreateSession(db, lab, "puma", plan);
  auto devices = OpenInstruments(lab);
  auto controller = OpenController(lab);
  const auto s = RunCapture(db, lab, session, devices, *controller, {});
  ASSERT_TRUE(s.completed);
  EXPECT_GT(sequential_ms, 250.0);                  // 60 + 90 + 120
  EXPECT_LT(s.mean_cycle_ms, 0.6 * sequential_ms);  // ≈ 120 + overhead
  EXPECT_GT(s.mean_cycle_ms, 110.0);
  EXPECT_LT(s.mean_overhead_ms, 5.0);
}

// kill -9 of the capture process at 20+ random moments, then --resume each time: every
// committed configuration is present exactly once and the session completes.
TEST_F(VirtualLabFixture, KillNineAtRandomMomentsThenResume) {
  Start({12, 12, 12});
  std::mt19937 rng(20261122);
  std::uniform_int_distribution<int> delay(20, 120);
  const std::string binary = ARMSIG_BINARY;
  int kills = 0;
  for (int round = 0; round < 60 && kills < 22; ++round) {
    bool have_session = false;
    if (std::filesystem::exists(Db())) {
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
    const pid_t child = SpawnQuietly(args);
    ASSERT_GE(child, 0);
    if (!have_session) {
      // Planning takes a moment; start killing once the session exists.
      for (int wait = 0; wait < 1000; ++wait) {
        std::this_thread::sleep_for(10ms);
        if (!std::filesystem::exists(Db())) continue;
        db::Database db(Db());
        if (Count(db, "SELECT count(*) FROM sessions") > 0) break;
      }
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(delay(rng)));
    int status = 0;
    if (::waitpid(child, &status, WNOHANG) == 0) {
      ::kill(child, SIGKILL);
      ::waitpid(child, &status, 0);
      ++kills;
    } else if (WIFEXITED(status) && WEXITSTATUS(status) == 0) {
      db::Database db(Db());
      if (db.sql().execAndGet("SELECT state FROM sessions WHERE id = 1").getString() == "completed")
        break;
    }
  }
  EXPECT_GE(kills, 20);
  // Finish the session.
  const auto last = testing::RunArmsig("--db '" + Db() + "' capture --lab '" +
                                       dir_.File("lab.yaml") + "' --resume 1");
  ASSERT_EQ(last.exit_code, 0) << last.err;
  db::Database db(Db());
  EXPECT_EQ(db.sql().execAndGet("PRAGMA integrity_check").getString(), "ok");
  EXPECT_EQ(db.sql().execAndGet("SELECT state FROM sessions WHERE id = 1").getString(),
            "completed");
  EXPECT_EQ(Count(db, "SELECT count(*) FROM poses WHERE session_id = 1"), 100);
  EXPECT_EQ(Count(db, "SELECT count(DISTINCT seq) FROM poses WHERE session_id = 1"), 100);
  EXPECT_EQ(Count(db, "SELECT max(seq) FROM poses WHERE session_id = 1"), 99);
  // Exactly three rays and one point per configuration: nothing half-written, nothing twice.
  EXPECT_EQ(Count(db,
                  "SELECT count(*) FROM (SELECT pose_id, count(*) c FROM observations GROUP BY "
                  "pose_id) WHERE c != 3"),
            0);
  EXPECT_EQ(Count(db, "SELECT count(*) FROM observations"), 300);
  EXPECT_EQ(Count(db, "SELECT count(*) FROM points WHERE session_id = 1"), 100);
}

TEST_F(VirtualLabFixture, InstrumentFaultPausesThenResumes) {
  Start();
  const LabConfig lab = LoadLab(dir_.File("lab.yaml"));
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
  EXPECT_EQ(db.sql().execAndGet("SELECT state FROM sessions").getString(), "paused");
  // Fixed: resume from the configuration that failed.
  const auto resumed = RunCapture(db, lab, session, devices, *controller, {});
  EXPECT_TRUE(resumed.completed);
  EXPECT_EQ(resumed.already, 3);
  EXPECT_EQ(resumed.measured, 5);
  EXPECT_EQ(Count(db, "SELECT count(*) FROM poses"), 8);
}

TEST_F(VirtualLabFixture, SkipOnFaultRecordsTheConfigurationAsSkipped) {
  Start();
  const LabConfig lab = LoadLab(dir_.File("lab.yaml"));
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

TEST_F(VirtualLabFixture, PortThatVanishesAndReturnsMidSession) {
  Start();
  const LabConfig lab = LoadLab(dir_.File("lab.yaml"));
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
  const pid_t child = SpawnQuietly(args);
  ASSERT_GE(child, 0);
  // Interrupt once some configurations are stored.
  for (int wait = 0; wait < 1000; ++wait) {
    std::this_thread::sleep_for(10ms);
    if (!std::filesystem::exists(Db())) continue;
    db::Database db(Db());
    if (Count(db, "SELECT count(*) FROM poses") >= 5) break;
  }
  ::kill(child, SIGINT);
  int status = 0;
  ::waitpid(child, &status, 0);
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 1);
  {
    db::Database db(Db());
    EXPECT_EQ(db.sql().execAndGet("SELECT state FROM sessions").getString(), "paused");
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
  EXPECT_EQ(db.sql().execAndGet("SELECT state FROM sessions").getString(), "completed");
}

// Two-face sets: every configuration read in face I, the telescopes turned, read in face
// II, turned back; both faces are stored and intersect to the same point.
TEST_F(VirtualLabFixture, TwoFaceSetsStoreBothFaces) {
  Start();
  std::string yaml = testing::ReadText(dir_.File("lab.yaml"));
  yaml.replace(yaml.find("settle_ms: 0"), 12, "settle_ms: 0, two_face: true");
  testing::WriteText(dir_.File("lab2.yaml"), yaml);
  const LabConfig lab = LoadLab(dir_.File("lab2.yaml"));
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

TEST(Lab, MalformedLabFileNamesLineAndColumn) {
  testing::TempDir dir;
  testing::WriteText(dir.File("lab.yaml"),
                     "robot:\n  model: '" + testing::SourcePath("models/puma760.yaml") +
                         "'\n  controller: {protocol: fanuc, port: /dev/null}\ninstruments: []\n");
  try {
    LoadLab(dir.File("lab.yaml"));
    FAIL();
  } catch (const armsig::InputError& e) {
    EXPECT_EQ(e.where().line, 3);
    EXPECT_NE(std::string(e.what()).find("expected val, as or counter"), std::string::npos);
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

}  // namespace armsig::acquisition
