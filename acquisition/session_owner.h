// Which process runs a session. A capture or demo records itself on the session it runs
// (pid, host, and a token of the process's start: boot id and start tick, so that a pid
// reused after a reboot or by another program is not taken for it). A session left
// `running` by a process that is gone (SIGKILL, a third Ctrl-C, a power cut) is then told
// apart from a live capture: it is `interrupted`, and resumable; resuming one whose owner
// still runs is refused.
#pragma once

#include <cstdint>
#include <optional>
#include <string>

#include "db/database.h"
#include "db/sessions.h"

namespace armsig::acquisition {

// This process, as recorded on the sessions it runs.
db::SessionOwner ThisProcess();

enum class OwnerState {
  kAlive,    // the recorded process runs on this host (same pid and start)
  kGone,     // no such process on this host (or its pid now belongs to another one)
  kUnknown,  // it ran on another host: armsig cannot tell from here
};
OwnerState StateOf(const db::SessionOwner& owner);

// The state `sessions` shows: a `running` session whose owner is not alive (or was never
// recorded, before schema v4) is `interrupted`; an `aborted` one is `discarded` (its
// measurements are not used); other states are as stored.
std::string DisplayState(db::SessionState stored_state,
                         const std::optional<db::SessionOwner>& owner);

// Makes this process the owner of `session` and marks it running, in one write
// transaction. Throws InputError (naming the pid and host) when the session is running in
// another process that is alive, or on another host.
void ClaimSession(db::Database& db, int64_t session);

}  // namespace armsig::acquisition
