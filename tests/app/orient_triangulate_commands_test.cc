// CLI smoke tests of orient, triangulate and reduce; the behaviour is tested on the library
// calls in tests/workflows/orient_triangulate_test.cc and reduce_test.cc.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "core/units.h"
#include "db/database.h"
#include "io/csv.h"
#include "io/network_files.h"
#include "reduction/observation.h"
#include "test_support.h"

namespace armsig::testing {
namespace {

std::string Net(const std::string& f) { return "'" + DataPath("networks/" + f) + "'"; }

}  // namespace

TEST(OrientCommand, K06WithScaleBarsWritesStationsAndReport) {
  TempDir dir;
  std::string bars;
  std::ifstream in(DataPath("networks/k06/scale_bars.txt"));
  for (std::string line; std::getline(in, line);) bars += " --scale-bar " + line;
  const auto r = RunArmsig("orient --observations " + Net("k06/observations.csv") + bars +
                           " --scale-bar-sigma-mm 0.005 --out '" + dir.File("st.yaml") +
                           "' --points '" + dir.File("pts.csv") + "'");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("185 degrees of freedom"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("sigma0 a posteriori 1.163"), std::string::npos);
  // The written stations triangulate the targets again.
  const auto t = RunArmsig("triangulate --stations '" + dir.File("st.yaml") + "' --observations " +
                           Net("k06/observations.csv") + " --out '" + dir.File("tri.csv") + "'");
  ASSERT_EQ(t.exit_code, 0) << t.err;
  const auto table = io::ReadCsvFile(dir.File("tri.csv"));
  EXPECT_EQ(table.rows().size(), 54u);
}

// A laser tracker's set-up through the command line: a tracker tilted on a bracket reads
// (Hz, V, D) to control points; `orient --control --unlevelled` gives back its pose. The
// readings are exact (written to 1e-10 gon and 1e-6 mm), so the pose must come back to the
// truth far inside its sigmas, and the sigmas must be the ones propagated here from the
// control points' 0.02 mm and the tracker's noise model. Two control points cannot fix
// six unknowns: refused, and no stations file is written.
TEST(OrientCommand, TrackerSetUpFromControlPointsThroughTheCommandLine) {
  TempDir dir;
  StationPose truth;
  truth.id = "LT1";
  truth.position_mm = {3200.0, -400.0, 1450.0};
  truth.levelled = false;
  truth.world_from_station =
      Eigen::AngleAxisd(0.35, Eigen::Vector3d(0.6, -0.8, 0.0)).toRotationMatrix() *
      reduction::LevelledRotation(2.1);
  const std::vector<Eigen::Vector3d> control = {{900.0, 300.0, 1800.0},
                                                {-700.0, 800.0, 1200.0},
                                                {200.0, -900.0, 600.0},
                                                {-400.0, -300.0, 1700.0},
                                                {600.0, 700.0, 400.0}};
  auto write = [&](size_t count) {
    std::string obs =
        "point,station,hz_gon,v_gon,distance_mm,sigma_hz_arcsec,sigma_v_arcsec,"
        "sigma_distance_mm\n";
    std::string ctrl = "point,x_mm,y_mm,z_mm,sx_mm,sy_mm,sz_mm\n";
    for (size_t k = 0; k < count; ++k) {
      const Eigen::Vector3d p =
          truth.world_from_station.transpose() * (control[k] - truth.position_mm);
      const AngleReading r = reduction::ReadingOf(p.normalized());
      const double sigma_mm = (0.015 + 0.006 * p.norm() / 1000.0) / 2.0;
      const double sigma_arcsec = sigma_mm / p.norm() / kRadPerArcsec;
      obs += fmt::format("C{},LT1,{:.10f},{:.10f},{:.6f},{:.3f},{:.3f},{:.4f}\n", k + 1,
                         r.hz_rad * 200.0 / kPi, r.v_rad * 200.0 / kPi, p.norm(), sigma_arcsec,
                         sigma_arcsec, sigma_mm);
      ctrl += fmt::format("C{},{:.4f},{:.4f},{:.4f},0.02,0.02,0.02\n", k + 1, control[k].x(),
                          control[k].y(), control[k].z());
    }
    WriteText(dir.File("obs.csv"), obs);
    WriteText(dir.File("ctrl.csv"), ctrl);
  };
  const std::string command = "orient --observations '" + dir.File("obs.csv") + "' --control '" +
                              dir.File("ctrl.csv") + "' --unlevelled LT1 --out '" +
                              dir.File("st.yaml") + "'";
  write(control.size());
  const auto r = RunArmsig(command);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto stations = io::ReadStationsYaml(dir.File("st.yaml"));
  ASSERT_EQ(stations.size(), 1u);
  const reduction::Station& lt1 = stations[0];
  EXPECT_EQ(lt1.pose.id, "LT1");
  EXPECT_FALSE(lt1.pose.levelled);
  EXPECT_LT((lt1.pose.position_mm - truth.position_mm).norm(), 1e-3);
  const Eigen::AngleAxisd rotation_error(lt1.pose.world_from_station.transpose() *
                                         truth.world_from_station);
  EXPECT_LT(rotation_error.angle(), 1e-7);
  // The position's sigmas, propagated independently: the linearised rigid fit
  // x_k = t + δθ × (x_k − t) with each point's isotropic variance (control 0.02 mm and the
  // tracker's own σ), unknowns t and δθ; a priori (the readings are exact, so a posteriori
  // scaling would say nothing).
  Eigen::Matrix<double, 6, 6> normal = Eigen::Matrix<double, 6, 6>::Zero();
  for (const auto& x : control) {
    const double d = (x - truth.position_mm).norm();
    const double sigma_mm = (0.015 + 0.006 * d / 1000.0) / 2.0;
    Eigen::Matrix<double, 3, 6> a;
    const Eigen::Vector3d lever = x - truth.position_mm;
    Eigen::Matrix3d cross;
    cross << 0, -lever.z(), lever.y(), lever.z(), 0, -lever.x(), -lever.y(), lever.x(), 0;
    a << Eigen::Matrix3d::Identity(), -cross;
    normal += a.transpose() * a / (0.02 * 0.02 + sigma_mm * sigma_mm);
  }
  const Eigen::Matrix<double, 6, 6> covariance = normal.inverse();
  for (int k = 0; k < 3; ++k) {
    const double expected = std::sqrt(covariance(k, k));
    EXPECT_NEAR(lt1.sigma_position_mm(k), expected, 0.05 * expected) << k;
  }

  std::filesystem::remove(dir.File("st.yaml"));
  write(2);
  const auto refused = RunArmsig(command);
  EXPECT_EQ(refused.exit_code, 2) << refused.err;
  EXPECT_NE(refused.err.find("LT1"), std::string::npos) << refused.err;
  EXPECT_FALSE(std::filesystem::exists(dir.File("st.yaml")));
}

namespace {

// K06's observations with `delta` added to column `column` (2 hz_gon, 3 v_gon) of the line of
// `station`'s sighting of `point`.
std::string K06With(const std::vector<std::tuple<std::string, std::string, int, double>>& plants) {
  std::ifstream in(DataPath("networks/k06/observations.csv"));
  std::string text, line;
  while (std::getline(in, line)) {
    for (const auto& [station, point, column, delta] : plants) {
      if (line.rfind(point + "," + station + ",", 0) != 0) continue;
      std::vector<std::string> fields;
      std::stringstream split(line);
      for (std::string f; std::getline(split, f, ',');) fields.push_back(f);
      fields[column] = fmt::format("{:.5f}", std::stod(fields[column]) + delta);
      line.clear();
      for (size_t k = 0; k < fields.size(); ++k) line += (k ? "," : "") + fields[k];
    }
    text += line + "\n";
  }
  return text;
}

std::string K06Bars() {
  std::string bars;
  std::ifstream in(DataPath("networks/k06/scale_bars.txt"));
  for (std::string line; std::getline(in, line);) bars += " --scale-bar " + line;
  return bars + " --scale-bar-sigma-mm 0.005";
}

}  // namespace

// The three cases, as a metrologist would meet them: each planted reading is
// removed and named (report, stations file, JSON), the stations are written (exit 0) within
// 5 µm and 0.5″ of the clean ones; tested only (--no-reject) they are as before.
TEST(OrientCommand, K06BlundersAreRemovedNamedAndTheStationsWritten) {
  TempDir dir;
  const std::string bars = K06Bars();
  auto orient = [&](const std::string& obs, const std::string& extra) {
    return RunArmsig("orient --observations '" + obs + "'" + bars + " --out '" +
                     dir.File("st.yaml") + "' --json '" + dir.File("st.json") + "'" + extra);
  };
  WriteText(dir.File("clean.csv"), K06With({}));
  ASSERT_EQ(orient(dir.File("clean.csv"), "").exit_code, 0);
  const auto clean = io::ReadStationsYaml(dir.File("st.yaml"));
  const std::vector<std::pair<std::string, std::vector<std::tuple<std::string, std::string, int, double>>>>
      cases = {{"Hz 1->202 +0.1 gon", {{"1", "202", 2, 0.1}}},
               {"Hz 1->202 +0.02 gon, V 2->204 +0.01 gon", {{"1", "202", 2, 0.02}, {"2", "204", 3, 0.01}}},
               {"Hz 1->202 +1 gon", {{"1", "202", 2, 1.0}}}};
  for (const auto& [name, plants] : cases) {
    std::filesystem::remove(dir.File("st.yaml"));
    WriteText(dir.File("obs.csv"), K06With(plants));
    const auto r = orient(dir.File("obs.csv"), "");
    ASSERT_EQ(r.exit_code, 0) << name << "\n" << r.err;
    const auto stations = io::ReadStationsYaml(dir.File("st.yaml"));
    const std::string yaml = ReadText(dir.File("st.yaml"));
    const auto json = nlohmann::json::parse(ReadText(dir.File("st.json")));
    for (const auto& [station, point, column, delta] : plants) {
      const std::string kind = column == 2 ? "Hz" : "V";
      EXPECT_NE(r.out.find(kind + " " + station + "->" + point), std::string::npos) << r.out;
      EXPECT_NE(yaml.find(fmt::format("{{station: \"{}\", point: \"{}\", kind: {}", station, point,
                                      column == 2 ? "hz" : "v")),
                std::string::npos)
          << yaml;
      bool in_json = false;
      for (const auto& m : json["snooping"]["removed"])
        in_json |= m["station"] == station && m["point"] == point &&
                   m["kind"] == (column == 2 ? "hz" : "v");
      EXPECT_TRUE(in_json) << json.dump(2);
    }
    for (size_t s = 0; s < clean.size(); ++s) {
      EXPECT_LT((stations[s].pose.position_mm - clean[s].pose.position_mm).norm(), 0.0055) << name;
      EXPECT_LT(std::abs(WrapPi(stations[s].pose.azimuth_rad - clean[s].pose.azimuth_rad)),
                0.5 * kRadPerArcsec)
          << name;
    }
  }
  // Tested only: nothing removed. The 1-gon reading is refused by the σ0 gate as before.
  WriteText(dir.File("obs.csv"), K06With({{"1", "202", 2, 1.0}}));
  const auto tested = orient(dir.File("obs.csv"), " --no-reject");
  EXPECT_EQ(tested.exit_code, 3) << tested.err;
  EXPECT_NE(tested.err.find("Hz         1->202"), std::string::npos) << tested.err;
  const auto json = nlohmann::json::parse(ReadText(dir.File("st.json")));
  EXPECT_TRUE(json["snooping"]["removed"].empty());
  EXPECT_FALSE(json["gate_failure"].is_null());
  // Kept in by the user, who vouches for it: never removed; what contradicts it goes instead
  // (here 202's other readings, until the kept one is all that places 202).
  const auto kept = orient(dir.File("obs.csv"), " --keep '1->202'");
  EXPECT_EQ(kept.exit_code, 0) << kept.err;
  const auto kept_json = nlohmann::json::parse(ReadText(dir.File("st.json")));
  for (const auto& m : kept_json["snooping"]["removed"])
    EXPECT_FALSE(m["station"] == "1" && m["point"] == "202") << m.dump();
  const auto unknown = orient(dir.File("obs.csv"), " --keep '1->999'");
  EXPECT_EQ(unknown.exit_code, 2);
  EXPECT_NE(unknown.err.find("--keep '1->999': no such sighting"), std::string::npos) << unknown.err;
}

TEST(TriangulateCommand, MalformedAngleNamesLineAndColumn) {
  TempDir dir;
  WriteText(dir.File("obs.csv"), "point,station,hz_gon,v_gon\nP,1,10,100\nP,2,2O,100\n");
  const auto r =
      RunArmsig("triangulate --stations " + Net("k06/stations.yaml") + " --observations '" +
                dir.File("obs.csv") + "' --out '" + dir.File("p.csv") + "'");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("obs.csv:3:3 (hz_gon)"), std::string::npos) << r.err;
}

TEST(ReduceCommand, UnknownSessionIsAnInputError) {
  TempDir dir;
  ASSERT_EQ(RunArmsig("--db '" + dir.File("lab.db") + "' db init").exit_code, 0);
  const auto r = RunArmsig("--db '" + dir.File("lab.db") + "' reduce --session 4");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("no session 4"), std::string::npos);
}

}  // namespace armsig::testing
