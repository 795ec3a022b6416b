// The demo's virtual lab (demo/demo_robots.h names its robots): a PUMA 760 whose hidden
// truth is the paper's Table 3 with its Kawasaki-AS-style controller on a pseudo-terminal, or
// a UR10, a KUKA KR 16-2 or an ABB IRB 4600 with hidden geometric and joint-angle errors
// (simulation/virtual_robots.h) and its virtual controller on loopback TCP
// (simulation/ur_simulator.h, simulation/kuka_simulator.h, simulation/rws_simulator.h), plus any planted change;
// and either three GeoCOM theodolites on pseudo-terminals, oriented from mutual pointings
// and a 1 m scale bar read through the real drivers, or one laser tracker speaking emScon on
// loopback TCP, whose own frame is the lab frame. Its devices run while the object lives;
// the lab file, stations file and model a technician would write go into its folder.
#pragma once

#include <Eigen/Geometry>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "acquisition/lab.h"
#include "calibration/model.h"
#include "reduction/orientation.h"
#include "simulation/emscon_simulator.h"
#include "simulation/rws_simulator.h"
#include "simulation/kuka_simulator.h"
#include "simulation/simulator.h"
#include "simulation/ur_simulator.h"
#include "simulation/val_simulator.h"
#include "simulation/virtual_lab.h"
#include "simulation/virtual_robots.h"
#include "demo/demo_robots.h"

namespace armsig::demo {

struct DemoLabOptions {
  std::string robot = "puma";  // DemoRobots()
  bool tracker = false;        // one laser tracker instead of three theodolites
  unsigned seed = 1985;      // the instruments' noise
  double time_scale = 0.25;  // multiplies every simulated instrument latency
  double repeatability_mm = 0.0;
  int setup = 0;  // the tracker set up anew at its N-th place (DemoOptions::setup)
  Eigen::VectorXd planted;       // added to the paper's Table 3 (empty: nothing planted)
  std::filesystem::path folder;  // the devices' links and the lab files
  // Measuring on the move: the tracker measures continuously, following the arm on its own
  // clock, which runs this far off the controller's (as no two clocks of a cell agree).
  bool on_the_move = false;
  double tracker_clock_offset_s = 0.0;
  double tracker_clock_drift_ppm = 0.0;
};

// The theodolites' set-up as adjusted (reduction::Orient) from their readings.
struct DemoOrientation {
  reduction::OrientationProblem setup;
  reduction::OrientationResult result;
};

class DemoLab {
 public:
  // Builds the truth and starts every device (the robot's controller last). `model` is the
  // robot's nominal model (its DemoRobot's file).
  DemoLab(const calibration::RobotModel& model, const DemoLabOptions& options);
  DemoLab(const DemoLab&) = delete;
  DemoLab& operator=(const DemoLab&) = delete;

  // Theodolites only: each aims at the other two and at both ends of a 1 m scale bar set up
  // at three places, read through its GeoCOM driver; the readings adjusted with the bar's
  // length as the scale. Throws std::runtime_error when the adjustment fails.
  DemoOrientation OrientTheodolites();

  // The robot's model file (puma760.yaml, ur10.yaml), stations.yaml (from `stations`) and
  // lab.yaml in the folder, the lab file naming these devices; `base_by_hand`: a tracker lab's `robot: base:` as a technician
  // would measure it, 3 mm and 1 mrad off the truth. Returns the lab file as loaded.
  io::LabConfig WriteLabFiles(const std::vector<reduction::Station>& stations, bool base_by_hand);

  // The one station of a tracker lab (LT1 at the origin, levelled, azimuth 0).
  std::vector<reduction::Station> TrackerStations() const;

  bool has_tracker() const { return tracker_ != nullptr; }
  simulation::EmsconSimulator* tracker() const { return tracker_; }
  // Where the devices are: the tracker's address, or the folder of the pseudo-terminals.
  std::string tracker_address() const { return tracker_ ? tracker_->path() : std::string(); }
  const std::filesystem::path& folder() const { return options_.folder; }
  simulation::VirtualLab& truth() { return lab_; }
  const DemoRobot& robot() const { return robot_; }
  // Where the arm stands when the lab starts (joints, rad).
  const simulation::VirtualRobot& robot_truth() const { return truth_; }
  Eigen::VectorXd home() const {
    return truth_.home_rad.size() ? truth_.home_rad
                                  : Eigen::VectorXd(Eigen::VectorXd::Zero(truth_.model.num_joints()));
  }
  // The virtual UR's controller (ur10), nullptr for the others.
  simulation::UrSimulator* ur() const { return ur_.get(); }
  // The virtual ABB controller (abb), nullptr for the others.
  simulation::RwsSimulator* abb() const { return abb_.get(); }
  // The ABB lab's credentials file, beside the lab file.
  static constexpr const char* kAbbCredentials = "abb-credentials.yaml";
  // The virtual KUKA controller (kuka), nullptr for the others.
  simulation::KukaSimulator* kuka() const { return kuka_.get(); }
  // Where the controller listens, for the narrative: its pseudo-terminal or HOST and ports.
  std::string controller_address() const;

 private:
  void AddTracker();
  void AddTheodolites();
  void StartController();
  void StartAbb();

  DemoLabOptions options_;
  const DemoRobot& robot_;
  simulation::VirtualRobot truth_;  // the robot's hidden errors and its controller's identity
  Eigen::Isometry3d base_ = Eigen::Isometry3d::Identity();  // the robot's base in the lab frame
  simulation::VirtualLab lab_;
  simulation::SimulatorOptions simulator_options_;
  std::vector<std::unique_ptr<simulation::Simulator>> simulators_;  // theodolites or tracker
  simulation::EmsconSimulator* tracker_ = nullptr;                  // in `simulators_`
  std::unique_ptr<simulation::ValSimulator> controller_;  // puma
  std::unique_ptr<simulation::UrSimulator> ur_;           // ur10
  std::unique_ptr<simulation::RwsSimulator> abb_;         // abb
  std::unique_ptr<simulation::KukaSimulator> kuka_;       // kuka
  io::LabFile lab_file_;
};

}  // namespace armsig::demo
