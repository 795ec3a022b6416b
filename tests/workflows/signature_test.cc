// A robot's stored arm signature as the commands load and export it, against a parameter
// set stored here in a real SQLite store: the active set is the one loaded, none is a clear
// error; the JSON export carries each stored parameter as stored, and the corrected model
// YAML, read back, moves like the calibrated robot in the frame asked for.
#include "workflows/signature.h"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <functional>
#include <nlohmann/json.hpp>
#include <random>

#include "calibration/synthetic.h"
#include "core/error.h"
#include "core/units.h"
#include "db/calibrations.h"
#include "db/robots.h"
#include "io/csv.h"
#include "io/model_yaml.h"
#include "test_support.h"
#include "workflows/lifecycle.h"

namespace armsig::testing {
namespace {

// A PUMA registered as "puma" in a fresh store.
struct Lab {
  TempDir dir;
  db::Database database{dir.File("lab.db")};
  calibration::RobotModel model = Puma();
  int64_t robot_id = 0;
  Lab() {
    EXPECT_TRUE(workflows::RegisterRobot(database, "puma", SourcePath("models/puma760.yaml")));
    robot_id = *db::FindRobot(database, "puma");
  }

  // Stores a set with `params` (every other parameter identified, with a sigma of its own)
  // measured in `world_from_base`.
  db::CalibrationRecord Store(const Eigen::VectorXd& params, bool active,
                              const Eigen::Isometry3d& world_from_base) {
    db::CalibrationRecord record;
    record.robot_id = robot_id;
    record.params_spec = "all";
    record.inputs_json = record.options_json = "{}";
    record.active = active;
    record.world_from_base = world_from_base;
    const auto names = model.ParameterNames();
    for (int k = 0; k < model.num_parameters(); ++k) {
      const bool identified = k % 2 == 0;
      record.parameters.push_back(
          {names[k], model.UnitOf(k) == calibration::ParameterUnit::kMm ? "mm" : "rad", params(k),
           identified ? 1e-4 * (k + 1) : NAN, identified});
    }
    db::WriteTransaction tx(database);
    db::InsertCalibration(database, record);
    tx.commit();
    return record;
  }
};

Eigen::Isometry3d SomeFrame() {
  Eigen::Isometry3d frame = Eigen::Isometry3d::Identity();
  frame.translate(Eigen::Vector3d(2400.0, -1300.0, -700.0));
  frame.rotate(Eigen::AngleAxisd(2.1, Eigen::Vector3d::UnitZ()));
  return frame;
}

std::string Refusal(const std::function<void()>& f) {
  try {
    f();
  } catch (const InputError& e) {
    return e.what();
  }
  return "(accepted)";
}

}  // namespace

// No active set (none stored, or only one that is not active): the error names the robot
// and the command that fits one. Once a set is active, it is the one loaded.
TEST(LoadActiveSignature, IsTheActiveSetAndNamesARobotWithoutOne) {
  Lab lab;
  const std::string none = Refusal([&] { workflows::LoadActiveSignature(lab.database, "puma"); });
  EXPECT_NE(none.find("robot puma has no active parameter set (fit one: "), std::string::npos)
      << none;
  EXPECT_NE(none.find("recalibrate --robot puma"), std::string::npos) << none;
  const std::string unknown =
      Refusal([&] { workflows::LoadActiveSignature(lab.database, "pumaa"); });
  EXPECT_NE(unknown.find("no robot pumaa in the database (did you mean puma?"), std::string::npos)
      << unknown;

  std::mt19937 rng(7);
  const Eigen::VectorXd inactive = calibration::RandomParameters(lab.model, 0.5, 1e-3, 0, rng);
  lab.Store(inactive, false, Eigen::Isometry3d::Identity());
  EXPECT_NE(Refusal([&] {
              workflows::LoadActiveSignature(lab.database, "puma");
            }).find("has no active parameter set"),
            std::string::npos);
  const Eigen::VectorXd active = calibration::RandomParameters(lab.model, 0.5, 1e-3, 0, rng);
  lab.Store(active, true, SomeFrame());
  const auto loaded = workflows::LoadActiveSignature(lab.database, "puma");
  EXPECT_EQ(loaded.signature.version, 2);
  EXPECT_EQ(loaded.model.num_parameters(), lab.model.num_parameters());
  EXPECT_EQ(loaded.signature.params, active);
  ASSERT_TRUE(loaded.signature.world_from_base.has_value());
  EXPECT_LT((loaded.signature.world_from_base->matrix() - SomeFrame().matrix()).norm(), 1e-12);
  EXPECT_EQ(loaded.signature.map, nullptr);
}

// The JSON export, parsed: the robot, the model, the version and each stored parameter by
// name with its value, unit, identified flag and sigma (null when not identified).
TEST(ExportSignature, JsonCarriesEveryStoredParameterAsStored) {
  Lab lab;
  std::mt19937 rng(8);
  const auto record = lab.Store(calibration::RandomParameters(lab.model, 0.5, 1e-3, 0, rng), true,
                                Eigen::Isometry3d::Identity());
  const auto active = workflows::LoadActiveSignature(lab.database, "puma");
  const auto exported = workflows::ExportSignature(active, "puma", "json", "robot");
  EXPECT_TRUE(exported.warning.empty()) << exported.warning;
  const auto json = nlohmann::json::parse(exported.text);
  EXPECT_EQ(json["robot"], "puma");
  EXPECT_EQ(json["model"], lab.model.name);
  EXPECT_EQ(json["version"], 1);
  EXPECT_TRUE(json["residual_map"].is_null());
  ASSERT_EQ(json["parameters"].size(), record.parameters.size());
  for (size_t k = 0; k < record.parameters.size(); ++k) {
    const auto& p = json["parameters"][k];
    const auto& stored = record.parameters[k];
    EXPECT_EQ(p["name"], stored.name);
    EXPECT_EQ(p["value"].get<double>(), stored.value) << stored.name;
    EXPECT_EQ(p["unit"], stored.unit) << stored.name;
    EXPECT_EQ(p["identified"], stored.identified) << stored.name;
    if (stored.identified) {
      EXPECT_EQ(p["sigma"].get<double>(), stored.sigma) << stored.name;
    } else {
      EXPECT_TRUE(p["sigma"].is_null()) << stored.name;
    }
  }
}

// The JSON says in which frame it is to be used (--frame) and carries the measuring frame of
// the set's data (issue 38: --frame was ignored and the base left out).
TEST(ExportSignature, JsonNamesItsFrameAndCarriesTheBase) {
  Lab lab;
  std::mt19937 rng(10);
  const Eigen::Isometry3d base = SomeFrame();
  lab.Store(calibration::RandomParameters(lab.model, 0.5, 1e-3, 0, rng), true, base);
  const auto active = workflows::LoadActiveSignature(lab.database, "puma");
  for (const char* frame : {"robot", "measurement"}) {
    const auto json =
        nlohmann::json::parse(workflows::ExportSignature(active, "puma", "json", frame).text);
    EXPECT_EQ(json["frame"]["name"], frame);
    const Eigen::Matrix4d expected = std::string(frame) == "robot"
                                         ? Eigen::Matrix4d::Identity()
                                         : Eigen::Matrix4d(base.matrix());
    for (int r = 0; r < 4; ++r) {
      for (int c = 0; c < 4; ++c) {
        EXPECT_NEAR(json["frame"]["frame_from_base"][r][c].get<double>(), expected(r, c), 1e-12)
            << frame << " " << r << c;
        EXPECT_NEAR(json["world_from_base"][r][c].get<double>(), base.matrix()(r, c), 1e-12);
      }
    }
  }
}

// The corrected model YAML, read back by the model reader: its nominal kinematics (its own
// base, zero parameters) are the stored set's calibrated kinematics, in the robot's frame
// or in the measuring frame the set was fitted in.
TEST(ExportSignature, ModelYamlMovesLikeTheCalibratedRobotInTheFrameAsked) {
  Lab lab;
  std::mt19937 rng(9);
  // The gravity twists and the backlash too: the model file keeps them as fixed values.
  const Eigen::VectorXd full = calibration::RandomParameters(lab.model, 0.5, 1e-3, 1e-4, rng);
  lab.Store(full, true, SomeFrame());
  const auto active = workflows::LoadActiveSignature(lab.database, "puma");
  calibration::Kinematics calibrated(lab.model);
  for (const char* frame : {"robot", "measurement"}) {
    const auto exported = workflows::ExportSignature(active, "puma", "model", frame);
    const auto corrected = io::ParseRobotModel(exported.text, std::string("export ") + frame);
    ASSERT_TRUE(corrected.base.has_value()) << exported.text;  // N1 with the set's H1 folded in
    calibration::Kinematics nominal(corrected);
    const Eigen::VectorXd zero = Eigen::VectorXd::Zero(corrected.num_parameters());
    const Eigen::Isometry3d world_from_base =
        std::string(frame) == "robot" ? Eigen::Isometry3d::Identity() : SomeFrame();
    for (const auto& q : calibration::RandomConfigurations(lab.model, 10, rng)) {
      const Eigen::Vector3d expected = calibrated.Position(world_from_base, full, q.data());
      const Eigen::Vector3d got = nominal.Position(*corrected.base, zero, q.data());
      EXPECT_LT((got - expected).norm(), 1e-6) << frame;
    }
  }
  EXPECT_NE(Refusal([&] {
              workflows::ExportSignature(active, "puma", "step", "robot");
            }).find("--format: expected json, model or urdf, got 'step'"),
            std::string::npos);
  EXPECT_NE(Refusal([&] {
              workflows::ExportSignature(active, "puma", "json", "tool");
            }).find("--frame: expected robot or measurement"),
            std::string::npos);
}

// The parametric prediction's standard error (predict's model_sigma_mm) against an
// independent computation: the stored covariance carried through central differences of
// the position by each identified parameter. A set stored without a covariance has none.
TEST(ParametricSigma, IsTheCovarianceCarriedThroughCentralDifferences) {
  Lab lab;
  std::mt19937 rng(11);
  const Eigen::VectorXd params = calibration::RandomParameters(lab.model, 0.5, 1e-3, 0, rng);
  db::CalibrationRecord record = lab.Store(params, true, SomeFrame());
  EXPECT_TRUE(std::isnan(workflows::ParametricSigmaMm(
      lab.model, workflows::LoadActiveSignature(lab.database, "puma").signature,
      Eigen::VectorXd::Zero(6))));

  const auto names = lab.model.ParameterNames();
  const std::vector<int> identified = {0, 3, 7, 12, 20};
  Eigen::MatrixXd a = Eigen::MatrixXd::Random(5, 5);
  const Eigen::MatrixXd covariance = 1e-6 * (a * a.transpose() + Eigen::MatrixXd::Identity(5, 5));
  record.active = true;
  for (int k : identified) record.covariance_parameters.push_back(names[k]);
  record.covariance = covariance;
  {
    db::WriteTransaction tx(lab.database);
    db::InsertCalibration(lab.database, record);
    tx.commit();
  }
  const auto signature = workflows::LoadActiveSignature(lab.database, "puma").signature;
  calibration::Kinematics kin(lab.model);
  std::uniform_real_distribution<double> angle(-2.5, 2.5);
  for (int trial = 0; trial < 5; ++trial) {
    Eigen::VectorXd q(6);
    for (int i = 0; i < 6; ++i) q(i) = angle(rng);
    Eigen::MatrixXd j(3, 5);
    for (int c = 0; c < 5; ++c) {
      const double h = lab.model.UnitOf(identified[c]) == calibration::ParameterUnit::kMm ? 1e-3 : 1e-6;
      Eigen::VectorXd plus = params, minus = params;
      plus(identified[c]) += h;
      minus(identified[c]) -= h;
      j.col(c) = (kin.Position(Eigen::Isometry3d::Identity(), plus, q.data()) -
                  kin.Position(Eigen::Isometry3d::Identity(), minus, q.data())) / (2 * h);
    }
    const double expected = std::sqrt((j * covariance * j.transpose()).trace() / 3.0);
    EXPECT_NEAR(workflows::ParametricSigmaMm(lab.model, signature, q), expected, 1e-6 * expected);
  }
}

// compensate says, per target, what error the stored covariance lets one expect where the
// compensated joints put the tool: the same figure predict gives at those joints; empty for a
// set stored without a covariance.
TEST(Compensate, EachTargetCarriesTheParametricSigmaAtItsCompensatedJoints) {
  Lab lab;
  std::mt19937 rng(5);
  const Eigen::VectorXd params = calibration::RandomParameters(lab.model, 0.5, 1e-3, 0, rng);
  db::CalibrationRecord record = lab.Store(params, true, SomeFrame());
  const auto names = lab.model.ParameterNames();
  const std::vector<int> identified = {0, 4, 9, 14, 22};
  Eigen::MatrixXd a = Eigen::MatrixXd::Random(5, 5);
  record.covariance = 1e-6 * (a * a.transpose() + Eigen::MatrixXd::Identity(5, 5));
  for (int k : identified) record.covariance_parameters.push_back(names[k]);

  // Targets the calibrated robot reaches, with the nominal program's joints beside them.
  calibration::Kinematics kin(lab.model);
  std::string targets = "point,x_mm,y_mm,z_mm,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg\n";
  std::uniform_real_distribution<double> angle(-1.0, 1.0);
  for (int t = 0; t < 4; ++t) {
    Eigen::VectorXd q(6);
    for (int i = 0; i < 6; ++i) q(i) = angle(rng);
    q(2) += 1.2;
    const Eigen::Vector3d x = kin.Position(Eigen::Isometry3d::Identity(), params, q.data());
    targets += fmt::format("T{},{:.6f},{:.6f},{:.6f}", t, x(0), x(1), x(2));
    for (int i = 0; i < 6; ++i) targets += fmt::format(",{:.6f}", (q(i) + 0.01) * 180.0 / kPi);
    targets += "\n";
  }
  WriteText(lab.dir.File("targets.csv"), targets);

  auto sigmas = [&](const workflows::ActiveSignature& active) {
    const auto result = workflows::Compensate(active, Eigen::Isometry3d::Identity(),
                                              lab.dir.File("targets.csv"), std::nullopt);
    WriteText(lab.dir.File("out.csv"), result.csv);
    const io::CsvTable out = io::ReadCsvFile(lab.dir.File("out.csv"));
    std::vector<std::pair<Eigen::VectorXd, std::string>> rows;
    for (const auto& row : out.rows()) {
      EXPECT_EQ(out.Text(row, out.Column("status")), "ok");
      Eigen::VectorXd q(6);
      for (int i = 0; i < 6; ++i)
        q(i) = out.Number(row, out.Column("q" + std::to_string(i + 1) + "_deg")) * kPi / 180.0;
      rows.emplace_back(q, out.Text(row, out.Column("model_sigma_mm")));
    }
    return rows;
  };
  // Without a covariance: no figure to give.
  for (const auto& [q, sigma] : sigmas(workflows::LoadActiveSignature(lab.database, "puma")))
    EXPECT_EQ(sigma, "");
  {
    db::WriteTransaction tx(lab.database);
    db::InsertCalibration(lab.database, record);
    tx.commit();
  }
  const auto active = workflows::LoadActiveSignature(lab.database, "puma");
  const auto rows = sigmas(active);
  ASSERT_EQ(rows.size(), 4u);
  for (const auto& [q, sigma] : rows) {
    ASSERT_FALSE(sigma.empty());
    const double expected = workflows::ParametricSigmaMm(lab.model, active.signature, q);
    EXPECT_GT(expected, 0.0);
    EXPECT_NEAR(std::stod(sigma), expected, 1e-5 + 1e-4 * expected);
  }
}

}  // namespace armsig::testing
