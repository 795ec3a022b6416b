// Issue 15, inputs: numbers outside physical plausibility, YAML of the wrong shape and
// names with control characters are input errors naming file:line:column and what was
// expected, in every reader (core/plausibility.h holds the ranges).
#include <gtest/gtest.h>

#include <functional>

#include "acquisition/lab.h"
#include "core/error.h"
#include "core/plausibility.h"
#include "io/model_yaml.h"
#include "io/network_io.h"
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
  EXPECT_NE(e.message().find("a finite coordinate within ±1e+10 mm"), std::string::npos) << e.what();
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
  EXPECT_NE(e.message().find("sigma > 0"), std::string::npos) << e.what();

  WriteText(dir.File("c.csv"), "point,x_mm,y_mm,z_mm\nC1,0,-3e11,0\n");
  e = Refusal([&] { ReadControlCsv(dir.File("c.csv")); });
  EXPECT_EQ(e.where().column, 3);

  PoseImportOptions options;
  options.joint_columns = {"j1"};
  options.xyz_columns = {"X", "Y", "Z"};
  options.length_scale_to_mm = 1000.0;                           // metres
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
  EXPECT_NE(e.message().find("sigma > 0"), std::string::npos) << e.what();
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
  const auto lab = [](const std::string& p) { acquisition::LoadLab(p); };
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

}  // namespace
}  // namespace armsig::io
