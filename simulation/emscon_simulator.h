// A virtual Leica laser tracker behind an emScon server: the TPI binary protocol over TCP
// (a Boost.Asio acceptor on its own thread), answering through the same codec as the
// driver (instruments/emscon_codec.h). It measures the true position of what its station
// of the VirtualLab is aimed at, with the noise model below, in the units, coordinate
// system type (RHR Cartesian, SCC, SCW: SphericalConvention), measurement mode and system
// settings the client set. It starts in a state
// that is deliberately not armsig's (metres, gon, °F, mmHg, Cartesian, continuous mode, a
// user transformation applied, not initialised), so a driver that assumes any of it
// measures wrong or not at all.
//
// Noise model (MPE class of an AT401-like tracker): the maximum permissible error of a
// point is MPE(d) = 15 µm + 6 µm/m · d; one standard deviation is half of it, isotropic:
// σ(d) = MPE(d) / 2 on each of x, y, z (d the distance from the tracker). The result
// reports it per component in spherical form: σ_Hz = σ / (d sin V), σ_V = σ / d, σ_d = σ.
//
// The weather drifts slowly: T = 20 °C + 0.3 °C sin(2πt/1 h) + 0.1 °C/h · t,
// p = 1013.25 hPa + 0.8 hPa sin(2πt/2 h + 1), RH = 45 % + 2 % sin(2πt/1.5 h + 2), t the time
// since start (times environment_time_scale).
//
// Faults (FaultSpec, once or on every request): silence, partial (half the first packet),
// noise (garbage before the reply), flood-bytes / endless-line (binary or printable bytes
// without pause), flood-lines (status-change and reflector-position packets without
// pause, never the reply), busy (ES_RS_ServerBusy), error (an ErrorResponse with the given
// status), wrong-command-id, vanish (the server closes the connection), out-of-range (a
// negative zenith angle), beam-break, reflector-not-found, status-between, status-inside.
#pragma once

#include <Eigen/Core>
#include <atomic>
// clang-format off
#include <utility>  // first: Boost 1.74 Asio uses std::exchange without including it (C++20)
#include <boost/asio.hpp>
// clang-format on
#include <chrono>
#include <deque>
#include <memory>
#include <mutex>
#include <optional>
#include <random>
#include <string>
#include <thread>

#include "instruments/emscon_codec.h"
#include "simulation/simulator.h"
#include "simulation/tcp_peer.h"
#include "simulation/virtual_arm.h"
#include "simulation/virtual_lab.h"

namespace armsig::simulation {

// How the virtual tracker writes (and, for GoPosition, reads) spherical values. kPublic:
// SCC as public emScon clients read it (instruments/emscon_codec.h PointFromScc: Hz =
// atan2(y, x) counter-clockwise from +x, V the zenith angle, d). The others are a tracker
// whose SCC follows another convention, for the driver's self-check: Hz clockwise from +y
// (armsig's theodolite circle), or V an elevation above the horizon. SCW, which no public
// source fixes, is written as Hz clockwise from +x (the mirror of SCC), V the zenith angle.
enum class SphericalConvention { kPublic, kClockwiseFromY, kElevation };

struct EmsconSimulatorOptions {
  SphericalConvention scc_convention = SphericalConvention::kPublic;
  double time_scale = 1.0;  // multiplies every latency (0 = answer at once)
  std::chrono::milliseconds command_latency{2};
  std::chrono::milliseconds motion_latency{100};      // GoPosition, ChangeFace, FindReflector
  std::chrono::milliseconds initialize_latency{300};  // Initialize
  // A stationary measurement takes the measurement time the client set (times time_scale).
  double mpe_constant_mm = 0.015;
  double mpe_per_metre_mm = 0.006;
  double environment_time_scale = 1.0;  // seconds of weather per second
  bool initialized = false;             // the tracker processor's state at start
  unsigned seed = 7;
  // Where the beam points. 0: the tracker always finds its reflector (it follows it).
  // Otherwise a measurement finds the reflector only when the beam passes within this
  // distance of it (at the reflector), and answers MeasurementStatusNotReady otherwise. The
  // beam points along the last GoPosition, the last reflector it measured or found, or,
  // at start, horizontally towards circle zero (+y).
  double acquire_radius_mm = 0.0;
  // FindReflector searches this far around the beam (at the reflector) and locks on it.
  double search_radius_mm = 150.0;
  // Continuous modes (an AT9xx behind emScon; an AT4xx measures stationary only): time-
  // triggered (SetContinuousTimeModeParams) or distance-triggered, the records in
  // MultiMeasResult packets stamped with the tracker's own clock, which runs
  // `clock_offset_s` + (1 + `clock_drift_ppm`·10⁻⁶) · t on the arm's physical time t (the
  // two clocks of a real cell never agree: armsig must estimate this from the data).
  bool continuous_modes = false;
  double clock_offset_s = 0.0;
  double clock_drift_ppm = 0.0;
};

// σ of each Cartesian component at `distance_mm` of a tracker with these options: half the
// MPE (the noise model above). The virtual cells that check programs measure with it too.
double TrackerSigmaMm(const EmsconSimulatorOptions& options, double distance_mm);

class EmsconSimulator : public Simulator {
 public:
  // Listens on `host`:`port` (port 0: any free port; path() names the one taken).
  EmsconSimulator(VirtualLab& lab, int station, std::string host = "127.0.0.1",
                  unsigned short port = 0, EmsconSimulatorOptions options = {});
  ~EmsconSimulator() override;
  EmsconSimulator(const EmsconSimulator&) = delete;
  EmsconSimulator& operator=(const EmsconSimulator&) = delete;

  void Start() override;  // throws std::runtime_error when the address cannot be bound
  void Stop() override;
  const std::string& path() const override { return address_; }
  unsigned short port() const { return port_; }
  void InjectOnce(FaultSpec fault) override;
  void InjectAlways(FaultSpec fault) override;
  void ClearFaults() override;
  int requests() const override { return requests_.load(); }
  int64_t flood_bytes() const override { return flood_bytes_.load(); }
  int connections() const { return connections_.load(); }

  // σ of each Cartesian component at `distance_mm` (the noise model above).
  double SigmaMm(double distance_mm) const;

  // The tracker's state as the client left it (a snapshot, thread-safe).
  struct State {
    instruments::emscon::Units units;
    int32_t coordinate_system = 0;
    int32_t meas_mode = 0;
    int32_t meas_time_ms = 0;
    bool use_adm = false;
    int32_t reflector = 0;
    bool initialized = false;
    instruments::emscon::SystemSettings settings;
    int face = 1;
    std::optional<Eigen::Vector3d> go_position_mm;  // the last GoPosition, tracker frame
    int measurements = 0;
    Eigen::Vector3d beam = Eigen::Vector3d::UnitY();  // unit direction, tracker frame
    int go_positions = 0, searches = 0, found = 0, not_found = 0, guided = 0;
  };
  State state() const;
  // The true point the tracker would measure now, in its own frame (mm).
  Eigen::Vector3d TruePointInTracker() const;
  // The operator points the beam at the reflector (a real tracker: its camera, or the
  // head turned by hand): the next measurement finds it.
  void GuideBeamToReflector();
  // The next `count` measurements are poor (turbulent air, a dirty reflector): their noise
  // is `noise_factor` times the model's; the sigma they state is `stated_factor` times it
  // (1: the tracker does not notice).
  void DegradeNextMeasurements(int count, double noise_factor, double stated_factor);
  // How far the beam passes from the reflector now, mm (at the reflector's distance).
  double BeamMissMm() const;
  // Measure the arm as it moves: continuous records sample the arm's joints at their own
  // instant (VirtualArm::At) instead of the lab's robot as last set, on the arm's physical
  // clock. Without it the tracker's physical time is the wall time since start.
  void FollowArm(const VirtualArm* arm);
  // The beam breaks (someone walks through it) over the arm's physical time [from_s, to_s):
  // no records then; the tracker pushes ES_RS_NoDistanceSet when it breaks and
  // MeasStatus_Ready when it relocks.
  void BreakBeam(double from_s, double to_s);
  // Continuous records sent so far, and those a beam break left out.
  int continuous_records() const { return continuous_records_.load(); }
  int records_lost_to_breaks() const { return records_broken_.load(); }
  // The tracker's clock at physical time t.
  double TrackerTime(double physical_s) const;

  // The weather at `seconds` after start (°C, hPa, %RH).
  static instruments::emscon::EnvironmentParams WeatherAt(double seconds);

  // The shift the simulated user transformation applies while bApplyTransformationParams
  // is set (a driver that leaves it on measures in the wrong frame).
  static constexpr double kUserTransformationShiftMm = 100.0;

 private:
  struct Connection;
  using Step = TcpPeer::Step;
  void StartAccept();
  void StartRead(std::shared_ptr<Connection> c);
  void OnFrame(const std::shared_ptr<Connection>& c, const std::string& frame);
  void Flood(std::shared_ptr<Connection> c, bool packets, bool printable, int64_t k,
             uint64_t generation);
  void FloodChunk(std::shared_ptr<Connection> c, std::shared_ptr<std::string> data, size_t offset,
                  bool packets, bool printable, int64_t k, uint64_t generation);
  // The packets answering `request` (before faults), and the latency of the first.
  std::vector<Step> Answer(const instruments::emscon::Request& request, const FaultSpec& fault);
  // What the table answers a request: the reply, its latency, whether a measurement follows,
  // the status changes to send once the reply is out, the packets before the reply.
  struct TableAnswer {
    instruments::emscon::CommandAnswer answer;
    std::chrono::milliseconds latency;
    bool measured = false;
    std::vector<std::string> after;
    std::vector<Step> before;
  };
  TableAnswer FromTable(const instruments::emscon::Request& request, int32_t id,
                        std::chrono::milliseconds latency, const FaultSpec& fault);
  void MeasurementSteps(instruments::emscon::CommandAnswer answer, const FaultSpec& fault,
                        bool wrong_id, std::vector<Step>& steps, std::vector<std::string>& after);
  static std::vector<Step> InterleaveStatus(std::vector<Step> steps);
  instruments::emscon::MeasResult MeasureNow(bool out_of_range);
  void PointBeam(const instruments::emscon::GoPosition& request);
  bool SearchReflector(const FaultSpec& fault);
  void ContinuousCommand(const instruments::emscon::Request& request,
                         instruments::emscon::CommandAnswer& answer, std::vector<std::string>& after);
  // Continuous measurement: the stream's next records up to now, sent each tick.
  void StartStream(const std::shared_ptr<Connection>& c);
  void StreamTick(std::shared_ptr<Connection> c, uint64_t generation);
  double PhysicalNow() const;
  Eigen::Vector3d TrackerPointAt(double physical_s) const;  // the true point then
  instruments::emscon::MeasRecord RecordAt(double physical_s);
  double Seconds() const;
  std::chrono::milliseconds Scaled(std::chrono::milliseconds latency) const;

  VirtualLab& lab_;
  int station_;
  std::string host_;
  unsigned short port_;
  std::string address_;
  EmsconSimulatorOptions options_;
  boost::asio::io_context io_;
  std::unique_ptr<boost::asio::ip::tcp::acceptor> acceptor_;
  std::shared_ptr<Connection> connection_;  // the one client (an AT4xx takes only one)
  std::thread thread_;
  std::optional<boost::asio::executor_work_guard<boost::asio::io_context::executor_type>> work_;
  std::chrono::steady_clock::time_point start_;

  mutable std::mutex mutex_;  // faults and state
  FaultQueue faults_;
  State state_;
  int degraded_ = 0;
  double noise_factor_ = 1.0, stated_factor_ = 1.0;
  std::mt19937 rng_;

  const VirtualArm* arm_ = nullptr;
  std::optional<std::pair<double, double>> beam_break_;  // physical [from, to)
  int32_t continuous_time_ms_ = 10;
  double continuous_distance_mm_ = 0.0;  // > 0: distance-triggered
  // The stream (io thread): the next sample's physical time, the last point sent (distance
  // mode), whether the beam is broken now.
  double next_sample_s_ = 0.0;
  std::optional<Eigen::Vector3d> last_streamed_;
  bool broken_now_ = false;
  bool start_stream_ = false;  // StartMeasurement in a continuous mode was accepted
  std::optional<boost::asio::steady_timer> stream_timer_;
  std::atomic<uint64_t> stream_generation_{0};
  std::atomic<int> continuous_records_{0}, records_broken_{0};

  std::atomic<int> requests_{0}, connections_{0};
  std::atomic<int64_t> flood_bytes_{0};
  std::atomic<uint64_t> flood_generation_{0};
};

}  // namespace armsig::simulation
