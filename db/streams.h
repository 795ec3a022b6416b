// A sweep's raw streams (`capture --on-the-move`, schema v16): the controller's joint
// packages, each tracker's continuous records and what interrupted them, stored one segment
// of the sweep per transaction so that a stopped sweep keeps every segment it finished.
#pragma once

#include <Eigen/Core>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "db/database.h"

namespace armsig::db {

struct StreamJointRow {
  double t_s = 0.0;  // the controller's clock
  Eigen::VectorXd q_rad, qd_rad_s;
};

struct StreamPointRow {
  std::string station;  // code
  double t_s = 0.0;     // the tracker's clock
  double hz_rad = 0.0, v_rad = 0.0, distance_mm = 0.0;  // armsig's convention (the station frame)
  int status = 0;
  int segment = 0;  // the sweep's segment it was stored with (loaded; insert takes the segment's)
};

struct StreamEventRow {
  std::string station;
  double t_s = 0.0;
  int status = 0;
  std::string what;
};

struct StreamSegment {
  int segment = 0;
  std::vector<StreamJointRow> joints;
  std::vector<StreamPointRow> points;
  std::vector<StreamEventRow> events;
};

// Adds one segment's rows (call inside the segment's transaction).
void InsertStreamSegment(Database& db, int64_t session_id, const StreamSegment& segment);
// The segments a session has stored (those with joint packages).
std::set<int> StoredStreamSegments(Database& db, int64_t session_id);
// Every stored row of a session, by segment then time.
struct SessionStreams {
  std::vector<StreamJointRow> joints;
  std::vector<StreamPointRow> points;
  std::vector<StreamEventRow> events;
};
SessionStreams LoadSessionStreams(Database& db, int64_t session_id);

// The clock estimate of a session measured on the move (sessions.sync_json), when it has one.
void SetSessionSync(Database& db, int64_t session_id, const std::string& json);
std::optional<std::string> SessionSync(Database& db, int64_t session_id);

}  // namespace armsig::db
