// Virtual instruments on pseudo-terminals, speaking the real protocols with realistic
// latency and noise, and fault injection: noise bytes, dropped or truncated replies,
// wrong transaction ids, bad CRC, busy / error / warning return codes, a port that
// disappears and comes back. Each simulator runs its own Boost.Asio loop on the pty
// master; drivers open the slave by path like any serial port.
#pragma once

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
#include <string>
#include <thread>

#include "instruments/robot_codec.h"
#include "simulation/virtual_lab.h"
#include "simulation/virtual_port.h"

namespace armsig::simulation {

enum class Fault {
  kNone,
  kNoiseBytes,     // garbage bytes (and a garbage line) before the reply
  kDropReply,      // no reply at all
  kTruncateReply,  // the reply cut in half (and no terminator)
  kWrongTrid,      // GeoCOM: the reply carries another transaction id
  kBadCrc,         // GeoCOM: the reply's CRC is wrong
  kBusy,           // GeoCOM 13 SYSBUSY / GSI @W, once
  kErrorCode,      // the given code (GeoCOM rc, GSI @E, VAL error message)
  kWarningCode,    // GeoCOM: the given warning code with valid data (1283/1284/1285)
};

struct FaultSpec {
  Fault fault = Fault::kNone;
  int code = 0;
};

struct SimulatorOptions {
  double time_scale = 1.0;  // multiplies every latency (0.1 = ten times faster)
  std::chrono::milliseconds angle_latency{40};
  std::chrono::milliseconds distance_latency{150};
  std::chrono::milliseconds motion_latency{800};
};

class LineSimulator {
 public:
  LineSimulator(std::string link_path, SimulatorOptions options);
  virtual ~LineSimulator();
  LineSimulator(const LineSimulator&) = delete;
  LineSimulator& operator=(const LineSimulator&) = delete;

  void Start();
  void Stop();
  const std::string& path() const { return port_.path(); }
  void InjectOnce(FaultSpec fault);  // applies to the next request
  void Disappear();                  // the port vanishes (thread-safe)
  void Reappear();
  int requests() const { return requests_.load(); }

 protected:
  struct Response {
    std::string bytes;
    std::chrono::milliseconds latency{0};
  };
  // Handles one request line; nullopt = silence.
  virtual std::optional<Response> Handle(const std::string& line, const FaultSpec& fault) = 0;
  std::chrono::milliseconds Scaled(std::chrono::milliseconds latency) const;
  SimulatorOptions options_;

 private:
  void StartRead();
  void OnLine(const std::string& line);
  void Send(std::string bytes, std::chrono::milliseconds latency);

  VirtualPort port_;
  boost::asio::io_context io_;
  std::unique_ptr<boost::asio::posix::stream_descriptor> descriptor_;
  std::thread thread_;
  std::string buffer_;
  char chunk_[512];
  std::mutex fault_mutex_;
  std::deque<FaultSpec> faults_;
  std::atomic<int> requests_{0};
  bool present_ = true;
  std::optional<boost::asio::executor_work_guard<boost::asio::io_context::executor_type>> work_;
};

// Leica GeoCOM total station / theodolite attached to one station of the lab.
class GeoComSimulator : public LineSimulator {
 public:
  GeoComSimulator(VirtualLab& lab, int station, std::string link_path,
                  SimulatorOptions options = {}, std::string instrument_name = "TDRA6000",
                  long serial = 358123);

 protected:
  std::optional<Response> Handle(const std::string& line, const FaultSpec& fault) override;

 private:
  VirtualLab& lab_;
  int station_;
  std::string name_;
  long serial_;
  bool distance_ready_ = false;
};

// GSI Online theodolite (GSI-8 words; SET/137/1 switches to GSI-16).
class GsiOnlineSimulator : public LineSimulator {
 public:
  GsiOnlineSimulator(VirtualLab& lab, int station, std::string link_path,
                     SimulatorOptions options = {});

 protected:
  std::optional<Response> Handle(const std::string& line, const FaultSpec& fault) override;

 private:
  VirtualLab& lab_;
  int station_;
  bool gsi16_ = false;
  AngleReading last_{};
  double last_distance_mm_ = 0.0;
};

// VAL II / Kawasaki AS monitor: WHERE and DO JMOVE #[…].
class ValSimulator : public LineSimulator {
 public:
  enum class Layout { kValII, kKawasakiAs };
  ValSimulator(VirtualLab& lab, std::string link_path, Layout layout = Layout::kKawasakiAs,
               SimulatorOptions options = {});

 protected:
  std::optional<Response> Handle(const std::string& line, const FaultSpec& fault) override;

 private:
  VirtualLab& lab_;
  Layout layout_;
};

// One QSB-style counter channel reading one joint's encoder.
class CounterSimulator : public LineSimulator {
 public:
  CounterSimulator(VirtualLab& lab, int joint, instruments::EncoderCalibration calibration,
                   std::string link_path, SimulatorOptions options = {});

 protected:
  std::optional<Response> Handle(const std::string& line, const FaultSpec& fault) override;

 private:
  VirtualLab& lab_;
  int joint_;
  instruments::EncoderCalibration calibration_;
};

}  // namespace armsig::simulation
