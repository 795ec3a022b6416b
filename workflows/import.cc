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
#include "db/robots.h"
#include "io/atomic_file.h"
#include "io/gsi_import.h"
#include "io/point_joint_join.h"
#include "io/poses_csv.h"
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
  return r.preset.empty() && r.joint_columns.empty() && r.xyz_columns.empty() &&
         r.rotation_columns.empty() && r.rotation_sigma_columns.empty() && r.rotation_unit.empty();
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
  if (!r.rotation_columns.empty()) import.rotation_columns = SplitList(r.rotation_columns);
  if (!r.rotation_sigma_columns.empty())
    import.rotation_sigma_columns = SplitList(r.rotation_sigma_columns);
  if (!r.rotation_unit.empty()) {
    import.rotation_unit = AngleUnitFromSuffix("_" + r.rotation_unit);
    if (!import.rotation_unit) {
      throw InputError({"--rotation-unit", 0, 0, ""},
                       "expected deg, gon or rad, got " + Quoted(r.rotation_unit));
    }
  }
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
  if (!r.file.empty() || !r.preset.empty() || !r.xyz_columns.empty() || !r.id_column.empty() ||
      !r.rotation_columns.empty() || !r.rotation_sigma_columns.empty()) {
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

// Puts the --out file in place once the session is stored: should that fail, the session is
// stored all the same and the error says so (exit 6) and how to write the file again.
void CommitAfterStore(std::optional<io::PreparedFile>& out, const ImportPosesRequest& request,
                      const ImportPosesResult& result) {
  if (!out) return;
  try {
    out->Commit();
  } catch (const OutputError& e) {
    if (result.db_path.empty() || result.duplicate) throw;
    throw StoredButOutputError(fmt::format(
        "session {}: {} poses of robot {} stored in {}; the poses CSV could not be written: {} "
        "(armsig session export {} --poses FILE writes it)",
        result.session, result.poses, request.robot, Printable(result.db_path), e.what(),
        result.session));
  }
}

// A pose table (the poses format itself, or a table with named columns), read row by row:
// each pose goes into the store's transaction and the --out file as it is read, so memory
// does not grow with the file; both are kept only when the whole file was read without a
// fault (a repeated id is found at the end).
ImportPosesResult ImportPoseTable(const ImportPosesRequest& request, db::Database* database,
                                  int num_joints) {
  ImportPosesResult result;
  std::optional<PosesSessionWriter> store;
  if (database) store.emplace(*database, request.robot, request.file, request.kind);
  std::optional<io::PreparedFile> out;
  if (!request.out.empty()) out.emplace(request.out);
  io::PosesCsvLayout layout;  // the input's columns, set once its header is read
  const auto take = [&](const MeasuredPose& pose, int) {
    if (store) store->Add(pose);
    if (out) {
      if (result.poses == 0) out->Write(io::PosesCsvHeader(layout));
      out->Write(io::PosesCsvRow(pose, layout));
    }
    ++result.poses;
  };
  if (IsPosesCsv(request)) {
    // The poses format itself: ids from `pose`, units from the suffixes.
    if (!request.id_column.empty() || request.length_scale != 1.0 || request.decimal_comma ||
        !request.delimiter.empty()) {
      throw InputError({request.file, 0, 0, ""},
                       "--id, --length-scale, --delimiter and --decimal-comma describe a pose "
                       "table's columns: give --joint-columns and --xyz-columns with them (a "
                       "poses CSV, pose,q1_deg,…,x_mm,y_mm,z_mm, needs no options)");
    }
    io::ReadPosesStreamed(
        request.file, num_joints > 0 ? num_joints : -1,
        request.joint_unit.empty() ? std::nullopt : std::optional<AngleUnit>(JointUnit(request)),
        take, request.progress, &layout);
  } else {
    io::ImportPosesStreamed(request.file, ImportOptionsOf(request), take, request.progress,
                            &layout);
  }
  // The file is written in full before the session is stored and put in place after: a full
  // disk stores nothing.
  if (out) out->Ready();
  if (store) {
    const auto stored = store->Finish(request.allow_duplicate);
    result.session = stored.session;
    result.duplicate = stored.duplicate;
    result.db_path = database->path();
  }
  CommitAfterStore(out, request, result);
  if (out) {
    spdlog::info("import poses: {} poses from {} to {}", result.poses, request.file, request.out);
  }
  return result;
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
    db::FindRobotInUse(*database, request.robot);  // a removed robot takes no new sessions
    num_joints = RegisteredModel(*database, request.robot).num_joints();
  }
  if (!tracker) return ImportPoseTable(request, database ? &*database : nullptr, num_joints);
  io::JoinedPoses joined = JoinTrackerExport(request, num_joints);
  result.unused_joint_rows = joined.unused_joint_rows;
  result.poses = joined.poses.size();
  const std::string source = request.points + " + " + request.joints;
  std::optional<io::PreparedFile> out;
  if (!request.out.empty()) out.emplace(request.out, io::FormatPosesCsv(joined.poses));
  if (database) {
    const auto stored = StorePosesSession(*database, request.robot, joined.poses, source,
                                          request.allow_duplicate, joined.covariances_mm2,
                                          request.kind);
    result.session = stored.session;
    result.duplicate = stored.duplicate;
    result.db_path = database->path();
  }
  CommitAfterStore(out, request, result);
  if (out) {
    spdlog::info("import poses: {} poses from {} to {}", joined.poses.size(), source, request.out);
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
