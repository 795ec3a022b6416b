// The nightly job as a library function, on databases filled with simulated sessions of
// a PUMA 760 whose truth the test knows.
#include "nightly/recalibrate.h"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <optional>

#include <chrono>
#include <cstdlib>
#include <ctime>
#include <filesystem>
#include <thread>
#include <tuple>

#include "calibration/synthetic.h"
#include "core/error.h"
#include "db/database.h"
#include "db/schema.h"
#include "db/store.h"
#include "io/file_lock.h"
#include "support/simulated_sessions.h"
#include "support/stores.h"
#include "test_support.h"
#include "workflows/calibration_run.h"
#include "workflows/lifecycle.h"
#include "nightly/worker.h"

namespace armsig::testing {

namespace {

nightly::RecalibrateOptions Options(const std::string& path) {
  nightly::RecalibrateOptions o;
  o.db_path = path;
  o.robot = "puma";
  return o;
}

// The store's clock now, as session start times are stored.
std::string StoreNow(db::Database& database) {
  auto q = database.connection().Prepare("SELECT " +
                                         std::string(db::NowIsoSql(database.backend())));
  return q->Step() ? q->Text(0) : std::string();
}

}  // namespace

// The nightly job on either store: a lab's SQLite file or the plant's server.
class Recalibrate : public ::testing::TestWithParam<db::Backend> {
 protected:
  std::string NewStore() { return testing::NewStore(GetParam(), dir_, "lab"); }
  TempDir dir_;
};

TEST_P(Recalibrate, PassesThenRejectsPlantedBadDataKeepingTheActiveSet) {
  [[maybe_unused]] TempDir& dir = dir_;
  const std::string path = NewStore();
  {
    db::Database database(path);
    AddSession(database, calibration::PaperTable3Parameters(), 150, 1);
  }
  const auto first = nightly::Recalibrate(Options(path));
  ASSERT_EQ(first.outcome, nightly::RecalibrationDecision::Outcome::kStored) << first.Describe();
  EXPECT_EQ(first.version, 1);
  EXPECT_FALSE(first.previous_version.has_value());
  EXPECT_LT(first.validation.mean_mm, 0.03);
  EXPECT_EQ(ActiveVersion(path), 1);
  const auto j = first.ToJson();
  EXPECT_EQ(j["decision"], "stored");
  EXPECT_EQ(j["version"], 1);
  // Planted bad data: a session where a third of the points are off by millimetres.
  {
    db::Database database(path);
    AddSession(database, calibration::PaperTable3Parameters(), 150, 2, 0.33);
  }
  const auto second = nightly::Recalibrate(Options(path));
  EXPECT_EQ(second.outcome, nightly::RecalibrationDecision::Outcome::kRejected);
  EXPECT_FALSE(second.passed());
  bool failed_gate = false;
  for (const auto& g : second.gates) failed_gate |= !g.passed;
  EXPECT_TRUE(failed_gate);
  // The decision names the gate that failed, with its value and limit.
  for (const auto& g : second.gates) {
    if (!g.passed) {
      EXPECT_NE(second.Describe().find(fmt::format("{} {:.4f} mm > {:.4f} mm", g.name, g.value_mm,
                                                   g.limit_mm)),
                std::string::npos)
          << second.Describe();
    }
  }
  EXPECT_NE(second.Describe().find("version 1 stays active"), std::string::npos);
  EXPECT_EQ(second.previous_version, 1);
  EXPECT_TRUE(second.ToJson()["version"].is_null());
  EXPECT_EQ(ActiveVersion(path), 1);  // the old set stays active
  EXPECT_EQ(Versions(path), 1);       // and nothing was stored
}

TEST_P(Recalibrate, SameInputsAreUpToDate) {
  [[maybe_unused]] TempDir& dir = dir_;
  const std::string path = NewStore();
  {
    db::Database database(path);
    AddSession(database, calibration::PaperTable3Parameters(), 150, 3);
  }
  EXPECT_EQ(nightly::Recalibrate(Options(path)).outcome,
            nightly::RecalibrationDecision::Outcome::kStored);
  const auto again = nightly::Recalibrate(Options(path));
  EXPECT_EQ(again.outcome, nightly::RecalibrationDecision::Outcome::kUpToDate);
  EXPECT_EQ(again.version, 1);
  EXPECT_EQ(Versions(path), 1);
}

// The same measurements fitted with another --params: the sets differ (the PUMA's h-terms are
// in the truth, the geometric model left them out) but the robot cannot have changed
// between them — no new measurement was taken. Stored, never called drift (it was: exit 4
// on the real UR10 for auto → geometric, "differs by up to 1.360 mm").
TEST_P(Recalibrate, AnotherModelOnTheSameMeasurementsIsNotDrift) {
  [[maybe_unused]] TempDir& dir = dir_;
  const std::string path = NewStore();
  {
    db::Database database(path);
    AddSession(database, calibration::PaperTable3Parameters(), 150, 3);
  }
  auto o = Options(path);
  o.params = "geometric";  // the h-terms left out: 0.49 mm on validation, the gates pass
  ASSERT_EQ(nightly::Recalibrate(o).outcome, nightly::RecalibrationDecision::Outcome::kStored);
  o.params = "all";  // the model the truth has: not worse, and 1.7 mm apart from the first
  const auto other = nightly::Recalibrate(o);
  EXPECT_EQ(other.outcome, nightly::RecalibrationDecision::Outcome::kStored);
  EXPECT_FALSE(other.drift);
  EXPECT_EQ(other.ExitCode(), 0);
  ASSERT_TRUE(other.model_drift.has_value());
  // The test means something: the two sets differ by more than the drift tolerance.
  EXPECT_GT(other.model_drift->max_mm, other.model_drift->tolerance_mm);
  EXPECT_LT(other.model_drift->p_value, 1e-3);
  EXPECT_EQ(Versions(path), 2);
}

// "Up to date" is decided by the measurements and options, not by how --since was
// written; --since takes ISO dates only.
TEST_P(Recalibrate, IdempotentOnContentAndSinceIsIso) {
  [[maybe_unused]] TempDir& dir = dir_;
  const std::string path = NewStore();
  {
    db::Database database(path);
    AddSession(database, calibration::PaperTable3Parameters(), 150, 13);
  }
  auto options = Options(path);
  options.since = "2000-01-01";
  EXPECT_EQ(nightly::Recalibrate(options).outcome,
            nightly::RecalibrationDecision::Outcome::kStored);
  for (const std::string since :
       {"1999-12-31T23:59", "2001-02-03 04:05:06", "1970-01-01T00:00:00Z", ""}) {
    options.since = since;
    EXPECT_EQ(nightly::Recalibrate(options).outcome,
              nightly::RecalibrationDecision::Outcome::kUpToDate)
        << since;
  }
  EXPECT_EQ(Versions(path), 1);
  for (const std::string bad : {"yesterday", "2026-13-01", "2026-11-01T25:00", "01.11.2026"}) {
    options.since = bad;
    EXPECT_THROW(nightly::Recalibrate(options), InputError) << bad;
  }
  // Different options are a different fit.
  options.since = "";
  options.select = 100;
  EXPECT_EQ(nightly::Recalibrate(options).outcome,
            nightly::RecalibrationDecision::Outcome::kStored);
  EXPECT_EQ(Versions(path), 2);
}

// Every output path is checked before the database is written: a --json into a missing
// folder or a --report over a file stores nothing.
TEST_P(Recalibrate, UnwritableOutputsStoreNothing) {
  [[maybe_unused]] TempDir& dir = dir_;
  const std::string path = NewStore();
  {
    db::Database database(path);
    AddSession(database, calibration::PaperTable3Parameters(), 150, 14);
  }
  auto options = Options(path);
  options.json_path = dir.File("missing/summary.json");
  EXPECT_THROW(nightly::Recalibrate(options), InputError);
  options.json_path = "";
  WriteText(dir.File("plain-file"), "x");
  options.report_dir = dir.File("plain-file");
  EXPECT_THROW(nightly::Recalibrate(options), InputError);
  EXPECT_EQ(Versions(path), 0);
  const auto cli = RunArmsig("--db '" + path + "' recalibrate --robot puma --json '" +
                             dir.File("missing/summary.json") + "'");
  EXPECT_EQ(cli.exit_code, 2) << cli.err;
  EXPECT_NE(cli.err.find("missing"), std::string::npos) << cli.err;
  EXPECT_EQ(Versions(path), 0);
}

TEST_P(Recalibrate, DetectsAPlantedDrift) {
  [[maybe_unused]] TempDir& dir = dir_;
  const std::string path = NewStore();
  const Eigen::VectorXd before = calibration::PaperTable3Parameters();
  {
    db::Database database(path);
    AddSession(database, before, 150, 4);
  }
  ASSERT_TRUE(nightly::Recalibrate(Options(path)).passed());
  // The robot changes: joint 3's backlash h4 triples, its arm offset c4 grows 0.4 mm.
  Eigen::VectorXd after = before;
  const auto model = Puma();
  after(model.IndexOf("h4")) *= 3.0;
  after(model.IndexOf("c4")) += 0.4;
  std::string since;
  {
    db::Database database(path);
    since = StoreNow(database);
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    AddSession(database, after, 150, 5);
  }
  auto options = Options(path);
  options.since = since;
  const auto d = nightly::Recalibrate(options);
  EXPECT_TRUE(d.passed()) << d.Describe();
  EXPECT_EQ(d.poses, 150);  // only the new session
  EXPECT_TRUE(d.drift);
  bool h4 = false;
  for (const auto& p : d.drifted) h4 |= p.name == "h4";
  EXPECT_TRUE(h4) << d.ToJson()["drift"].dump();
  EXPECT_EQ(ActiveVersion(path), 2);
}

// The controller's own calibration (UR KinematicsInfo) changed between the two sessions: the
// drift night names it first among the causes, and the JSON carries it.
TEST_P(Recalibrate, AChangedControllerCalibrationIsNamedFirstAmongTheCauses) {
  [[maybe_unused]] TempDir& dir = dir_;
  const std::string path = NewStore();
  const auto model = Puma();
  const Eigen::VectorXd before = calibration::PaperTable3Parameters();
  Eigen::VectorXd after = before;
  after(model.IndexOf("gamma2")) += 5e-4;  // the arm repaired: joint 2's zero moved
  std::string since;
  {
    db::Database database(path);
    AddSession(database, before, 150, 4);
    db::SetSessionController(database, db::SessionIds(database).back(),
                             {"UR10", "2018", "URSoftware 5.11", "aaaa-0001", "{}"});
  }
  ASSERT_TRUE(nightly::Recalibrate(Options(path)).passed());
  {
    db::Database database(path);
    since = StoreNow(database);
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    AddSession(database, after, 150, 5);
    db::SetSessionController(database, db::SessionIds(database).back(),
                             {"UR10", "2018", "URSoftware 5.11", "bbbb-0002", "{}"});
  }
  auto options = Options(path);
  options.since = since;
  const auto d = nightly::Recalibrate(options);
  EXPECT_TRUE(d.drift);
  EXPECT_EQ(d.controller_calibration,
            "the controller's own calibration changed (KinematicsInfo checksum aaaa-0001 in "
            "session 1, bbbb-0002 in session 2)");
  const std::string line = d.DriftLine();
  const size_t named = line.find("the controller's own calibration changed");
  ASSERT_NE(named, std::string::npos) << line;
  EXPECT_LT(named, line.find("joint 2 zero")) << line;  // first, before the model's causes
  EXPECT_EQ(d.ToJson()["controller_calibration"], d.controller_calibration);
}

// Night after night on one database: a new session of the same robot each night (new
// configurations, new noise), the job fitting that night's session. No night may ring
// the drift alarm; a planted change of 0.2 mm in one link length, or of 0.5 mrad in one
// joint axis, rings it on the first night after, naming the change in mm (or mrad).
TEST_P(Recalibrate, TenNightsWithoutFalseDriftThenPlantedChangesAreFlagged) {
  [[maybe_unused]] TempDir& dir = dir_;
  const std::string path = NewStore();
  const auto model = Puma();
  const Eigen::VectorXd truth = calibration::PaperTable3Parameters();
  auto night = [&](const Eigen::VectorXd& robot, unsigned seed) {
    std::string since;
    {
      db::Database database(path);
      since = StoreNow(database);
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
      AddSession(database, robot, 150, seed);
    }
    auto options = Options(path);
    options.since = since;
    return nightly::Recalibrate(options);
  };
  int nights_with_drift = 0;
  double worst_mm = 0.0;
  for (unsigned n = 1; n <= 10; ++n) {
    const auto d = night(truth, 100 + n);
    ASSERT_EQ(d.outcome, nightly::RecalibrationDecision::Outcome::kStored) << d.Describe();
    EXPECT_EQ(d.poses, 150);
    if (n > 1) {
      ASSERT_TRUE(d.model_drift.has_value());
      EXPECT_TRUE(d.model_drift->previous_covariance);
      worst_mm = std::max(worst_mm, d.model_drift->max_mm);
      nights_with_drift += d.drift;
      EXPECT_FALSE(d.drift) << "night " << n << ": " << d.ToJson()["drift"].dump();
    }
  }
  EXPECT_EQ(nights_with_drift, 0);
  EXPECT_LT(worst_mm, 0.05);  // nights differ by noise only: hundredths of a millimetre

  for (const auto& [name, change, unit_scale] :
       std::vector<std::tuple<std::string, double, double>>{{"a3", 0.2, 1.0},
                                                            {"beta3", 0.5e-3, 1e3}}) {
    Eigen::VectorXd changed = truth;
    changed(model.IndexOf(name)) += change;
    const auto d = night(changed, name == "a3" ? 201 : 202);
    EXPECT_TRUE(d.drift) << name << ": " << d.ToJson()["drift"].dump();
    ASSERT_TRUE(d.model_drift.has_value());
    EXPECT_GT(d.model_drift->max_mm, 0.05) << name;
    // The named parameter is the planted one, with its change to within 10 %.
    ASSERT_FALSE(d.drifted.empty()) << name;
    EXPECT_EQ(d.drifted.front().name, name) << d.ToJson()["drift"].dump();
    EXPECT_NEAR(d.drifted.front().change * unit_scale, change * unit_scale,
                0.1 * change * unit_scale)
        << name;
    // Back to the unchanged robot the next night: the change is flagged again (it is one).
    if (name == "a3") {
      const auto back = night(truth, 203);
      EXPECT_TRUE(back.drift);
    }
  }
}

// The gates come from the lab file stored with the sessions; a malformed block there is
// an input error (exit 2), never a silent fall-back to the defaults.
TEST_P(Recalibrate, MalformedStoredRecalibrationBlockIsAnInputError) {
  [[maybe_unused]] TempDir& dir = dir_;
  const std::string path = NewStore();
  const std::string lab =
      "robot:\n  model: m.yaml\n  controller: {protocol: as, port: p}\n"
      "instruments:\n  - {station: T1, protocol: geocom, port: q}\n"
      "recalibration:\n  max_validation_mean_mm: half a mm\n";
  {
    db::Database database(path);
    AddSession(database, calibration::PaperTable3Parameters(), 150, 12, 0.0, lab);
  }
  try {
    nightly::Recalibrate(Options(path));
    FAIL() << "a malformed recalibration block was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("max_validation_mean_mm"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find(":7:"), std::string::npos) << e.what();
  }
  EXPECT_EQ(Versions(path), 0);
  const auto cli = RunArmsig("--db '" + path + "' recalibrate --robot puma");
  EXPECT_EQ(cli.exit_code, 2) << cli.err;
  EXPECT_NE(cli.err.find("max_validation_mean_mm"), std::string::npos) << cli.err;
}

// After a roll-back the nightly job does not undo the technician's choice: the inputs are
// already fitted by a stored set (not the active one), so it is up to date; every
// activation (the job's, the roll-back) is in the history with what it replaced.
TEST_P(Recalibrate, RollbackIsRespectedAndEveryActivationIsRecorded) {
  [[maybe_unused]] TempDir& dir = dir_;
  const std::string path = NewStore();
  {
    db::Database database(path);
    AddSession(database, calibration::PaperTable3Parameters(), 120, 31);
  }
  ASSERT_EQ(nightly::Recalibrate(Options(path)).outcome,
            nightly::RecalibrationDecision::Outcome::kStored);
  {
    db::Database database(path);
    AddSession(database, calibration::PaperTable3Parameters(), 120, 32);
  }
  const auto second = nightly::Recalibrate(Options(path));
  ASSERT_EQ(second.outcome, nightly::RecalibrationDecision::Outcome::kStored)
      << second.Describe();
  EXPECT_EQ(second.sessions, (std::vector<int64_t>{1, 2}));
  {
    db::Database database(path);
    EXPECT_EQ(workflows::Activate(database, "puma", 1, "v2 moved the tool"), 2);
  }
  const auto night = nightly::Recalibrate(Options(path));
  EXPECT_EQ(night.outcome, nightly::RecalibrationDecision::Outcome::kUpToDate);
  EXPECT_EQ(night.version, 2);
  EXPECT_EQ(night.previous_version, 1);
  EXPECT_EQ(night.active_chosen_by, "activate");
  EXPECT_NE(night.Describe().find("version 1 stays active"), std::string::npos)
      << night.Describe();
  EXPECT_EQ(night.ToJson()["active_version"], 1);
  EXPECT_EQ(ActiveVersion(path), 1);
  EXPECT_EQ(Versions(path), 2);
  // --force refits and the new set becomes active as a nightly result.
  auto force = Options(path);
  force.force = true;
  const auto forced = nightly::Recalibrate(force);
  EXPECT_EQ(forced.outcome, nightly::RecalibrationDecision::Outcome::kStored);
  EXPECT_EQ(ActiveVersion(path), 3);

  db::Database database(path);
  const auto versions = workflows::Versions(database, "puma");
  ASSERT_EQ(versions.size(), 3u);
  ASSERT_EQ(versions[0].activations.size(), 2u);  // by the first night, then the roll-back
  EXPECT_EQ(versions[0].activations[0].activated_by, "recalibrate");
  EXPECT_FALSE(versions[0].activations[0].previous_version.has_value());
  EXPECT_EQ(versions[0].activations[1].activated_by, "activate");
  EXPECT_EQ(versions[0].activations[1].previous_version, 2);
  EXPECT_EQ(versions[0].activations[1].note, "v2 moved the tool");
  ASSERT_EQ(versions[1].activations.size(), 1u);
  EXPECT_EQ(versions[1].activations[0].previous_version, 1);
  // Each night's drift decision is kept with its set, against the set it replaced.
  EXPECT_FALSE(versions[0].drift.has_value());
  ASSERT_TRUE(versions[1].drift.has_value());
  EXPECT_FALSE(*versions[1].drift);
  EXPECT_EQ(versions[1].drift_against, 1);
  EXPECT_EQ(versions[2].drift_against, 1);  // version 1 was active when 3 was fitted
}

ARMSIG_BOTH_BACKENDS(Recalibrate);

// $TZ set for one test and put back as it was (unset stays unset) when it ends.
class ScopedTimeZone {
 public:
  explicit ScopedTimeZone(const char* zone) {
    if (const char* saved = std::getenv("TZ")) saved_ = saved;
    setenv("TZ", zone, 1);
    tzset();
  }
  ~ScopedTimeZone() {
    if (saved_) {
      setenv("TZ", saved_->c_str(), 1);
    } else {
      unsetenv("TZ");
    }
    tzset();
  }
  ScopedTimeZone(const ScopedTimeZone&) = delete;
  ScopedTimeZone& operator=(const ScopedTimeZone&) = delete;

 private:
  std::optional<std::string> saved_;
};

// --since is read in the time zone it names (Z, an offset) or else in local time, and
// becomes the UTC bound the sessions' start times are stored with.
// A cause these data cannot tell from others is said to be equivalent on them, never "the
// same" (issue 38): other configurations would tell them apart.
TEST(NamedCauseText, EquivalentCausesAreSaidToBeIndistinguishableHere) {
  nightly::NamedCause cause;
  cause.name = "joint 2 zero";
  cause.unit = "mrad";
  cause.size = 0.35;
  cause.explained = 1.0;
  cause.effect_max_mm = 0.46;
  cause.equivalent = {"joint 3 zero", "link 2 length"};
  const std::string text = cause.Describe();
  EXPECT_EQ(text.find("the same"), std::string::npos) << text;
  EXPECT_NE(text.find("; these data cannot tell it from joint 3 zero or link 2 length (an "
                      "equivalent cause: configurations that move them differently would)"),
            std::string::npos)
      << text;
}

TEST(SinceToUtc, ReadsIsoDatesInTheirTimeZoneAndRefusesImpossibleOnes) {
  const ScopedTimeZone zone("XST-3");  // POSIX: local time is three hours east of UTC
  EXPECT_EQ(nightly::SinceToUtc("2026-11-01T02:30:00Z"), "2026-11-01T02:30:00.000Z");
  EXPECT_EQ(nightly::SinceToUtc("2026-11-01T02:30+01:00"), "2026-11-01T01:30:00.000Z");
  EXPECT_EQ(nightly::SinceToUtc("2026-11-01T02:30-0130"), "2026-11-01T04:00:00.000Z");
  EXPECT_EQ(nightly::SinceToUtc("2026-11-01 12:00"), "2026-11-01T09:00:00.000Z");
  EXPECT_EQ(nightly::SinceToUtc("2026-11-01"), "2026-10-31T21:00:00.000Z");
  EXPECT_EQ(nightly::SinceToUtc("2024-02-29T00:00:00.25Z"), "2024-02-29T00:00:00.250Z");
  for (const std::string bad : {"2026-02-29", "2026-11-31", "2026-04-31T00:00Z", "2026-00-10",
                                "2026-11-01T24:00", "2026-11-01T12:60", "2026-11-01T12:00+25:00",
                                "yesterday", "2026-11-1", "1.11.2026", "2026-11-01T12:00 Z"}) {
    EXPECT_THROW(nightly::SinceToUtc(bad), InputError) << bad;
  }
  try {
    nightly::SinceToUtc("2026-02-30");
    ADD_FAILURE();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("2026-02 has 28 days"), std::string::npos) << e.what();
  }
}

// Issue 38: a local time the clocks skipped or passed twice was read as mktime guessed (an
// hour off, silently). POSIX rules for central Europe: summer time from the last Sunday of
// March 02:00 to the last Sunday of October 03:00.
TEST(SinceToUtc, ALocalTimeThatDoesNotExistOrHappenedTwiceIsRefusedWithItsOffsets) {
  std::string skipped, twice;
  {
    const ScopedTimeZone zone("CET-1CEST,M3.5.0,M10.5.0/3");
    EXPECT_EQ(nightly::SinceToUtc("2026-03-29T01:59"), "2026-03-29T00:59:00.000Z");
    EXPECT_EQ(nightly::SinceToUtc("2026-03-29T03:00"), "2026-03-29T01:00:00.000Z");
    EXPECT_EQ(nightly::SinceToUtc("2026-07-01"), "2026-06-30T22:00:00.000Z");
    EXPECT_EQ(nightly::SinceToUtc("2026-10-25T03:00"), "2026-10-25T02:00:00.000Z");
    EXPECT_EQ(nightly::SinceToUtc("2026-10-25T02:30+02:00"), "2026-10-25T00:30:00.000Z");
    try {
      nightly::SinceToUtc("2026-03-29T02:30");
    } catch (const InputError& e) {
      skipped = e.what();
    }
    try {
      nightly::SinceToUtc("2026-10-25T02:30");
    } catch (const InputError& e) {
      twice = e.what();
    }
  }
  EXPECT_NE(skipped.find("'2026-03-29T02:30': this local time (TZ=CET-1CEST,M3.5.0,M10.5.0/3) "
                         "does not exist: the clocks skipped it"),
            std::string::npos)
      << skipped;
  EXPECT_NE(twice.find("happened twice"), std::string::npos) << twice;
  EXPECT_NE(twice.find("+02:00 for the first or +01:00 for the second"), std::string::npos)
      << twice;
}

// --since echoed its value raw; a line break in it began a line of its own.
TEST(SinceToUtc, ARefusedValueIsQuotedWithItsControlCharactersEscapedAndCut) {
  try {
    nightly::SinceToUtc("2026\narmsig: info: forged" + std::string(200, '9'));
    ADD_FAILURE();
  } catch (const InputError& e) {
    const std::string what = e.what();
    EXPECT_EQ(what.find('\n'), std::string::npos) << what;
    EXPECT_NE(what.find("'2026\\narmsig: info: forged"), std::string::npos) << what;
    EXPECT_NE(what.find("bytes)"), std::string::npos) << what;  // cut, with its size
  }
}

// A queued job runs with the options it was scheduled with: the orientation and tool-rotation
// choices survive the queue's JSON, and a job queued before they existed gets the defaults.
TEST(RecalibrateOptionsJson, CarriesTheOrientationChoices) {
  nightly::RecalibrateOptions o;
  o.orientation = "off";
  o.tool_rotation = "shared";
  o.params = "auto";
  const auto back = nightly::RecalibrateOptionsFromJson(nightly::RecalibrateOptionsToJson(o), 1);
  EXPECT_EQ(back.orientation, "off");
  EXPECT_EQ(back.tool_rotation, "shared");
  EXPECT_EQ(back.params, "auto");
  const auto old = nightly::RecalibrateOptionsFromJson(R"({"params": "all"})", 2);
  EXPECT_EQ(old.orientation, "auto");
  EXPECT_EQ(old.tool_rotation, "per-session");
}

// A session only validated (none of its poses fitted) with --tool-rotation shared takes the
// fitted probe rotation, so a remount the user said did not happen shows in its orientation
// errors; per-session aligns its own on its validation orientations and sees none.
TEST(CalibrationRunOrientations, AValidationOnlySessionTakesTheSharedToolRotation) {
  const calibration::RobotModel model = Ur10();
  std::mt19937 rng(41);
  const Eigen::VectorXd truth = calibration::RandomParameters(model, 0.5, 5e-4, 0.0, rng);
  const Eigen::Matrix3d probe =
      Eigen::AngleAxisd(-M_PI / 2, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  const Eigen::Matrix3d remounted =
      probe * Eigen::AngleAxisd(3.5e-3, Eigen::Vector3d(0.2, 0.1, 1).normalized()).toRotationMatrix();
  Eigen::Isometry3d moved = Eigen::Isometry3d::Identity();
  moved.rotate(Eigen::AngleAxisd(0.4, Eigen::Vector3d::UnitZ()));
  moved.translation() << 2500.0, -800.0, 100.0;
  auto fit = calibration::SimulateSixDofPoses(model, Eigen::Isometry3d::Identity(), truth, probe,
                                              calibration::RandomConfigurations(model, 150, rng, 3.0),
                                              0.02, 1e-5, rng);
  auto held = calibration::SimulateSixDofPoses(model, moved, truth, remounted,
                                               calibration::RandomConfigurations(model, 40, rng, 3.0),
                                               0.02, 1e-5, rng);
  for (auto& p : fit) p.frame = 1;
  for (size_t i = 0; i < held.size(); ++i) {
    held[i].frame = 2;
    held[i].id = "V" + std::to_string(i);
  }
  const auto mean_angle = [](const workflows::CalibrationRun& run) {
    double sum = 0.0;
    for (const auto& r : run.validation_orientation_residuals) sum += r->norm();
    return sum / static_cast<double>(run.validation_orientation_residuals.size());
  };
  workflows::CalibrateSettings settings;
  settings.params = "geometric";
  settings.residual_model = "off";
  const auto own = workflows::RunCalibration(model, fit, held, settings);
  settings.tool_rotation = "shared";
  const auto shared = workflows::RunCalibration(model, fit, held, settings);
  ASSERT_EQ(own.validation_orientation_residuals.size(), 40u);
  ASSERT_EQ(shared.validation_orientation_residuals.size(), 40u);
  EXPECT_LT(mean_angle(own), 5e-5);
  EXPECT_NEAR(mean_angle(shared), 3.5e-3, 3e-4);
  EXPECT_EQ(shared.tool_rotations.at(2), shared.tool_rotations.at(1));
}

}  // namespace armsig::testing

namespace armsig::nightly {
namespace {

// The nightly job's lock is the store's, whatever path names it: through a symlink or a
// relative path a second run waits for the first. A 64-byte robot name that is 192 bytes
// %-encoded, beside a long store name, still makes a lock file the system accepts (at most
// 255 bytes a name), and two such robots get two locks.
TEST(RobotLockPath, OneStoreOneLockAndNamesTheSystemAccepts) {
  testing::TempDir dir;
  const std::string db = dir.File("lab.db");
  testing::WriteText(db, "");
  std::filesystem::create_symlink(db, dir.File("link.db"));
  EXPECT_EQ(workflows::RobotLockPath(dir.File("link.db"), "ur10"), workflows::RobotLockPath(db, "ur10"));
  EXPECT_EQ(workflows::RobotLockPath(dir.File("sub/../lab.db"), "ur10"), workflows::RobotLockPath(db, "ur10"));
  EXPECT_NE(workflows::RobotLockPath(db, "ur10"), workflows::RobotLockPath(db, "ur5"));
  {
    io::FileLock first(workflows::RobotLockPath(dir.File("link.db"), "ur10"), 0);
    EXPECT_THROW(io::FileLock(workflows::RobotLockPath(db, "ur10"), 0), std::runtime_error);
  }

  const std::string store = dir.File(std::string(200, 's') + ".db");
  testing::WriteText(store, "");
  std::string robot_a, robot_b;
  for (int k = 0; k < 32; ++k) robot_a += "é";  // 64 bytes, 192 %-encoded
  robot_b = robot_a.substr(0, 62) + "ü";
  const std::string a = workflows::RobotLockPath(store, robot_a), b = workflows::RobotLockPath(store, robot_b);
  EXPECT_LE(std::filesystem::path(a).filename().string().size(), 255u) << a;
  EXPECT_NE(a, b);
  EXPECT_EQ(std::filesystem::path(a).parent_path(), dir.path());
  io::FileLock lock_a(a, 0), lock_b(b, 0);  // both made, neither refused
}

}  // namespace
}  // namespace armsig::nightly
