// Reading three instruments costs the slowest one's latency, not their sum (issue #5):
// three virtual GeoCOM theodolites on pseudo-terminals with 60, 90 and 120 ms latency,
// read one after another and all at once. Run by hand: build/bench/instruments_bench
#include <benchmark/benchmark.h>
#include <unistd.h>

#include <filesystem>
#include <future>

#include "calibration/simulation.h"
#include "instruments/geocom_device.h"
#include "reduction/observation.h"
#include "simulation/simulators.h"

namespace armsig {
namespace {

using namespace std::chrono_literals;

struct ThreeStations {
  simulation::VirtualLab lab{calibration::RobotModel{}, Eigen::VectorXd::Zero(3),
                             Eigen::Isometry3d::Identity()};
  std::vector<std::unique_ptr<simulation::GeoComSimulator>> sims;
  std::vector<std::unique_ptr<instruments::GeoComDevice>> devices;
  ThreeStations() {
    const std::string dir =
        std::filesystem::temp_directory_path() / ("armsig-bench-" + std::to_string(::getpid()));
    std::filesystem::create_directories(dir);
    lab.AddPoint("P", Eigen::Vector3d(0, 0, 1000));
    const int latency[3] = {60, 90, 120};
    for (int s = 0; s < 3; ++s) {
      simulation::VirtualStation st;
      st.pose.id = "T" + std::to_string(s + 1);
      st.pose.position_mm =
          Eigen::Vector3d(3000 * std::cos(2.1 * s), 3000 * std::sin(2.1 * s), 1400);
      lab.AddStation(st);
      lab.Aim(s, "P");
      simulation::SimulatorOptions options;
      options.angle_latency = std::chrono::milliseconds(latency[s]);
      sims.push_back(std::make_unique<simulation::GeoComSimulator>(
          lab, s, dir + "/t" + std::to_string(s), options));
      sims.back()->Start();
      instruments::SerialSettings port;
      port.path = sims.back()->path();
      devices.push_back(
          std::make_unique<instruments::GeoComDevice>(instruments::MakeSerialTransport(port)));
      devices.back()->Face();  // open and wake up
    }
  }
};

void BM_ReadThreeSequentially(benchmark::State& state) {
  ThreeStations lab;
  for (auto _ : state) {
    for (auto& d : lab.devices) benchmark::DoNotOptimize(d->MeasureAngles());
  }
}
BENCHMARK(BM_ReadThreeSequentially)->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(10);

void BM_ReadThreeConcurrently(benchmark::State& state) {
  ThreeStations lab;
  for (auto _ : state) {
    std::vector<std::future<instruments::Reading>> readings;
    for (auto& d : lab.devices)
      readings.push_back(std::async(std::launch::async, [&d] { return d->MeasureAngles(); }));
    for (auto& r : readings) benchmark::DoNotOptimize(r.get());
  }
}
BENCHMARK(BM_ReadThreeConcurrently)->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(10);

}  // namespace
}  // namespace armsig

BENCHMARK_MAIN();
