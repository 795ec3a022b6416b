// Hostile inputs: numbers outside physical plausibility, YAML of the wrong shape and
// names with control characters are input errors naming file:line:column and what was
// expected, in every reader (core/plausibility.h holds the ranges).
#include <gtest/gtest.h>
#include <sys/stat.h>

#include <chrono>
#include <filesystem>
#include <functional>

#include "acquisition/lab.h"
#include "core/error.h"
#include "core/plausibility.h"
#include "io/atomic_file.h"
#include "io/gsi_import.h"
#include "io/model_yaml.h"
#include "io/network_files.h"
#include "io/poses_csv.h"
#include "test_support.h"

namespace armsig::io {
namespace {

using testing::DataPath;
using testing::TempDir;
using testing::WriteText;

InputError Refusal(const std::function<void()>& read) {
  try {
    read();
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()).find("yaml-cpp"), std::string::npos) << e.what();
    return e;
  } catch (const std::exception& e) {
    ADD_FAILURE() << "expected an InputError, got: " << e.what();
    return InputError("other");
  }
  ADD_FAILURE() << "expected an InputError";
  return InputError("none");
}

TEST(Plausibility, RangesAreFiniteAndNamed) {
  using plausible::Quantity;
  EXPECT_TRUE(plausible::IsPlausible(Quantity::kLength, 1e6));
  EXPECT_FALSE(plausible::IsPlausible(Quantity::kLength, 1.000001e6));
  EXPECT_FALSE(plausible::IsPlausible(Quantity::kLength, std::nan("")));
  // Survey grid coordinates (a projected northing of 5,500 km) are coordinates, not lengths.
  EXPECT_TRUE(plausible::IsPlausible(Quantity::kCoordinate, 5.5e9));
  EXPECT_FALSE(plausible::IsPlausible(Quantity::kLength, 5.5e9));
  EXPECT_FALSE(plausible::IsPlausible(Quantity::kCoordinate, 1e308));
  EXPECT_TRUE(plausible::IsPlausible(Quantity::kJointAngle, ToRad(-720, AngleUnit::kDeg)));
  EXPECT_FALSE(plausible::IsPlausible(Quantity::kJointAngle, ToRad(721, AngleUnit::kDeg)));
  EXPECT_FALSE(plausible::IsPlausible(Quantity::kSigmaAngle, 0.0));
  EXPECT_FALSE(plausible::IsPlausible(Quantity::kSigmaLength, -1.0));
  EXPECT_EQ(*plausible::Check(Quantity::kJointAngle, 800, plausible::UnitOf(AngleUnit::kDeg)),
            "expected a finite joint angle within ±720 deg, got 800");
}

TEST(Plausibility, NamesWithoutControlCharactersAndOfSaneLength) {
  EXPECT_EQ(plausible::CheckName("puma760 cell 2"), std::nullopt);
  EXPECT_EQ(plausible::CheckName("Ständer-Ost"), std::nullopt);  // UTF-8 letters are fine
  EXPECT_NE(plausible::CheckName("puma\nERROR: forged"), std::nullopt);
  EXPECT_NE(plausible::CheckName("red\x1b[31m"), std::nullopt);
  EXPECT_NE(plausible::CheckName("a\xc2\x85"
                                 "b"),
            std::nullopt);  // U+0085 NEL
  EXPECT_NE(plausible::CheckName("a\xe2\x80\xae"
                                 "b"),
            std::nullopt);  // U+202E RLO
  EXPECT_NE(plausible::CheckName(std::string(65, 'x')), std::nullopt);
  EXPECT_EQ(plausible::CheckName(std::string(64, 'x')), std::nullopt);
  EXPECT_NE(plausible::CheckName(""), std::nullopt);
  EXPECT_EQ(plausible::CheckNote(""), std::nullopt);
  EXPECT_NE(plausible::CheckNote(std::string(1001, 'n')), std::nullopt);
  EXPECT_NE(plausible::CheckNote("line\nline"), std::nullopt);
}

TEST(HostileInputs, PosesCoordinateOf1e308IsRefusedAtItsLineAndColumn) {
  const std::string path = DataPath("faults/poses-coordinate-1e308.csv");
  const InputError e = Refusal([&] { ReadPosesCsv(path, 6); });
  EXPECT_EQ(e.where().file, path);
  EXPECT_EQ(e.where().line, 2);
  EXPECT_EQ(e.where().column, 10);
  EXPECT_NE(e.message().find("a finite coordinate within ±1e+10 mm"), std::string::npos)
      << e.what();
}

TEST(HostileInputs, JointAnglesBeyond720DegreesAndHugeLengthsInEveryCsvReader) {
  TempDir dir;
  WriteText(dir.File("p.csv"), "pose,q1_deg,q2_deg,x_mm,y_mm,z_mm\na,10,9999,1,2,3\n");
  InputError e = Refusal([&] { ReadPosesCsv(dir.File("p.csv"), 2); });
  EXPECT_EQ(e.where().line, 2);
  EXPECT_EQ(e.where().column, 3);
  EXPECT_NE(e.message().find("±720 deg"), std::string::npos) << e.what();

  WriteText(dir.File("o.csv"), "point,station,hz_gon,v_gon,distance_mm\nP,S1,10,100,2e9\n");
  e = Refusal([&] { ReadObservationsCsv(dir.File("o.csv")); });
  EXPECT_EQ(e.where().column, 5);
  WriteText(dir.File("o.csv"), "point,station,hz_gon,v_gon\nP,S1,1e300,100\n");
  e = Refusal([&] { ReadObservationsCsv(dir.File("o.csv")); });
  EXPECT_EQ(e.where().column, 3);
  WriteText(dir.File("o.csv"), "point,station,hz_gon,v_gon,sigma_hz_arcsec\nP,S1,10,100,0\n");
  e = Refusal([&] { ReadObservationsCsv(dir.File("o.csv")); });
  EXPECT_EQ(e.where().column, 5);
  EXPECT_NE(e.message().find("an angular sigma from 0.0001 arcsec"), std::string::npos) << e.what();

  WriteText(dir.File("c.csv"), "point,x_mm,y_mm,z_mm\nC1,0,-3e11,0\n");
  e = Refusal([&] { ReadControlCsv(dir.File("c.csv")); });
  EXPECT_EQ(e.where().column, 3);

  PoseImportOptions options;
  options.joint_columns = {"j1"};
  options.xyz_columns = {"X", "Y", "Z"};
  options.length_scale_to_mm = 1000.0;                          // metres
  WriteText(dir.File("i.csv"), "j1,X,Y,Z\n0.1,1.5,2e7,0.3\n");  // 20,000 km
  e = Refusal([&] { ImportPoses(dir.File("i.csv"), options); });
  EXPECT_EQ(e.where().column, 3);
}

TEST(HostileInputs, ModelLinkLengthOf1e19mmIsRefusedAtTheNumber) {
  const std::string path = DataPath("faults/model-link-1e19mm.yaml");
  const InputError e = Refusal([&] { LoadRobotModel(path); });
  EXPECT_EQ(e.where().file, path);
  EXPECT_EQ(e.where().line, 6);
  EXPECT_EQ(e.where().column, 13);
  EXPECT_NE(e.message().find("within ±1000000 mm"), std::string::npos) << e.what();
}

TEST(HostileInputs, ModelDhLengthsToolAndJointLimitsAreChecked) {
  const std::string head = "name: r\ndh:\n";
  EXPECT_EQ(Refusal([&] {
              ParseRobotModel(head + "  - {d_mm: 1e7, a_mm: 0, alpha_deg: 90}\n", "m.yaml");
            })
                .where()
                .line,
            3);
  EXPECT_EQ(
      Refusal([&] { ParseRobotModel(head + "  - {d_mm: 1, a_mm: 0, alpha_deg: 1e9}\n", "m.yaml"); })
          .where()
          .line,
      3);
  const std::string one = head + "  - {d_mm: 100, a_mm: 0, alpha_deg: 90}\n";
  EXPECT_EQ(
      Refusal([&] { ParseRobotModel(one + "tool_mm: [0, 0, -inf]\n", "m.yaml"); }).where().line, 4);
  EXPECT_EQ(
      Refusal([&] { ParseRobotModel(one + "tool_mm: [0, 0, 2e6]\n", "m.yaml"); }).where().line, 4);
  EXPECT_EQ(Refusal([&] { ParseRobotModel(one + "joint_limits_deg: [[-900, 0]]\n", "m.yaml"); })
                .where()
                .line,
            4);
}

TEST(HostileInputs, StationsOutsideAKilometreOrWithZeroSigmasAreRefused) {
  InputError e = Refusal([] {
    ParseStationsYaml("stations:\n  - {id: S1, position_mm: [0, 5e10, 0], azimuth_gon: 0}\n",
                      "s.yaml");
  });
  EXPECT_EQ(e.where().line, 2);
  e = Refusal([] {
    ParseStationsYaml(
        "stations:\n  - {id: S1, position_mm: [0, 0, 0], azimuth_gon: 0, sigma_hz_arcsec: 0}\n",
        "s.yaml");
  });
  EXPECT_NE(e.message().find("an angular sigma from 0.0001 arcsec"), std::string::npos) << e.what();
}

// A sigma is a weight's root: 1e-31 mm weighed 1e62 and the adjustment overflowed into a
// "non_finite" point naming no sigma, while 1e-320 arcsec in another column was refused. One
// floor for every sigma column (1 nm, 0.0001 arc second), refused at the cell that breaks it,
// in the column's unit; the floor itself is accepted.
TEST(HostileInputs, EverySigmaColumnHasTheSameFloorNamedWhenRefused) {
  TempDir dir;
  const std::string header =
      "point,station,hz_gon,v_gon,distance_mm,sigma_hz_arcsec,sigma_v_arcsec,sigma_distance_mm\n";
  const struct {
    std::string row;
    int column;
    std::string expected;
  } cases[] = {
      {"P,S1,10,100,2000,1,1,1e-31", 8, "expected a sigma from 1e-06 mm to 1000000 mm, got 1e-31"},
      {"P,S1,10,100,2000,1,1,1e-7", 8, "expected a sigma from 1e-06 mm"},
      {"P,S1,10,100,2000,1e-320,1,1", 6, "expected an angular sigma from 0.0001 arcsec"},
      {"P,S1,10,100,2000,1,5e-5,1", 7, "expected an angular sigma from 0.0001 arcsec"},
  };
  for (const auto& c : cases) {
    WriteText(dir.File("o.csv"), header + c.row + "\n");
    const InputError e = Refusal([&] { ReadObservationsCsv(dir.File("o.csv")); });
    EXPECT_EQ(e.where().line, 2) << c.row;
    EXPECT_EQ(e.where().column, c.column) << c.row;
    EXPECT_NE(e.message().find(c.expected), std::string::npos) << e.what();
  }
  WriteText(dir.File("o.csv"), header + "P,S1,10,100,2000,0.0001,0.0001,1e-6\n");
  const auto floor = ReadObservationsCsv(dir.File("o.csv"));
  ASSERT_EQ(floor.size(), 1u);
  ASSERT_TRUE(floor[0].sigma_distance_mm.has_value());
  EXPECT_DOUBLE_EQ(*floor[0].sigma_distance_mm, 1e-6);
  // The control points' sigma columns, and a stations file's sigma keys, the same floor.
  WriteText(dir.File("c.csv"), "point,x_mm,y_mm,z_mm,sx_mm,sy_mm,sz_mm\nC1,0,0,0,1,1e-9,1\n");
  InputError e = Refusal([&] { ReadControlCsv(dir.File("c.csv")); });
  EXPECT_EQ(e.where().column, 6);
  EXPECT_NE(e.message().find("expected a sigma from 1e-06 mm"), std::string::npos) << e.what();
  e = Refusal([] {
    ParseStationsYaml(
        "stations:\n  - {id: S1, position_mm: [0, 0, 0], azimuth_gon: 0, "
        "sigma_v_arcsec: 1e-5}\n",
        "s.yaml");
  });
  EXPECT_NE(e.message().find("expected an angular sigma from 0.0001 arcsec"), std::string::npos)
      << e.what();
}

// Every YAML file of a wrong shape: exit 2 material (an InputError) with the file, line
// and column and what was expected, never a yaml-cpp message.
TEST(HostileInputs, YamlOfTheWrongShapeNamesFileLineColumnAndTheExpectedShape) {
  struct Case {
    std::string file;
    std::function<void(const std::string&)> read;
    int line;
    std::string expected;
  };
  const auto model = [](const std::string& p) { LoadRobotModel(p); };
  const auto stations = [](const std::string& p) { ReadStationsYaml(p); };
  const auto lab = [](const std::string& p) { io::LoadLab(p); };
  const std::vector<Case> cases = {
      {"model-list-root.yaml", model, 2, "expected a mapping"},
      {"model-scalar-term.yaml", model, 7, "expected a mapping"},
      {"model-links-map.yaml", model, 4, "expected a list"},
      {"stations-scalar-item.yaml", stations, 3, "expected a mapping"},
      {"stations-map-not-list.yaml", stations, 3, "expected a list"},
      {"stations-list-root.yaml", stations, 2, "expected a mapping"},
      {"lab-instruments-map.yaml", lab, 6, "expected a list"},
      {"lab-robot-list.yaml", lab, 3, "expected a mapping"},
  };
  for (const auto& c : cases) {
    const std::string path = DataPath("faults/" + c.file);
    const InputError e = Refusal([&] { c.read(path); });
    EXPECT_EQ(e.where().file, path) << e.what();
    EXPECT_EQ(e.where().line, c.line) << e.what();
    EXPECT_GT(e.where().column, 0) << e.what();
    EXPECT_NE(e.message().find(c.expected), std::string::npos) << e.what();
  }
}

TEST(HostileInputs, NamesWithControlCharactersAreRefusedWhereTheyEnter) {
  InputError e = Refusal([] { LoadRobotModel(DataPath("faults/model-name-newline.yaml")); });
  EXPECT_EQ(e.where().line, 1);
  EXPECT_NE(e.message().find("control character U+000A"), std::string::npos) << e.what();
  e = Refusal([] {
    ParseStationsYaml("stations:\n  - {id: \"S\\e[2J\", position_mm: [0, 0, 0], azimuth_gon: 0}\n",
                      "s.yaml");
  });
  EXPECT_EQ(e.where().line, 2);
  TempDir dir;
  WriteText(dir.File("o.csv"), "point,station,hz_gon,v_gon\nP,\"S1\nFAKE\",10,100\n");
  e = Refusal([&] { ReadObservationsCsv(dir.File("o.csv")); });
  EXPECT_EQ(e.where().line, 2);
  EXPECT_EQ(e.where().column, 2);
  WriteText(dir.File("p.csv"),
            "pose,q1_deg,x_mm,y_mm,z_mm\n" + std::string(70, 'p') + ",1,2,3,4\n");
  e = Refusal([&] { ReadPosesCsv(dir.File("p.csv"), 1); });
  EXPECT_NE(e.message().find("1 to 64"), std::string::npos) << e.what();
}

// --- Hostile inputs, a second audit.

InputError FaultRefusal(const std::function<void(const std::string&)>& read,
                        const std::string& file) {
  return Refusal([&] { read(DataPath("faults/" + file)); });
}

TEST(HostileInputs, AmbiguousCsvHeadersAreRefusedNamingBothColumns) {
  const auto observations = [](const std::string& p) { ReadObservationsCsv(p); };
  InputError e = FaultRefusal(observations, "observations-duplicate-column.csv");
  EXPECT_EQ(e.where().line, 2);  // the header, after a comment line
  EXPECT_EQ(e.where().column, 6);
  EXPECT_NE(e.message().find("duplicate column 'distance_mm' (also column 5)"), std::string::npos)
      << e.what();
  e = FaultRefusal(observations, "observations-hz-two-units.csv");
  EXPECT_EQ(e.where().column, 5);
  EXPECT_NE(e.message().find("'hz_deg' gives the same quantity as column 3 'hz_gon'"),
            std::string::npos)
      << e.what();
  e = FaultRefusal(observations, "observations-distance-in-metres.csv");
  EXPECT_EQ(e.where().column, 5);
  EXPECT_NE(e.message().find("expected distance_mm"), std::string::npos) << e.what();
  e = FaultRefusal(observations, "observations-sigma-mgon.csv");
  EXPECT_NE(e.message().find("'sigma_hz_mgon' is in a unit armsig does not read: expected "
                             "sigma_hz_arcsec"),
            std::string::npos)
      << e.what();

  TempDir dir;
  WriteText(dir.File("p.csv"), "pose,q1_deg,x_mm,y_mm,z_mm,x_mm\na,1,2,3,4,5\n");
  EXPECT_EQ(Refusal([&] { ReadPosesCsv(dir.File("p.csv"), 1); }).where().column, 6);
  WriteText(dir.File("p.csv"), "pose,q1_grad,x_mm,y_mm,z_mm\na,1,2,3,4\n");
  e = Refusal([&] { ReadPosesCsv(dir.File("p.csv"), 1); });
  EXPECT_EQ(e.where().column, 2);
  EXPECT_NE(e.message().find("expected q1_gon, q1_deg or q1_rad"), std::string::npos) << e.what();
  WriteText(dir.File("c.csv"), "point,x_mm,y_mm,z_mm,sx_m\nC,1,2,3,0.001\n");
  EXPECT_EQ(Refusal([&] { ReadControlCsv(dir.File("c.csv")); }).where().column, 5);
  // Extra columns of other names are still the file's own (docs/reference/file-formats.md).
  WriteText(dir.File("p.csv"),
            "pose,q1_deg,x_mm,y_mm,z_mm,operator,temperature_c\na,1,2,3,4,ann,20\n");
  EXPECT_EQ(ReadPosesCsv(dir.File("p.csv"), 1).size(), 1u);

  PoseImportOptions options;
  options.joint_columns = {"q1_deg", "q1_deg"};
  options.xyz_columns = {"x", "y", "z"};
  WriteText(dir.File("i.csv"), "q1_deg,x,y,z\n1,2,3,4\n");
  e = Refusal([&] { ImportPoses(dir.File("i.csv"), options); });
  EXPECT_EQ(e.where().file, "--joint-columns");
  EXPECT_NE(e.message().find("'q1_deg' is given twice"), std::string::npos) << e.what();
}

TEST(HostileInputs, MessagesNameTheColumnAndTheValue) {
  TempDir dir;
  WriteText(dir.File("p.csv"), "pose,q1_deg,q2_deg,q3_deg,x_mm,y_mm,z_mm\na,1,2,3,4,5,6\n");
  InputError e = Refusal([&] { ReadPosesCsv(dir.File("p.csv"), 2); });
  EXPECT_EQ(e.where().line, 1);
  EXPECT_EQ(e.where().column, 4);
  EXPECT_NE(e.message().find("'q3_deg'"), std::string::npos) << e.what();
  WriteText(dir.File("x.csv"), "point,station,hz_gon,v_gon\nP,S1,10\n");
  e = Refusal([&] { ReadObservationsCsv(dir.File("x.csv")); });
  EXPECT_EQ(e.where().line, 2);
  EXPECT_EQ(e.where().column, 4);  // where the row ends short
  WriteText(dir.File("v.csv"), "point,station,hz_gon,v_gon\nP,S1,10,401\n");
  e = Refusal([&] { ReadObservationsCsv(dir.File("v.csv")); });
  EXPECT_EQ(e.where().column, 4);
  EXPECT_NE(e.message().find("got 401"), std::string::npos) << e.what();
}

TEST(HostileInputs, CircleReadingsFollowOneRuleInEveryReader) {
  TempDir dir;
  const std::string head = "point,station,hz_gon,v_gon\n";
  for (const std::string row : {"P,S1,-10,100", "P,S1,401,100", "P,S1,799,100"}) {
    WriteText(dir.File("o.csv"), head + row + "\n");
    const InputError e = Refusal([&] { ReadObservationsCsv(dir.File("o.csv")); });
    EXPECT_EQ(e.where().column, 3) << row;
    EXPECT_NE(e.message().find("horizontal circle reading from 0 to 400 gon"), std::string::npos)
        << e.what();
  }
  WriteText(dir.File("o.csv"), "point,station,hz_deg,v_deg\nP,S1,361,90\n");
  EXPECT_EQ(Refusal([&] { ReadObservationsCsv(dir.File("o.csv")); }).where().column, 3);
  WriteText(dir.File("o.csv"), "point,station,hz_rad,v_rad\nP,S1,7,1\n");
  EXPECT_EQ(Refusal([&] { ReadObservationsCsv(dir.File("o.csv")); }).where().column, 3);
  EXPECT_NE(FaultRefusal([](const std::string& p) { ReadObservationsCsv(p); },
                         "observations-hz-401gon.csv")
                .message()
                .find("got 401"),
            std::string::npos);

  // GSI: a distance of 1e16 mm or a negative one is refused, not written or dropped.
  InputError e =
      FaultRefusal([](const std::string& p) { ImportGsi(p, "S1"); }, "gsi-distance-1e16mm.gsi");
  EXPECT_EQ(e.where().column_name, "WI31");
  EXPECT_NE(e.message().find("a distance > 0 and ≤ 1000000 mm"), std::string::npos) << e.what();
  e = FaultRefusal([](const std::string& p) { ImportGsi(p, "S1"); }, "gsi-negative-distance.gsi");
  EXPECT_NE(e.message().find("got -1500"), std::string::npos) << e.what();

  // What import gsi writes, the observations reader reads: V = 400 gon included.
  WriteText(dir.File("v.gsi"), "110001+00000001 21.322+00000000 22.322+40000000\r\n");
  WriteText(dir.File("v.csv"),
            FormatObservationsCsv(ImportGsi(dir.File("v.gsi"), "S1").observations));
  const auto back = ReadObservationsCsv(dir.File("v.csv"));
  ASSERT_EQ(back.size(), 1u);
  EXPECT_NEAR(back[0].reading.v_rad, 2 * kPi, 1e-12);
}

TEST(HostileInputs, EchoedValuesAreQuotedEscapedAndCut) {
  const InputError e = FaultRefusal([](const std::string& p) { ReadObservationsCsv(p); },
                                    "observations-forged-log-line.csv");
  const std::string what = e.what();
  EXPECT_EQ(what.find('\n'), std::string::npos) << what;
  EXPECT_NE(what.find("\\narmsig: info: orientation accepted"), std::string::npos) << what;
  TempDir dir;
  WriteText(dir.File("o.csv"), "point,station,hz_gon,v_gon\nP,S1,\"1\x1b[2J\",100\n");
  EXPECT_NE(std::string(Refusal([&] { ReadObservationsCsv(dir.File("o.csv")); }).what())
                .find("'1\\x1b[2J'"),
            std::string::npos);
  using namespace std::string_literals;
  WriteText(dir.File("n.csv"), "point,station,hz_gon,v_gon\nP,S1,\"1\0\",100\n"s);
  EXPECT_NE(
      std::string(Refusal([&] { ReadObservationsCsv(dir.File("n.csv")); }).what()).find("\\0"),
      std::string::npos);
  WriteText(dir.File("big.csv"),
            "point,station,hz_gon,v_gon\nP,S1," + std::string(500'000, '9') + "x,100\n");
  const std::string big = Refusal([&] { ReadObservationsCsv(dir.File("big.csv")); }).what();
  EXPECT_LT(big.size(), 400u);
  EXPECT_NE(big.find("(500001 bytes)"), std::string::npos) << big;
  // A record beyond the readers' limit (1 MiB) is refused before its value is looked at.
  WriteText(dir.File("huge.csv"),
            "point,station,hz_gon,v_gon\nP,S1," + std::string(50'000'000, '9') + "x,100\n");
  const std::string huge = Refusal([&] { ReadObservationsCsv(dir.File("huge.csv")); }).what();
  EXPECT_LT(huge.size(), 400u);
  EXPECT_NE(huge.find("huge.csv:2: a record longer than 1 MiB"), std::string::npos) << huge;
  // YAML values and keys too.
  const std::string yaml = Refusal([] {
                             ParseRobotModel(
                                 "name: r\nlinks: [[[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]]\n"
                                 "tool_mm: [0, 0, \"\\e[2J\\n\"]\n",
                                 "m.yaml");
                           }).what();
  EXPECT_EQ(yaml.find('\x1b'), std::string::npos) << yaml;
  EXPECT_EQ(yaml.find('\n'), std::string::npos) << yaml;
}

TEST(HostileInputs, NonRegularAndOversizedFilesAreRefusedWithoutReading) {
  // /dev/zero never ends (it was read to 2.1 GB and bad_alloc), a FIFO blocks the reader.
  for (const auto& read : std::vector<std::function<void()>>{
           [] { LoadRobotModel("/dev/zero"); }, [] { ReadPosesCsv("/dev/zero", 6); },
           [] { ReadStationsYaml("/dev/urandom"); }, [] { ImportGsi("/dev/zero", "S1"); }}) {
    const InputError e = Refusal(read);
    EXPECT_NE(e.message().find("is a character device, not a regular file"), std::string::npos)
        << e.what();
  }
  TempDir dir;
  const std::string fifo = dir.File("fifo.csv");
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  const auto start = std::chrono::steady_clock::now();
  EXPECT_NE(Refusal([&] { ReadObservationsCsv(fifo); }).message().find("is a FIFO"),
            std::string::npos);
  EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(2));
  EXPECT_NE(Refusal([&] { ReadPosesCsv(dir.path().string(), 6); }).message().find("is a folder"),
            std::string::npos);
  // A sparse file beyond the YAML limit: refused by its size, not read.
  const std::string huge = dir.File("huge.yaml");
  WriteText(huge, "name: r\n");
  std::filesystem::resize_file(huge, kYamlFileLimit.max_bytes + 1);
  EXPECT_NE(Refusal([&] { LoadRobotModel(huge); }).message().find("at most 16 MiB"),
            std::string::npos);
  // A lab naming /dev/urandom as its stations file: refused at the lab's key.
  WriteText(dir.File("lab.yaml"),
            "robot:\n  model: " + testing::SourcePath("models/puma760.yaml") +
                "\n  controller: {protocol: val, port: /dev/null}\ninstruments:\n"
                "  - {station: S1, protocol: geocom, port: /dev/null}\nstations: /dev/urandom\n");
  const InputError lab = Refusal([&] { io::LoadLab(dir.File("lab.yaml")); });
  EXPECT_EQ(lab.where().file, dir.File("lab.yaml"));
  EXPECT_NE(lab.message().find("not a regular file"), std::string::npos) << lab.what();
}

TEST(HostileInputs, YamlAliasesAreRefusedWhereTheyAreUsed) {
  const InputError e =
      FaultRefusal([](const std::string& p) { LoadRobotModel(p); }, "model-alias.yaml");
  EXPECT_EQ(e.where().line, 5);  // the alias, not the anchor on line 4
  EXPECT_NE(e.message().find("aliases"), std::string::npos) << e.what();
  // Aliases of aliases (the "billion laughs") are refused before any reader walks them.
  std::string bomb = "a: &a [x, x, x, x, x, x, x, x, x, x]\n";
  for (char c = 'b'; c <= 'k'; ++c) {
    bomb += std::string(1, c) + ": &" + c + " [";
    for (int k = 0; k < 10; ++k) bomb += std::string(k ? ", *" : "*") + static_cast<char>(c - 1);
    bomb += "]\n";
  }
  EXPECT_NE(Refusal([&] { ParseStationsYaml(bomb, "bomb.yaml"); }).message().find("aliases"),
            std::string::npos);
}

TEST(HostileInputs, LabSettingsHavePlausibleMaximums) {
  for (const std::string file : {"lab-fault-retries-2e9.yaml", "lab-readings-1e9.yaml"}) {
    const InputError e = FaultRefusal(
        [](const std::string& p) { io::ParseLabSettings(ReadWholeFile(p, kYamlFileLimit), p); },
        file);
    EXPECT_EQ(e.where().line, 7) << e.what();
    EXPECT_NE(e.message().find("an integer from"), std::string::npos) << e.what();
  }
}

TEST(HostileInputs, ScaleBarsAndControlPointsMustJoinDifferentPoints) {
  InputError e = Refusal([] { ParseScaleBar("A:A=1000", 0.01); });
  EXPECT_EQ(e.where().file, "--scale-bar");
  EXPECT_NE(e.message().find("both ends are point 'A'"), std::string::npos) << e.what();
  EXPECT_NE(Refusal([] { ParseScaleBar("A:B\xff=1000", 0.01); }).message().find("not UTF-8"),
            std::string::npos);
  e = FaultRefusal([](const std::string& p) { ReadControlCsv(p); }, "control-one-position.csv");
  EXPECT_EQ(e.where().line, 4);
  EXPECT_NE(e.message().find("'T2' has the position of control point 'T1' (line 3)"),
            std::string::npos)
      << e.what();
}

}  // namespace
}  // namespace armsig::io
