#include "instruments/other_devices.h"

#include <cmath>
#include <numbers>
#include <thread>

namespace armsig::instruments {

namespace {

template <typename F>
auto WithRetries(LineTransport& transport, const RetryPolicy& policy, F&& attempt) {
  std::string last = "no attempt";
  for (int k = 0; k < policy.attempts; ++k) {
    try {
      if (!transport.IsOpen()) {
        transport.Open();
        transport.Drain(Millis(20));
      }
      return attempt();
    } catch (const TransportError& e) {
      last = e.what();
      if (e.kind() == TransportError::Kind::kTimeout) {
        try {
          transport.Drain(Millis(50));  // no transaction ids: clear late replies
        } catch (const TransportError&) {
        }
      } else {
        transport.Close();
        std::this_thread::sleep_for(policy.reconnect_delay);
      }
    }
  }
  throw InstrumentError(transport.name(), 3077,
                        "failed after " + std::to_string(policy.attempts) + " attempts: " + last);
}

}  // namespace

GsiOnlineDevice::GsiOnlineDevice(std::unique_ptr<LineTransport> transport, RetryPolicy policy)
    : transport_(std::move(transport)), policy_(policy) {}

gsi::Word GsiOnlineDevice::Get(char mode, int wi) {
  return WithRetries(*transport_, policy_, [&]() -> gsi::Word {
    transport_->Write("GET/" + std::string(1, mode) + "/WI" + std::to_string(wi) + "\r\n",
                      policy_.timeout);
    for (;;) {
      std::string line = transport_->ReadLine(policy_.timeout);
      if (line.rfind("@E", 0) == 0 || line.rfind("@W", 0) == 0) {
        const int code = std::atoi(line.c_str() + 2);
        throw InstrumentError(
            name(), code, "GSI Online " + line + " for GET/" + mode + "/WI" + std::to_string(wi));
      }
      const size_t start = line.find_first_not_of(' ');
      if (start == std::string::npos) continue;
      bool wide = line[start] == '*';
      std::string_view text = std::string_view(line).substr(start + (wide ? 1 : 0));
      while (!text.empty() && text.back() == ' ') text.remove_suffix(1);
      wide = text.size() >= 23;
      auto word = gsi::ParseWord(text, wide);
      if (!word || word->wi != wi) continue;  // noise or a reply to something else
      return *word;
    }
  });
}

DeviceInfo GsiOnlineDevice::Identify() {
  DeviceInfo info;
  info.name = gsi::Identifier(Get('I', 13));
  info.serial = gsi::Identifier(Get('I', 12));
  info.firmware = gsi::Identifier(Get('I', 590));
  return info;
}

Reading GsiOnlineDevice::MeasureAngles() {
  const gsi::Word hz = Get('M', 21);
  const gsi::Word v = Get('I', 22);
  std::string why;
  auto hz_rad = gsi::AngleRad(hz, &why);
  if (!hz_rad) throw InstrumentError(name(), 3074, "WI21: " + why);
  auto v_rad = gsi::AngleRad(v, &why);
  if (!v_rad) throw InstrumentError(name(), 3074, "WI22: " + why);
  Reading r;
  r.time = std::chrono::system_clock::now();
  r.angles = {*hz_rad, *v_rad, *v_rad > std::numbers::pi ? 2 : 1};
  return r;
}

Reading GsiOnlineDevice::MeasureDistanceAndAngles() {
  const gsi::Word distance = Get('M', 31);
  std::string why;
  auto mm = gsi::LengthMm(distance, &why);
  if (!mm) throw InstrumentError(name(), 3074, "WI31: " + why);
  if (!(*mm > 0)) throw InstrumentError(name(), 1292, "WI31: no distance measured");
  auto hz = gsi::AngleRad(Get('I', 21), &why);
  if (!hz) throw InstrumentError(name(), 3074, "WI21: " + why);
  auto v = gsi::AngleRad(Get('I', 22), &why);
  if (!v) throw InstrumentError(name(), 3074, "WI22: " + why);
  Reading r;
  r.time = std::chrono::system_clock::now();
  r.angles = {*hz, *v, *v > std::numbers::pi ? 2 : 1};
  r.distance_mm = *mm;
  return r;
}

int GsiOnlineDevice::Face() { return MeasureAngles().angles.face; }

void GsiOnlineDevice::ChangeFace() {
  throw InstrumentError(name(), 5, "GSI Online has no face change: turn the telescope by hand");
}

bool GsiOnlineDevice::CompensatorOn() {
  throw InstrumentError(name(), 5, "GSI Online does not report the compensator state");
}

ValController::ValController(std::unique_ptr<LineTransport> transport, bool can_move,
                             RetryPolicy policy)
    : transport_(std::move(transport)), can_move_(can_move), policy_(policy) {}

std::string ValController::Command(const std::string& command, Millis timeout) {
  transport_->Write(command + "\r\n", policy_.timeout);
  std::string text;
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  for (;;) {
    const auto left =
        std::chrono::duration_cast<Millis>(deadline - std::chrono::steady_clock::now());
    if (left.count() <= 0)
      throw TransportError(TransportError::Kind::kTimeout, name(), "no prompt after " + command);
    std::string line = transport_->ReadLine(left);
    const size_t start = line.find_first_not_of(' ');
    if (start == std::string::npos) continue;
    const std::string trimmed = line.substr(start);
    if (trimmed == "." || trimmed == ">") return text;  // the monitor prompt
    if (trimmed.rfind("(P", 0) == 0 || trimmed.rfind("*", 0) == 0 ||
        trimmed.rfind("Error", 0) == 0) {
      throw InstrumentError(name(), 1, "controller: " + trimmed);
    }
    text += line + "\n";
  }
}

Eigen::VectorXd ValController::ReadJointsRad() {
  return WithRetries(*transport_, policy_, [&]() -> Eigen::VectorXd {
    const std::string text = Command("WHERE", policy_.timeout);
    std::string why;
    auto where = ParseWhere(text, &why);
    if (!where) throw InstrumentError(name(), 3074, why);
    return where->joints_deg * (std::numbers::pi / 180.0);
  });
}

void ValController::MoveTo(const Eigen::VectorXd& joints_rad) {
  if (!can_move_) throw InstrumentError(name(), 5, "this controller is not commanded by armsig");
  std::string command = "DO JMOVE #[";
  char buffer[32];
  for (int i = 0; i < joints_rad.size(); ++i) {
    std::snprintf(buffer, sizeof buffer, "%s%.4f", i ? "," : "",
                  joints_rad(i) * 180.0 / std::numbers::pi);
    command += buffer;
  }
  command += "]";
  WithRetries(*transport_, policy_, [&]() {
    Command(command, policy_.timeout * 10);
    return 0;
  });
}

CounterBox::CounterBox(std::vector<std::unique_ptr<LineTransport>> channels,
                       EncoderCalibration calibration, RetryPolicy policy)
    : channels_(std::move(channels)), calibration_(std::move(calibration)), policy_(policy) {
  name_ = "counter box";
  for (const auto& c : channels_) name_ += " " + c->name();
}

Eigen::VectorXd CounterBox::ReadCounts() {
  Eigen::VectorXd counts(channels_.size());
  for (size_t i = 0; i < channels_.size(); ++i) {
    LineTransport& t = *channels_[i];
    counts(i) = static_cast<double>(WithRetries(t, policy_, [&]() -> int64_t {
      t.Write("R0E\n", policy_.timeout);
      for (;;) {
        std::string why;
        auto reply = ParseCounterReply(t.ReadLine(policy_.timeout), &why);
        if (!reply) {
          if (why.rfind("counter box error", 0) == 0) throw InstrumentError(t.name(), 1, why);
          continue;  // noise
        }
        if (reply->kind == 'r' && reply->reg == 0x0E) return reply->value;
      }
    }));
  }
  return counts;
}

Eigen::VectorXd CounterBox::ReadJointsRad() { return calibration_.ToJoints(ReadCounts()); }

void CounterBox::MoveTo(const Eigen::VectorXd&) {
  throw InstrumentError(name_, 5, "an encoder-counter box cannot move the robot");
}

}  // namespace armsig::instruments
