// Virtual instruments on pseudo-terminals, speaking the real protocols with realistic
// latency and noise, and fault injection: noise bytes, dropped or truncated replies,
// wrong transaction ids, bad or missing CRC, busy / error / warning return codes, a port
// that disappears and comes back, floods (bytes, an endless line, unrelated lines, all
// without pause), another command's reply, readings out of range or in wrong units.
// A fault applies to the next request (InjectOnce) or to every request (InjectAlways).
// Each simulator runs its own Boost.Asio loop on the pty master; drivers open the slave
// by path like any serial port.
#pragma once

#include <atomic>
// clang-format off
#include <utility>  // first: Boost 1.74 Asio uses std::exchange without including it (C++20)
#include <boost/asio.hpp>
// clang-format on
#include <chrono>
#include <deque>
#include <functional>
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
  kNoCrc,          // GeoCOM: the reply without its CRC field although the request had one
  kFloodBytes,     // instead of the reply: binary garbage (CR and LF among it), without pause
  kEndlessLine,    // instead of the reply: printable bytes without pause, never a line end
  kFloodLines,     // instead of the reply: lines of the protocol, none of them the reply
                   // asked for (GeoCOM other transaction ids, GSI other words, VAL text
                   // rows without a prompt, counter other registers), without pause
  kOtherReply,     // the reply to another command (GeoCOM: same transaction id, another
                   // RPC's values; GSI: another word; VAL: a move's reply to WHERE;
                   // counter: another register)
  kOutOfRange,     // a reading no instrument can give: GeoCOM angles in degrees, GSI a
                   // negative zenith angle, VAL a joint at 1000°, counter a count at 2^31-1
  kWrongUnit,      // GSI: Hz and V words with a length unit
  kVanish,         // the port vanishes as the request arrives (the peer closes the pty)
  kStopShort,      // VAL: a move acknowledged as usual, but the arm stops 2° short on joint 2
                   // (a safety fence, a limit, someone holding the pendant's hold button)
  // Laser tracker (emScon) faults:
  kWrongCommandId,     // every reply echoes another command's id (a measurement: no result)
  kBeamBreak,          // StartMeasurement: accepted, then an error for it (NoDistanceSet)
  kReflectorNotFound,  // StartMeasurement / FindReflector: MeasurementStatusNotReady
  kStatusBetween,      // status changes and an unsolicited error before the reply and between
                       // the reply and the result; the reply's header and body in two writes
  kStatusInside,       // a status-change packet written between the reply's 8 header bytes and
                       // the rest of it (a corrupted stream)
};

struct FaultSpec {
  Fault fault = Fault::kNone;
  int code = 0;
};

// The faults a simulator applies: queued ones to the next requests, then one to every
// request. Thread-safe (the test thread injects, the io thread takes).
class FaultQueue {
 public:
  void Once(FaultSpec fault);
  void Always(FaultSpec fault);
  void Clear();
  FaultSpec Next();  // Fault::kNone when there is none

 private:
  std::mutex mutex_;
  std::deque<FaultSpec> once_;
  std::optional<FaultSpec> always_;
};

struct SimulatorOptions {
  double time_scale = 1.0;  // multiplies every latency (0.1 = ten times faster)
  std::chrono::milliseconds angle_latency{40};
  std::chrono::milliseconds distance_latency{150};
  std::chrono::milliseconds motion_latency{800};
};

// What every virtual instrument offers: start and stop, where a driver finds it, and
// fault injection.
class Simulator {
 public:
  virtual ~Simulator() = default;
  virtual void Start() = 0;
  virtual void Stop() = 0;
  // Where a driver finds it: the pty's path, or HOST:PORT for a TCP simulator.
  virtual const std::string& path() const = 0;
  virtual void InjectOnce(FaultSpec fault) = 0;  // applies to the next request
  virtual void InjectAlways(
      FaultSpec fault) = 0;        // applies to every request (after the queued ones)
  virtual void ClearFaults() = 0;  // and stops a flood
  virtual int requests() const = 0;
  virtual int64_t flood_bytes() const = 0;  // written by floods so far
};

class LineSimulator : public Simulator {
 public:
  LineSimulator(std::string link_path, SimulatorOptions options);
  ~LineSimulator() override;
  LineSimulator(const LineSimulator&) = delete;
  LineSimulator& operator=(const LineSimulator&) = delete;

  void Start() override;
  void Stop() override;
  const std::string& path() const override { return port_.path(); }
  void InjectOnce(FaultSpec fault) override;
  void InjectAlways(FaultSpec fault) override;
  void ClearFaults() override;
  void Disappear();  // the port vanishes (thread-safe)
  void Reappear();
  int requests() const override { return requests_.load(); }
  int64_t flood_bytes() const override { return flood_bytes_.load(); }

 protected:
  struct Response {
    std::string bytes;
    std::chrono::milliseconds latency{0};
  };
  // Handles one request line; nullopt = silence.
  virtual std::optional<Response> Handle(const std::string& line, const FaultSpec& fault) = 0;
  // The k-th line of a kFloodLines flood (with its terminator): the protocol's own kind
  // of line, never the reply to `request`.
  virtual std::string FloodLine(const std::string& request, int64_t k) = 0;
  std::chrono::milliseconds Scaled(std::chrono::milliseconds latency) const;
  SimulatorOptions options_;

 private:
  void StartRead();
  void OnLine(const std::string& line);
  void Send(std::string bytes, std::chrono::milliseconds latency);
  void Vanish();  // on the io thread
  // Writes chunks made by `next` back to back until the fault is cleared or the port
  // goes; one flood at a time.
  void StartFlood(std::function<std::string(int64_t)> next);
  void FloodMore(std::shared_ptr<std::function<std::string(int64_t)>> next, int64_t k,
                 uint64_t generation);
  void FloodChunk(std::shared_ptr<std::function<std::string(int64_t)>> next, int64_t k,
                  uint64_t generation, std::shared_ptr<std::string> data, size_t offset);

  VirtualPort port_;
  boost::asio::io_context io_;
  std::unique_ptr<boost::asio::posix::stream_descriptor> descriptor_;
  std::thread thread_;
  std::string buffer_;
  char chunk_[512];
  FaultQueue faults_;
  std::atomic<int> requests_{0};
  std::atomic<int64_t> flood_bytes_{0};
  std::atomic<uint64_t> flood_generation_{0};  // a cleared flood stops at its next chunk
  bool flooding_ = false;
  bool present_ = true;
  std::optional<boost::asio::executor_work_guard<boost::asio::io_context::executor_type>> work_;
};

// Leica GeoCOM total station / theodolite attached to one station of the lab.
class GeoComSimulator : public LineSimulator {
 public:
  GeoComSimulator(VirtualLab& lab, int station, std::string link_path,
                  SimulatorOptions options = {}, std::string instrument_name = "TDRA6000",
                  long serial = 358123);
  // Stops the io thread before this part of the object goes: it calls Handle and
  // FloodLine.
  ~GeoComSimulator() override { Stop(); }

 protected:
  std::optional<Response> Handle(const std::string& line, const FaultSpec& fault) override;
  std::string FloodLine(const std::string& request, int64_t k) override;

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
  // Stops the io thread before this part of the object goes: it calls Handle and
  // FloodLine.
  ~GsiOnlineSimulator() override { Stop(); }

 protected:
  std::optional<Response> Handle(const std::string& line, const FaultSpec& fault) override;
  std::string FloodLine(const std::string& request, int64_t k) override;

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
  using Layout = instruments::MonitorDialect;
  ValSimulator(VirtualLab& lab, std::string link_path, Layout layout = Layout::kKawasakiAs,
               SimulatorOptions options = {});
  // Stops the io thread before this part of the object goes: it calls Handle and
  // FloodLine.
  ~ValSimulator() override { Stop(); }

 protected:
  std::optional<Response> Handle(const std::string& line, const FaultSpec& fault) override;
  std::string FloodLine(const std::string& request, int64_t k) override;

 private:
  VirtualLab& lab_;
  Layout layout_;
};

// One QSB-style counter channel reading one joint's encoder.
class CounterSimulator : public LineSimulator {
 public:
  CounterSimulator(VirtualLab& lab, int joint, instruments::EncoderCalibration calibration,
                   std::string link_path, SimulatorOptions options = {});
  // Stops the io thread before this part of the object goes: it calls Handle and
  // FloodLine.
  ~CounterSimulator() override { Stop(); }

 protected:
  std::optional<Response> Handle(const std::string& line, const FaultSpec& fault) override;
  std::string FloodLine(const std::string& request, int64_t k) override;

 private:
  VirtualLab& lab_;
  int joint_;
  instruments::EncoderCalibration calibration_;
};

}  // namespace armsig::simulation
