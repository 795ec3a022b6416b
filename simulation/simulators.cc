#include "simulation/simulators.h"

#include <spdlog/spdlog.h>

#include <cctype>
#include <cmath>
#include <cstdio>
#include <future>
#include <numbers>

#include "core/units.h"
#include "instruments/geocom_codec.h"
#include "instruments/gsi_codec.h"

namespace armsig::simulation {

namespace asio = boost::asio;
namespace geocom = instruments::geocom;
namespace gsi = instruments::gsi;

LineSimulator::LineSimulator(std::string link_path, SimulatorOptions options)
    : options_(options), port_(std::move(link_path)) {}

LineSimulator::~LineSimulator() { Stop(); }

std::chrono::milliseconds LineSimulator::Scaled(std::chrono::milliseconds latency) const {
  return std::chrono::milliseconds(
      static_cast<long>(std::llround(latency.count() * options_.time_scale)));
}

void LineSimulator::Start() {
  descriptor_ = std::make_unique<asio::posix::stream_descriptor>(io_, ::dup(port_.master_fd()));
  work_.emplace(asio::make_work_guard(io_));
  StartRead();
  thread_ = std::thread([this] { io_.run(); });
}

void LineSimulator::Stop() {
  if (!thread_.joinable()) return;
  asio::post(io_, [this] {
    boost::system::error_code ignored;
    if (descriptor_) descriptor_->close(ignored);
    work_.reset();
  });
  io_.stop();
  thread_.join();
}

void FaultQueue::Once(FaultSpec fault) {
  std::lock_guard lock(mutex_);
  once_.push_back(fault);
}

void FaultQueue::Always(FaultSpec fault) {
  std::lock_guard lock(mutex_);
  always_ = fault;
}

void FaultQueue::Clear() {
  std::lock_guard lock(mutex_);
  once_.clear();
  always_.reset();
}

FaultSpec FaultQueue::Next() {
  std::lock_guard lock(mutex_);
  if (!once_.empty()) {
    const FaultSpec fault = once_.front();
    once_.pop_front();
    return fault;
  }
  return always_.value_or(FaultSpec{});
}

void LineSimulator::InjectOnce(FaultSpec fault) { faults_.Once(fault); }

void LineSimulator::InjectAlways(FaultSpec fault) { faults_.Always(fault); }

void LineSimulator::ClearFaults() {
  faults_.Clear();
  ++flood_generation_;
  std::promise<void> done;
  asio::post(io_, [&] {
    flooding_ = false;
    done.set_value();
  });
  done.get_future().wait();
}

void LineSimulator::Vanish() {
  present_ = false;
  flooding_ = false;
  ++flood_generation_;
  boost::system::error_code ignored;
  if (descriptor_) descriptor_->close(ignored);  // our duplicate of the master
  port_.Disappear();
  buffer_.clear();
}

void LineSimulator::Disappear() {
  std::promise<void> done;
  asio::post(io_, [&] {
    Vanish();
    done.set_value();
  });
  done.get_future().wait();
}

void LineSimulator::Reappear() {
  std::promise<void> done;
  asio::post(io_, [&] {
    port_.Reappear();
    descriptor_ = std::make_unique<asio::posix::stream_descriptor>(io_, ::dup(port_.master_fd()));
    present_ = true;
    StartRead();
    done.set_value();
  });
  done.get_future().wait();
}

void LineSimulator::StartRead() {
  descriptor_->async_read_some(
      asio::buffer(chunk_), [this](const boost::system::error_code& ec, size_t n) {
        if (ec) {
          // EIO while no driver has the slave open is normal on a pty: keep listening.
          if (ec != asio::error::operation_aborted && present_ && descriptor_->is_open()) {
            auto timer = std::make_shared<asio::steady_timer>(io_, std::chrono::milliseconds(5));
            timer->async_wait([this, timer](const boost::system::error_code& e) {
              if (!e && present_ && descriptor_->is_open()) StartRead();
            });
          }
          return;
        }
        buffer_.append(chunk_, n);
        for (;;) {
          const size_t end = buffer_.find_first_of("\r\n");
          if (end == std::string::npos) break;
          std::string line = buffer_.substr(0, end);
          buffer_.erase(0, end + 1);
          if (!line.empty()) OnLine(line);
        }
        StartRead();
      });
}

void LineSimulator::OnLine(const std::string& line) {
  ++requests_;
  const FaultSpec fault = faults_.Next();
  switch (fault.fault) {
    case Fault::kVanish:
      Vanish();
      return;
    case Fault::kFloodBytes: {
      // Deterministic garbage, every byte value, CR and LF among it.
      StartFlood([](int64_t k) {
        std::string chunk(4096, '\0');
        uint32_t x = static_cast<uint32_t>(k) * 2654435761u + 12345u;
        for (char& c : chunk) {
          x = x * 1664525u + 1013904223u;
          c = static_cast<char>(x >> 24);
        }
        return chunk;
      });
      return;
    }
    case Fault::kEndlessLine:
      StartFlood([](int64_t) {
        std::string chunk;
        while (chunk.size() < 4096) chunk += "%R1P,0,1:0,3.14159265358979,";
        return chunk;
      });
      return;
    case Fault::kFloodLines:
      StartFlood([this, line](int64_t k) {
        std::string chunk;
        for (int64_t i = 0; chunk.size() < 4096; ++i) chunk += FloodLine(line, k * 1000 + i);
        return chunk;
      });
      return;
    default:
      break;
  }
  auto response = Handle(line, fault);
  if (!response || fault.fault == Fault::kDropReply) return;
  std::string bytes = response->bytes;
  if (fault.fault == Fault::kNoiseBytes) bytes = "\x13\xfe~#garbage\r\n\x07" + bytes;
  if (fault.fault == Fault::kTruncateReply) bytes = bytes.substr(0, bytes.size() / 2);
  Send(std::move(bytes), response->latency);
}

void LineSimulator::StartFlood(std::function<std::string(int64_t)> next) {
  if (flooding_ || !present_ || !descriptor_->is_open()) return;
  flooding_ = true;
  FloodMore(std::make_shared<std::function<std::string(int64_t)>>(std::move(next)), 0,
            flood_generation_.load());
}

void LineSimulator::FloodMore(std::shared_ptr<std::function<std::string(int64_t)>> next, int64_t k,
                              uint64_t generation) {
  if (!flooding_ || generation != flood_generation_.load() || !present_ ||
      !descriptor_->is_open()) {
    return;
  }
  // The chunk first: the order in which function arguments are evaluated is unspecified,
  // and moving `next` into its parameter before calling it left it empty under clang.
  auto data = std::make_shared<std::string>((*next)(k));
  FloodChunk(std::move(next), k, generation, std::move(data), 0);
}

// One write_some at a time, so flood_bytes() counts what the line took as it takes it (a
// composed async_write would count a 4 KiB chunk only once all of it was read).
void LineSimulator::FloodChunk(std::shared_ptr<std::function<std::string(int64_t)>> next, int64_t k,
                               uint64_t generation, std::shared_ptr<std::string> data,
                               size_t offset) {
  if (!flooding_ || generation != flood_generation_.load() || !present_ ||
      !descriptor_->is_open()) {
    return;
  }
  descriptor_->async_write_some(
      asio::buffer(data->data() + offset, data->size() - offset),
      [this, next, k, generation, data, offset](const boost::system::error_code& ec, size_t n) {
        flood_bytes_ += static_cast<int64_t>(n);
        if (ec) {
          if (generation == flood_generation_.load()) flooding_ = false;
          return;
        }
        if (offset + n < data->size()) {
          FloodChunk(next, k, generation, data, offset + n);
        } else {
          FloodMore(next, k + 1, generation);
        }
      });
}

void LineSimulator::Send(std::string bytes, std::chrono::milliseconds latency) {
  auto timer = std::make_shared<asio::steady_timer>(io_, Scaled(latency));
  auto data = std::make_shared<std::string>(std::move(bytes));
  timer->async_wait([this, timer, data](const boost::system::error_code& ec) {
    if (ec || !present_ || !descriptor_->is_open()) return;
    boost::system::error_code ignored;
    asio::write(*descriptor_, asio::buffer(*data), ignored);
  });
}

// --- GeoCOM -------------------------------------------------------------------------

GeoComSimulator::GeoComSimulator(VirtualLab& lab, int station, std::string link_path,
                                 SimulatorOptions options, std::string instrument_name, long serial)
    : LineSimulator(std::move(link_path), options),
      lab_(lab),
      station_(station),
      name_(std::move(instrument_name)),
      serial_(serial) {}

std::optional<LineSimulator::Response> GeoComSimulator::Handle(const std::string& line,
                                                               const FaultSpec& fault) {
  const auto parsed = geocom::ParseRequest(line);
  if (parsed.error == geocom::ParseError::kNotAFrame) return std::nullopt;  // garbage: silence
  const bool crc = parsed.had_crc;
  if (parsed.error == geocom::ParseError::kBadCrc) {
    return Response{geocom::EncodeReply({3101, 0, 0, {}}, crc), std::chrono::milliseconds(5)};
  }
  if (parsed.error)
    return Response{geocom::EncodeReply({3080, 0, 0, {}}, crc), std::chrono::milliseconds(5)};
  const geocom::Request& q = *parsed.request;
  geocom::Reply r;
  r.trid = q.trid.value_or(0);
  auto latency = options_.angle_latency / 4;
  const auto face_value = [&] { return lab_.Face(station_) == 2 ? 1L : 0L; };  // TMC_FACE
  switch (q.rpc) {
    case geocom::rpc::kNullProc:
      break;
    case geocom::rpc::kGetDoublePrecision:
      r.values = {geocom::EncodeLong(15)};
      break;
    case geocom::rpc::kGetGeoComVersion:
      r.values = geocom::EncodeValues(geocom::Version{1, 50, 0});
      break;
    case geocom::rpc::kGetInstrumentName:
      r.values = {geocom::EncodeString(name_)};
      break;
    case geocom::rpc::kGetInstrumentNo:
      r.values = {geocom::EncodeLong(serial_)};
      break;
    case geocom::rpc::kGetFirmwareVersion:
      r.values = geocom::EncodeValues(geocom::Version{3, 20, 7});
      break;
    case geocom::rpc::kGetInclineSwitch:
      r.values = {geocom::EncodeLong(1)};
      break;
    case geocom::rpc::kSetInclineSwitch:
      break;
    case geocom::rpc::kGetFace:
      r.values = {geocom::EncodeLong(face_value())};
      break;
    case geocom::rpc::kChangeFace:
      lab_.SetFace(station_, 3 - lab_.Face(station_));
      latency = options_.motion_latency;
      break;
    case geocom::rpc::kMakePositioning:
    case geocom::rpc::kFineAdjust:
      latency = options_.motion_latency / 2;
      break;
    case geocom::rpc::kGetAngleComplete: {
      const AngleReading a = lab_.Read(station_);
      geocom::AngleComplete values;
      values.hz_rad = a.hz_rad;
      values.v_rad = a.v_rad;
      values.angle_accuracy_rad = 0.000001;
      values.angle_time_ms = 1000;
      values.cross_incline_rad = 0.00001;
      values.length_incline_rad = 0.00002;
      values.incline_accuracy_rad = 0.000003;
      values.incline_time_ms = 1000;
      values.face = face_value();
      r.values = geocom::EncodeValues(values);
      latency = options_.angle_latency;
      break;
    }
    case geocom::rpc::kGetAngleSimple: {
      const AngleReading a = lab_.Read(station_);
      r.values = geocom::EncodeValues(geocom::AngleSimple{a.hz_rad, a.v_rad});
      latency = options_.angle_latency;
      break;
    }
    case geocom::rpc::kDoMeasure: {
      const auto program =
          q.params.empty() ? std::optional<long>(1) : geocom::DecodeLong(q.params[0]);
      distance_ready_ = program != 0L;  // 0 = TMC_STOP
      latency = options_.angle_latency / 4;
      break;
    }
    case geocom::rpc::kGetSimpleMea: {
      double distance_mm = 0.0;
      const AngleReading a = lab_.Read(station_, distance_ready_ ? &distance_mm : nullptr);
      geocom::SimpleMeasurement m{a.hz_rad, a.v_rad, distance_mm / 1000.0};
      if (!distance_ready_) {
        r.rc = 1285;  // angles valid, no distance measured
        m.slope_distance_m = 0.0;
      }
      r.values = geocom::EncodeValues(m);
      latency = options_.distance_latency;
      break;
    }
    case geocom::rpc::kMeasDistanceAngle: {
      const auto mode = q.params.empty() ? std::optional<long>(2) : geocom::DecodeLong(q.params[0]);
      if (!mode) {
        r.rc = 2;  // GRC_IVPARAM
        break;
      }
      double distance_mm = 0.0;
      const AngleReading a = lab_.Read(station_, &distance_mm);
      r.values = geocom::EncodeValues(
          geocom::DistanceAngle{a.hz_rad, a.v_rad, distance_mm / 1000.0, *mode});
      latency = options_.distance_latency;
      break;
    }
    default:
      r.rc_com = 3081;  // PROC_UNAVAIL
      r.values.clear();
  }
  switch (fault.fault) {
    case Fault::kOtherReply:
      // The right transaction id with another RPC's values (CSV_GetFirmwareVersion).
      r.rc_com = 0;
      r.rc = 0;
      r.values = geocom::EncodeValues(geocom::Version{3, 20, 7});
      break;
    case Fault::kOutOfRange:
      // Angles in degrees where radians belong, and a zenith angle below 0.
      if (r.values.size() >= 2) {
        const auto hz = geocom::DecodeDouble(r.values[0]);
        const auto v = geocom::DecodeDouble(r.values[1]);
        if (hz && v) {
          r.values[0] = geocom::EncodeDouble(*hz * 180.0 / std::numbers::pi);
          r.values[1] = geocom::EncodeDouble(-*v);
        }
      }
      break;
    case Fault::kBusy:
      r.rc = 13;
      r.values.clear();
      break;
    case Fault::kErrorCode:
      r.rc = fault.code;
      r.values.clear();
      break;
    case Fault::kWarningCode:
      r.rc = fault.code;
      break;
    case Fault::kWrongTrid:
      r.trid = (r.trid + 7) % 32768;
      break;
    default:
      break;
  }
  std::string bytes = geocom::EncodeReply(
      r, (crc || fault.fault == Fault::kBadCrc) && fault.fault != Fault::kNoCrc);
  if (fault.fault == Fault::kBadCrc) {
    // Corrupt one digit of the CRC field (the third comma-separated header field).
    const size_t colon = bytes.find(':');
    const size_t last_comma = bytes.rfind(',', colon);
    bytes[last_comma + 1] = bytes[last_comma + 1] == '1' ? '2' : '1';
  }
  return Response{bytes, latency};
}

std::string GeoComSimulator::FloodLine(const std::string& request, int64_t k) {
  // Well-formed replies (with a CRC when the request had one) whose transaction ids are
  // far from the request's: late replies to requests never sent.
  const auto parsed = geocom::ParseRequest(request);
  const int trid = parsed.request ? parsed.request->trid.value_or(0) : 0;
  geocom::Reply r;
  r.trid = (trid + 10000 + static_cast<int>(k % 1000)) % 32768;
  r.values = geocom::EncodeValues(geocom::AngleSimple{1.0, 1.5});
  return geocom::EncodeReply(r, parsed.had_crc);
}

// --- GSI Online ---------------------------------------------------------------------

GsiOnlineSimulator::GsiOnlineSimulator(VirtualLab& lab, int station, std::string link_path,
                                       SimulatorOptions options)
    : LineSimulator(std::move(link_path), options), lab_(lab), station_(station) {}

std::optional<LineSimulator::Response> GsiOnlineSimulator::Handle(const std::string& line,
                                                                  const FaultSpec& fault) {
  using Reply = gsi::OnlineReply;
  const auto reply = [](Reply::Kind kind, int code = 0) {
    Reply r;
    r.kind = kind;
    r.code = code;
    return gsi::FormatOnlineReply(r);
  };
  if (fault.fault == Fault::kErrorCode)
    return Response{reply(Reply::Kind::kError, fault.code), options_.angle_latency};
  if (fault.fault == Fault::kBusy)
    return Response{reply(Reply::Kind::kWarning, 100), options_.angle_latency};
  const std::string invalid = reply(Reply::Kind::kWarning, 427);  // invalid command
  const auto q = gsi::ParseOnlineRequest(line);
  if (!q) return Response{invalid, std::chrono::milliseconds(5)};
  if (q->kind == gsi::OnlineRequest::Kind::kSet) {
    if (q->param != 137) return Response{invalid, std::chrono::milliseconds(5)};
    gsi16_ = q->value == 1;  // 137: GSI type, 0 GSI-8, 1 GSI-16
    return Response{reply(Reply::Kind::kAck), std::chrono::milliseconds(5)};
  }
  auto latency = std::chrono::milliseconds(5);
  if (q->mode == 'M' && (q->wi == 21 || q->wi == 22)) {
    last_ = lab_.Read(station_);
    latency = options_.angle_latency;
  } else if (q->mode == 'M' && q->wi == 31) {
    last_ = lab_.Read(station_, &last_distance_mm_);
    latency = options_.distance_latency;
  }
  Reply word;
  if (fault.fault == Fault::kOtherReply && q->kind == gsi::OnlineRequest::Kind::kGet) {
    // Another word than the one asked for (the reply to another GET).
    word.word = gsi::TextWord(q->wi == 12 ? 13 : 12, "4711", gsi16_);
    return Response{gsi::FormatOnlineReply(word), latency};
  }
  if (fault.fault == Fault::kWrongUnit && (q->wi == 21 || q->wi == 22)) {
    word.word = gsi::LengthWord(q->wi, 1234.5, gsi16_, '0');  // metres on an angle word
    return Response{gsi::FormatOnlineReply(word), latency};
  }
  if (fault.fault == Fault::kOutOfRange && q->wi == 22) {
    word.word = gsi::AngleWord(22, -WrapTwoPi(last_.v_rad), gsi16_);  // a negative zenith angle
    return Response{gsi::FormatOnlineReply(word), latency};
  }
  try {
    switch (q->wi) {
      case 21:  // a circle reading: [0, 400 gon)
        word.word = gsi::AngleWord(21, WrapTwoPi(last_.hz_rad), gsi16_);
        break;
      case 22:
        word.word = gsi::AngleWord(22, WrapTwoPi(last_.v_rad), gsi16_);
        break;
      case 31:
        word.word = gsi::LengthWord(31, last_distance_mm_, gsi16_, '8');
        break;
      case 12:
        word.word = gsi::TextWord(12, "4711", gsi16_);
        break;
      case 13:
        word.word = gsi::TextWord(13, "T2002", gsi16_);
        break;
      case 590:
        word.word = gsi::TextWord(590, "3.04", gsi16_);
        break;
      default:
        return Response{invalid, std::chrono::milliseconds(5)};
    }
  } catch (const std::out_of_range& e) {  // e.g. a distance beyond a GSI-8 word
    spdlog::warn("GSI Online simulator: {}", e.what());
    return Response{invalid, std::chrono::milliseconds(5)};
  }
  return Response{gsi::FormatOnlineReply(word), latency};
}

std::string GsiOnlineSimulator::FloodLine(const std::string& request, int64_t k) {
  // Words of the instrument, none the one asked for.
  const auto q = gsi::ParseOnlineRequest(request);
  gsi::OnlineReply word;
  word.word = gsi::TextWord(q && q->wi == 12 ? 13 : 12, std::to_string(4700 + k % 100), gsi16_);
  return gsi::FormatOnlineReply(word);
}

// --- VAL / AS -----------------------------------------------------------------------

ValSimulator::ValSimulator(VirtualLab& lab, std::string link_path, Layout layout,
                           SimulatorOptions options)
    : LineSimulator(std::move(link_path), options), lab_(lab), layout_(layout) {}

std::optional<LineSimulator::Response> ValSimulator::Handle(const std::string& line,
                                                            const FaultSpec& fault) {
  const std::string echo = line + "\r\n";
  const std::string prompt = instruments::FormatMonitorPrompt(layout_);
  if (fault.fault == Fault::kErrorCode) {
    return Response{echo +
                        instruments::FormatMonitorError(
                            1000, "Cannot execute program because motor power is OFF.") +
                        prompt,
                    options_.angle_latency};
  }
  const auto command = instruments::ParseMonitorCommand(line);
  if (!command) {
    return Response{echo + instruments::FormatMonitorError(2000, "Unknown command.") + prompt,
                    std::chrono::milliseconds(5)};
  }
  const double to_deg = 180.0 / std::numbers::pi;
  if (command->kind == instruments::MonitorCommand::Kind::kWhere &&
      fault.fault == Fault::kOtherReply) {
    return Response{echo + prompt, options_.angle_latency};  // what a move prints
  }
  if (command->kind == instruments::MonitorCommand::Kind::kWhere) {
    Eigen::VectorXd q = lab_.Joints() * to_deg;
    if (fault.fault == Fault::kOutOfRange) q(0) = 1000.0;  // no joint turns that far
    const Eigen::Vector3d x = lab_.TruePosition("robot");
    Eigen::VectorXd pose(6);
    pose << x.x(), x.y(), x.z(), 0.0, 0.0, 0.0;
    return Response{echo + instruments::FormatWhere(q, pose, layout_) + prompt,
                    options_.angle_latency};
  }
  if (command->joints_deg.size() != lab_.model().num_joints()) {
    return Response{
        echo + instruments::FormatMonitorError(2008, "Wrong number of joint values.") + prompt,
        std::chrono::milliseconds(5)};
  }
  Eigen::VectorXd reached = command->joints_deg / to_deg;
  if (fault.fault == Fault::kStopShort && reached.size() >= 2) {
    reached(1) -= (reached(1) >= 0.0 ? 2.0 : -2.0) / to_deg;
  }
  lab_.SetJoints(reached);
  return Response{echo + prompt, options_.motion_latency};
}

std::string ValSimulator::FloodLine(const std::string&, int64_t k) {
  // Rows of numbers, never the prompt.
  char row[96];
  std::snprintf(row, sizeof row, "%9.3f %9.3f %9.3f %9.3f %9.3f %9.3f\r\n",
                static_cast<double>(k % 360), 1.0, 2.0, 3.0, 4.0, 5.0);
  return row;
}

// --- Counter box --------------------------------------------------------------------

CounterSimulator::CounterSimulator(VirtualLab& lab, int joint,
                                   instruments::EncoderCalibration calibration,
                                   std::string link_path, SimulatorOptions options)
    : LineSimulator(std::move(link_path), options),
      lab_(lab),
      joint_(joint),
      calibration_(std::move(calibration)) {}

std::optional<LineSimulator::Response> CounterSimulator::Handle(const std::string& line,
                                                                const FaultSpec& fault) {
  instruments::CounterReading error;
  error.kind = 'e';
  const std::string error_reply = instruments::FormatCounterReply(error);
  if (fault.fault == Fault::kErrorCode) return Response{error_reply, std::chrono::milliseconds(2)};
  const auto q = instruments::ParseCounterRequest(line);
  if (!q || q->kind == 'S')
    return Response{error_reply, std::chrono::milliseconds(2)};  // no streaming
  instruments::CounterReading r;
  r.kind = static_cast<char>(std::tolower(static_cast<unsigned char>(q->kind)));
  r.reg = q->reg;
  if (fault.fault == Fault::kOtherReply) {
    r.reg = 0x14;  // the version register
    r.value = 1;
  } else if (q->kind == 'R' && q->reg == 0x0E) {
    const Eigen::VectorXd counts = calibration_.ToCounts(lab_.Joints());
    r.value = static_cast<int64_t>(counts(joint_));
    if (fault.fault == Fault::kOutOfRange) r.value = 2147483647;  // the counter's limit
  }
  return Response{instruments::FormatCounterReply(r), std::chrono::milliseconds(2)};
}

}  // namespace armsig::simulation

namespace armsig::simulation {

std::string CounterSimulator::FloodLine(const std::string&, int64_t k) {
  // Replies for another register (the stream-interval register), never the count.
  instruments::CounterReading r;
  r.reg = 0x0C;
  r.value = k % 1000;
  return instruments::FormatCounterReply(r);
}

}  // namespace armsig::simulation
