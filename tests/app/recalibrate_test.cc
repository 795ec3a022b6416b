// The nightly job, compensation, reports and exports on databases filled with simulated
// sessions of a PUMA 760 whose truth the test knows.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <future>
#include <nlohmann/json.hpp>
#include <random>
#include <regex>
#include <thread>

#include "calibration/compensation.h"
#include "calibration/simulation.h"
#include "db/database.h"
#include "db/store.h"
#include "io/csv.h"
#include "io/model_export.h"
#include "io/model_yaml.h"
#include "test_support.h"

namespace armsig::testing {
namespace {

constexpr double kNoiseMm = 0.01;

// One session of `count` configurations of the true robot, stored like a capture.
void AddSession(db::Database& db, const Eigen::VectorXd& truth, int count, unsigned seed,
                double blunder_fraction = 0.0) {
  const auto model = Puma();
  std::mt19937 rng(seed);
  const auto poses =
      calibration::SimulatePoses(model, Eigen::Isometry3d::Identity(), truth,
                                 calibration::LabTestConfigurations(model, rng), kNoiseMm, rng);
  SQLite::Transaction tx(db.sql());
  const int64_t robot =
      db::EnsureRobot(db, "puma", "puma760", ReadText(SourcePath("models/puma760.yaml")));
  const int64_t session = db::CreateSession(db, robot, "", "", "completed", "simulated");
  std::uniform_real_distribution<double> u(0, 1);
  for (int i = 0; i < count && i < static_cast<int>(poses.size()); ++i) {
    const int64_t pose =
        db::InsertPose(db, session, i, poses[i].id, poses[i].joints_rad, "measured", 1);
    Eigen::Vector3d x = poses[i].target_in_world;
    if (u(rng) < blunder_fraction) x += Eigen::Vector3d(3.0, -2.0, 1.5);  // a bad measurement
    SQLite::Statement s(db.sql(),
                        "INSERT INTO points(session_id, pose_id, point, x_mm, y_mm, z_mm, rays) "
                        "VALUES (?,?,?,?,?,?,3)");
    s.bind(1, session);
    s.bind(2, pose);
    s.bind(3, "target");
    s.bind(4, x.x());
    s.bind(5, x.y());
    s.bind(6, x.z());
    s.exec();
  }
  tx.commit();
}

int ActiveVersion(const std::string& path) {
  db::Database db(path);
  return db.sql()
      .execAndGet("SELECT coalesce(max(version), 0) FROM calibrations WHERE active = 1")
      .getInt();
}

int Versions(const std::string& path) {
  db::Database db(path);
  return db.sql().execAndGet("SELECT count(*) FROM calibrations").getInt();
}

}  // namespace

TEST(Recalibrate, PassesThenRejectsPlantedBadDataKeepingTheActiveSet) {
  TempDir dir;
  const std::string path = dir.File("lab.db");
  const std::string db = "--db '" + path + "' ";
  {
    db::Database database(path);
    AddSession(database, calibration::PaperTable3Parameters(), 150, 1);
  }
  auto first = RunArmsig(db + "recalibrate --robot puma --json '" + dir.File("1.json") + "'");
  ASSERT_EQ(first.exit_code, 0) << first.err;
  auto j = nlohmann::json::parse(ReadText(dir.File("1.json")));
  EXPECT_EQ(j["decision"], "stored");
  EXPECT_EQ(j["version"], 1);
  EXPECT_LT(j["validation"]["mean_mm"].get<double>(), 0.03);
  EXPECT_EQ(ActiveVersion(path), 1);
  // Planted bad data: a session where a third of the points are off by millimetres.
  {
    db::Database database(path);
    AddSession(database, calibration::PaperTable3Parameters(), 150, 2, 0.33);
  }
  auto second = RunArmsig(db + "recalibrate --robot puma --json '" + dir.File("2.json") + "'");
  EXPECT_EQ(second.exit_code, 3) << second.err;
  j = nlohmann::json::parse(ReadText(dir.File("2.json")));
  EXPECT_EQ(j["decision"], "rejected");
  EXPECT_TRUE(j["version"].is_null());
  EXPECT_NE(second.err.find("FAILED"), std::string::npos);
  EXPECT_EQ(ActiveVersion(path), 1);  // the old set stays active
  EXPECT_EQ(Versions(path), 1);       // and nothing was stored
}

TEST(Recalibrate, IsIdempotentAndSafeAgainstTwoRunsAtOnce) {
  TempDir dir;
  const std::string path = dir.File("lab.db");
  {
    db::Database database(path);
    AddSession(database, calibration::PaperTable3Parameters(), 150, 3);
  }
  const std::string command = "--db '" + path + "' recalibrate --robot puma";
  auto a = std::async(std::launch::async, [&] { return RunArmsig(command); });
  auto b = std::async(std::launch::async, [&] { return RunArmsig(command); });
  const auto ra = a.get(), rb = b.get();
  EXPECT_EQ(ra.exit_code, 0) << ra.err;
  EXPECT_EQ(rb.exit_code, 0) << rb.err;
  EXPECT_EQ(Versions(path), 1);  // one stored it, the other found it up to date
  EXPECT_TRUE((ra.err + rb.err).find("up to date") != std::string::npos);
  EXPECT_EQ(RunArmsig(command).exit_code, 0);
  EXPECT_EQ(Versions(path), 1);
}

TEST(Recalibrate, DetectsAPlantedDrift) {
  TempDir dir;
  const std::string path = dir.File("lab.db");
  const Eigen::VectorXd before = calibration::PaperTable3Parameters();
  {
    db::Database database(path);
    AddSession(database, before, 150, 4);
  }
  ASSERT_EQ(RunArmsig("--db '" + path + "' recalibrate --robot puma").exit_code, 0);
  // The robot changes: joint 3's backlash h4 triples, its arm offset c4 grows 0.4 mm.
  Eigen::VectorXd after = before;
  const auto model = Puma();
  after(model.IndexOf("h4")) *= 3.0;
  after(model.IndexOf("c4")) += 0.4;
  std::string since;
  {
    db::Database database(path);
    since = database.sql().execAndGet("SELECT strftime('%Y-%m-%dT%H:%M:%fZ','now')").getString();
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    AddSession(database, after, 150, 5);
  }
  const auto r = RunArmsig("--db '" + path + "' recalibrate --robot puma --since " + since +
                           " --json '" + dir.File("d.json") + "'");
  EXPECT_EQ(r.exit_code, 0) << r.err;
  const auto j = nlohmann::json::parse(ReadText(dir.File("d.json")));
  EXPECT_EQ(j["poses"], 150);  // only the new session
  EXPECT_TRUE(j["drift"]["flag"].get<bool>());
  bool h4 = false;
  for (const auto& p : j["drift"]["parameters"]) h4 |= p["name"] == "h4";
  EXPECT_TRUE(h4) << j["drift"].dump();
  EXPECT_EQ(ActiveVersion(path), 2);
}

// Compensated joints land on the target in the calibrated model, and the true robot then
// misses by about the calibration's validation error instead of the nominal millimetres.
TEST(Compensate, RoundTripAndTheTrueRobotLands) {
  TempDir dir;
  const std::string path = dir.File("lab.db");
  const Eigen::VectorXd truth = calibration::PaperTable3Parameters();
  {
    db::Database database(path);
    AddSession(database, truth, 180, 6);
  }
  ASSERT_EQ(
      RunArmsig("--db '" + path + "' recalibrate --robot puma --json '" + dir.File("c.json") + "'")
          .exit_code,
      0);
  const double validation =
      nlohmann::json::parse(ReadText(dir.File("c.json")))["validation"]["mean_mm"];
  // Targets the true robot can reach, in the measuring frame (truth's base = identity).
  const auto model = Puma();
  std::mt19937 rng(7);
  calibration::Kinematics kin(model);
  std::string targets = "point,x_mm,y_mm,z_mm\n";
  std::vector<Eigen::Vector3d> wanted;
  for (const auto& q : calibration::RandomConfigurations(model, 25, rng, 1.2)) {
    Eigen::VectorXd bent = q;
    bent(2) += 1.2;  // keep the elbow bent (away from the stretched singularity)
    const Eigen::Vector3d x = kin.Position(Eigen::Isometry3d::Identity(), truth, bent.data());
    wanted.push_back(x);
    targets += fmt::format("T{},{:.6f},{:.6f},{:.6f}\n", wanted.size(), x.x(), x.y(), x.z());
  }
  WriteText(dir.File("targets.csv"), targets);
  const auto r = RunArmsig(
      "--db '" + path +
      "' compensate --robot puma --frame measurement --seed-deg 0,0,90,0,30,0 --targets '" +
      dir.File("targets.csv") + "' --out '" + dir.File("joints.csv") + "'");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto t = io::ReadCsvFile(dir.File("joints.csv"));
  // Predict the compensated joints back with the calibrated model: < 0.01 mm.
  std::string joints = "pose";
  for (int i = 1; i <= 6; ++i) joints += fmt::format(",q{}_deg", i);
  joints += "\n";
  double true_miss = 0, nominal_miss = 0;
  for (size_t k = 0; k < t.rows().size(); ++k) {
    const auto& row = t.rows()[k];
    ASSERT_EQ(t.Text(row, t.Column("status")), "ok");
    Eigen::VectorXd q(6), qn(6);
    joints += t.Text(row, 0);
    for (int i = 0; i < 6; ++i) {
      q(i) = t.Number(row, t.Column(fmt::format("q{}_deg", i + 1))) * M_PI / 180;
      qn(i) = t.Number(row, t.Column(fmt::format("nominal_q{}_deg", i + 1))) * M_PI / 180;
      joints += fmt::format(",{:.10f}", q(i) * 180 / M_PI);
    }
    joints += "\n";
    true_miss += (kin.Position(Eigen::Isometry3d::Identity(), truth, q.data()) - wanted[k]).norm() /
                 t.rows().size();
    nominal_miss +=
        (kin.Position(Eigen::Isometry3d::Identity(), truth, qn.data()) - wanted[k]).norm() /
        t.rows().size();
  }
  WriteText(dir.File("predict.csv"), joints);
  const auto p =
      RunArmsig("--db '" + path + "' predict --robot puma --frame measurement --joints '" +
                dir.File("predict.csv") + "' --out '" + dir.File("positions.csv") + "'");
  ASSERT_EQ(p.exit_code, 0) << p.err;
  const auto positions = io::ReadCsvFile(dir.File("positions.csv"));
  for (size_t k = 0; k < positions.rows().size(); ++k) {
    const auto& row = positions.rows()[k];
    const Eigen::Vector3d x(positions.Number(row, 1), positions.Number(row, 2),
                            positions.Number(row, 3));
    EXPECT_LT((x - wanted[k]).norm(), 0.01) << k;
  }
  EXPECT_GT(nominal_miss, 1.0);            // the nominal program misses by millimetres
  EXPECT_LT(true_miss, 3.0 * validation);  // the compensated one by the validation error
  EXPECT_LT(true_miss, 0.05);
}

TEST(Compensate, UnreachableTargetIsReportedByName) {
  TempDir dir;
  const std::string path = dir.File("lab.db");
  {
    db::Database database(path);
    AddSession(database, calibration::PaperTable3Parameters(), 150, 8);
  }
  ASSERT_EQ(RunArmsig("--db '" + path + "' recalibrate --robot puma").exit_code, 0);
  WriteText(dir.File("t.csv"), "point,x_mm,y_mm,z_mm\nFAR,9000,0,0\n");
  const auto r = RunArmsig("--db '" + path + "' compensate --robot puma --targets '" +
                           dir.File("t.csv") + "' --out '" + dir.File("j.csv") + "'");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("target FAR"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("no joint angles reach"), std::string::npos);
}

TEST(Export, CorrectedModelYamlReproducesTheCalibratedRobot) {
  TempDir dir;
  const std::string path = dir.File("lab.db");
  const Eigen::VectorXd truth = calibration::PaperTable3Parameters();
  {
    db::Database database(path);
    AddSession(database, truth, 150, 9);
  }
  ASSERT_EQ(RunArmsig("--db '" + path + "' recalibrate --robot puma").exit_code, 0);
  ASSERT_EQ(RunArmsig("--db '" + path +
                      "' export --robot puma --format model --frame measurement --out '" +
                      dir.File("m.yaml") + "'")
                .exit_code,
            0);
  ASSERT_EQ(RunArmsig("--db '" + path + "' export --robot puma --format json --out '" +
                      dir.File("p.json") + "'")
                .exit_code,
            0);
  const auto corrected = io::LoadRobotModel(dir.File("m.yaml"));
  ASSERT_TRUE(corrected.base.has_value());
  const auto params = nlohmann::json::parse(ReadText(dir.File("p.json")))["parameters"];
  EXPECT_EQ(params.size(), 43u);
  // Nominal positions of the exported model = the true robot, to the calibration's accuracy.
  const auto puma = Puma();
  calibration::Kinematics exported(corrected), real(puma);
  std::mt19937 rng(10);
  double worst = 0;
  for (const auto& q : calibration::RandomConfigurations(Puma(), 50, rng)) {
    const Eigen::Vector3d a =
        exported.Position(*corrected.base, Eigen::VectorXd::Zero(43), q.data());
    const Eigen::Vector3d b = real.Position(Eigen::Isometry3d::Identity(), truth, q.data());
    worst = std::max(worst, (a - b).norm());
  }
  EXPECT_LT(worst, 0.1);
}

// URDF: compose the joints' origins (xyz in m, rpy) and rotations about z; it must give
// the corrected model's positions.
TEST(Export, UrdfChainMatchesTheModel) {
  auto model = Puma();
  model.nongeometric.clear();
  std::mt19937 rng(11);
  const Eigen::VectorXd params = calibration::RandomParameters(model, 1.0, 2e-3, 0, rng);
  const auto corrected = calibration::CorrectedModel(model, params, Eigen::Isometry3d::Identity());
  std::string warning;
  const std::string urdf = io::FormatUrdf(corrected, &warning);
  EXPECT_TRUE(warning.empty());
  std::regex origin_re(
      "<origin xyz=\"([^ ]+) ([^ ]+) ([^\"]+)\" rpy=\"([^ ]+) ([^ ]+) ([^\"]+)\"/>");
  std::vector<Eigen::Isometry3d> origins;
  for (auto it = std::sregex_iterator(urdf.begin(), urdf.end(), origin_re);
       it != std::sregex_iterator(); ++it) {
    Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
    t.translation() =
        1000.0 * Eigen::Vector3d(std::stod((*it)[1]), std::stod((*it)[2]), std::stod((*it)[3]));
    t.linear() = (Eigen::AngleAxisd(std::stod((*it)[6]), Eigen::Vector3d::UnitZ()) *
                  Eigen::AngleAxisd(std::stod((*it)[5]), Eigen::Vector3d::UnitY()) *
                  Eigen::AngleAxisd(std::stod((*it)[4]), Eigen::Vector3d::UnitX()))
                     .toRotationMatrix();
    origins.push_back(t);
  }
  ASSERT_EQ(origins.size(), 7u);  // six joints and the tool point
  calibration::Kinematics kin(model);
  for (const auto& q : calibration::RandomConfigurations(model, 20, rng)) {
    Eigen::Isometry3d chain = Eigen::Isometry3d::Identity();
    for (int i = 0; i < 6; ++i)
      chain = chain * origins[i] * Eigen::AngleAxisd(q(i), Eigen::Vector3d::UnitZ());
    const Eigen::Vector3d urdf_x = (chain * origins[6]).translation();
    const Eigen::Vector3d model_x = kin.Position(Eigen::Isometry3d::Identity(), params, q.data());
    EXPECT_LT((urdf_x - model_x).norm(), 1e-5);
  }
}

}  // namespace armsig::testing
