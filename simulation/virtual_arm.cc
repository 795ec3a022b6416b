#include "simulation/virtual_arm.h"

#include <algorithm>

namespace armsig::simulation {

namespace {
constexpr double kEmergencyDeceleration = 10.0;  // rad/s², stop category 1
constexpr double kMinProtectiveDeceleration = 2.0;
}  // namespace

VirtualArm::VirtualArm(VirtualLab& lab, PhysicalClock clock, Eigen::VectorXd home)
    : lab_(lab), clock_(clock), rest_(std::move(home)) {
  pushed_ = rest_;
  drift_offset_ = Eigen::VectorXd::Zero(rest_.size());
  lab_.SetJoints(rest_);
}

VirtualArm::Motion VirtualArm::SampledPath::At(double tau) const {
  const double clamped = std::clamp(tau, 0.0, duration());
  const auto i = std::min(static_cast<size_t>(clamped / dt), q.size() - 2);
  const double f = (clamped - dt * static_cast<double>(i)) / dt;
  Motion m{q[i] + f * (q[i + 1] - q[i]), (q[i + 1] - q[i]) / dt};
  if (tau >= duration() || tau <= 0.0) m.qd.setZero();
  return m;
}

bool VirtualArm::MovePath(std::vector<Eigen::VectorXd> joints, double dt) {
  if (joints.size() < 2 || !(dt > 0.0)) return false;
  std::lock_guard lock(mutex_);
  const double t = clock_.Now();
  const State now = StateAt(t);
  if (stop_ != Stop::kNone || !powered_) return false;
  if (move_) {
    if (!halt_at_) Remember(move_start_, t, *move_);
    moving_s_ += t - move_start_;
    move_.reset();
  }
  if (path_) {
    past_.push_back({path_->start, t, JointMove(rest_, rest_, 1.0, 1.0),
                     std::make_shared<const SampledPath>(*path_)});
    moving_s_ += t - path_->start;
    path_.reset();
  }
  rest_ = now.q;
  drift_offset_.setZero();
  drift_joint_.reset();
  drift_until_.reset();
  path_ = SampledPath{t, dt, std::move(joints)};
  ++moves_;
  return true;
}

VirtualArm::State VirtualArm::StateAt(double t) {
  State s;
  s.t = t;
  s.q = rest_;
  s.qd = Eigen::VectorXd::Zero(rest_.size());
  s.target = rest_;
  if (path_) {
    const double tau = t - path_->start;
    if (stop_ != Stop::kNone) {  // held where the stop found it
      rest_ = path_->At(std::min(tau, stopped_at_ - path_->start)).q;
      moving_s_ += std::max(0.0, stopped_at_ - path_->start);
      path_.reset();
      s.q = rest_;
    } else if (tau >= path_->duration()) {
      rest_ = path_->q.back();
      moving_s_ += path_->duration();
      past_.push_back({path_->start, path_->start + path_->duration(), JointMove(rest_, rest_, 1.0, 1.0),
                       std::make_shared<const SampledPath>(*path_)});
      if (past_.size() > 256) past_.pop_front();
      path_.reset();
      s.q = rest_;
      s.target = rest_;
    } else {
      const Motion m = path_->At(tau);
      s.q = m.q;
      s.qd = m.qd;
      s.target = path_->q.back();
      s.moving = true;
      s.move_start = path_->start;
    }
    s.stop = stop_;
    s.powered = powered_;
    return s;
  }
  if (move_) {
    const double tau = t - move_start_;
    if (stop_at_ && !halt_at_ && t >= *stop_at_) {
      // The planned stop (a collision) happens now, at its own moment of the move.
      halt_at_ = *stop_at_ - move_start_;
      halt_deceleration_ = std::max(halt_deceleration_, kMinProtectiveDeceleration);
      stop_ = Stop::kProtective;
      stopped_at_ = *stop_at_;
      ++stops_;
      stop_at_.reset();
    }
    if (halt_at_) {
      const double until = move_->BrakedUntil(*halt_at_, halt_deceleration_);
      const JointMove::PathPoint p = move_->Braked(*halt_at_, halt_deceleration_, tau);
      s.q = move_->PositionAlong(p.s);
      if (tau >= until) {
        rest_ = s.q;
        moving_s_ += until;
        move_.reset();
        halt_at_.reset();
      } else {
        s.qd = move_->VelocityAlong(p.ds);
        s.target = move_->to();
        s.moving = true;
        s.move_start = move_start_;
      }
    } else if (tau >= move_->duration_s()) {
      Remember(move_start_, move_start_ + move_->duration_s(), *move_);
      rest_ = move_->to();
      s.q = rest_;
      moving_s_ += move_->duration_s();
      if (pending_drift_) {  // something moves the arm once it stands
        drift_joint_ = pending_drift_->joint;
        drift_speed_ = pending_drift_->speed;
        drift_since_ = move_start_ + move_->duration_s() + pending_drift_->delay;
        drift_until_ = drift_since_ + pending_drift_->duration;
        pending_drift_.reset();
      }
      move_.reset();
    } else {
      s.q = move_->PositionAt(tau);
      s.qd = move_->VelocityAt(tau);
      s.target = move_->to();
      s.moving = true;
      s.move_start = move_start_;
    }
    if (!move_) s.target = rest_;
  }
  if (drift_joint_ && drift_until_ && t >= *drift_until_) EndDrift(*drift_until_);
  s.q += drift_offset_;
  if (drift_joint_ && t > drift_since_) {
    s.q(*drift_joint_) += drift_speed_ * (t - drift_since_);
    s.qd(*drift_joint_) += drift_speed_;
  }
  s.stop = stop_;
  s.powered = powered_;
  return s;
}

void VirtualArm::Remember(double start, double end, const JointMove& move) {
  constexpr size_t kKept = 256;
  past_.push_back({start, end, move, nullptr});
  if (past_.size() > kKept) past_.pop_front();
}

VirtualArm::Motion VirtualArm::At(double t) const {
  std::lock_guard lock(mutex_);
  const auto zero = Eigen::VectorXd::Zero(rest_.size());
  if (path_ && t >= path_->start) return path_->At(t - path_->start);
  if (move_ && t >= move_start_) {
    const double tau = t - move_start_;
    if (halt_at_ && tau >= *halt_at_) {
      const JointMove::PathPoint p = move_->Braked(*halt_at_, halt_deceleration_, tau);
      return {move_->PositionAlong(p.s), move_->VelocityAlong(p.ds)};
    }
    if (tau >= move_->duration_s()) return {move_->to(), zero};
    return {move_->PositionAt(tau), move_->VelocityAt(tau)};
  }
  for (auto it = past_.rbegin(); it != past_.rend(); ++it) {
    if (t < it->start) continue;
    if (it->path) {
      Motion m = it->path->At(std::min(t, it->end) - it->start);
      if (t >= it->end) m.qd.setZero();
      return m;
    }
    if (t >= it->end) return {it->move.PositionAt(it->end - it->start), zero};
    return {it->move.PositionAt(t - it->start), it->move.VelocityAt(t - it->start)};
  }
  return {rest_, zero};
}

VirtualArm::State VirtualArm::Now() {
  std::lock_guard lock(mutex_);
  State s = StateAt(clock_.Now());
  if (s.q != pushed_) {
    pushed_ = s.q;
    lab_.SetJoints(s.q);
  }
  return s;
}

bool VirtualArm::MoveJ(const Eigen::VectorXd& target, double a, double v) {
  std::lock_guard lock(mutex_);
  const double t = clock_.Now();
  const State now = StateAt(t);
  if (stop_ != Stop::kNone || !powered_) return false;
  // A move starts from where the arm stands (one still running ends where it is).
  if (path_) {
    past_.push_back({path_->start, t, JointMove(rest_, rest_, 1.0, 1.0),
                     std::make_shared<const SampledPath>(*path_)});
    moving_s_ += t - path_->start;
    path_.reset();
  }
  if (move_) {
    if (!halt_at_) Remember(move_start_, t, *move_);
    moving_s_ += t - move_start_;
    move_.reset();
  }
  // Whatever turned a joint meanwhile is where the move starts from; the controller's move
  // takes the arm from it (another program's motion ends).
  rest_ = now.q;
  drift_offset_.setZero();
  drift_joint_.reset();
  drift_until_.reset();
  move_.emplace(rest_, target, a, v);
  move_start_ = t;
  halt_at_.reset();
  halt_deceleration_ = a;
  stop_at_.reset();
  if (stop_fraction_) {
    stop_at_ = t + *stop_fraction_ * move_->duration_s();
    stop_fraction_.reset();
  }
  ++moves_;
  return true;
}

void VirtualArm::Halt(double t, double deceleration, Stop why) {
  StateAt(t);  // settles a move that has ended
  if (move_ && !halt_at_) {
    halt_at_ = t - move_start_;
    halt_deceleration_ = deceleration;
  }
  stop_at_.reset();
  if (stop_ != why) ++stops_;
  stop_ = why;
  stopped_at_ = t;
}

void VirtualArm::ProtectiveStop() {
  std::lock_guard lock(mutex_);
  if (stop_ == Stop::kEmergency) return;
  Halt(clock_.Now(), std::max(halt_deceleration_, kMinProtectiveDeceleration), Stop::kProtective);
}

void VirtualArm::EmergencyStop() {
  std::lock_guard lock(mutex_);
  Halt(clock_.Now(), kEmergencyDeceleration, Stop::kEmergency);
  emergency_pressed_ = true;
  powered_ = false;
}

void VirtualArm::ProtectiveStopDuringNextMove(double fraction) {
  std::lock_guard lock(mutex_);
  stop_fraction_ = std::clamp(fraction, 0.0, 1.0);
}

double VirtualArm::ClearProtectiveStop() {
  std::lock_guard lock(mutex_);
  const double t = clock_.Now();
  StateAt(t);
  if (stop_ != Stop::kProtective) return 0.0;
  stop_ = Stop::kNone;
  return t - stopped_at_;
}

double VirtualArm::SecondsSinceStop() {
  std::lock_guard lock(mutex_);
  const double t = clock_.Now();
  StateAt(t);
  return stop_ == Stop::kNone ? 0.0 : t - stopped_at_;
}

void VirtualArm::ReleaseEmergencyStop() {
  std::lock_guard lock(mutex_);
  emergency_pressed_ = false;
  if (stop_ == Stop::kEmergency) stop_ = Stop::kNone;
}

bool VirtualArm::emergency_pressed() const {
  std::lock_guard lock(mutex_);
  return emergency_pressed_;
}

bool VirtualArm::PowerOn() {
  std::lock_guard lock(mutex_);
  if (emergency_pressed_) return false;
  powered_ = true;
  return true;
}

void VirtualArm::EndDrift(double t) {
  // Where the drift took the joint, it stays.
  if (t > drift_since_) drift_offset_(*drift_joint_) += drift_speed_ * (t - drift_since_);
  drift_joint_.reset();
  drift_until_.reset();
}

void VirtualArm::Drift(int joint, double speed) {
  std::lock_guard lock(mutex_);
  const double t = clock_.Now();
  if (drift_joint_) EndDrift(t);
  drift_joint_ = joint;
  drift_speed_ = speed;
  drift_since_ = t;
}

void VirtualArm::StopDrifting() {
  std::lock_guard lock(mutex_);
  if (drift_joint_) EndDrift(clock_.Now());
}

void VirtualArm::DriftAfterNextMove(int joint, double speed, double delay, double duration) {
  std::lock_guard lock(mutex_);
  pending_drift_ = PendingDrift{joint, speed, delay, duration};
}

int VirtualArm::moves() const {
  std::lock_guard lock(mutex_);
  return moves_;
}
int VirtualArm::stops() const {
  std::lock_guard lock(mutex_);
  return stops_;
}
double VirtualArm::moving_s() const {
  std::lock_guard lock(mutex_);
  return moving_s_;
}

}  // namespace armsig::simulation
