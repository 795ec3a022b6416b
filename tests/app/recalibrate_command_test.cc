// The nightly job, compensation and exports through the binary, as the lab runs them:
// two recalibrations at once, predicted and compensated CSV files, exported models.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <future>
#include <nlohmann/json.hpp>
#include <random>

#include "calibration/compensation.h"
#include "calibration/synthetic.h"
#include "db/database.h"
#include "io/csv.h"
#include "io/model_yaml.h"
#include "support/simulated_sessions.h"
#include "test_support.h"

namespace armsig::testing {

TEST(RecalibrateCommand, IsIdempotentAndSafeAgainstTwoRunsAtOnce) {
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

// A fit the solver did not finish is a failure (exit 1) that says so, not a gate that
// failed (exit 3): a scheduler retries or pages on 1, files a rejected set under 3. The
// gates are not even the point: the active set stays, nothing is stored.
TEST(RecalibrateCommand, AFitThatDoesNotConvergeFailsNamingItAndStoresNothing) {
  TempDir dir;
  const std::string path = dir.File("lab.db");
  {
    db::Database database(path);
    AddSession(database, calibration::PaperTable3Parameters(), 150, 3);
  }
  const auto r = RunArmsig("--db '" + path + "' recalibrate --robot puma --max-iterations 1 " +
                           "--json '" + dir.File("d.json") + "'");
  EXPECT_EQ(r.exit_code, 1) << r.err;
  EXPECT_NE((r.out + r.err).find("did not give a usable estimate: no convergence after 1 iterations"), std::string::npos)
      << r.out << r.err;
  EXPECT_EQ((r.out + r.err).find("a gate failed"), std::string::npos) << r.out << r.err;
  EXPECT_EQ(Versions(path), 0);
  const auto j = nlohmann::json::parse(ReadText(dir.File("d.json")));
  EXPECT_EQ(j["decision"], "failed");
  EXPECT_NE(j["failure"].get<std::string>().find("no convergence"), std::string::npos);
  EXPECT_EQ((r.out + r.err).find("validation mean: "), std::string::npos) << r.err;  // no gate judged
  // The same data with the iterations it needs passes.
  EXPECT_EQ(RunArmsig("--db '" + path + "' recalibrate --robot puma").exit_code, 0);
  EXPECT_EQ(Versions(path), 1);
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
  // Issue 38: the same targets in metres under mm columns compensated as "ok": none lies
  // where the set was validated (they sit in the robot's base), most do read in metres.
  // Points the session measured (inside the volume by construction), written in metres.
  ASSERT_EQ(RunArmsig("--db '" + path + "' session export 1 --poses '" + dir.File("s.csv") + "'")
                .exit_code,
            0);
  const auto measured = io::ReadCsvFile(dir.File("s.csv"));
  std::string in_metres = "point,x_mm,y_mm,z_mm\n";
  for (size_t k = 0; k < 25 && k < measured.rows().size(); ++k) {
    const auto& row = measured.rows()[k];
    in_metres += fmt::format("T{},{:.9f},{:.9f},{:.9f}\n", k + 1,
                             measured.Number(row, measured.Column("x_mm")) / 1000,
                             measured.Number(row, measured.Column("y_mm")) / 1000,
                             measured.Number(row, measured.Column("z_mm")) / 1000);
  }
  WriteText(dir.File("metres.csv"), in_metres);
  const auto metres = RunArmsig("--db '" + path +
                                "' compensate --robot puma --frame measurement --targets '" +
                                dir.File("metres.csv") + "' --out '" + dir.File("m.csv") + "'");
  EXPECT_EQ(metres.exit_code, 2) << metres.err;
  EXPECT_NE(metres.err.find("metres.csv:2:2 (x_mm): no target lies where the set was validated"),
            std::string::npos)
      << metres.err;
  EXPECT_NE(metres.err.find("of the 25 lie there: the columns say mm"), std::string::npos)
      << metres.err;
  EXPECT_FALSE(std::filesystem::exists(dir.File("m.csv")));
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
  // A targets file with a header and no target is refused at its line 2, nothing written.
  WriteText(dir.File("none.csv"), "point,x_mm,y_mm,z_mm\n");
  const auto none = RunArmsig("--db '" + path + "' compensate --robot puma --targets '" +
                              dir.File("none.csv") + "' --out '" + dir.File("none-j.csv") + "'");
  EXPECT_EQ(none.exit_code, 2) << none.err;
  EXPECT_NE(none.err.find("none.csv:2: a header and no targets"), std::string::npos) << none.err;
  EXPECT_FALSE(std::filesystem::exists(dir.File("none-j.csv")));
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

}  // namespace armsig::testing
