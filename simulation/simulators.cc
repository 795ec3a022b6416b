#include "simulation/simulators.h"

#include <cmath>
#include <cstdio>
#include <future>
#include <numbers>
#include <random>
#include <sstream>

#include "instruments/geocom_codec.h"
#include "instruments/gsi_codec.h"

namespace armsig::simulation {

namespace asio = boost::asio;
namespace geocom = instruments::geocom;

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

void LineSimulator::InjectOnce(FaultSpec fault) {
  std::lock_guard lock(fault_mutex_);
  faults_.push_back(fault);
}

void LineSimulator::Disappear() {
  std::promise<void> done;
  asio::post(io_, [&] {
    present_ = false;
    boost::system::error_code ignored;
    descriptor_->close(ignored);  // our duplicate of the master
    port_.Disappear();
    buffer_.clear();
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
  FaultSpec fault;
  {
    std::lock_guard lock(fault_mutex_);
    if (!faults_.empty()) {
      fault = faults_.front();
      faults_.pop_front();
    }
  }
  auto response = Handle(line, fault);
  if (!response || fault.fault == Fault::kDropReply) return;
  std::string bytes = response->bytes;
  if (fault.fault == Fault::kNoiseBytes) bytes = "\x13\xfe~#garbage\r\n\x07" + bytes;
  if (fault.fault == Fault::kTruncateReply) bytes = bytes.substr(0, bytes.size() / 2);
  Send(std::move(bytes), response->latency);
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
  auto angles = [&](bool with_distance, std::vector<std::string>& out) {
    double distance_mm = 0.0;
    const AngleReading a = lab_.Read(station_, with_distance ? &distance_mm : nullptr);
    out.push_back(geocom::EncodeDouble(a.hz_rad));
    out.push_back(geocom::EncodeDouble(a.v_rad));
    return distance_mm;
  };
  switch (q.rpc) {
    case geocom::rpc::kNullProc:
      break;
    case geocom::rpc::kGetDoublePrecision:
      r.values = {"15"};
      break;
    case geocom::rpc::kGetGeoComVersion:
      r.values = {"1", "50", "0"};
      break;
    case geocom::rpc::kGetInstrumentName:
      r.values = {geocom::EncodeString(name_)};
      break;
    case geocom::rpc::kGetInstrumentNo:
      r.values = {std::to_string(serial_)};
      break;
    case geocom::rpc::kGetFirmwareVersion:
      r.values = {"3", "20", "7"};
      break;
    case geocom::rpc::kGetInclineSwitch:
      r.values = {"1"};
      break;
    case geocom::rpc::kSetInclineSwitch:
      break;
    case geocom::rpc::kGetFace:
      r.values = {lab_.Face(station_) == 2 ? "1" : "0"};
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
      angles(false, r.values);
      r.values.insert(r.values.end(),
                      {"0.000001", "1000", "0.00001", "0.00002", "0.000003", "1000"});
      r.values.push_back(lab_.Face(station_) == 2 ? "1" : "0");
      latency = options_.angle_latency;
      break;
    }
    case geocom::rpc::kGetAngleSimple:
      angles(false, r.values);
      latency = options_.angle_latency;
      break;
    case geocom::rpc::kDoMeasure:
      distance_ready_ = q.params.empty() || q.params[0] != "0";
      latency = options_.angle_latency / 4;
      break;
    case geocom::rpc::kGetSimpleMea: {
      const double d = angles(distance_ready_, r.values);
      if (distance_ready_) {
        r.values.push_back(geocom::EncodeDouble(d / 1000.0, 6));
      } else {
        r.rc = 1285;  // angles valid, no distance measured
        r.values.push_back("0");
      }
      latency = options_.distance_latency;
      break;
    }
    case geocom::rpc::kMeasDistanceAngle: {
      const double d = angles(true, r.values);
      r.values.push_back(geocom::EncodeDouble(d / 1000.0, 6));
      r.values.push_back(q.params.empty() ? "2" : q.params[0]);
      latency = options_.distance_latency;
      break;
    }
    default:
      r.rc_com = 3081;  // PROC_UNAVAIL
      r.values.clear();
  }
  switch (fault.fault) {
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
  std::string bytes = geocom::EncodeReply(r, crc || fault.fault == Fault::kBadCrc);
  if (fault.fault == Fault::kBadCrc) {
    // Corrupt one digit of the CRC field (the third comma-separated header field).
    const size_t colon = bytes.find(':');
    const size_t last_comma = bytes.rfind(',', colon);
    bytes[last_comma + 1] = bytes[last_comma + 1] == '1' ? '2' : '1';
  }
  return Response{bytes, latency};
}

// --- GSI Online ---------------------------------------------------------------------

GsiOnlineSimulator::GsiOnlineSimulator(VirtualLab& lab, int station, std::string link_path,
                                       SimulatorOptions options)
    : LineSimulator(std::move(link_path), options), lab_(lab), station_(station) {}

std::optional<LineSimulator::Response> GsiOnlineSimulator::Handle(const std::string& line,
                                                                  const FaultSpec& fault) {
  if (fault.fault == Fault::kErrorCode)
    return Response{"@E" + std::to_string(fault.code) + "\r\n", options_.angle_latency};
  if (fault.fault == Fault::kBusy) return Response{"@W100\r\n", options_.angle_latency};
  const std::string prefix = gsi16_ ? "*" : "";
  if (line.rfind("SET/137/", 0) == 0) {
    gsi16_ = line.substr(8) == "1";
    return Response{"?\r\n", std::chrono::milliseconds(5)};
  }
  if (line.rfind("GET/", 0) != 0 || line.size() < 9 || line[5] != '/' ||
      line.substr(6, 2) != "WI") {
    return Response{"@W427\r\n", std::chrono::milliseconds(5)};
  }
  const char mode = line[4];
  const int wi = std::atoi(line.c_str() + 8);
  auto latency = std::chrono::milliseconds(5);
  if (mode == 'M' && (wi == 21 || wi == 22)) {
    last_ = lab_.Read(station_);
    latency = options_.angle_latency;
  } else if (mode == 'M' && wi == 31) {
    last_ = lab_.Read(station_, &last_distance_mm_);
    latency = options_.distance_latency;
  }
  std::string word;
  switch (wi) {
    case 21:
      word = instruments::gsi::EncodeAngleWord(21, last_.hz_rad, gsi16_);
      break;
    case 22:
      word = instruments::gsi::EncodeAngleWord(22, last_.v_rad, gsi16_);
      break;
    case 31:
      word = instruments::gsi::EncodeLengthWord(31, last_distance_mm_, gsi16_, '8');
      break;
    case 12:
      word = instruments::gsi::EncodeTextWord(12, "4711", gsi16_);
      break;
    case 13:
      word = instruments::gsi::EncodeTextWord(13, "T2002", gsi16_);
      break;
    case 590:
      word = instruments::gsi::EncodeTextWord(590, "3.04", gsi16_);
      break;
    default:
      return Response{"@W427\r\n", std::chrono::milliseconds(5)};
  }
  return Response{prefix + word + "\r\n", latency};
}

// --- VAL / AS -----------------------------------------------------------------------

ValSimulator::ValSimulator(VirtualLab& lab, std::string link_path, Layout layout,
                           SimulatorOptions options)
    : LineSimulator(std::move(link_path), options), lab_(lab), layout_(layout) {}

std::optional<LineSimulator::Response> ValSimulator::Handle(const std::string& line,
                                                            const FaultSpec& fault) {
  const std::string prompt = layout_ == Layout::kValII ? ".\r\n" : ">\r\n";
  std::string upper = line;
  for (char& c : upper) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  if (fault.fault == Fault::kErrorCode) {
    return Response{
        line + "\r\n(P1000)Cannot execute program because motor power is OFF.\r\n" + prompt,
        options_.angle_latency};
  }
  const double to_deg = 180.0 / std::numbers::pi;
  if (upper == "WHERE" || upper == "WH" || upper == "WHERE 3") {
    const Eigen::VectorXd q = lab_.Joints() * to_deg;
    const Eigen::Vector3d x = lab_.TruePosition("robot");
    Eigen::VectorXd pose(6);
    pose << x.x(), x.y(), x.z(), 0.0, 0.0, 0.0;
    std::string text = line + "\r\n";
    if (layout_ == Layout::kKawasakiAs) {
      text += instruments::FormatWhere(q, pose);
    } else {
      char buffer[64];
      text += "     X/JT1      Y/JT2      Z/JT3      O/JT4      A/JT5      T/JT6     HAND\r\n";
      for (int i = 0; i < 6; ++i) {
        std::snprintf(buffer, sizeof buffer, "%11.3f", pose(i));
        text += buffer;
      }
      text += "      0.000\r\n";
      for (int i = 0; i < q.size(); ++i) {
        std::snprintf(buffer, sizeof buffer, "%11.3f", q(i));
        text += buffer;
      }
      text += "\r\n";
    }
    return Response{text + prompt, options_.angle_latency};
  }
  if (upper.rfind("DO JMOVE #[", 0) == 0 && upper.back() == ']') {
    std::stringstream in(upper.substr(11, upper.size() - 12));
    Eigen::VectorXd q(lab_.model().num_joints());
    std::string item;
    int i = 0;
    while (std::getline(in, item, ',') && i < q.size()) q(i++) = std::atof(item.c_str()) / to_deg;
    if (i != q.size())
      return Response{line + "\r\n(P2008)Wrong number of joint values.\r\n" + prompt,
                      std::chrono::milliseconds(5)};
    lab_.SetJoints(q);
    return Response{line + "\r\n" + prompt, options_.motion_latency};
  }
  return Response{line + "\r\n(P2000)Unknown command.\r\n" + prompt, std::chrono::milliseconds(5)};
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
  if (fault.fault == Fault::kErrorCode) return Response{"e!\r\n", std::chrono::milliseconds(2)};
  if (line == "R0E") {
    const Eigen::VectorXd counts = calibration_.ToCounts(lab_.Joints());
    instruments::CounterReading r;
    r.kind = 'r';
    r.reg = 0x0E;
    r.value = static_cast<int64_t>(counts(joint_));
    return Response{instruments::FormatCounterReply(r), std::chrono::milliseconds(2)};
  }
  if (line.size() >= 3 && (line[0] == 'W' || line[0] == 'R')) {
    instruments::CounterReading r;
    r.kind = static_cast<char>(std::tolower(line[0]));
    r.reg = std::stoi(line.substr(1, 2), nullptr, 16);
    return Response{instruments::FormatCounterReply(r), std::chrono::milliseconds(2)};
  }
  return Response{"e!\r\n", std::chrono::milliseconds(2)};
}

}  // namespace armsig::simulation
