// orient and triangulate on files (workflows/orient_triangulate): real networks through the library
// calls the commands make, and the input errors they refuse.
#include "workflows/orient_triangulate.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>

#include "core/error.h"
#include "io/csv.h"
#include "io/network_files.h"
#include "test_support.h"

namespace armsig::workflows {
namespace {

using testing::DataPath;
using testing::TempDir;
using testing::WriteText;

std::string Net(const std::string& f) { return DataPath("networks/" + f); }

std::vector<std::string> K06ScaleBars() {
  std::vector<std::string> bars;
  std::ifstream in(Net("k06/scale_bars.txt"));
  for (std::string line; std::getline(in, line);)
    if (!line.empty()) bars.push_back(line);
  return bars;
}

// Comp3D's published adjustment of polygone_K06: σ0 1.16316 on 185 degrees of freedom
// (data/README). The stations written are read back by the stations reader and
// triangulate every target again.
TEST(OrientFiles, K06WithScaleBarsReproducesComp3DAndWritesReadableStations) {
  TempDir dir;
  OrientFilesOptions o;
  o.observations = Net("k06/observations.csv");
  o.scale_bars = K06ScaleBars();
  o.scale_bar_sigma_mm = 0.005;
  o.out = dir.File("st.yaml");
  o.points_out = dir.File("pts.csv");
  const OrientRun run = OrientFiles(o);
  ASSERT_TRUE(run.result.status.ok()) << run.result.status.message;
  EXPECT_EQ(run.result.dof, 185);
  EXPECT_NEAR(run.result.sigma0, 1.16307, 2e-4);
  const std::string report = FormatOrientReport(run);
  EXPECT_NE(report.find("185 degrees of freedom"), std::string::npos) << report;
  const auto stations = io::ReadStationsYaml(o.out);
  ASSERT_EQ(stations.size(), 4u);
  // The global test, by the Wilson–Hilferty approximation of χ²(185) written out here:
  // σ0 1.163 on 185 dof fails it (p ≈ 0.001), so the written sigmas are a posteriori.
  const double k = run.result.dof, x = run.result.sigma0 * run.result.sigma0 * k;
  const double z = (std::cbrt(x / k) - (1.0 - 2.0 / (9.0 * k))) / std::sqrt(2.0 / (9.0 * k));
  const double p = 0.5 * std::erfc(z / std::sqrt(2.0));
  EXPECT_NEAR(run.global_test_p, p, 0.05 * p);
  EXPECT_LT(run.global_test_p, 0.05);
  EXPECT_DOUBLE_EQ(run.sigma_scale, run.result.sigma0);
  EXPECT_NE(report.find("failed, sigmas a posteriori"), std::string::npos) << report;
  for (size_t i = 1; i < stations.size(); ++i) {  // the first is the datum (σ 0)
    for (int c = 0; c < 3; ++c) {
      const double a_priori = run.result.stations[i].sigma_position_mm(c);
      EXPECT_NEAR(stations[i].sigma_position_mm(c), a_priori * run.result.sigma0, 1e-3 * a_priori)
          << stations[i].pose.id;
    }
  }
  EXPECT_TRUE(run.gate_failure.empty());
  const auto points = io::ReadCsvFile(o.points_out);
  EXPECT_EQ(points.rows().size(), run.result.points.size());

  TriangulateFilesOptions t;
  t.stations = o.out;
  t.observations = o.observations;
  t.out = dir.File("tri.csv");
  const TriangulateRun tri = TriangulateFiles(t);
  EXPECT_EQ(tri.points.size(), 54u);
  EXPECT_EQ(tri.intersected, 54);
  EXPECT_EQ(io::ReadCsvFile(t.out).rows().size(), 54u);
}

// An observation that fails the blunder test and cannot be removed (the nadir reading's
// distance and the only scale bar, which the data cannot tell apart) is a gate: no stations
// file, the JSON says why.
TEST(OrientFiles, AnUndecidedBlunderWritesNoStations) {
  TempDir dir;
  OrientFilesOptions o;
  o.observations = DataPath("faults/orient-nadir-blunder.csv");
  o.scale_bars = {"A:B=1000"};
  o.out = dir.File("st.yaml");
  o.json_out = dir.File("st.json");
  const OrientRun run = OrientFiles(o);
  ASSERT_TRUE(run.result.status.ok()) << run.result.status.message;
  ASSERT_FALSE(run.result.undecided.empty());
  EXPECT_NE(run.gate_failure.find("could not be removed"), std::string::npos) << run.gate_failure;
  EXPECT_NE(run.gate_failure.find("distance S2->T1"), std::string::npos) << run.gate_failure;
  EXPECT_FALSE(std::filesystem::exists(o.out));
  const std::string json = testing::ReadText(o.json_out);
  EXPECT_NE(json.find("\"gate_failure\": \"observations fail the blunder test"), std::string::npos)
      << json;
  const std::string report = FormatOrientReport(run);
  EXPECT_NE(report.find("NOT removed: distance S2->T1"), std::string::npos) << report;
}

TEST(OrientFiles, NetworkWithoutScaleIsRefusedAndNothingWritten) {
  TempDir dir;
  // k06's angles without its 11 slope distances and without the scale bars: no scale.
  const auto table = io::ReadCsvFile(Net("k06/observations.csv"));
  std::string angles = "point,station,hz_gon,v_gon\n";
  for (const auto& row : table.rows()) {
    angles +=
        row.fields[0] + "," + row.fields[1] + "," + row.fields[2] + "," + row.fields[3] + "\n";
  }
  WriteText(dir.File("angles.csv"), angles);
  OrientFilesOptions o;
  o.observations = dir.File("angles.csv");
  o.out = dir.File("st.yaml");
  try {
    OrientFiles(o);
    FAIL() << "a network without scale was adjusted";
  } catch (const InputError& e) {
    EXPECT_NE(e.message().find("no scale"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(std::filesystem::exists(o.out));
}

// k06 by its angles alone and one scale bar whose 1.72 m were typed as 1.72 (millimetres):
// the network scales to instruments millimetres apart, which no tripods allow. Refused,
// naming the bar and the unit; nothing written.
TEST(OrientFiles, ABarLengthInTheWrongUnitIsRefusedNamingIt) {
  TempDir dir;
  // Its angles with the source's sigmas, without the 11 slope distances (they would give the
  // scale on their own).
  const auto table = io::ReadCsvFile(Net("k06/observations.csv"));
  std::string angles = "point,station,hz_gon,v_gon,sigma_hz_arcsec,sigma_v_arcsec\n";
  for (const auto& row : table.rows()) {
    angles += row.fields[0] + "," + row.fields[1] + "," + row.fields[2] + "," + row.fields[3] +
              "," + row.fields[5] + "," + row.fields[6] + "\n";
  }
  WriteText(dir.File("angles.csv"), angles);
  OrientFilesOptions o;
  o.observations = dir.File("angles.csv");
  o.out = dir.File("st.yaml");
  o.scale_bars = {"1008:1180=1720.000"};
  EXPECT_NO_THROW(OrientFiles(o));  // in millimetres: the stations metres apart
  EXPECT_TRUE(std::filesystem::exists(o.out));
  std::filesystem::remove(o.out);
  o.scale_bars = {"1008:1180=1.72"};
  try {
    OrientFiles(o);
    FAIL() << "a 1.72 mm bar scaled the network";
  } catch (const InputError& e) {
    EXPECT_NE(e.message().find("closer than two instruments can stand"), std::string::npos)
        << e.what();
    EXPECT_NE(e.message().find("1008:1180=1.72"), std::string::npos) << e.what();
    EXPECT_NE(e.message().find("a 1 m bar is =1000"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(std::filesystem::exists(o.out));
}

TEST(OrientFiles, MalformedOrUnobservedScaleBarIsAnInputError) {
  OrientFilesOptions o;
  o.observations = Net("k06/observations.csv");
  o.scale_bars = {"1008-1180"};
  EXPECT_THROW(OrientFiles(o), InputError);
  o.scale_bars = {"1008:9999=100"};
  try {
    OrientFiles(o);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(e.message().find("9999 is never observed"), std::string::npos) << e.what();
  }
}

// The 41 k06 targets seen by angles only and on no bar do not depend on any weighting:
// from the published stations they land on Comp3D's coordinates (data/README: 3.1 µm).
TEST(TriangulateFiles, K06AngleOnlyTargetsLandOnComp3D) {
  TriangulateFilesOptions t;
  t.stations = Net("k06/stations.yaml");
  t.observations = Net("k06/observations.csv");
  const TriangulateRun run = TriangulateFiles(t);
  const auto expected = io::ReadCsvFile(Net("k06/expected.csv"));
  int compared = 0;
  for (const auto& p : run.points) {
    if (!p.result.status.ok()) continue;
    for (const auto& row : expected.rows()) {
      if (expected.Text(row, 0) != p.id) continue;
      const Eigen::Vector3d published(expected.Number(row, 1), expected.Number(row, 2),
                                      expected.Number(row, 3));
      if ((p.result.position_mm - published).norm() < 0.01) ++compared;
    }
  }
  EXPECT_GE(compared, 41);
}

TEST(TriangulateFiles, UnknownStationNamesTheLineAndWritesNothing) {
  TempDir dir;
  WriteText(dir.File("obs.csv"), "point,station,hz_gon,v_gon\nP,1,10,100\nP,9,20,100\n");
  TriangulateFilesOptions t;
  t.stations = Net("k06/stations.yaml");
  t.observations = dir.File("obs.csv");
  t.out = dir.File("p.csv");
  try {
    TriangulateFiles(t);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(e.where().line, 3);
    EXPECT_NE(e.message().find("station '9'"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(std::filesystem::exists(t.out));
}

// One ray gives no point: it is reported with its flag and written without coordinates.
TEST(TriangulateFiles, OneRayPointIsReportedNotInvented) {
  TempDir dir;
  WriteText(dir.File("obs.csv"), "point,station,hz_gon,v_gon\nLONE,1,10,100\n");
  TriangulateFilesOptions t;
  t.stations = Net("k06/stations.yaml");
  t.observations = dir.File("obs.csv");
  t.out = dir.File("p.csv");
  const TriangulateRun run = TriangulateFiles(t);
  ASSERT_EQ(run.points.size(), 1u);
  EXPECT_EQ(run.intersected, 0);
  EXPECT_FALSE(run.points[0].result.status.ok());
  const auto table = io::ReadCsvFile(t.out);
  ASSERT_EQ(table.rows().size(), 1u);
  EXPECT_TRUE(table.Text(table.rows()[0], table.Column("x_mm")).empty());
  EXPECT_NE(table.Text(table.rows()[0], table.Column("status")).find("one_ray"), std::string::npos);
  EXPECT_NE(FormatTriangulateSummary(run, t.out).find("0 points intersected, 1 not"),
            std::string::npos);
}

}  // namespace
}  // namespace armsig::workflows
