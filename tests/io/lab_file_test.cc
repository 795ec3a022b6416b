#include "io/lab_file.h"

#include <gtest/gtest.h>

#include "core/error.h"
#include "core/units.h"
#include "io/network_files.h"
#include "test_support.h"

namespace armsig::io {
namespace {

// A lab folder: the shipped PUMA model, a stations file and a lab file naming both.
class LabFile : public ::testing::Test {
 protected:
  static constexpr const char* kStations =
      "stations:\n"
      "  - {id: T1, position_mm: [0, 0, 0], azimuth_gon: 0}\n"
      "  - {id: T2, position_mm: [3000, 0, 0], azimuth_gon: 100}\n";

  std::string Lab(const std::string& stations_line, const std::string& extra = "") const {
    return "robot:\n"
           "  model: '" +
           testing::SourcePath("models/puma760.yaml") +
           "'\n"
           "  controller: {protocol: as, port: /dev/ttyS0, can_move: true}\n"
           "instruments:\n"
           "  - {station: T1, protocol: geocom, port: /dev/ttyUSB0, sigma_hz_arcsec: 0.3}\n"
           "  - {station: T2, protocol: gsi, tcp: '192.168.0.12:1212'}\n" +
           stations_line + extra;
  }

  // Writes `text` as lab.yaml and returns the InputError LoadLab throws.
  InputError LabRefusal(const std::string& text) const {
    testing::WriteText(dir_.File("lab.yaml"), text);
    try {
      LoadLab(dir_.File("lab.yaml"));
    } catch (const InputError& e) {
      return e;
    }
    ADD_FAILURE() << "expected an InputError for\n" << text;
    return InputError("none");
  }

  std::string Path(const std::string& name) const { return dir_.File(name); }

  testing::TempDir dir_;
};

TEST_F(LabFile, LoadsEverythingItGives) {
  testing::WriteText(Path("stations.yaml"), kStations);
  testing::WriteText(Path("lab.yaml"),
                     Lab("stations: stations.yaml\n",
                         "tolerances: {max_miss_mm: 0.1, readings: 2, settle_ms: 0, two_face: "
                         "true, timeout_ms: 2000}\n"
                         "recalibration: {max_validation_mean_mm: 0.3, drift_sigma: 4}\n"));
  const LabConfig lab = LoadLab(Path("lab.yaml"));
  EXPECT_EQ(lab.model.num_joints(), 6);
  EXPECT_EQ(lab.model_yaml, testing::ReadText(testing::SourcePath("models/puma760.yaml")));
  EXPECT_EQ(lab.controller.protocol, ControllerProtocol::kKawasakiAs);
  EXPECT_EQ(lab.controller.port, "/dev/ttyS0");
  EXPECT_TRUE(lab.controller.can_move);
  ASSERT_EQ(lab.instruments.size(), 2u);
  EXPECT_EQ(lab.instruments[0].sigma_hz_arcsec, 0.3);
  ASSERT_TRUE(lab.instruments[1].tcp);
  EXPECT_EQ(lab.instruments[1].tcp->Text(), "192.168.0.12:1212");
  ASSERT_EQ(lab.stations.size(), 2u);
  EXPECT_EQ(lab.stations[1].pose.position_mm.x(), 3000.0);
  EXPECT_DOUBLE_EQ(lab.stations[1].pose.azimuth_rad, kPi / 2);
  EXPECT_EQ(lab.tolerances.max_miss_mm, 0.1);
  EXPECT_EQ(lab.tolerances.readings, 2);
  EXPECT_EQ(lab.tolerances.max_repeat_mm, Tolerances{}.max_repeat_mm);  // not given: default
  EXPECT_TRUE(lab.tolerances.two_face);
  EXPECT_EQ(lab.policy.timeout, std::chrono::milliseconds(2000));
  ASSERT_TRUE(lab.recalibration.has_value());
  EXPECT_EQ(lab.recalibration->max_validation_mean_mm, 0.3);
  EXPECT_EQ(lab.recalibration->drift_sigma, 4.0);
  EXPECT_FALSE(lab.recalibration->max_validation_max_mm.has_value());
  EXPECT_FALSE(lab.recalibration->tolerance_mm.has_value());
}

TEST_F(LabFile, InlineStationsAreReadLikeAStationsFile) {
  testing::WriteText(Path("stations.yaml"), kStations);
  const std::string inline_list = std::string("stations:\n") +
                                  "  - {id: T1, position_mm: [0, 0, 0], azimuth_gon: 0}\n"
                                  "  - {id: T2, position_mm: [3000, 0, 0], azimuth_gon: 100}\n";
  const LabConfig lab = ParseLab(Lab(inline_list), Path("lab.yaml"));
  const auto file = io::ReadStationsYaml(Path("stations.yaml"));
  ASSERT_EQ(lab.stations.size(), file.size());
  for (size_t i = 0; i < file.size(); ++i) {
    EXPECT_EQ(lab.stations[i].pose.id, file[i].pose.id);
    EXPECT_EQ(lab.stations[i].pose.position_mm, file[i].pose.position_mm);
    EXPECT_EQ(lab.stations[i].pose.world_from_station, file[i].pose.world_from_station);
  }
}

TEST_F(LabFile, MisspeltKeysAreRefusedWithLineAndSuggestion) {
  // Line 7 is the first line after the instruments.
  EXPECT_STREQ(
      LabRefusal(Lab("tolerance: {max_miss_mm: 0.1}\n")).what(),
      (Path("lab.yaml") + ":7:1: unknown key 'tolerance' (did you mean 'tolerances'?)").c_str());
  EXPECT_STREQ(
      LabRefusal(Lab("tolerances:\n  max_mis_mm: 0.1\n")).what(),
      (Path("lab.yaml") + ":8:3: unknown key 'max_mis_mm' (did you mean 'max_miss_mm'?)").c_str());
  EXPECT_STREQ(
      LabRefusal(Lab("recalibration:\n  drift_sigma: 4\n  tolerance: 0.02\n")).what(),
      (Path("lab.yaml") + ":9:3: unknown key 'tolerance' (did you mean 'tolerance_mm'?)").c_str());
  const InputError instrument = LabRefusal(
      "robot:\n  model: m.yaml\n  controller: {protocol: as, port: p}\n"
      "instruments:\n  - {station: T1, protocol: geocom, prot: /dev/ttyUSB0}\n");
  EXPECT_EQ(instrument.where().line, 5);
  EXPECT_EQ(instrument.message(), "unknown key 'prot' (did you mean 'port'?)");
}

TEST_F(LabFile, MisspeltKeyInTheModelItNamesIsRefusedInTheModelFile) {
  std::string model = testing::ReadText(testing::SourcePath("models/ur10.yaml"));
  model.replace(model.find("tool_mm:"), 8, "tool_m: ");
  testing::WriteText(Path("ur10.yaml"), model);
  std::string lab = Lab("");
  lab.replace(lab.find("model: '"), lab.find("'\n") - lab.find("model: '") + 1, "model: ur10.yaml");
  const InputError e = LabRefusal(lab);
  EXPECT_EQ(e.where().file, Path("ur10.yaml"));
  EXPECT_GT(e.where().line, 5);
  EXPECT_EQ(e.message(), "unknown key 'tool_m' (did you mean 'tool_mm'?)");
}

TEST_F(LabFile, WrongShapesNamePositionAndWhatWasExpected) {
  const std::string robot = "robot:\n  model: m.yaml\n  controller: {protocol: as, port: p}\n";
  {
    const InputError e = LabRefusal(robot + "instruments: {station: T1, protocol: gsi}\n");
    EXPECT_EQ(e.where().line, 4);
    EXPECT_EQ(e.where().column, 14);
    EXPECT_EQ(e.where().column_name, "instruments");
    EXPECT_EQ(e.message(), "expected a list, got a mapping");
  }
  {
    const InputError e = LabRefusal(Lab("tolerances: {readings: 1.5}\n"));
    EXPECT_EQ(e.where().line, 7);
    EXPECT_EQ(e.where().column, 24);
    EXPECT_EQ(e.message(), "expected an integer from 1 to 100, got '1.5'");
  }
  {
    const InputError e = LabRefusal(Lab("tolerances: [0.1]\n"));
    EXPECT_EQ(e.message().rfind("expected a mapping with max_miss_mm, ", 0), 0u) << e.message();
  }
  {
    const InputError e = LabRefusal(Lab("stations: {id: T1}\n"));
    EXPECT_EQ(e.message(), "expected a stations file name or a list of stations, got a mapping");
  }
  {
    const InputError e =
        LabRefusal(robot + "instruments:\n  - {station: T1, protocol: gsi, tcp: host}\n");
    EXPECT_EQ(e.message(), "expected HOST:PORT with a port from 1 to 65535, got 'host'");
  }
  for (const std::string bad : {"host:70000", "host:12ab", ":1212", "host:"}) {
    const InputError e =
        LabRefusal(robot + "instruments:\n  - {station: T1, protocol: gsi, tcp: '" + bad + "'}\n");
    EXPECT_EQ(e.where().line, 5) << bad;
    EXPECT_EQ(e.where().column_name, "tcp") << bad;
  }
  {
    const InputError e =
        LabRefusal("robot:\n  model: m.yaml\n  controller: {protocol: as, port: p, ports: [a]}\n");
    EXPECT_EQ(e.message(), "'ports' belongs to protocol counter, not as");
  }
  {
    const InputError e = LabRefusal(Lab("stations: nowhere.yaml\n"));
    EXPECT_EQ(e.where().file, Path("lab.yaml"));
    EXPECT_EQ(e.where().line, 7);
    EXPECT_EQ(e.message(), "cannot read stations file '" + Path("nowhere.yaml") +
                               "': cannot open file for reading (No such file or directory)");
  }
}

// One stations reader: each refusal reads the same from a stations file, from a lab file
// naming that file, and (at the lab file's own lines) from the lab file's inline list.
TEST_F(LabFile, StationRefusalsAreTheSameAsFromAStationsFile) {
  const std::vector<std::string> bad_lists = {
      "  - {id: T1, position_mm: [0, 0, 0], azimuth_gon: 0}\n"
      "  - {id: T1, position_mm: [1, 0, 0], azimuth_gon: 0}\n",
      "  - {id: T1, position_mm: [0, 0, 0], rotation: [[1, 0, 0], [0, 1, 0], [0, 0.1, 1]]}\n",
      "  - {id: T1, position_mm: [0, 0, 0], azimuth_gon: 0, rotation: [[1, 0, 0], [0, 1, 0], [0, "
      "0, 1]]}\n",
      "  - {id: T1, position_mm: [0, 0, 0], azimut_gon: 0}\n",
      "  - {id: T1, position_mm: [0, 0], azimuth_gon: 0}\n",
  };
  for (const std::string& list : bad_lists) {
    SCOPED_TRACE(list);
    testing::WriteText(Path("stations.yaml"), "stations:\n" + list);
    std::string from_file;
    try {
      io::ReadStationsYaml(Path("stations.yaml"));
      ADD_FAILURE() << "ReadStationsYaml accepted it";
    } catch (const InputError& e) {
      from_file = e.what();
      EXPECT_EQ(e.where().file, Path("stations.yaml"));
    }
    const InputError via_lab = LabRefusal(Lab("stations: stations.yaml\n"));
    EXPECT_EQ(via_lab.what(), from_file);

    const InputError in_lab = LabRefusal(Lab("stations:\n" + list));
    const InputError in_file = [&] {
      try {
        io::ReadStationsYaml(Path("stations.yaml"));
      } catch (const InputError& e) {
        return e;
      }
      return InputError("none");
    }();
    EXPECT_EQ(in_lab.message(), in_file.message());
    EXPECT_EQ(in_lab.where().file, Path("lab.yaml"));
    EXPECT_EQ(in_lab.where().line, in_file.where().line + 6);  // the lab's 6 lines before
    EXPECT_EQ(in_lab.where().column, in_file.where().column);
  }
}

TEST_F(LabFile, InstrumentOnAnUnknownStationIsRefusedAtItsStation) {
  testing::WriteText(Path("stations.yaml"),
                     "stations:\n  - {id: T1, position_mm: [0, 0, 0], azimuth_gon: 0}\n");
  const InputError e = LabRefusal(Lab("stations: stations.yaml\n"));
  EXPECT_EQ(e.where().line, 6);
  EXPECT_EQ(e.message(), "instrument station 'T2' is not in the stations");
}

// A laser tracker in the lab file: protocol emscon over tcp (always distances, its own
// sigmas), the stationary measurement time, the tolerances against its stated sigmas, and
// the robot's base in the lab frame for pointing the beam; theodolites and trackers mix.
TEST(LabSettings, TrackerInstrumentsAndTheRobotBase) {
  const std::string text =
      "robot:\n  model: m.yaml\n  controller: {protocol: as, port: p}\n"
      "  base: [[0, -1, 0, 2500], [1, 0, 0, 1500], [0, 0, 1, -900], [0, 0, 0, 1]]\n"
      "instruments:\n"
      "  - {station: LT1, protocol: emscon, tcp: '192.168.0.20:700', measurement_time_ms: 250}\n"
      "  - {station: T1, protocol: geocom, port: /dev/ttyUSB0}\n"
      "tolerances: {max_sigma_mm: 0.03, max_repeat_sigma: 3.5}\n";
  const LabSettings s = ParseLabSettings(text, "lab.yaml");
  ASSERT_EQ(s.instruments.size(), 2u);
  EXPECT_EQ(s.instruments[0].protocol, io::InstrumentProtocol::kEmScon);
  ASSERT_TRUE(s.instruments[0].tcp);
  EXPECT_EQ(s.instruments[0].tcp->Text(), "192.168.0.20:700");
  EXPECT_TRUE(s.instruments[0].distance);
  EXPECT_EQ(s.instruments[0].measurement_time_ms, 250);
  EXPECT_FALSE(s.instruments[1].distance);
  EXPECT_EQ(s.tolerances.max_sigma_mm, 0.03);
  EXPECT_EQ(s.tolerances.max_repeat_sigma, 3.5);
  ASSERT_TRUE(s.robot_base.has_value());
  EXPECT_NEAR((*s.robot_base * Eigen::Vector3d(1, 0, 0) - Eigen::Vector3d(2500, 1501, -900)).norm(),
              0.0, 1e-12);
  EXPECT_FALSE(
      ParseLabSettings(
          text.substr(0, text.find("  base:")) + text.substr(text.find("instruments:")), "lab.yaml")
          .robot_base.has_value());

  auto refusal = [](const std::string& lab) {
    try {
      ParseLabSettings(lab, "lab.yaml");
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string("(accepted)");
  };
  const std::string head = "robot:\n  model: m.yaml\n  controller: {protocol: as, port: p}\n";
  EXPECT_NE(refusal(head + "instruments:\n  - {station: LT1, protocol: emscon, port: /dev/ttyS1}\n")
                .find("lab.yaml:5:44 (port): instrument LT1: 'port' is no emscon setting"),
            std::string::npos)
      << refusal(head + "instruments:\n  - {station: LT1, protocol: emscon, port: /dev/ttyS1}\n");
  EXPECT_NE(refusal(head + "instruments:\n  - {station: LT1, protocol: emscon}\n")
                .find("protocol emscon needs tcp: HOST:PORT"),
            std::string::npos);
  EXPECT_NE(refusal(head + "instruments:\n  - {station: T1, protocol: geocom, port: p, "
                           "measurement_time_ms: 9}\n")
                .find("'measurement_time_ms' belongs to protocol emscon, not geocom"),
            std::string::npos);
  EXPECT_NE(refusal(head + "instruments:\n  - {station: LT1, protocol: emscon, tcp: 'h:700', "
                           "distance: false}\n")
                .find("always measures the distance"),
            std::string::npos);
  // A base that is no rigid transform.
  EXPECT_NE(refusal("robot:\n  model: m.yaml\n  controller: {protocol: as, port: p}\n"
                    "  base: [[2, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]\n"
                    "instruments:\n  - {station: T1, protocol: geocom, port: q}\n")
                .find("lab.yaml:4:9 (base): expected a rotation"),
            std::string::npos)
      << refusal(
             "robot:\n  model: m.yaml\n  controller: {protocol: as, port: p}\n"
             "  base: [[2, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]\n"
             "instruments:\n  - {station: T1, protocol: geocom, port: q}\n");
  EXPECT_NE(refusal(head + "instruments:\n  - {station: T1, protocol: geocom, port: q}\n"
                           "tolerances: {max_sigma_mm: 0}\n")
                .find("max_sigma_mm"),
            std::string::npos);
}

// FormatLabYaml writes a tracker as a technician would: tcp, no sigmas of its own.
TEST(LabSettings, FormattedTrackerLabReadsBack) {
  io::LabFile lab;
  lab.model_path = "puma760.yaml";
  lab.stations_path = "stations.yaml";
  lab.controller.protocol = ControllerProtocol::kKawasakiAs;
  lab.controller.port = "/dev/pts/3";
  InstrumentConfig tracker;
  tracker.station = "LT1";
  tracker.protocol = io::InstrumentProtocol::kEmScon;
  tracker.tcp = io::HostPort{"127.0.0.1", 7000};
  tracker.distance = true;
  tracker.measurement_time_ms = 200;
  lab.instruments.push_back(tracker);
  lab.tolerances.max_sigma_mm = 0.02;
  lab.tolerances.max_joint_error_deg = 0.25;
  Eigen::Isometry3d base = Eigen::Isometry3d::Identity();
  base.translate(Eigen::Vector3d(2301.25, 1597.5, -1098.5));
  base.rotate(Eigen::AngleAxisd(2.601, Eigen::Vector3d::UnitZ()));
  lab.robot_base = base;
  const std::string text = FormatLabYaml(lab);
  EXPECT_EQ(text.find("sigma_hz_arcsec"), std::string::npos) << text;
  EXPECT_NE(text.find("max_miss_mm: 0.2,"), std::string::npos) << text;  // as written by hand
  const LabSettings s = ParseLabSettings(text, "lab.yaml");
  ASSERT_TRUE(s.robot_base.has_value());
  EXPECT_LT((s.robot_base->matrix() - base.matrix()).cwiseAbs().maxCoeff(), 1e-9);
  EXPECT_EQ(s.tolerances.max_joint_error_deg, 0.25);
  ASSERT_EQ(s.instruments.size(), 1u);
  EXPECT_EQ(s.instruments[0].protocol, io::InstrumentProtocol::kEmScon);
  ASSERT_TRUE(s.instruments[0].tcp);
  EXPECT_EQ(s.instruments[0].tcp->Text(), "127.0.0.1:7000");
  EXPECT_EQ(s.instruments[0].measurement_time_ms, 200);
  EXPECT_EQ(s.tolerances.max_sigma_mm, 0.02);
}

// The database keeps each session's lab text; the files it names may be gone.
TEST(LabSettings, ReadsTheStoredTextWithoutItsFiles) {
  const std::string text =
      "robot:\n  model: /gone/puma760.yaml\n  controller: {protocol: val, port: /dev/ttyS0}\n"
      "instruments:\n  - {station: T1, protocol: geocom, port: /dev/ttyUSB0}\n"
      "stations: /gone/stations.yaml\n"
      "tolerances: {max_miss_mm: 0.15}\n"
      "recalibration: {max_validation_mean_mm: 0.4, max_validation_max_mm: 1.5, tolerance_mm: "
      "0.03, drift_sigma: 6}\n";
  const LabSettings s = ParseLabSettings(text, "stored lab file of session 3");
  EXPECT_EQ(s.robot_model_path, "/gone/puma760.yaml");
  EXPECT_EQ(s.stations_path, "/gone/stations.yaml");
  EXPECT_EQ(s.tolerances.max_miss_mm, 0.15);
  ASSERT_TRUE(s.recalibration.has_value());
  EXPECT_EQ(s.recalibration->max_validation_mean_mm, 0.4);
  EXPECT_EQ(s.recalibration->max_validation_max_mm, 1.5);
  EXPECT_EQ(s.recalibration->tolerance_mm, 0.03);
  EXPECT_EQ(s.recalibration->drift_sigma, 6.0);
  // ParseLab needs the model file and says so at the lab's `model:` line.
  try {
    ParseLab(text, "lab.yaml");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(e.where().line, 2);
    EXPECT_EQ(e.message(),
              "cannot read robot model '/gone/puma760.yaml': cannot open file for reading (No "
              "such file or directory)");
  }
  const std::string without = text.substr(0, text.find("recalibration:"));
  EXPECT_FALSE(ParseLabSettings(without, "stored").recalibration.has_value());
}

TEST(LabSettings, MalformedRecalibrationBlockIsAnInputError) {
  const std::string head =
      "robot:\n  model: m.yaml\n  controller: {protocol: as, port: p}\n"
      "instruments:\n  - {station: T1, protocol: geocom, port: q}\n";
  try {
    ParseLabSettings(head + "recalibration:\n  max_validation_mean_mm: half a mm\n", "stored");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_STREQ(e.what(),
                 "stored:7:27 (max_validation_mean_mm): expected a finite number, got 'half a mm'");
  }
  EXPECT_THROW(ParseLabSettings(head + "recalibration: {drift_sigma: -1}\n", "stored"), InputError);
  EXPECT_THROW(ParseLabSettings(head + "recalibration: 0.5\n", "stored"), InputError);
  EXPECT_THROW(ParseLabSettings(head + "recalibration: {max_validation_mean: 0.5}\n", "stored"),
               InputError);
  EXPECT_THROW(ParseLabSettings(head + "recalibration: {\n", "stored"), InputError);
}

}  // namespace
}  // namespace armsig::io

namespace armsig::io {
namespace {

// A UR lab's controller section (and what ParseLabSettings makes of it).
LabSettings UrLab(const std::string& controller) {
  return ParseLabSettings("robot:\n  model: ur10.yaml\n  controller: " + controller +
                              "\ninstruments:\n  - {station: LT1, protocol: emscon, tcp: "
                              "'127.0.0.1:700'}\n",
                          "/lab/lab.yaml");
}

std::string UrRefusal(const std::string& controller) {
  try {
    UrLab(controller);
  } catch (const InputError& e) {
    return e.message();
  }
  ADD_FAILURE() << "accepted " << controller;
  return "";
}

TEST(NetworkControllers, AUrIsItsHostAndItsInterfacesPortsWithUrsDefaults) {
  const auto lab = UrLab("{protocol: ur, host: 192.168.0.20, can_move: true}");
  const ControllerConfig& c = lab.controller;
  EXPECT_EQ(c.protocol, ControllerProtocol::kUr);
  EXPECT_EQ(c.host, "192.168.0.20");
  EXPECT_TRUE(c.can_move);
  EXPECT_EQ(c.Port("rtde_port"), 30004);
  EXPECT_EQ(c.Port("primary_port"), 30001);
  EXPECT_EQ(c.Port("secondary_port"), 30002);
  EXPECT_EQ(c.Port("dashboard_port"), 29999);
  EXPECT_TRUE(c.port.empty());
  const auto moved = UrLab(
      "{protocol: ur, host: ur10.cell, can_move: false, rtde_port: 40004, dashboard_port: 39999}");
  EXPECT_EQ(moved.controller.Port("rtde_port"), 40004);
  EXPECT_EQ(moved.controller.Port("primary_port"), 30001);
  EXPECT_EQ(moved.controller.Port("dashboard_port"), 39999);
}

TEST(NetworkControllers, KeysOfAnotherProtocolOrMisspeltOnesAreRefusedByName) {
  EXPECT_EQ(UrRefusal("{protocol: ur, host: h, rtde_prot: 30004}"),
            "unknown key 'rtde_prot' (did you mean 'rtde_port'?)");
  EXPECT_EQ(UrRefusal("{protocol: ur, host: h, port: /dev/ttyS0}"),
            "ur: the controller is reached over the network: give 'host' (and its ports), not "
            "'port'");
  EXPECT_EQ(UrRefusal("{protocol: ur, host: h, ports: [a]}"),
            "'ports' belongs to protocol counter, not ur");
  EXPECT_EQ(UrRefusal("{protocol: as, port: p, host: h}"),
            "'host' belongs to protocol ur, abb or kuka, not as");
  EXPECT_EQ(UrRefusal("{protocol: as, port: p, rtde_port: 1}"),
            "'rtde_port' belongs to protocol ur, not as");
  EXPECT_EQ(UrRefusal("{protocol: ur, can_move: true}"),
            "missing 'host' (expected the controller's address (host name or IP address))");
  EXPECT_EQ(UrRefusal("{protocol: ur, host: 'a b'}"),
            "expected a host name or an IP address, got 'a b'");
  EXPECT_EQ(UrRefusal("{protocol: ur, host: h, rtde_port: 70000}"),
            "expected an integer from 1 to 65535, got '70000'");
  EXPECT_EQ(UrRefusal("{protocol: ur, host: h, rtde_port: 29999}"),
            "rtde_port and dashboard_port are both port 29999: each interface of the controller "
            "has its own");
  EXPECT_EQ(UrRefusal("{protocol: ur, host: h, credentials: c.yaml}"),
            "'credentials' belongs to protocol abb, not ur");
  EXPECT_EQ(UrRefusal("{protocol: abb, host: h, rtde_port: 1}"),
            "'rtde_port' belongs to protocol ur, not abb");
  EXPECT_EQ(UrRefusal("{protocol: ur, host: h, speed_percent: 20}"),
            "'speed_percent' belongs to protocol abb, not ur");
}

// A KUKA controller: its variable server's port (7000 unless given), ARMSIG's velocity and
// acceleration as written; no credentials (a variable server asks for none), no UR ports.
TEST(NetworkControllers, AKukaIsItsHostItsVariableServerPortAndArmsigsSettings) {
  auto c = UrLab("{protocol: kuka, host: 192.168.1.147, can_move: true}").controller;
  EXPECT_EQ(c.protocol, ControllerProtocol::kKuka);
  EXPECT_EQ(c.host, "192.168.1.147");
  EXPECT_EQ(c.Port("variable_server_port"), 7000);
  EXPECT_TRUE(c.settings.empty());
  c = UrLab("{protocol: kuka, host: h, variable_server_port: 7001, velocity_percent: 35}").controller;
  EXPECT_EQ(c.Port("variable_server_port"), 7001);
  EXPECT_EQ(c.settings.at("velocity_percent"), "35");
  EXPECT_EQ(UrRefusal("{protocol: kuka, host: h, credentials: c.yaml}"),
            "'credentials' belongs to protocol abb, not kuka");
  EXPECT_EQ(UrRefusal("{protocol: kuka, host: h, rtde_port: 30004}"),
            "'rtde_port' belongs to protocol ur, not kuka");
  EXPECT_EQ(UrRefusal("{protocol: kuka, host: h, velocity_percnt: 30}"),
            "unknown key 'velocity_percnt' (did you mean 'velocity_percent'?)");
}

TEST(NetworkControllers, AFormattedUrLabReadsBackTheSame) {
  ::armsig::io::LabFile file;
  file.model_path = "ur10.yaml";
  file.stations_path = "stations.yaml";
  file.controller.protocol = ControllerProtocol::kUr;
  file.controller.host = "127.0.0.1";
  file.controller.can_move = true;
  file.controller.ports = {{"rtde_port", 41000}, {"primary_port", 30001},
                           {"secondary_port", 41002}, {"dashboard_port", 41003}};
  InstrumentConfig tracker;
  tracker.station = "LT1";
  tracker.protocol = io::InstrumentProtocol::kEmScon;
  tracker.tcp = io::HostPort{"127.0.0.1", 700};
  tracker.distance = true;
  file.instruments = {tracker};
  const std::string text = FormatLabYaml(file);
  EXPECT_EQ(text.find("primary_port"), std::string::npos) << text;  // its default: not written
  const auto lab = ParseLabSettings(text, "/lab/lab.yaml");
  EXPECT_EQ(lab.controller.host, "127.0.0.1");
  EXPECT_EQ(lab.controller.ports, file.controller.ports);
  EXPECT_TRUE(lab.controller.can_move);
}

}  // namespace
}  // namespace armsig::io
