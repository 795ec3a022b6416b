#include <gtest/gtest.h>

#include <filesystem>
#include <nlohmann/json.hpp>
#include <yaml-cpp/yaml.h>

#include "calibration/synthetic.h"
#include "io/csv.h"
#include "io/model_yaml.h"
#include "reduction/intersection.h"
#include "reduction/observation.h"
#include "simulation/geocom_simulator.h"
#include "simulation/simulator.h"
#include "simulation/virtual_robots.h"
#include "test_support.h"

namespace armsig::testing {

namespace {
void AddStation(simulation::VirtualLab& lab) {
  simulation::VirtualStation s;
  s.pose.id = "T1";
  s.pose.position_mm = {2500, 800, 900};
  s.pose.world_from_station = reduction::LevelledRotation(1.0);
  s.pose.azimuth_rad = 1.0;
  lab.AddStation(s);
}
}  // namespace

TEST(InstrumentCommand, ProbeAndReadJsonAgainstAVirtualInstrument) {
  TempDir dir;
  simulation::VirtualLab lab(Puma(), calibration::PaperTable3Parameters(),
                             Eigen::Isometry3d::Identity());
  AddStation(lab);
  simulation::GeoComSimulator sim(lab, 0, dir.File("tps"));
  sim.Start();
  const auto probe =
      RunArmsig("instrument probe --port '" + sim.path() + "' --protocol geocom --json");
  ASSERT_EQ(probe.exit_code, 0) << probe.err;
  const auto info = nlohmann::json::parse(probe.out);
  EXPECT_EQ(info["name"], "TDRA6000");
  EXPECT_EQ(info["serial"], "358123");
  const auto read =
      RunArmsig("instrument read --port '" + sim.path() + "' --protocol geocom --json");
  ASSERT_EQ(read.exit_code, 0) << read.err;
  const auto j = nlohmann::json::parse(read.out);
  const AngleReading truth =
      reduction::PredictReading(lab.station(0).pose.position_mm,
                                lab.station(0).pose.world_from_station, lab.TruePosition("robot"));
  EXPECT_NEAR(j["hz_rad"].get<double>(), truth.hz_rad, 1e-12);
  EXPECT_TRUE(j["distance_mm"].is_null());
  EXPECT_EQ(j["face"], 1);
  // A warning that carries valid data is reported, not fatal.
  sim.InjectOnce({simulation::Fault::kWarningCode, 1284});
  const auto warned =
      RunArmsig("instrument read --port '" + sim.path() + "' --protocol geocom --json");
  EXPECT_EQ(warned.exit_code, 0);
  EXPECT_EQ(nlohmann::json::parse(warned.out)["return_code"], 1284);
  // An error code is a failure with the code named, and no reading.
  sim.InjectOnce({simulation::Fault::kErrorCode, 1292});
  const auto failed =
      RunArmsig("instrument read --port '" + sim.path() + "' --protocol geocom --json");
  EXPECT_EQ(failed.exit_code, 1);
  EXPECT_TRUE(failed.out.empty());
  EXPECT_NE(failed.err.find("TMC_DIST_ERROR"), std::string::npos) << failed.err;
}

// `armsig instrument probe --protocol ur|kuka|abb --tcp HOST[:PORT]` against the virtual
// controllers `demo --serve --robot …` runs: each names the arm its simulator was given (the
// virtual robot of the same seed, made here independently); a UR adds its kinematics checksum.
// The ABB's password comes from the environment and is never printed; without a pinned
// certificate an OmniCore is refused, its fingerprint named.
TEST(InstrumentCommand, ProbeNamesEachNetworkControllerOfTheServedLab) {
  struct Case {
    std::string robot, model_file;
  };
  for (const Case& c : {Case{"ur10", "models/ur10.yaml"}, Case{"kuka", "models/kr16_2.yaml"},
                       Case{"abb", "models/irb4600.yaml"}}) {
    SCOPED_TRACE(c.robot);
    TempDir dir;
    ServedLab served(dir, "lab", {"--robot", c.robot, "--seed", "7"});
    ASSERT_TRUE(served.ready()) << served.errors();
    const std::string lab = served.folder();
    const auto truth =
        simulation::MakeVirtualRobot(c.robot, io::LoadRobotModel(SourcePath(c.model_file)), 7)
            .identity;
    const YAML::Node controller = YAML::LoadFile(lab + "/lab.yaml")["robot"]["controller"];
    const std::string host = controller["host"].as<std::string>();
    std::string args = "instrument probe --json --protocol " + c.robot.substr(0, 4) + " --tcp ";
    std::string launcher;
    if (c.robot == "ur10") {
      args = "instrument probe --json --protocol ur --tcp " + host + ":" +
             controller["dashboard_port"].as<std::string>();
      for (const char* key : {"rtde_port", "primary_port", "secondary_port"})
        args += std::string(" --controller-port ") + key + "=" + controller[key].as<std::string>();
    } else if (c.robot == "kuka") {
      args += host + ":" + controller["variable_server_port"].as<std::string>();
    } else {
      args += host + ":" + controller["rws_port"].as<std::string>();
      const YAML::Node login = YAML::LoadFile(lab + "/abb-credentials.yaml");
      const std::string password = login["password"].as<std::string>();
      launcher = "env ARMSIG_CONTROLLER_USER='" + login["user"].as<std::string>() +
                 "' ARMSIG_CONTROLLER_PASSWORD='" + password + "'";
      const auto unpinned = RunArmsigThrough(launcher, args);
      EXPECT_NE(unpinned.exit_code, 0);
      EXPECT_NE(unpinned.err.find("certificate_sha256: " +
                                  controller["certificate_sha256"].as<std::string>()),
                std::string::npos)
          << unpinned.err;
      EXPECT_EQ(unpinned.err.find("(code 0)"), std::string::npos) << unpinned.err;
      args += " --controller-setting certificate_sha256=" +
              controller["certificate_sha256"].as<std::string>();
      const auto probed = RunArmsigThrough(launcher, args);
      EXPECT_EQ(probed.out.find(password), std::string::npos);
      EXPECT_EQ(probed.err.find(password), std::string::npos);
    }
    const auto probe = RunArmsigThrough(launcher, args);
    ASSERT_EQ(probe.exit_code, 0) << probe.err;
    const auto j = nlohmann::json::parse(probe.out);
    EXPECT_EQ(j["vendor"], truth.vendor);
    EXPECT_EQ(j["model"], truth.model);
    EXPECT_EQ(j["serial"], truth.serial);
    if (c.robot == "ur10") EXPECT_FALSE(j["kinematics_checksum"].get<std::string>().empty());
    served.Stop();
    EXPECT_FALSE(std::filesystem::exists(dir.File("unused.db")));
  }
}

TEST(InstrumentCommand, MissingPortAndUnknownProtocol) {
  EXPECT_EQ(RunArmsig("instrument read --protocol geocom").exit_code, 2);
  EXPECT_EQ(RunArmsig("instrument read --port /dev/null --protocol morse").exit_code, 2);
  const auto gone = RunArmsig("instrument probe --port /nonexistent/tty --timeout-ms 100");
  EXPECT_EQ(gone.exit_code, 1);
  EXPECT_NE(gone.err.find("/nonexistent/tty"), std::string::npos);
}

TEST(ImportGsi, RealGsi16FileToObservations) {
  TempDir dir;
  const auto r = RunArmsig("import gsi '" + DataPath("gsi/tos-leica_gsi16_gurob.gsi") +
                           "' --station S7 --out '" + dir.File("obs.csv") + "'");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto t = io::ReadCsvFile(dir.File("obs.csv"));
  ASSERT_FALSE(t.rows().empty());
  const auto& first = t.rows()[0];
  EXPECT_EQ(t.Text(first, t.Column("point")), "GDEM5415");
  EXPECT_EQ(t.Text(first, t.Column("station")), "S7");
  // 35°45′10.0″ and 91°17′51.0″ in gon; 13.825 m.
  EXPECT_NEAR(t.Number(first, t.Column("hz_gon")), (35 + 45 / 60.0 + 10 / 3600.0) / 0.9, 1e-8);
  EXPECT_NEAR(t.Number(first, t.Column("v_gon")), (91 + 17 / 60.0 + 51 / 3600.0) / 0.9, 1e-8);
  EXPECT_NEAR(t.Number(first, t.Column("distance_mm")), 13825.0, 1e-6);
}

TEST(ImportGsi, MalformedWordNamesLineAndColumnAndWritesNothing) {
  TempDir dir;
  WriteText(dir.File("bad.gsi"),
            "110001+00000001 21.322+03496940 22.322+09364360\r\n"
            "110002+00000002 21.322+0217933X 22.322+09442590\r\n");
  const auto r = RunArmsig("import gsi '" + dir.File("bad.gsi") + "' --station S1 --out '" +
                           dir.File("o.csv") + "'");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("bad.gsi:2:17 (WI21)"), std::string::npos) << r.err;
  EXPECT_FALSE(std::filesystem::exists(dir.File("o.csv")));
}

TEST(ImportGsi, LevellingFileHasNoAnglesAndIsRefused) {
  TempDir dir;
  const auto r = RunArmsig("import gsi '" + DataPath("gsi/geocompy-dna_data.gsi") +
                           "' --station S1 --out '" + dir.File("o.csv") + "'");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("no block with both Hz"), std::string::npos);
}

}  // namespace armsig::testing
