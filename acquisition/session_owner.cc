#include "acquisition/session_owner.h"

#include <fmt/format.h>
#include <signal.h>
#include <unistd.h>

#include <cerrno>
#include <fstream>
#include <sstream>

#include "core/error.h"

namespace armsig::acquisition {

namespace {

std::string HostName() {
  char name[256] = {};
  if (::gethostname(name, sizeof name - 1) != 0) return "unknown";
  return name;
}

// Field 22 of /proc/<pid>/stat: the process's start, in clock ticks after boot. The
// command name (field 2) may hold spaces and parentheses: fields are counted after the
// last ')'. "" when the process does not exist.
std::string StartTick(int64_t pid) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/stat");
  std::string text;
  if (!in || !std::getline(in, text)) return "";
  const size_t close = text.rfind(')');
  if (close == std::string::npos) return "";
  std::istringstream fields(text.substr(close + 1));
  std::string field;
  for (int k = 3; k <= 22 && fields >> field; ++k) {
    if (k == 22) return field;
  }
  return "";
}

std::string BootId() {
  std::ifstream in("/proc/sys/kernel/random/boot_id");
  std::string id;
  std::getline(in, id);
  return id;
}

std::string StartToken(int64_t pid) {
  const std::string tick = StartTick(pid);
  return tick.empty() ? std::string() : BootId() + "/" + tick;
}

}  // namespace

db::SessionOwner ThisProcess() {
  const int64_t pid = ::getpid();
  return {pid, HostName(), StartToken(pid)};
}

OwnerState StateOf(const db::SessionOwner& owner) {
  if (owner.host != HostName()) return OwnerState::kUnknown;
  if (owner.pid <= 0) return OwnerState::kGone;
  if (::kill(static_cast<pid_t>(owner.pid), 0) != 0 && errno == ESRCH) return OwnerState::kGone;
  // The pid exists: is it still the process that claimed the session?
  const std::string token = StartToken(owner.pid);
  if (token.empty()) return OwnerState::kGone;
  return owner.started.empty() || token == owner.started ? OwnerState::kAlive : OwnerState::kGone;
}

std::string DisplayState(db::SessionState stored_state,
                         const std::optional<db::SessionOwner>& owner) {
  using db::SessionState;
  if (stored_state == SessionState::kAborted) return "discarded";  // its measurements are not used
  if (stored_state != SessionState::kRunning) return db::ToString(stored_state);
  if (!owner) return "interrupted";
  return StateOf(*owner) == OwnerState::kGone ? "interrupted" : db::ToString(stored_state);
}

void ClaimSession(db::Database& db, int64_t session) {
  db::WriteTransaction tx(db);
  const auto row = db::LoadSession(db, session);
  if (!row) throw InputError({db.path(), 0, 0, ""}, fmt::format("no session {}", session));
  const db::SessionOwner me = ThisProcess();
  if (row->state == db::SessionState::kRunning && row->owner && !(*row->owner == me)) {
    const auto& o = *row->owner;
    switch (StateOf(o)) {
      case OwnerState::kAlive:
        throw InputError(
            {db.path(), 0, 0, ""},
            fmt::format("session {} is running in process {} on {}: resuming it as well would "
                        "measure its configurations twice; wait for it to end, or stop it "
                        "(kill -INT {}) and resume then",
                        session, o.pid, o.host, o.pid));
      case OwnerState::kUnknown:
        throw InputError(
            {db.path(), 0, 0, ""},
            fmt::format("session {} is marked running by process {} on host {}; armsig cannot "
                        "tell from {} whether that process still runs: check there (and stop it "
                        "or let it end) before resuming",
                        session, o.pid, o.host, me.host));
      case OwnerState::kGone:
        break;  // interrupted: ours now
    }
  }
  db::SetSessionOwner(db, session, me);
  db::SetSessionState(db, session, db::SessionState::kRunning);
  tx.commit();
}

}  // namespace armsig::acquisition
