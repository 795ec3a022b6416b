// Reading three instruments costs the slowest one's latency, not their sum:
// three virtual GeoCOM theodolites on pseudo-terminals with 60, 90 and 120 ms latency,
// read one after another and all at once. Faults on the line: the time from
// a driver call to its typed error for every case of simulation::FaultMatrix() at a
// 1000 ms deadline (the README's table). Laser trackers: the software overhead
// of one tracker reading, StartMeasurement to the parsed and checked Reading, with the
// virtual tracker answering without latency over loopback TCP (driver, codec, transport,
// kernel and the simulator's own work), and the codec alone. Run by hand:
// build/bench/instruments_bench (--benchmark_filter=Fault for the fault table alone,
// --benchmark_filter=Tracker for the tracker figures).
#include <benchmark/benchmark.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <future>

#include "calibration/synthetic.h"
#include "instruments/emscon_device.h"
#include "instruments/geocom_device.h"
#include "io/model_yaml.h"
#include "reduction/observation.h"
#include "simulation/emscon_simulator.h"
#include "simulation/fault_matrix.h"
#include "simulation/geocom_simulator.h"
#include "simulation/simulator.h"
#include "io/builtin_models.h"

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

// One case of the fault matrix per argument: time per iteration = time to the typed
// error; counters: the worst time over the deadline (1 = on time) and the error's code.
void BM_FaultOnTheLine(benchmark::State& state) {
  const auto cases = simulation::FaultMatrix();
  const auto& c = cases.at(static_cast<size_t>(state.range(0)));
  simulation::VirtualLab lab(io::ParseRobotModel(io::kPuma760Yaml, "PUMA 760"),
                             Eigen::VectorXd::Zero(43), Eigen::Isometry3d::Identity());
  simulation::VirtualStation st;
  st.pose.id = "T1";
  st.pose.position_mm = Eigen::Vector3d(3000, -500, 1200);
  lab.AddStation(st);
  Eigen::VectorXd q(6);
  q << 0.3, -0.4, 0.9, 0.2, -0.5, 0.1;
  lab.SetJoints(q);
  const std::string link = std::filesystem::temp_directory_path() /
                           ("armsig-fault-" + std::to_string(::getpid()));
  instruments::RetryPolicy policy;
  policy.timeout = 1000ms;
  double worst = 0.0;
  int code = 0;
  bool typed = true;
  for (auto _ : state) {
    const auto out = simulation::RunFaultCase(lab, c, link, policy);
    worst = std::max(worst, out.ms);
    code = out.code.value_or(-1);
    typed = typed && out.code && !out.reading &&
            std::find(c.codes.begin(), c.codes.end(), *out.code) != c.codes.end();
  }
  state.SetLabel(c.name() + (typed ? "" : " NOT TYPED AS EXPECTED"));
  state.counters["worst_over_deadline"] = worst / 1000.0;
  state.counters["code"] = code;
}
BENCHMARK(BM_FaultOnTheLine)
    ->DenseRange(0, static_cast<int>(simulation::FaultMatrix().size()) - 1)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->Iterations(3);

// One tracker reading, command to parsed result: the virtual tracker answers at once
// (time_scale 0), so the time is the software's: driver, codec, Asio, loopback TCP and
// the simulator. Target: at most 2 ms added to the instrument's own measuring time.
void BM_TrackerReading(benchmark::State& state) {
  simulation::VirtualLab lab(io::ParseRobotModel(io::kPuma760Yaml, "PUMA 760"),
                             Eigen::VectorXd::Zero(43), Eigen::Isometry3d::Identity());
  simulation::VirtualStation st;
  st.pose.id = "LT1";
  st.pose.position_mm = Eigen::Vector3d(3000, -500, 1200);
  lab.AddStation(st);
  simulation::EmsconSimulatorOptions options;
  options.time_scale = 0.0;
  options.initialized = true;
  simulation::EmsconSimulator tracker(lab, 0, "127.0.0.1", 0, options);
  tracker.Start();
  instruments::EmsconDevice device(
      instruments::MakeEmsconTcpTransport("127.0.0.1", tracker.port()));
  device.Connect();
  for (auto _ : state) benchmark::DoNotOptimize(device.Measure());
  state.counters["status_packets"] = device.statistics().status_changes;
}
BENCHMARK(BM_TrackerReading)->Unit(benchmark::kMicrosecond)->UseRealTime()->MinTime(2.0);

// The codec's share: encode StartMeasurement, split and decode a reply, a status change
// and a 156-byte result arriving in one read.
void BM_TrackerCodec(benchmark::State& state) {
  namespace es = instruments::emscon;
  es::MeasResult m;
  m.value = {1.25, 1.5, 4000.0};
  const std::string answer =
      es::EncodePacket(es::CommandAnswer{es::StartMeasurement::kCommand, 0, {}}) +
      es::EncodePacket(es::StatusChange{27}) + es::EncodePacket(m);
  es::FrameSplitter splitter;
  std::string frame;
  for (auto _ : state) {
    benchmark::DoNotOptimize(es::EncodeRequest(es::StartMeasurement{}));
    splitter.Append(answer);
    while (splitter.Next(frame) == es::FrameSplitter::Status::kFrame) {
      benchmark::DoNotOptimize(es::DecodePacket(frame));
    }
  }
}
BENCHMARK(BM_TrackerCodec)->Unit(benchmark::kNanosecond);

}  // namespace
}  // namespace armsig

BENCHMARK_MAIN();
