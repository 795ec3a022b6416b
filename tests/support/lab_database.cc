#include "support/lab_database.h"

#include <fmt/format.h>
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <random>
#include <stdexcept>

#include "calibration/synthetic.h"
#include "core/units.h"
#include "db/database.h"
#include "support/simulated_sessions.h"
#include "test_support.h"

namespace armsig::testing {

namespace {

void Run(const std::string& args) {
  const auto r = RunArmsig(args);
  if (r.exit_code != 0) {
    throw std::runtime_error(fmt::format("making the lab database: armsig {} exited {}:\n{}{}",
                                         args, r.exit_code, r.out, r.err));
  }
}

// Two stations and four points read exactly: S1 levelled at the origin (azimuth 0), S2 not
// levelled (its rotation given, the identity) 3 m along x; the instrument frame's unit
// vector of a reading is (sin V sin Hz, sin V cos Hz, cos V).
void WriteObservedSession(const std::string& stations_yaml, const std::string& observations_csv) {
  WriteText(stations_yaml,
            "stations:\n"
            "  - {id: S1, position_mm: [0, 0, 0], azimuth_gon: 0}\n"
            "  - {id: S2, position_mm: [3000, 0, 0],\n"
            "     rotation: [[1, 0, 0], [0, 1, 0], [0, 0, 1]]}\n");
  const Eigen::Vector3d stations[] = {{0, 0, 0}, {3000, 0, 0}};
  const Eigen::Vector3d points[] = {
      {1000, 2000, 300}, {2000, 2500, -200}, {1500, 1800, 600}, {500, 2200, 100}};
  std::string csv = "point,station,hz_gon,v_gon\n";
  for (int p = 0; p < 4; ++p) {
    for (int s = 0; s < 2; ++s) {
      const Eigen::Vector3d d = points[p] - stations[s];
      double hz = std::atan2(d.x(), d.y());
      if (hz < 0) hz += 2 * kPi;
      const double v = std::acos(d.z() / d.norm());
      csv += fmt::format("P{},S{},{:.8f},{:.8f}\n", p + 1, s + 1, hz / kRadPerGon, v / kRadPerGon);
    }
  }
  WriteText(observations_csv, csv);
}

// The folder of the lab database, made at the first call and removed when the program ends.
const std::string& Made() {
  static const std::string folder = [] {
    std::random_device rd;
    const auto dir = std::filesystem::temp_directory_path() /
                     fmt::format("armsig-lab-database-{}-{}", ::getpid(), rd());
    std::filesystem::create_directories(dir);
    static const std::string removed = dir.string();
    std::atexit([] { std::filesystem::remove_all(removed); });
    const std::string db_path = (dir / "lab.db").string();
    const std::string db = "--db " + Quoted(db_path) + " ";
    const Eigen::VectorXd truth = calibration::PaperTable3Parameters();
    {
      db::Database database(db_path);
      AddSession(database, truth, 80, 11);
    }
    Run(db + "recalibrate --robot puma");
    {
      db::Database database(db_path, db::OpenMode::kMustExist);
      AddSession(database, truth, 80, 12);
    }
    Run(db + "recalibrate --robot puma");  // version 2, with its drift decision against 1
    WriteObservedSession((dir / "stations.yaml").string(), (dir / "observations.csv").string());
    Run(db + "import observations " + Quoted((dir / "observations.csv").string()) + " --stations " +
        Quoted((dir / "stations.yaml").string()) + " --robot puma --note observed");
    Run(db + "reduce --session 3");  // the simulated sessions have points but no observations
    Run(db + "schedule recalibrate --robot puma");
    Run(db + "worker --once");  // the job finds version 2 up to date: a result stored
    Run(db + "session export 1 --poses " + Quoted((dir / "poses.csv").string()));
    // Joints (and targets with the nominal program's joints) from the exported poses.
    std::string joints = "pose,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg\n";
    std::string targets = "point,x_mm,y_mm,z_mm,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg\n";
    const std::string poses = ReadText((dir / "poses.csv").string());
    size_t line_start = poses.find('\n') + 1;
    for (int row = 0; row < 5 && line_start < poses.size(); ++row) {
      const size_t end = poses.find('\n', line_start);
      const std::string line = poses.substr(line_start, end - line_start);
      std::vector<std::string> f;
      for (size_t a = 0;;) {
        const size_t b = line.find(',', a);
        f.push_back(line.substr(a, b == std::string::npos ? b : b - a));
        if (b == std::string::npos) break;
        a = b + 1;
      }
      joints += fmt::format("{},{},{},{},{},{},{}\n", f[0], f[1], f[2], f[3], f[4], f[5], f[6]);
      targets += fmt::format("{},{},{},{},{},{},{},{},{},{}\n", f[0], f[7], f[8], f[9], f[1], f[2],
                             f[3], f[4], f[5], f[6]);
      line_start = end + 1;
    }
    WriteText((dir / "joints.csv").string(), joints);
    WriteText((dir / "targets.csv").string(), targets);
    return dir.string();
  }();
  return folder;
}

}  // namespace

LabDatabase CopyLabDatabase(const std::string& folder) {
  const std::filesystem::path from(Made()), to(folder);
  LabDatabase lab;
  for (const char* file :
       {"lab.db", "joints.csv", "targets.csv", "poses.csv", "stations.yaml", "observations.csv"}) {
    std::filesystem::copy_file(from / file, to / file,
                               std::filesystem::copy_options::overwrite_existing);
  }
  lab.path = (to / "lab.db").string();
  lab.joints_csv = (to / "joints.csv").string();
  lab.targets_csv = (to / "targets.csv").string();
  lab.poses_csv = (to / "poses.csv").string();
  lab.stations_yaml = (to / "stations.yaml").string();
  lab.observations_csv = (to / "observations.csv").string();
  lab.model_yaml = SourcePath("models/puma760.yaml");
  lab.simulated_session = 1;
  lab.observed_session = 3;
  return lab;
}

}  // namespace armsig::testing
