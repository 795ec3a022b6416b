#include "simulation/kuka_simulator.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>

#include "calibration/model.h"
#include "simulation/kuka_contract_files.h"  // generated: kKukaConfigGlobals

namespace armsig::simulation {

namespace asio = boost::asio;
namespace kuka = robots::kuka;
namespace contract = robots::kuka::contract;
namespace sv = robots::kuka::system_variable;
using tcp = asio::ip::tcp;

struct KukaSimulator::Connection : FramedPeer {
  explicit Connection(asio::io_context& io) : FramedPeer(io, kuka::kRequestFrames) {}
  bool flooding = false;  // one flood at a time
};

namespace {

constexpr double kRadPerDeg = std::numbers::pi / 180.0;
constexpr auto kInterpreterCycle = std::chrono::milliseconds(12);  // KR C4's IPO cycle

// A REAL as the controller keeps it (32-bit float) and shows it.
std::string Real(double v) { return kuka::FormatReal(static_cast<float>(v)); }

std::string E6Axis(const Eigen::VectorXd& a, const Eigen::VectorXd& e) {
  std::string out = "{E6AXIS: ";
  for (int i = 0; i < 6; ++i) out += "A" + std::to_string(i + 1) + " " + Real(a(i)) + ", ";
  for (int i = 0; i < 6; ++i)
    out += "E" + std::to_string(i + 1) + " " + Real(e(i)) + (i < 5 ? ", " : "}");
  return out;
}

std::string Quoted(const std::string& s) { return "\"" + s + "\""; }

std::string Upper(std::string s) {
  for (char& c : s) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  return s;
}

}  // namespace

KukaSimulator::KukaSimulator(VirtualLab& lab, std::string host, unsigned short port,
                             KukaSimulatorOptions options)
    : lab_(lab),
      host_(std::move(host)),
      port_(port),
      address_(host_ + ":" + std::to_string(port)),
      options_(std::move(options)),
      axes_(lab.model().num_joints()) {
  if (axes_ > 6) throw std::invalid_argument("a KUKA controller drives at most 6 robot axes");
  const double kr16_velocity[] = {156, 156, 156, 330, 330, 615};  // KR 16-2, deg/s
  vmax_ = options_.max_velocity_deg_s;
  if (vmax_.empty()) vmax_.assign(std::begin(kr16_velocity), std::end(kr16_velocity));
  amax_ = options_.max_acceleration_deg_s2;
  if (amax_.empty())
    for (double v : vmax_) amax_.push_back(v / 0.4);  // full speed in 0.4 s
  limits_ = options_.software_limits_deg;
  const auto& model = lab.model();
  for (int i = static_cast<int>(limits_.size()); i < 6; ++i) {
    if (i < axes_ && static_cast<int>(model.joint_min_rad.size()) > i)
      limits_.emplace_back(model.joint_min_rad[i] / kRadPerDeg, model.joint_max_rad[i] / kRadPerDeg);
    else
      limits_.emplace_back(-350.0, 350.0);
  }
  if (vmax_.size() < 6 || amax_.size() < 6)
    throw std::invalid_argument("virtual KUKA: velocities and accelerations for 6 axes");
  // The globals a controller set up from controllers/kuka/config_globals.dat declares.
  for (const auto& d : kuka::ParseDeclarations(kKukaConfigGlobals))
    globals_[d.name] = {d.type, d.value};
  Eigen::VectorXd home = options_.home_rad;
  if (home.size() != axes_) home = lab.Joints();
  if (home.size() != axes_) home = Eigen::VectorXd::Zero(axes_);
  arm_ = std::make_unique<VirtualArm>(lab, PhysicalClock(options_.time_scale), home);
  joints_deg_ = Eigen::VectorXd::Zero(6);
  joints_deg_.head(axes_) = home / kRadPerDeg;
  mode_ = options_.mode;
  if (!options_.program_running) program_state_ = "P_RESET";
  controller_ = programs::NominalController(model, programs::ControllerKind::kKuka, "nominal " + options_.trafo_name);
  for (auto& [name, g] : globals_)
    if (g.type == "CHAR" && g.text.empty()) g.text = Quoted("");
}

KukaSimulator::~KukaSimulator() { Stop(); }

// --- The server -------------------------------------------------------------------------

void KukaSimulator::Start() {
  acceptor_ = ListenTcp(io_, host_, port_, "virtual KUKA controller");
  port_ = acceptor_->local_endpoint().port();
  address_ = host_ + ":" + std::to_string(port_);
  work_.emplace(asio::make_work_guard(io_));
  tick_ = std::make_unique<asio::steady_timer>(io_);
  StartAccept();
  Tick();
  thread_ = std::thread([this] { io_.run(); });
}

void KukaSimulator::Stop() {
  if (!thread_.joinable()) return;
  asio::post(io_, [this] {
    boost::system::error_code ignored;
    if (acceptor_) acceptor_->close(ignored);
    if (tick_) tick_->cancel();
    for (auto& w : clients_)
      if (auto c = w.lock()) c->Close();
    work_.reset();
  });
  io_.stop();
  thread_.join();
  boost::system::error_code ignored;
  if (acceptor_) acceptor_->close(ignored);
  for (auto& w : clients_)
    if (auto c = w.lock()) c->Close();
}

void KukaSimulator::ClearFaults() {
  faults_.Clear();
  ++flood_generation_;
}

void KukaSimulator::DropConnections() {
  asio::post(io_, [this] {
    for (auto& w : clients_)
      if (auto c = w.lock()) c->Close();
  });
}

void KukaSimulator::SetReachable(bool reachable) {
  reachable_ = reachable;
  if (!reachable) DropConnections();
}

void KukaSimulator::Tick() {
  {
    std::lock_guard lock(mutex_);
    Advance();
  }
  tick_->expires_after(kInterpreterCycle);
  tick_->async_wait([this](const boost::system::error_code& ec) {
    if (!ec) Tick();
  });
}

void KukaSimulator::StartAccept() {
  auto c = std::make_shared<Connection>(io_);
  acceptor_->async_accept(c->socket, [this, c](const boost::system::error_code& ec) {
    if (ec) {
      if (ec != asio::error::operation_aborted && acceptor_->is_open()) StartAccept();
      return;
    }
    if (!reachable_) {
      c->Close();
    } else {
      ++connections_;
      boost::system::error_code ignored;
      c->socket.set_option(tcp::no_delay(true), ignored);
      std::erase_if(clients_, [](const std::weak_ptr<Connection>& w) { return w.expired(); });
      clients_.push_back(c);
      StartRead(c);
    }
    StartAccept();
  });
}

void KukaSimulator::StartRead(std::shared_ptr<Connection> c) {
  // KukaVarProxy reads on past bytes it cannot split and answers nothing for them.
  FramedPeer::ReadFrames(c, "virtual KUKA controller",
                         [this, c](const std::string& frame) { OnFrame(c, frame); });
}

void KukaSimulator::OnFrame(const std::shared_ptr<Connection>& c, const std::string& frame) {
  ++requests_;
  const FaultSpec fault = faults_.Next();
  if (fault.fault == Fault::kVanish) {
    c->Close();
    return;
  }
  if (fault.fault == Fault::kFloodBytes || fault.fault == Fault::kFloodLines) {
    if (!c->flooding) {
      c->flooding = true;
      Flood(c, fault.fault == Fault::kFloodLines, 0, flood_generation_.load());
    }
    return;
  }
  const kuka::DecodedRequest decoded = kuka::DecodeRequest(frame);
  if (!decoded.request) {
    spdlog::debug("virtual KUKA: no answer to a frame that is no request: {}", decoded.why);
    return;  // the server may leave unknown or incorrect requests unanswered (C3 §3)
  }
  const kuka::Request& r = *decoded.request;
  kuka::Response a{r.tag, static_cast<uint8_t>(r.type), "", 1, true};
  {
    std::lock_guard lock(mutex_);
    Advance();
    if (r.type == kuka::MessageType::kRead) {
      if (fault.fault == Fault::kOtherReply) {
        a.value = ReadVariable(Upper(r.name) == sv::kRobStopped ? sv::kModeOp : sv::kRobStopped,
                               false)
                      .value_or("");
      } else {
        // KukaVarProxy: an unknown variable is an empty value, success 1.
        a.value = ReadVariable(Upper(r.name), fault.fault == Fault::kOutOfRange).value_or("");
      }
    } else {
      a.value = r.value;
      a.success = WriteVariable(Upper(r.name), r.value);
      if (!a.success) a.error_code = 0;
      Advance();
    }
  }
  if (fault.fault == Fault::kDropReply) return;
  if (fault.fault == Fault::kErrorCode) {
    a.success = false;
    a.error_code = 0;
  }
  const auto latency = std::chrono::microseconds(
      static_cast<int64_t>(std::llround(options_.latency.count() * options_.time_scale)));
  std::string bytes = kuka::EncodeResponse(a);
  std::vector<Step> steps;
  switch (fault.fault) {
    case Fault::kNoiseBytes:
      bytes = std::string("\x13\xfe~#garbage\r\n\x07", 13) + bytes;
      break;
    case Fault::kTruncateReply:
      bytes.resize(bytes.size() / 2);
      break;
    case Fault::kMalformed:
      bytes[6] = static_cast<char>(0x7F);  // the value length's low byte: runs past the frame
      bytes[5] = static_cast<char>(0x10);
      break;
    case Fault::kWrongTrid: {
      kuka::Response stale = a;
      stale.tag = static_cast<uint16_t>(a.tag - 1);
      stale.value = "{E6AXIS: A1 0.0}";
      steps.push_back({latency, kuka::EncodeResponse(stale)});
      break;
    }
    default:
      break;
  }
  steps.push_back({latency, std::move(bytes)});
  TcpPeer::Send(c, std::move(steps));
}

void KukaSimulator::Flood(std::shared_ptr<Connection> c, bool frames, int64_t k,
                          uint64_t generation) {
  if (c->closed || generation != flood_generation_.load()) {
    c->flooding = false;
    return;
  }
  auto data = std::make_shared<std::string>();
  if (frames) {  // well-formed answers, none with a tag anyone waits for
    while (data->size() < 4096)
      *data += kuka::EncodeResponse({static_cast<uint16_t>(0xF000 + k % 0x0FFF), 0, "TRUE", 1, true});
  } else {
    data->resize(4096);
    uint32_t x = static_cast<uint32_t>(k) * 2654435761u + 12345u;
    for (char& ch : *data) {
      x = x * 1664525u + 1013904223u;
      ch = static_cast<char>(x >> 24);
    }
  }
  asio::async_write(c->socket, asio::buffer(*data),
                    [this, c, data, frames, k, generation](const boost::system::error_code& ec,
                                                           size_t n) {
                      flood_bytes_ += static_cast<int64_t>(n);
                      if (ec) {
                        c->flooding = false;
                        return;
                      }
                      Flood(c, frames, k + 1, generation);
                    });
}

// --- The controller -----------------------------------------------------------------------

KukaSimulator::MovePlan KukaSimulator::Plan(const Eigen::VectorXd& from_deg,
                                            const Eigen::VectorXd& to_deg, int velocity_percent,
                                            int acceleration_percent) const {
  MovePlan plan;
  for (int i = 0; i < axes_; ++i) {
    const double d = std::abs(to_deg(i) - from_deg(i));
    const double v = vmax_[i] * velocity_percent / 100.0;
    const double a = amax_[i] * acceleration_percent / 100.0;
    // Trapezoid when the axis reaches its velocity (d ≥ v²/a), else a triangle.
    const bool trapezoid = d >= v * v / a;
    const double t = trapezoid ? d / v + v / a : 2.0 * std::sqrt(d / a);
    if (t > plan.seconds) plan = {t, trapezoid ? v / a : t / 2.0};
  }
  return plan;
}

double KukaSimulator::MoveSeconds(const Eigen::VectorXd& from_deg, const Eigen::VectorXd& to_deg,
                                  int velocity_percent, int acceleration_percent) const {
  return Plan(from_deg, to_deg, velocity_percent, acceleration_percent).seconds;
}

// A synchronous PTP: every axis on the slowest one's time and ramps. The arm's joint move
// runs the joint that turns farthest on a trapezoid of speed v and acceleration a; these give
// it the PTP's duration T and ramp r (v = D / (T − r), a = v / r), and the other axes follow
// in proportion, as in the PTP.
bool KukaSimulator::Ptp(const Eigen::VectorXd& target_rad, int velocity_percent, int acceleration_percent) {
  const Eigen::VectorXd from = arm_state_.q;
  Eigen::VectorXd from_deg = Eigen::VectorXd::Zero(6);
  from_deg.head(axes_) = from / kRadPerDeg;
  Eigen::VectorXd to_deg = from_deg;
  to_deg.head(axes_) = target_rad / kRadPerDeg;
  const MovePlan plan = Plan(from_deg, to_deg, velocity_percent, acceleration_percent);
  last_move_seconds_ = plan.seconds;
  const double distance = (target_rad - from).cwiseAbs().maxCoeff();
  if (!(distance > 0.0) || !(plan.seconds > 0.0) || !(plan.ramp > 0.0)) return false;
  const double v = distance / (plan.seconds - plan.ramp);
  return arm_->MoveJ(target_rad, v / plan.ramp, v);
}

void KukaSimulator::Issue() {
  Command& c = *command_;
  const bool turn = (c.target_rad - arm_state_.q).cwiseAbs().maxCoeff() > 0.0;
  // Nothing to move: done on the next cycle.
  c.issued = Ptp(c.target_rad, c.velocity, c.acceleration) || !turn;
}

void KukaSimulator::Halt(HaltKind kind) {
  switch (kind) {
    case HaltKind::kEmergency:
      arm_->EmergencyStop();
      break;
    case HaltKind::kSafety:
      arm_->ProtectiveStop();
      break;
    case HaltKind::kStopKey:  // brakes along the path and stands, no stop to clear
      arm_->ProtectiveStop();
      arm_->ClearProtectiveStop();
      break;
  }
  if (command_ && command_->issued) {
    command_->issued = false;
    ++halts_;
  }
  Advance();
}

void KukaSimulator::Advance() {
  arm_state_ = arm_->Now();
  joints_deg_.head(axes_) = arm_state_.q / kRadPerDeg;
  AdvanceRunner();
  // The PTP has ended (a halt un-issues it): the interpolator is done, so WAIT SEC 0 lets
  // ARMSIG go on, whatever moves the arm afterwards.
  if (command_ && command_->issued && !arm_state_.moving &&
      arm_state_.stop == VirtualArm::Stop::kNone) {
    SetGlobal(contract::kDone, command_->number);
    command_.reset();
  }
  if (program_state_ != "P_ACTIVE" || program_ != contract::kProgram) return;
  if (fresh_start_) {  // ARMSIG's first lines
    fresh_start_ = false;
    SetGlobal(contract::kContractVersion, contract::kVersion);
    const int64_t cmd = GlobalInt(contract::kCommand);
    if (cmd != GlobalInt(contract::kDone)) {
      SetGlobal(contract::kResult, contract::kNotExecuted);
      SetGlobal(contract::kBusy, cmd);
      SetGlobal(contract::kDone, cmd);
    }
  }
  if (!command_ && GlobalInt(contract::kCommand) != GlobalInt(contract::kDone)) TakeCommand();
}

void KukaSimulator::TakeCommand() {
  const int64_t n = GlobalInt(contract::kCommand);
  SetGlobal(contract::kBusy, n);
  const auto target = kuka::ParseAxes(globals_.at(contract::kTarget).text, 6);
  Eigen::VectorXd goal = joints_deg_;
  if (target) goal.head(axes_) = target->head(axes_);
  int result = contract::kReached;
  for (int i = 0; i < axes_; ++i)
    if (goal(i) < limits_[i].first || goal(i) > limits_[i].second)
      result = contract::kBeyondSoftwareLimit;
  const int64_t vel = GlobalInt(contract::kVelocity), acc = GlobalInt(contract::kAcceleration);
  if (vel < 1 || vel > 100 || acc < 1 || acc > 100) result = contract::kVelocityOutOfRange;
  SetGlobal(contract::kResult, result);
  if (result != contract::kReached) {
    ++refused_;
    SetGlobal(contract::kDone, n);
    return;
  }
  Command c;
  c.number = n;
  c.target_rad = goal.head(axes_) * kRadPerDeg;
  c.velocity = static_cast<int>(vel);
  c.acceleration = static_cast<int>(acc);
  command_ = c;
  ++moves_;
  Issue();
  Advance();  // a move of no time is done at once
}

int64_t KukaSimulator::GlobalInt(const std::string& name) const {
  return kuka::ParseInt(globals_.at(name).text).value_or(0);
}

void KukaSimulator::SetGlobal(const std::string& name, int64_t value) {
  globals_.at(name).text = std::to_string(value);
}

std::optional<std::string> KukaSimulator::ReadVariable(const std::string& name,
                                                       bool out_of_range) {
  auto flag = [](bool b) { return kuka::FormatBool(b); };
  if (name == "PING") return "PONG";
  if (name == sv::kAxisAct) {
    Eigen::VectorXd a = joints_deg_;
    if (out_of_range) a(0) = 1000.0;
    return E6Axis(a, Eigen::VectorXd::Zero(6));
  }
  if (name == sv::kPosAct) {
    // The flange by the controller's own (nominal) kinematics, in $ROBROOT = $BASE.
    calibration::Kinematics kin(lab_.model());
    const Eigen::VectorXd q = joints_deg_.head(axes_) * kRadPerDeg;
    const Eigen::Vector3d p = kin.Position(
        Eigen::Isometry3d::Identity(), Eigen::VectorXd::Zero(lab_.model().num_parameters()),
        q.data());
    const Eigen::Matrix3d r = kin.LastRotation();
    // KUKA's A, B, C: rotations about Z, then the new Y, then the newest X.
    const double b = std::asin(std::clamp(-r(2, 0), -1.0, 1.0));
    const double a = std::atan2(r(1, 0), r(0, 0)), c = std::atan2(r(2, 1), r(2, 2));
    return "{E6POS: X " + Real(p.x()) + ", Y " + Real(p.y()) + ", Z " + Real(p.z()) + ", A " +
           Real(a / kRadPerDeg) + ", B " + Real(b / kRadPerDeg) + ", C " + Real(c / kRadPerDeg) +
           ", S 2, T 10, E1 0.0, E2 0.0, E3 0.0, E4 0.0, E5 0.0, E6 0.0}";
  }
  if (name == sv::kModeOp) return "#" + mode_;
  if (name == sv::kProState) return "#" + program_state_;
  if (name == sv::kProName) return Quoted(program_.empty() ? "" : "/R1/" + program_ + ".SRC");
  if (name == sv::kStopMess) return flag(stop_message_);
  if (name == sv::kAlarmStop) return flag(alarm_stop_);
  if (name == sv::kUserSaf) return flag(user_saf_);
  if (name == sv::kPeriRdy) return flag(drives_on_ && arm_state_.powered);
  if (name == sv::kRobStopped)  // every axis at standstill, whatever turns it
    return flag(!arm_state_.moving && arm_state_.qd.cwiseAbs().maxCoeff() == 0.0);
  if (name == sv::kRobName) return Quoted(options_.robot_name);
  if (name == sv::kSerialNo) return std::to_string(options_.serial);
  if (name == sv::kTrafoName) return Quoted(options_.trafo_name);
  if (name == sv::kSoftware) return Quoted(options_.software);
  if (name == "$OV_PRO") return "100";
  const auto g = globals_.find(name);
  if (g != globals_.end()) return g->second.text;
  return std::nullopt;
}

bool KukaSimulator::WriteVariable(const std::string& name, const std::string& value) {
  const auto g = globals_.find(name);
  if (g == globals_.end()) return false;  // system variables are read-only here
  if (g->second.type == "INT") {
    const auto v = kuka::ParseInt(value);
    if (!v) return false;
    g->second.text = std::to_string(*v);
    return true;
  }
  if (g->second.type == "CHAR") {  // NAME[] = "text"
    const auto text = kuka::ParseString(value);
    if (!text || text->size() > 24) return false;
    g->second.text = Quoted(*text);
    return true;
  }
  if (g->second.type == "E6AXIS") {
    // A (partial) aggregate: the components given change, the others stay (KRL assignment).
    const auto s = kuka::ParseStructure(value);
    if (!s || (!s->type.empty() && s->type != "E6AXIS" && s->type != "AXIS")) return false;
    const auto now = kuka::ParseStructure(g->second.text);
    Eigen::VectorXd a(6), e(6);
    for (int i = 0; i < 6; ++i) {
      for (auto [vec, letter] : {std::pair{&a, 'A'}, std::pair{&e, 'E'}}) {
        const std::string component = std::string(1, letter) + std::to_string(i + 1);
        const std::string* old = now ? now->Find(component) : nullptr;
        (*vec)(i) = old ? kuka::ParseReal(*old).value_or(0.0) : 0.0;
      }
    }
    for (const auto& [component, text] : s->components) {
      const auto v = kuka::ParseReal(text);
      if (!v || component.size() != 2 || (component[0] != 'A' && component[0] != 'E') ||
          component[1] < '1' || component[1] > '6')
        return false;
      (component[0] == 'A' ? a : e)(component[1] - '1') = *v;
    }
    g->second.text = E6Axis(a, e);
    return true;
  }
  return false;
}

// --- The cell ----------------------------------------------------------------------------

void KukaSimulator::PressEmergencyStop() {
  std::lock_guard lock(mutex_);
  Halt(HaltKind::kEmergency);
  alarm_stop_ = false;
  stop_message_ = true;
  drives_on_ = false;
  if (program_state_ == "P_ACTIVE") program_state_ = "P_STOP";
}

void KukaSimulator::ReleaseEmergencyStop() {
  std::lock_guard lock(mutex_);
  alarm_stop_ = true;
  arm_->ReleaseEmergencyStop();
}

void KukaSimulator::OpenSafetyGate() {
  std::lock_guard lock(mutex_);
  user_saf_ = false;
  if (!Automatic()) return;  // operator safety is not active in T1 and T2
  Halt(HaltKind::kSafety);
  stop_message_ = true;
  if (program_state_ == "P_ACTIVE") program_state_ = "P_STOP";
}

void KukaSimulator::CloseSafetyGate() {
  std::lock_guard lock(mutex_);
  user_saf_ = true;
}

void KukaSimulator::Acknowledge() {
  std::lock_guard lock(mutex_);
  if (!alarm_stop_ || (!user_saf_ && Automatic())) return;  // its cause is still there
  stop_message_ = false;
  arm_->ClearProtectiveStop();
}

void KukaSimulator::StartProgram() {
  std::lock_guard lock(mutex_);
  if (stop_message_ || program_.empty() || program_state_ == "P_ACTIVE") return;
  if (!arm_->PowerOn()) return;  // drives on: not while an EMERGENCY STOP is pressed
  drives_on_ = true;
  program_state_ = "P_ACTIVE";
  Advance();
  if (command_ && !command_->issued) Issue();  // the halted PTP goes on to its target
  Advance();
}

void KukaSimulator::StopProgram() {
  std::lock_guard lock(mutex_);
  Halt(HaltKind::kStopKey);
  if (program_state_ == "P_ACTIVE") program_state_ = "P_STOP";
}

void KukaSimulator::SwitchDrivesOff() {
  std::lock_guard lock(mutex_);
  Halt(HaltKind::kStopKey);
  drives_on_ = false;
  if (program_state_ == "P_ACTIVE") program_state_ = "P_STOP";
}

void KukaSimulator::SetMode(const std::string& mode) {
  std::lock_guard lock(mutex_);
  if (mode == mode_) return;
  Halt(HaltKind::kStopKey);
  mode_ = mode;
  drives_on_ = false;
  if (program_state_ == "P_ACTIVE") program_state_ = "P_STOP";
}

void KukaSimulator::SelectProgram(const std::string& name) {
  std::lock_guard lock(mutex_);
  Halt(HaltKind::kStopKey);
  command_.reset();  // deselecting cancels the interrupted motion
  program_ = name;
  program_state_ = name.empty() ? "P_FREE" : "P_RESET";
  fresh_start_ = true;
}

void KukaSimulator::CommandMove(const Eigen::VectorXd& target_deg, int velocity_percent) {
  std::lock_guard lock(mutex_);
  Eigen::VectorXd full = joints_deg_;
  full.head(target_deg.size()) = target_deg;
  globals_.at(contract::kTarget).text = E6Axis(full, Eigen::VectorXd::Zero(6));
  SetGlobal(contract::kVelocity, velocity_percent);
  SetGlobal(contract::kCommand,
            std::max(GlobalInt(contract::kCommand), GlobalInt(contract::kDone)) + 1);
  Advance();
}

KukaSimulator::Snapshot KukaSimulator::snapshot() const {
  std::lock_guard lock(mutex_);
  Snapshot s;
  const VirtualArm::State now = arm_->Now();
  s.joints_deg = now.q / kRadPerDeg;
  s.moving = now.moving;
  s.halted = command_ && !command_->issued;
  s.cmd = GlobalInt(contract::kCommand);
  s.busy = GlobalInt(contract::kBusy);
  s.done = GlobalInt(contract::kDone);
  s.result = GlobalInt(contract::kResult);
  s.version = GlobalInt(contract::kContractVersion);
  s.moves = moves_;
  s.refused = refused_;
  s.halts = halts_;
  s.mode = mode_;
  s.program_state = program_state_;
  s.program = program_;
  s.last_move_seconds = last_move_seconds_;
  s.runs = runs_;
  s.last_run_refusal = last_run_refusal_;
  return s;
}

}  // namespace armsig::simulation
