// `armsig db push`: a cell's local database copied into a central store, so
// that a cell without a permanent network still ends in the plant's one place.
//
// What travels: every finished session (completed or aborted) with its station set-ups,
// poses, observations and reduced points, and every parameter set with its parameters and
// residuals; the robots, stations and instruments they name are matched by name (and
// created on the server when new). What makes it idempotent: a session and a parameter set
// get a UUID in the local database the first time they are pushed (schema v8); the server
// keeps it, and a second push skips what it finds. What makes it resumable: each session
// and each parameter set is one transaction on the server, so a cut connection or a killed
// push leaves whole items or nothing, and the next push carries on.
//
// Ids are the server's (its sequences); the session ids a parameter set names in its
// inputs are rewritten to the server's. Versions are the server's too: a pushed set is the
// robot's next version there, and it becomes the active one when it is active in the cell
// and newer than the server's active set (recorded as an activation, `activate`, noting the
// cell's file and version). Open sessions (running, paused) are left for a later push.
#pragma once

#include <atomic>
#include <cstdint>
#include <string>
#include <vector>

#include "db/connection.h"

namespace armsig::db {

struct PushOptions {
  std::string source_name;  // how the cell's database is named in the activation notes
  const std::atomic<bool>* stop = nullptr;  // checked between items
};

struct PushSummary {
  int sessions_pushed = 0, sessions_present = 0;
  int64_t poses = 0, observations = 0, points = 0;  // rows the pushed sessions carried
  int64_t stream_rows = 0;  // their raw streams' rows (sessions measured on the move)
  int sets_pushed = 0, sets_present = 0;
  int activations_pushed = 0;  // rows of the cell's activation history new to the server
  int activated = 0;           // robots whose active set the server took from the cell
  int robots_created = 0;
  std::vector<std::string> open_sessions;  // "session 7 (paused)": not pushed
  std::vector<std::string> versions;       // "puma v3 -> v5": local to server version
  bool stopped = false;
};

// Copies what `target` does not hold yet. `source` must be writable (UUIDs are assigned in
// it); `target` is at the same schema version. Throws InputError when a robot exists on
// the server with another model than the cell's (nothing of that robot is pushed, items
// pushed before stay), DatabaseError when a backend fails (items committed before stay).
PushSummary Push(Connection& source, Connection& target, const PushOptions& options);

}  // namespace armsig::db
