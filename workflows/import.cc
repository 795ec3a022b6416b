#include "workflows/import.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <optional>
#include <sstream>
#include <vector>

#include "core/error.h"
#include "core/text.h"
#include "core/units.h"
#include "db/database.h"
#include "io/atomic_file.h"
#include "io/gsi_import.h"
#include "io/poses_csv.h"
#include "io/tracker_import.h"
#include "workflows/lifecycle.h"

namespace armsig::workflows {

namespace {

std::vector<std::string> SplitList(const std::string& text) {
  std::vector<std::string> out;
  std::stringstream stream(text);
  std::string item;
  while (std::getline(stream, item, ',')) {
    if (!item.empty()) out.push_back(item);
  }
  return out;
}

AngleUnit JointUnit(const ImportPosesRequest& r) {
  const auto unit = AngleUnitFromSuffix("_" + r.joint_unit);
  if (!unit) {
    throw InputError({"--joint-unit", 0, 0, ""},
                     "expected deg, gon or rad, got " + Quoted(r.joint_unit));
  }
  return *unit;
}

// A file in the poses format armsig writes (`session export`, `import poses --out`): no
// preset and no columns named. Its header says everything.
bool IsPosesCsv(const ImportPosesRequest& r) {
  return r.preset.empty() && r.joint_columns.empty() && r.xyz_columns.empty();
}

io::PoseImportOptions ImportOptionsOf(const ImportPosesRequest& r) {
  io::PoseImportOptions import;
  if (r.preset == "ur-ipa") {
    import = io::PoseImportOptions::UrIpa();
  } else if (!r.preset.empty()) {
    throw InputError({"--preset", 0, 0, ""},
                     "unknown preset " + Quoted(r.preset) + " (expected ur-ipa)");
  }
  if (!r.joint_columns.empty()) import.joint_columns = SplitList(r.joint_columns);
  if (!r.xyz_columns.empty()) import.xyz_columns = SplitList(r.xyz_columns);
  if (!r.id_column.empty()) import.id_column = r.id_column;
  if (r.delimiter == "tab") {
    import.delimiter = '\t';
  } else if (r.delimiter.size() == 1) {
    import.delimiter = r.delimiter[0];
  } else if (!r.delimiter.empty()) {
    throw InputError({"--delimiter", 0, 0, ""}, "expected one character or 'tab'");
  }
  if (r.decimal_comma) import.decimal_comma = true;
  if (!r.joint_unit.empty()) import.joint_unit = JointUnit(r);
  if (!(r.length_scale > 0.0 && r.length_scale < 1e6)) {  // NaN fails too
    throw InputError({"--length-scale", 0, 0, ""},
                     fmt::format("expected a positive factor to mm (1000 for metres, 25.4 for "
                                 "inches), got {}",
                                 r.length_scale));
  }
  import.length_scale_to_mm = r.length_scale;
  return import;
}

}  // namespace

namespace {

// --points PTS --joints LOG: the tracker's point table joined with the robot's joint log.
io::JoinedPoses JoinTrackerExport(const ImportPosesRequest& r, int num_joints) {
  if (r.points.empty() || r.joints.empty()) {
    throw InputError({r.points.empty() ? "--points" : "--joints", 0, 0, ""},
                     "give both --points (the tracker's point table) and --joints (the robot's "
                     "joint log)");
  }
  if (!r.file.empty() || !r.preset.empty() || !r.xyz_columns.empty() || !r.id_column.empty()) {
    throw InputError({"--points", 0, 0, ""},
                     "--points/--joints take the place of a pose table: give no FILE, --preset, "
                     "--xyz-columns or --id");
  }
  io::PointTableOptions points;
  if (!r.points_unit.empty()) {
    points.unit = io::LengthUnitFromText(r.points_unit);
    if (!points.unit) {
      throw InputError({"--points-unit", 0, 0, ""},
                       "expected mm, m or inch, got '" + r.points_unit + "'");
    }
  }
  const io::PointTable table = io::ReadPointTable(r.points, points);
  io::JointLogOptions log;
  log.num_joints = num_joints;
  log.joint_columns = SplitList(r.joint_columns);
  if (!r.joint_unit.empty()) log.joint_unit = JointUnit(r);
  io::JoinOptions join;
  if (r.match == "time") {
    join.by = io::JoinBy::kTime;
  } else if (r.match != "id") {
    throw InputError({"--match", 0, 0, ""}, "expected id or time, got '" + r.match + "'");
  }
  if (!(r.time_tolerance_s > 0.0 && r.time_tolerance_s < 86400.0)) {
    throw InputError({"--time-tolerance-s", 0, 0, ""},
                     fmt::format("expected a positive number of seconds, got {}",
                                 r.time_tolerance_s));
  }
  join.time_tolerance_s = r.time_tolerance_s;
  io::JoinedPoses joined = io::JoinPointsAndJoints(table, io::ReadJointLog(r.joints, log), join);
  spdlog::info(
      "import poses: {} points of {} ({} delimiter{}, {} from {}) joined by {} with {} ({} joint "
      "readings unused{})",
      joined.poses.size(), r.points, table.delimiter, table.decimal_comma ? ", decimal comma" : "",
      io::ToString(table.unit), table.unit_from, r.match, r.joints, joined.unused_joint_rows,
      join.by == io::JoinBy::kTime ? fmt::format(", largest time gap {:.3f} s", joined.max_time_gap_s)
                                   : std::string());
  return joined;
}

}  // namespace

ImportPosesResult ImportPosesFile(const ImportPosesRequest& request) {
  if (request.out.empty() && request.robot.empty())
    throw InputError({"--out", 0, 0, ""}, "give --out FILE.csv, --robot NAME, or both");
  if (!request.out.empty()) io::CheckOutputFile(request.out, "--out");
  const bool tracker = !request.points.empty() || !request.joints.empty();
  if (!tracker && request.file.empty()) {
    throw InputError({"import poses", 0, 0, ""},
                     "give a pose table FILE, or --points PTS --joints LOG");
  }
  ImportPosesResult result;
  std::optional<db::Database> database;
  int num_joints = 0;
  if (!request.robot.empty()) {
    database.emplace(request.db_path, db::OpenMode::kMustExist);
    num_joints = RegisteredModel(*database, request.robot).num_joints();
  }
  std::vector<MeasuredPose> poses;
  std::vector<Eigen::Matrix3d> covariances;
  if (tracker) {
    io::JoinedPoses joined = JoinTrackerExport(request, num_joints);
    poses = std::move(joined.poses);
    covariances = std::move(joined.covariances_mm2);
    result.unused_joint_rows = joined.unused_joint_rows;
  } else if (IsPosesCsv(request)) {
    // The poses format itself: ids from `pose`, units from the suffixes.
    if (!request.id_column.empty() || request.length_scale != 1.0 || request.decimal_comma ||
        !request.delimiter.empty()) {
      throw InputError({request.file, 0, 0, ""},
                       "--id, --length-scale, --delimiter and --decimal-comma describe a pose "
                       "table's columns: give --joint-columns and --xyz-columns with them (a "
                       "poses CSV, pose,q1_deg,…,x_mm,y_mm,z_mm, needs no options)");
    }
    poses = io::ReadPosesCsv(request.file, num_joints > 0 ? num_joints : -1,
                             request.joint_unit.empty()
                                 ? std::nullopt
                                 : std::optional<AngleUnit>(JointUnit(request)));
  } else {
    poses = io::ImportPoses(request.file, ImportOptionsOf(request));
  }
  result.poses = poses.size();
  const std::string source = tracker ? request.points + " + " + request.joints : request.file;
  // The CSV is written in full before the session is stored and put in place after: a full
  // disk stores nothing.
  std::optional<io::PreparedFile> out;
  if (!request.out.empty()) out.emplace(request.out, io::FormatPosesCsv(poses));
  if (database) {
    const auto stored = StorePosesSession(*database, request.robot, poses, source,
                                          request.allow_duplicate, covariances);
    result.session = stored.session;
    result.duplicate = stored.duplicate;
    result.db_path = database->path();
  }
  if (out) {
    try {
      out->Commit();
    } catch (const OutputError& e) {
      if (!database || result.duplicate) throw;
      throw StoredButOutputError(fmt::format(
          "session {}: {} poses of robot {} stored in {}; the poses CSV could not be written: {} "
          "(armsig session export {} --poses FILE writes it)",
          result.session, result.poses, request.robot, Printable(result.db_path), e.what(),
          result.session));
    }
    spdlog::info("import poses: {} poses from {} to {}", poses.size(), source, request.out);
  }
  return result;
}

std::string ImportGsiFile(const std::string& file, const std::string& station,
                          const std::string& out) {
  const auto imported = io::ImportGsi(file, station);
  io::WriteFileAtomically(out, io::FormatObservationsCsv(imported.observations));
  return fmt::format(
      "import gsi: {} observations from {} blocks ({} without Hz and V skipped) -> {}",
      imported.observations.size(), imported.blocks, imported.skipped_blocks, out);
}

}  // namespace armsig::workflows
