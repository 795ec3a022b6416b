#include "simulation/ur_simulator.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <cctype>
#include <cstring>
#include <deque>
#include <future>
#include <stdexcept>

#include "instruments/frame_splitter.h"
#include "programs/urscript.h"
#include "simulation/path_motion.h"
#include "simulation/program_runner.h"

namespace armsig::simulation {

namespace asio = boost::asio;
using tcp = asio::ip::tcp;
namespace ur = robots::ur;
namespace rtde = robots::ur::rtde;
namespace primary = robots::ur::primary;

namespace {

// Data packages at most this often in wall time (a faster time scale sends every k-th).
constexpr double kMinWallPeriodS = 2e-4;
// The state messages of the primary and secondary interfaces: 10 Hz.
constexpr double kStatePeriodS = 0.1;
// Wall time between physics updates of the lab while nothing else asks the arm.
constexpr auto kPhysicsPeriod = std::chrono::milliseconds(4);
// Writes queued beyond this on a slow reader's connection: a state or data message is
// dropped instead (the controller does not wait for a client).
constexpr size_t kMaxQueued = 64;
// A program longer than this without its end is dropped (and said so).
constexpr std::size_t kMaxProgramBytes = 1 << 20;
// A protective stop unlocks 5 s after it happened at the earliest (the dashboard's answer).
constexpr double kUnlockAfterS = 5.0;
// A linear move's joints, one every 4 ms of physical time (a controller's interpolation).
constexpr double kLinearStepS = 0.004;

// A checksum per joint of the controller's own DH parameters (FNV-1a over their bytes):
// what changes when the calibration does.
uint32_t Checksum(double theta, double a, double d, double alpha) {
  uint32_t h = 2166136261u;
  for (const double v : {theta, a, d, alpha}) {
    unsigned char bytes[sizeof v];
    std::memcpy(bytes, &v, sizeof v);
    for (const unsigned char b : bytes) h = (h ^ b) * 16777619u;
  }
  return h;
}

}  // namespace

UrSimulatorOptions Cb3Options(UrSimulatorOptions o) {
  o.e_series = false;
  o.software = {3, 15, 7, 106331};
  o.build_date = "Jun 01 2021";
  return o;
}

programs::ControllerModel UrControllerModel(const instruments::ControllerKinematics& k) {
  programs::UrKinematics u;
  for (std::size_t j = 0; j < 6; ++j) {
    u.theta[j] = k.dh_theta_rad.at(j);
    u.a[j] = k.dh_a_mm.at(j) / 1000.0;
    u.d[j] = k.dh_d_mm.at(j) / 1000.0;
    u.alpha[j] = k.dh_alpha_rad.at(j);
  }
  u.source = "the controller's KinematicsInfo";
  return programs::UrController(u);
}

struct UrSimulator::Connection {
  Connection(asio::io_context& io, Port p) : socket(io), port(p), splitter(rtde::kFrames) {}
  tcp::socket socket;
  Port port;
  instruments::FrameSplitter splitter;  // RTDE
  std::string text;                     // script or dashboard lines
  std::string program;                  // a program's lines until its end
  int program_depth = 0;                // its blocks open (0: none being sent)
  char chunk[4096];
  std::deque<std::string> out;
  bool writing = false, closed = false;
  // RTDE
  uint16_t protocol = 1;
  bool set_up = false, streaming = false;
  std::vector<std::string> names;
  std::vector<rtde::ValueType> types;
  double frequency = 0.0;
  int64_t packages = 0;      // of this stream
  double first_stamp = 0.0;  // its first package's time stamp
  std::unique_ptr<asio::steady_timer> timer;  // the data stream, or the state messages
};

UrSimulator::UrSimulator(VirtualLab& lab, UrSimulatorOptions options)
    : lab_(lab), options_(std::move(options)) {
  arm_ = std::make_unique<VirtualArm>(lab_, PhysicalClock(options_.time_scale), options_.home_rad);
  remote_ = options_.remote_control;
  kinematics_ = options_.kinematics;
  if (kinematics_.dh_theta_rad.size() != 6) {
    kinematics_.dh_theta_rad.assign(6, 0.0);
    kinematics_.dh_a_mm.assign(6, 0.0);
    kinematics_.dh_d_mm.assign(6, 0.0);
    kinematics_.dh_alpha_rad.assign(6, 0.0);
  }
}

UrSimulator::~UrSimulator() { Stop(); }

std::chrono::steady_clock::duration UrSimulator::Wall(double physical_s) const {
  return arm_->clock().Wall(physical_s);
}

uint64_t UrSimulator::Microseconds() const {
  return static_cast<uint64_t>(arm_->clock().Now() * 1e6);
}

void UrSimulator::Listen(Port port, unsigned short wanted) {
  boost::system::error_code ec;
  const auto address = asio::ip::make_address(options_.host, ec);
  if (ec) throw std::runtime_error("virtual UR: '" + options_.host + "' is no IP address");
  auto& acceptor = acceptors_[static_cast<int>(port)];
  acceptor = std::make_unique<tcp::acceptor>(io_);
  const tcp::endpoint endpoint(address, wanted);
  acceptor->open(endpoint.protocol(), ec);
  if (!ec) acceptor->set_option(tcp::acceptor::reuse_address(true), ec);
  if (!ec) acceptor->bind(endpoint, ec);
  if (!ec) acceptor->listen(asio::socket_base::max_listen_connections, ec);
  if (ec) {
    throw std::runtime_error(fmt::format("virtual UR: cannot listen on {}:{} ({})", options_.host,
                                         wanted, ec.message()));
  }
  const unsigned short taken = acceptor->local_endpoint().port();
  switch (port) {
    case Port::kRtde: ports_.rtde = taken; break;
    case Port::kPrimary: ports_.primary = taken; break;
    case Port::kSecondary: ports_.secondary = taken; break;
    case Port::kDashboard: ports_.dashboard = taken; break;
  }
}

void UrSimulator::Start() {
  Listen(Port::kRtde, options_.rtde_port);
  Listen(Port::kPrimary, options_.primary_port);
  Listen(Port::kSecondary, options_.secondary_port);
  Listen(Port::kDashboard, options_.dashboard_port);
  work_.emplace(asio::make_work_guard(io_));
  for (const Port p : {Port::kRtde, Port::kPrimary, Port::kSecondary, Port::kDashboard}) Accept(p);
  physics_ = std::make_unique<asio::steady_timer>(io_);
  PhysicsTick();
  thread_ = std::thread([this] { io_.run(); });
}

void UrSimulator::Stop() {
  if (!thread_.joinable()) return;
  asio::post(io_, [this] {
    boost::system::error_code ignored;
    for (auto& a : acceptors_) {
      if (a) a->close(ignored);
    }
    for (const auto& c : std::set<ConnectionPtr>(live_)) Close(c);
    if (physics_) physics_->cancel();
    work_.reset();
  });
  io_.stop();
  thread_.join();
  if (planner_.joinable()) planner_.join();
  boost::system::error_code ignored;
  for (auto& a : acceptors_) {
    if (a) a->close(ignored);
  }
  for (const auto& c : live_) {
    c->closed = true;
    c->socket.close(ignored);
  }
  live_.clear();
}

void UrSimulator::PhysicsTick() {
  arm_->Now();  // the lab's robot follows the arm while no client asks
  ProgramTick();
  physics_->expires_after(kPhysicsPeriod);
  physics_->async_wait([this](const boost::system::error_code& ec) {
    if (!ec) PhysicsTick();
  });
}

void UrSimulator::Accept(Port port) {
  auto& acceptor = acceptors_[static_cast<int>(port)];
  auto c = std::make_shared<Connection>(io_, port);
  acceptor->async_accept(c->socket, [this, c, port](const boost::system::error_code& ec) {
    if (ec) {
      if (ec != asio::error::operation_aborted && acceptors_[static_cast<int>(port)]->is_open())
        Accept(port);
      return;
    }
    Accept(port);
    bool down = false;
    {
      std::lock_guard lock(mutex_);
      down = std::chrono::steady_clock::now() < down_until_;
    }
    if (down) {  // the network is down: the connection goes at once
      boost::system::error_code ignored;
      c->socket.close(ignored);
      return;
    }
    ++connections_;
    live_.insert(c);
    boost::system::error_code ignored;
    c->socket.set_option(tcp::no_delay(true), ignored);
    if (port == Port::kDashboard) {
      Queue(c, std::string(ur::dashboard::kWelcome) + "\n");
    } else if (port == Port::kPrimary || port == Port::kSecondary) {
      primary::VersionMessage v;
      v.project = "URControl";
      v.major = static_cast<uint8_t>(options_.software.major);
      v.minor = static_cast<uint8_t>(options_.software.minor);
      v.bugfix = options_.software.bugfix;
      v.build = options_.software.build;
      v.build_date = options_.build_date;
      Queue(c, primary::EncodeVersion(Microseconds(), v));
      c->timer = std::make_unique<asio::steady_timer>(io_, std::chrono::steady_clock::now());
      StateTick(c);
    }
    Read(c);
  });
}

void UrSimulator::Read(ConnectionPtr c) {
  c->socket.async_read_some(asio::buffer(c->chunk), [this, c](const boost::system::error_code& ec,
                                                              size_t n) {
    if (ec || c->closed) {
      Close(c);
      return;
    }
    if (c->port == Port::kRtde) {
      c->splitter.Append(std::string_view(c->chunk, n));
      std::string frame;
      for (;;) {
        int32_t size = 0;
        const auto status = c->splitter.Next(frame, &size);
        if (status == instruments::FrameSplitter::Status::kNeedMore) break;
        if (status == instruments::FrameSplitter::Status::kBadSize) {
          Close(c);  // the controller drops a client that lost its framing
          return;
        }
        OnRtde(c, frame);
        if (c->closed) return;
      }
    } else {
      c->text.append(c->chunk, n);
      for (size_t end; (end = c->text.find('\n')) != std::string::npos;) {
        std::string line = c->text.substr(0, end);
        c->text.erase(0, end + 1);
        if (!line.empty() && line.back() == '\r') line.pop_back();
        if (c->port == Port::kDashboard) {
          const std::string answer = Dashboard(c, line);
          Queue(c, answer + "\n");
          if (line == "quit") Close(c);
        } else {
          OnScript(c, line);
        }
        if (c->closed) return;
      }
      if (c->text.size() > 65536) c->text.clear();  // no line that long is a command
    }
    Read(c);
  });
}

void UrSimulator::Queue(const ConnectionPtr& c, std::string bytes, bool droppable) {
  if (c->closed) return;
  if (droppable && c->out.size() >= kMaxQueued) return;
  c->out.push_back(std::move(bytes));
  if (!c->writing) Pump(c);
}

void UrSimulator::Pump(ConnectionPtr c) {
  if (c->closed || c->out.empty()) {
    c->writing = false;
    return;
  }
  c->writing = true;
  auto bytes = std::make_shared<std::string>(std::move(c->out.front()));
  c->out.pop_front();
  asio::async_write(c->socket, asio::buffer(*bytes),
                    [this, c, bytes](const boost::system::error_code& ec, size_t) {
                      if (ec) {
                        c->writing = false;
                        Close(c);
                        return;
                      }
                      Pump(c);
                    });
}

void UrSimulator::Close(const ConnectionPtr& c) {
  if (!c->closed) {
    c->closed = true;
    boost::system::error_code ignored;
    if (c->timer) c->timer->cancel();
    c->socket.shutdown(tcp::socket::shutdown_both, ignored);
    c->socket.close(ignored);
  }
  live_.erase(c);
}

// --- RTDE --------------------------------------------------------------------------------

void UrSimulator::OnRtde(const ConnectionPtr& c, const std::string& frame) {
  std::string why;
  const auto package = rtde::Decode(frame, &why);
  if (!package) {
    Close(c);
    return;
  }
  const auto type = static_cast<rtde::Type>(package->type);
  switch (type) {
    case rtde::Type::kRequestProtocolVersion: {
      const auto version = rtde::DecodeProtocolVersionRequest(package->payload);
      bool refuse = false;
      {
        std::lock_guard lock(mutex_);
        refuse = refuse_v2_;
      }
      const bool accepted = version && (*version == 1 || (*version == 2 && !refuse));
      if (accepted) c->protocol = *version;
      Queue(c, rtde::Accepted(type, accepted));
      return;
    }
    case rtde::Type::kGetUrControlVersion:
      Queue(c, rtde::UrControlVersion(options_.software));
      return;
    case rtde::Type::kSetupOutputs: {
      const auto request = rtde::DecodeSetupOutputsRequest(package->payload);
      rtde::OutputsSetup answer;
      const double highest = options_.e_series ? rtde::kESeriesMaxHz : rtde::kCb3MaxHz;
      if (!request || !(request->frequency_hz > 0.0) || request->frequency_hz > highest) {
        Queue(c, rtde::Text({fmt::format("output frequency must be above 0 and at most {} Hz",
                                         highest),
                             "RTDE", 1}));
        Queue(c, rtde::SetupOutputsAnswer(answer));
        return;
      }
      std::set<std::string> hidden;
      {
        std::lock_guard lock(mutex_);
        hidden = hidden_outputs_;
      }
      c->names = request->names;
      c->types.clear();
      bool all = true;
      for (const auto& name : request->names) {
        const auto t = rtde::OutputType(name);
        if (!t || hidden.count(name)) {
          answer.types.push_back("NOT_FOUND");
          all = false;
          continue;
        }
        answer.types.push_back(rtde::ValueTypeName(*t));
        c->types.push_back(*t);
      }
      answer.recipe = all ? 1 : 0;
      c->set_up = all;
      c->frequency = request->frequency_hz;
      {
        std::lock_guard lock(mutex_);
        frequency_hz_ = request->frequency_hz;
      }
      Queue(c, rtde::SetupOutputsAnswer(answer));
      return;
    }
    case rtde::Type::kStart: {
      Queue(c, rtde::Accepted(type, c->set_up));
      if (c->set_up && !c->streaming) {
        c->streaming = true;
        c->packages = 0;
        c->timer = std::make_unique<asio::steady_timer>(io_, std::chrono::steady_clock::now());
        StreamTick(c);
      }
      return;
    }
    case rtde::Type::kPause:
      c->streaming = false;
      if (c->timer) c->timer->cancel();
      Queue(c, rtde::Accepted(type, true));
      return;
    default:
      Queue(c, rtde::Text({fmt::format("package type {} not supported", package->type), "RTDE", 1}));
      return;
  }
}

int UrSimulator::RobotMode(const VirtualArm::State& s) const {
  return s.powered ? rtde::robot_mode::kRunning : rtde::robot_mode::kPowerOff;
}

int UrSimulator::SafetyMode(const VirtualArm::State& s) const {
  switch (s.stop) {
    case VirtualArm::Stop::kEmergency: return rtde::safety_mode::kRobotEmergencyStop;
    case VirtualArm::Stop::kProtective: return rtde::safety_mode::kProtectiveStop;
    case VirtualArm::Stop::kNone: break;
  }
  return rtde::safety_mode::kNormal;
}

std::vector<double> UrSimulator::OutputValue(const std::string& name,
                                             const VirtualArm::State& s) const {
  const auto vec = [](const Eigen::VectorXd& v) { return std::vector<double>(v.data(), v.data() + v.size()); };
  if (name == "actual_q") return vec(s.q);
  if (name == "actual_qd" || name == "target_qd") return vec(s.qd);
  if (name == "target_q") return vec(s.target);
  if (name == "robot_mode") return {static_cast<double>(RobotMode(s))};
  if (name == "safety_mode" || name == "safety_status") return {static_cast<double>(SafetyMode(s))};
  if (name == "runtime_state")
    return {static_cast<double>(s.moving ? rtde::runtime_state::kPlaying : rtde::runtime_state::kStopped)};
  if (name == "joint_mode") return std::vector<double>(6, 253.0);  // JOINT_RUNNING_MODE
  if (name == "robot_status_bits") return {s.powered ? 1.0 + (s.moving ? 2.0 : 0.0) : 0.0};
  if (name == "safety_status_bits") {
    return {s.stop == VirtualArm::Stop::kNone ? 1.0 : s.stop == VirtualArm::Stop::kProtective ? 4.0 : 128.0};
  }
  if (name == "speed_scaling" || name == "target_speed_fraction") return {1.0};
  return std::vector<double>(6, 0.0);  // actual_TCP_pose: not modelled
}

void UrSimulator::StreamTick(ConnectionPtr c) {
  if (c->closed || !c->streaming) return;
  const VirtualArm::State s = arm_->Now();
  // The controller's clock in whole periods of the recipe, a package every `step`: every
  // period, or every k-th when the time scale would send them faster than the wall allows.
  const double period = 1.0 / c->frequency;
  const double step = period * Thinning(c->frequency, arm_->clock().time_scale());
  if (c->packages == 0) c->first_stamp = std::floor(s.t / period) * period;
  // A package's stamp is the period its values were sampled in, as on the controller: a tick
  // later than a whole step (a loaded machine) leaves out the periods it missed, counted,
  // rather than sending values of now under an older stamp (a move would look faster than
  // the arm can go).
  const auto due = static_cast<int64_t>(std::floor((s.t - c->first_stamp) / step + 1e-9));
  const bool late = c->packages > 0 && due > c->packages;
  if (late) {
    rtde_skipped_ += static_cast<int>(due - c->packages);
    c->packages = due;
  }
  const double stamp = c->first_stamp + static_cast<double>(c->packages) * step;
  // The values of the period the stamp names, as the controller samples them: a moving arm's
  // motion at the stamp (what a drift added meanwhile kept from now), not at this tick's wall
  // time — a tick a step late would otherwise date a moving arm wrong by up to a step. An arm
  // at rest, turned by something else, or whose move began after the stamp is sampled now
  // (VirtualArm::At knows the controller's moves, not what else turned the arm before them).
  VirtualArm::State sampled = s;
  if (stamp < s.t && s.moving && stamp >= s.move_start) {
    const VirtualArm::Motion then = arm_->At(stamp), now = arm_->At(s.t);
    sampled.q = then.q + (s.q - now.q);
    sampled.qd = then.qd + (s.qd - now.qd);
  }
  std::vector<std::vector<double>> values;
  for (const auto& name : c->names)
    values.push_back(name == "timestamp" ? std::vector<double>{stamp} : OutputValue(name, sampled));
  Queue(c, rtde::EncodeData(1, c->types, values), true);
  ++c->packages;
  ++rtde_packages_;
  // The next period on the controller's clock: from the timer's own expiry while on time
  // (drift-free), from now after a late tick.
  if (late)
    c->timer->expires_at(std::chrono::steady_clock::now() + Wall(stamp + step - s.t));
  else
    c->timer->expires_at(c->timer->expiry() + Wall(step));
  c->timer->async_wait([this, c](const boost::system::error_code& ec) {
    if (!ec) StreamTick(c);
  });
}

// --- Primary / secondary -------------------------------------------------------------------

primary::KinematicsInfo UrSimulator::kinematics_info() const {
  std::lock_guard lock(mutex_);
  primary::KinematicsInfo k;
  for (int j = 0; j < 6; ++j) {
    k.dh_theta[j] = kinematics_.dh_theta_rad[j];
    k.dh_a[j] = kinematics_.dh_a_mm[j] / 1000.0;
    k.dh_d[j] = kinematics_.dh_d_mm[j] / 1000.0;
    k.dh_alpha[j] = kinematics_.dh_alpha_rad[j];
    k.checksum[j] = Checksum(k.dh_theta[j], k.dh_a[j], k.dh_d[j], k.dh_alpha[j]);
  }
  k.calibration_status = static_cast<uint32_t>(kinematics_.calibration_status);
  return k;
}

void UrSimulator::StateTick(ConnectionPtr c) {
  if (c->closed) return;
  const VirtualArm::State s = arm_->Now();
  primary::RobotState state;
  state.e_series = options_.e_series;
  state.mode.timestamp = Microseconds();
  state.mode.power_on = s.powered;
  state.mode.emergency_stopped = s.stop == VirtualArm::Stop::kEmergency;
  state.mode.protective_stopped = s.stop == VirtualArm::Stop::kProtective;
  state.mode.program_running = s.moving || program_.has_value();
  state.mode.robot_mode = static_cast<uint8_t>(RobotMode(s));
  for (int k = 0; k < 6 && k < s.q.size(); ++k) {
    state.joints.q_actual[k] = s.q(k);
    state.joints.q_target[k] = s.target(k);
    state.joints.qd_actual[k] = s.qd(k);
    state.joints.mode[k] = 253;
  }
  state.kinematics = kinematics_info();
  Queue(c, primary::EncodeRobotState(state), true);
  c->timer->expires_at(std::max(c->timer->expiry() + Wall(kStatePeriodS),
                                std::chrono::steady_clock::now()));
  c->timer->async_wait([this, c](const boost::system::error_code& ec) {
    if (!ec) StateTick(c);
  });
}

namespace {

// The blocks a URScript line opens (def, sec, thread, if, while: a header ending in ':') or
// closes (end), a comment left out; else and elif neither.
int BlockChange(const std::string& line) {
  std::string code = line.substr(0, line.find('#'));
  const auto first = code.find_first_not_of(" \t");
  if (first == std::string::npos) return 0;
  code = code.substr(first, code.find_last_not_of(" \t\r") - first + 1);
  auto word = [&](const char* w) {
    const std::size_t n = std::strlen(w);
    return code.compare(0, n, w) == 0 && (code.size() == n || !std::isalnum(static_cast<unsigned char>(code[n])));
  };
  if (word("end")) return -1;
  if (code.back() != ':' || word("else") || word("elif")) return 0;
  return word("def") || word("sec") || word("thread") || word("if") || word("while") ? 1 : 0;
}

bool StartsProgram(const std::string& line) {
  const auto first = line.find_first_not_of(" \t");
  return first != std::string::npos && (line.compare(first, 4, "def ") == 0 || line.compare(first, 4, "sec ") == 0);
}


}  // namespace

void UrSimulator::OnScript(const ConnectionPtr& c, const std::string& line) {
  if (c->program_depth > 0 || StartsProgram(line)) {  // a program: its lines until its end
    c->program += line + "\n";
    c->program_depth += BlockChange(line);
    if (c->program.size() > kMaxProgramBytes) {  // no end in sight: not a program it takes
      c->program.clear();
      c->program_depth = 0;
      Queue(c, primary::EncodeText(Microseconds(), primary::kRuntimeExceptionMessage,
                                   "compile error: the program does not end within 1 MiB"));
      return;
    }
    if (c->program_depth > 0) return;
    std::string text = std::move(c->program);
    c->program.clear();
    c->program_depth = 0;
    ++scripts_;
    StartProgram(c, text);
    return;
  }
  if (line.find_first_not_of(" \t") == std::string::npos) return;
  ++scripts_;
  bool remote = true;
  {
    std::lock_guard lock(mutex_);
    remote = remote_;
  }
  if (options_.e_series && !remote) {
    spdlog::debug("virtual UR: local control: script not run: {}", line);
    return;  // the real controller runs no program from the network in local control
  }
  std::string why;
  const auto move = ur::ParseMove(line, &why);
  if (!move) {
    Queue(c, primary::EncodeText(Microseconds(), primary::kRuntimeExceptionMessage,
                                 "compile error: " + why));
    return;
  }
  if (move->linear) return MoveLinear(c, *move);
  if (!arm_->MoveJ(move->joints_rad, move->a, move->v)) {
    Queue(c, primary::EncodeText(Microseconds(), primary::kTextMessage,
                                 "the program cannot start: the robot is stopped or powered off"));
  }
}

// movel to joint positions: the TCP (the flange: a one-line script sets no TCP) on a straight
// line to the pose the controller's kinematics give the joints, at v (m/s) with acceleration
// a (m/s²), the joints by the controller's inverse along it (simulation/path_motion.h, solved
// every 20 ms and interpolated between) and the last exactly the ones sent; planned on a
// thread of its own while RTDE streams the arm standing (a loaded machine's planning would
// otherwise stop the stream); a line the inverse cannot follow is refused as the real
// controller refuses it, with a runtime exception message, and the arm does not move.
void UrSimulator::MoveLinear(const ConnectionPtr& c, const ur::MoveCommand& move) {
  instruments::ControllerKinematics kinematics;
  {
    std::lock_guard lock(mutex_);
    kinematics = kinematics_;
  }
  LinearPathRequest request;
  request.start_rad = arm_->Now().q;  // a running move is replaced from where the arm is
  request.speed_mm_s = move.v * 1e3;
  request.acceleration_mm_s2 = move.a * 1e3;
  request.dt_s = kLinearStepS;
  request.solve_every = 5;
  if (planner_.joinable()) planner_.join();  // the move before (sent before it was planned)
  planner_ = std::thread([this, c, move, kinematics, request]() mutable {
    const programs::ControllerModel controller = UrControllerModel(kinematics);
    request.to_tcp = programs::TcpPose(controller, move.joints_rad, Eigen::Isometry3d::Identity());
    if (move.via_rad) {  // movec: through the via joints' flange position
      request.via_mm =
          programs::TcpPose(controller, *move.via_rad, Eigen::Isometry3d::Identity()).translation();
    }
    std::string why;
    auto path = LinearPath(controller, request, &why);
    if (path && (path->back() - move.joints_rad).cwiseAbs().maxCoeff() > 1e-6) {
      path.reset();
      why = "the target joints are not where the linear path ends (another configuration)";
    }
    std::string refused;
    if (!path) {
      refused = (move.circular ? "movec: " : "movel: ") + why;
    } else {
      path->back() = move.joints_rad;
      if (!arm_->MovePath(std::move(*path), kLinearStepS))
        refused = "the program cannot start: the robot is stopped or powered off";
    }
    if (refused.empty()) return;
    asio::post(io_, [this, c, refused] {
      Queue(c, primary::EncodeText(Microseconds(),
                                   refused.rfind("move", 0) == 0 ? primary::kRuntimeExceptionMessage
                                                                  : primary::kTextMessage,
                                   refused));
    });
  });
}

void UrSimulator::StartProgram(const ConnectionPtr& c, const std::string& text) {
  bool remote = true;
  instruments::ControllerKinematics kinematics;
  {
    std::lock_guard lock(mutex_);
    remote = remote_;
    kinematics = kinematics_;
  }
  if (options_.e_series && !remote) {
    spdlog::debug("virtual UR: local control: program not run");
    return;
  }
  auto refuse = [&](const std::string& why) {
    Queue(c, primary::EncodeText(Microseconds(), primary::kRuntimeExceptionMessage, why));
  };
  programs::Program program;
  try {
    program = programs::ParseUrScript({"<program>", text});
  } catch (const std::exception& e) {
    refuse(std::string("compile error: ") + e.what());
    return;
  }
  if (text.compare(text.find_first_not_of(" \t"), 4, "sec ") == 0 && !program.motions.empty()) {
    // A secondary program runs beside the main one and may not move the arm.
    refuse(fmt::format("line {}: a secondary program cannot move the robot", program.motions.front().place.line));
    return;
  }
  const VirtualArm::State now = arm_->Now();
  const Execution run = simulation::RunProgram(program, UrControllerModel(kinematics), now.q);
  if (!run.skipped.empty()) {
    refuse(fmt::format("line {}: {}", run.skipped.front().place.line, run.skipped.front().why));
    return;
  }
  // Its steps in the order written: the motions' targets, and the sleeps between them.
  std::vector<programs::Wait> sleeps;
  int line_no = 0;
  for (std::size_t at = 0; at < text.size();) {
    const std::size_t end = std::min(text.find('\n', at), text.size());
    const std::string line = text.substr(at, end - at);
    at = end + 1;
    ++line_no;
    const auto call = line.find("sleep(");
    if (call == std::string::npos || line.find_first_not_of(" \t") != call) continue;
    char* stop = nullptr;
    const double seconds = std::strtod(line.c_str() + call + 6, &stop);
    if (stop == line.c_str() + call + 6 || !(seconds >= 0.0)) {
      refuse(fmt::format("line {}: sleep takes a number of seconds here", line_no));
      return;
    }
    sleeps.push_back({{0, line_no}, seconds, ""});
  }
  if (now.stop != VirtualArm::Stop::kNone || !now.powered) {
    Queue(c, primary::EncodeText(Microseconds(), primary::kTextMessage,
                                 "the program cannot start: the robot is stopped or powered off"));
    return;
  }
  program_.emplace(StepsOf(run, sleeps));  // in place of one running
  ++programs_started_;
  ProgramTick();
}

void UrSimulator::ProgramTick() {
  if (!program_) return;
  const auto status = program_->Tick(*arm_, [&](const Eigen::VectorXd& q) { arm_->MoveJ(q, 1.4, 1.05); });
  if (status == ProgramPlayer::Status::kRunning) return;
  if (status == ProgramPlayer::Status::kFinished) ++programs_finished_;
  program_.reset();  // finished, or a stop ended it
}

// --- Dashboard ------------------------------------------------------------------------------

std::string UrSimulator::Dashboard(const ConnectionPtr&, const std::string& command) {
  const auto& v = options_.software;
  const bool e = options_.e_series;
  const bool named = e ? v.AtLeast(5, 6) : v.AtLeast(3, 12);
  const VirtualArm::State s = arm_->Now();
  if (command == "PolyscopeVersion")
    return fmt::format("URSoftware {} ({})", v.Text(), options_.build_date);
  if (command == "robotmode") return "Robotmode: " + rtde::RobotModeName(RobotMode(s));
  if (command == "safetymode") return "Safetymode: " + rtde::SafetyModeName(SafetyMode(s));
  if (command == "safetystatus" && e && v.AtLeast(5, 4))
    return "Safetystatus: " + rtde::SafetyModeName(SafetyMode(s));
  if (command == "is in remote control" && e && v.AtLeast(5, 6)) {
    std::lock_guard lock(mutex_);
    return remote_ ? "true" : "false";
  }
  if (command == "get robot model" && named) return options_.model;
  if (command == "get serial number" && named) return options_.serial;
  if (command == "close safety popup") return "closing safety popup";
  if (command == "unlock protective stop") {
    if (s.stop == VirtualArm::Stop::kProtective && arm_->SecondsSinceStop() < kUnlockAfterS) {
      return "Cannot unlock protective stop until 5s after occurrence. Always inspect cause of "
             "protective stop before unlocking";
    }
    arm_->ClearProtectiveStop();
    return "Protective stop releasing";
  }
  if (command == "power on") return arm_->PowerOn() ? "Powering on" : "Failed to execute: power on";
  if (command == "brake release") return "Brake releasing";
  const bool running = s.moving || program_.has_value();
  if (command == "running") return std::string("Program running: ") + (running ? "true" : "false");
  if (command == "programState") return running ? "PLAYING <unnamed>" : "STOPPED <unnamed>";
  if (command == "quit") return "Disconnected";
  return "Could not understand: '" + command + "'";
}

// --- Faults ---------------------------------------------------------------------------------

void UrSimulator::ProtectiveStopDuringNextMove(double fraction) {
  arm_->ProtectiveStopDuringNextMove(fraction);
}
void UrSimulator::UnlockProtectiveStopOnPendant() { arm_->ClearProtectiveStop(); }
void UrSimulator::PressEmergencyStop() { arm_->EmergencyStop(); }
void UrSimulator::ReleaseEmergencyStop() { arm_->ReleaseEmergencyStop(); }
void UrSimulator::PowerOnFromPendant() { arm_->PowerOn(); }
void UrSimulator::SetRemoteControl(bool remote) {
  std::lock_guard lock(mutex_);
  remote_ = remote;
}
void UrSimulator::RefuseRtdeVersion2(bool refuse) {
  std::lock_guard lock(mutex_);
  refuse_v2_ = refuse;
}
void UrSimulator::HideRtdeOutput(const std::string& name) {
  std::lock_guard lock(mutex_);
  hidden_outputs_.insert(name);
}
void UrSimulator::KeepMoving(int joint, double speed) { arm_->Drift(joint, speed); }
void UrSimulator::StopMoving() { arm_->StopDrifting(); }
void UrSimulator::MoveAfterNextMove(int joint, double speed, double delay_s, double for_s) {
  arm_->DriftAfterNextMove(joint, speed, delay_s, for_s);
}
void UrSimulator::SetKinematics(const instruments::ControllerKinematics& kinematics) {
  std::lock_guard lock(mutex_);
  kinematics_ = kinematics;
}

int UrSimulator::Thinning(double frequency_hz, double time_scale) {
  const double wall_period = std::max(time_scale, 1e-3) / frequency_hz;  // PhysicalClock's floor
  return static_cast<int>(std::ceil(std::max(1.0, kMinWallPeriodS / wall_period) - 1e-9));
}

double UrSimulator::frequency_hz() const {
  std::lock_guard lock(mutex_);
  return frequency_hz_;
}

void UrSimulator::DropConnections(std::chrono::milliseconds down_for) {
  {
    std::lock_guard lock(mutex_);
    down_until_ = std::chrono::steady_clock::now() + down_for;
  }
  std::promise<void> done;
  auto closed = done.get_future();
  asio::post(io_, [this, &done] {
    for (const auto& c : std::set<ConnectionPtr>(live_)) Close(c);
    done.set_value();
  });
  closed.wait();
}

}  // namespace armsig::simulation
