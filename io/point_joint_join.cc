#include "io/point_joint_join.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <optional>
#include <stdexcept>
#include <string>

#include "core/error.h"
#include "core/units.h"

namespace armsig::io {

namespace {

// A point that found no joint reading, or not one alone: `message` for the first one
// refused, `brief` for the list of the others.
struct Problem {
  SourceLocation where;
  std::string message;
  std::string brief;
};

SourceLocation AtPoint(const PointTable& points, const TablePoint& p) {
  return SourceLocation{points.source, p.line, 0, ""};
}

// For each point, the joint reading with its name (-1: none, or more than one).
std::vector<int> MatchById(const PointTable& points, const JointLog& joints,
                           std::vector<Problem>* problems) {
  if (!joints.has_ids) {
    throw InputError({joints.source, 1, 0, ""},
                     "joining by id needs a pose id column (pose, point, id, name or label); "
                     "this log has only times: join by time (--match time)");
  }
  std::map<std::string, std::vector<int>> by_id;
  for (size_t j = 0; j < joints.rows.size(); ++j) {
    if (joints.rows[j].id) by_id[*joints.rows[j].id].push_back(static_cast<int>(j));
  }
  std::vector<int> match(points.points.size(), -1);
  for (size_t k = 0; k < points.points.size(); ++k) {
    const TablePoint& p = points.points[k];
    const auto it = by_id.find(p.name);
    if (it == by_id.end()) {
      problems->push_back(
          {AtPoint(points, p),
           fmt::format("point '{}' has no joint reading with that id in {}", p.name, joints.source),
           fmt::format("line {} ({}): no joint reading", p.line, p.name)});
    } else if (it->second.size() > 1) {
      problems->push_back({AtPoint(points, p),
                           fmt::format("point '{}' is ambiguous: {} has it on lines {} and {}",
                                       p.name, joints.source, joints.rows[it->second[0]].line,
                                       joints.rows[it->second[1]].line),
                           fmt::format("line {} ({}): two joint readings", p.line, p.name)});
    } else {
      match[k] = it->second.front();
    }
  }
  return match;
}

// The joint log's readings in time order, and the kind of their stamps (date-times or
// plain seconds), which must be one: two clocks are never compared.
struct JointTimes {
  std::vector<int> order;  // row indices by time
  bool absolute = false;
};

JointTimes JointTimesOf(const PointTable& points, const JointLog& joints) {
  if (!points.has_times) {
    throw InputError({points.source, points.header_line, 0, ""},
                     "joining by time needs a time column in the point table (Time, "
                     "Timestamp, …)");
  }
  if (!joints.has_times) {
    throw InputError({joints.source, 1, 0, ""},
                     "joining by time needs a time column in the joint log (time, timestamp, "
                     "time_s)");
  }
  JointTimes times;
  for (size_t j = 0; j < joints.rows.size(); ++j) {
    if (joints.rows[j].time) times.order.push_back(static_cast<int>(j));
  }
  times.absolute = joints.rows[times.order.front()].time->absolute;
  for (int j : times.order) {
    if (joints.rows[j].time->absolute != times.absolute) {
      throw InputError({joints.source, joints.rows[j].line, 0, "time"},
                       "mixes date-times and plain seconds: expected one kind of time stamp");
    }
  }
  std::stable_sort(times.order.begin(), times.order.end(), [&](int a, int b) {
    return joints.rows[a].time->seconds < joints.rows[b].time->seconds;
  });
  return times;
}

// The reading nearest in time to `t` (a row index) and how far it is, in seconds.
std::pair<int, double> NearestReading(const JointLog& joints, const JointTimes& times, double t) {
  const auto& order = times.order;
  const auto it = std::lower_bound(order.begin(), order.end(), t, [&](int j, double value) {
    return joints.rows[j].time->seconds < value;
  });
  int nearest = -1;
  double gap = std::numeric_limits<double>::infinity();
  for (auto c : {it, it == order.begin() ? order.end() : it - 1}) {
    if (c == order.end()) continue;
    const double g = std::abs(joints.rows[*c].time->seconds - t);
    if (g < gap) {
      gap = g;
      nearest = *c;
    }
  }
  return {nearest, gap};
}

// Every reading within the tolerance of the point's time must be the same configuration as
// the nearest one; the message when one is not (the robot moved, or two configurations fall
// in the window).
std::optional<std::string> AmbiguityAround(const TablePoint& p, int nearest, const JointLog& joints,
                                           const JointTimes& times, const JoinOptions& options) {
  const double t = p.time->seconds;
  const auto window =
      std::lower_bound(times.order.begin(), times.order.end(), t - options.time_tolerance_s,
                       [&](int j, double value) { return joints.rows[j].time->seconds < value; });
  for (auto c = window; c != times.order.end(); ++c) {
    const int j = *c;
    const JointLogRow& r = joints.rows[j];
    if (r.time->seconds > t + options.time_tolerance_s) break;
    if (j == nearest) continue;
    const Eigen::VectorXd d = (r.joints_rad - joints.rows[nearest].joints_rad).cwiseAbs();
    Eigen::Index worst = 0;
    if (d.maxCoeff(&worst) > options.moving_rad) {
      return fmt::format(
          "point '{}' is ambiguous: joint readings on lines {} and {} of {} are both within "
          "{:g} s and differ by {:.3f} deg in joint {} (the robot moved, or two "
          "configurations fall in the window; a smaller --time-tolerance-s?)",
          p.name, joints.rows[nearest].line, r.line, joints.source, options.time_tolerance_s,
          d(worst) / kRadPerDeg, worst + 1);
    }
  }
  return std::nullopt;
}

// For each point, the joint reading nearest its time within the tolerance, unambiguous
// (-1: none). A point stamped in another kind than the log is refused at once.
std::vector<int> MatchByTime(const PointTable& points, const JointLog& joints,
                             const JoinOptions& options, std::vector<Problem>* problems) {
  const JointTimes times = JointTimesOf(points, joints);
  std::vector<int> match(points.points.size(), -1);
  for (size_t k = 0; k < points.points.size(); ++k) {
    const TablePoint& p = points.points[k];
    if (p.time->absolute != times.absolute) {
      throw InputError(AtPoint(points, p),
                       fmt::format("the point table's time stamps are {} and the joint log's "
                                   "are {}: expected the same kind (both ISO date-times or "
                                   "both seconds)",
                                   p.time->absolute ? "date-times" : "plain seconds",
                                   times.absolute ? "date-times" : "plain seconds"));
    }
    const auto [nearest, gap] = NearestReading(joints, times, p.time->seconds);
    if (gap > options.time_tolerance_s) {
      problems->push_back(
          {AtPoint(points, p),
           fmt::format("point '{}' has no joint reading within {:g} s (the nearest, {} line "
                       "{}, is {:.3f} s away)",
                       p.name, options.time_tolerance_s, joints.source, joints.rows[nearest].line,
                       gap),
           fmt::format("line {} ({}): nearest {:.3f} s away", p.line, p.name, gap)});
      continue;
    }
    if (auto ambiguity = AmbiguityAround(p, nearest, joints, times, options)) {
      problems->push_back(
          {AtPoint(points, p), *ambiguity, fmt::format("line {} ({}): ambiguous", p.line, p.name)});
      continue;
    }
    match[k] = nearest;
  }
  return match;
}

// One joint reading serves one point: a later point that took a reading an earlier one
// took is refused. Returns how many readings the points took.
size_t CheckOneReadingPerPoint(const PointTable& points, const JointLog& joints,
                               const std::vector<int>& match, std::vector<Problem>* problems) {
  std::map<int, size_t> used;
  for (size_t k = 0; k < match.size(); ++k) {
    if (match[k] < 0) continue;
    const auto [it, fresh] = used.emplace(match[k], k);
    if (!fresh) {
      const TablePoint& p = points.points[k];
      const TablePoint& other = points.points[it->second];
      problems->push_back(
          {AtPoint(points, p),
           fmt::format("point '{}' and point '{}' (line {}) both take the joint reading on line "
                       "{} of {}: expected one joint reading per point",
                       p.name, other.name, other.line, joints.rows[match[k]].line, joints.source),
           fmt::format("line {} ({}): shares a joint reading", p.line, p.name)});
    }
  }
  return used.size();
}

// The first refused point at its line, the next five in brief: one run of the import shows
// what to fix in the files.
void ThrowIfRefused(const std::vector<Problem>& problems) {
  if (problems.empty()) return;
  std::string message = problems.front().message;
  if (problems.size() > 1) {
    message += fmt::format("; {} more:", problems.size() - 1);
    for (size_t k = 1; k < problems.size() && k <= 5; ++k) message += " " + problems[k].brief + ";";
    if (problems.size() > 6) message += " …";
  }
  throw InputError(problems.front().where, message);
}

// The measured poses of matched points: the point's name and position, the reading's joints,
// the point's covariance from its sigmas.
JoinedPoses PosesOf(const PointTable& points, const JointLog& joints, const std::vector<int>& match,
                    size_t used) {
  JoinedPoses out;
  const int n = static_cast<int>(joints.rows.front().joints_rad.size());
  for (size_t k = 0; k < points.points.size(); ++k) {
    const TablePoint& p = points.points[k];
    const JointLogRow& r = joints.rows[match[k]];
    if (r.joints_rad.size() != n) throw std::logic_error("joint log rows of different sizes");
    MeasuredPose pose;
    pose.id = p.name;
    pose.joints_rad = r.joints_rad;
    pose.target_in_world = p.position_mm;
    out.poses.push_back(std::move(pose));
    Eigen::Matrix3d c = Eigen::Matrix3d::Constant(std::numeric_limits<double>::quiet_NaN());
    if (p.sigma_mm) c = p.sigma_mm->cwiseAbs2().asDiagonal();
    out.covariances_mm2.push_back(c);
    if (p.time && r.time)
      out.max_time_gap_s =
          std::max(out.max_time_gap_s, std::abs(p.time->seconds - r.time->seconds));
  }
  out.unused_joint_rows = static_cast<int>(joints.rows.size() - used);
  return out;
}

}  // namespace

JoinedPoses JoinPointsAndJoints(const PointTable& points, const JointLog& joints,
                                const JoinOptions& options) {
  std::vector<Problem> problems;
  const std::vector<int> match = options.by == JoinBy::kId
                                     ? MatchById(points, joints, &problems)
                                     : MatchByTime(points, joints, options, &problems);
  const size_t used = CheckOneReadingPerPoint(points, joints, match, &problems);
  ThrowIfRefused(problems);
  return PosesOf(points, joints, match, used);
}

}  // namespace armsig::io
