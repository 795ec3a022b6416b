#include "workflows/import.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <sstream>
#include <vector>

#include "core/error.h"
#include "core/text.h"
#include "core/units.h"
#include "db/database.h"
#include "io/atomic_file.h"
#include "io/gsi_import.h"
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
  if (r.preset.empty() || r.joint_unit != "rad") {
    const auto unit = AngleUnitFromSuffix("_" + r.joint_unit);
    if (!unit) throw InputError({"--joint-unit", 0, 0, ""}, "expected deg, gon or rad");
    import.joint_unit = *unit;
  }
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

ImportPosesResult ImportPosesFile(const ImportPosesRequest& request) {
  if (request.out.empty() && request.robot.empty())
    throw InputError({"--out", 0, 0, ""}, "give --out FILE.csv, --robot NAME, or both");
  if (!request.out.empty()) io::CheckOutputFile(request.out, "--out");
  const auto poses = io::ImportPoses(request.file, ImportOptionsOf(request));
  ImportPosesResult result;
  result.poses = poses.size();
  if (!request.robot.empty()) {
    db::Database database(request.db_path, db::OpenMode::kMustExist);
    const auto stored =
        StorePosesSession(database, request.robot, poses, request.file, request.allow_duplicate);
    result.session = stored.session;
    result.duplicate = stored.duplicate;
    result.db_path = database.path();
  }
  if (!request.out.empty()) {
    io::WriteFileAtomically(request.out, io::FormatPosesCsv(poses));
    spdlog::info("import poses: {} poses from {} to {}", poses.size(), request.file, request.out);
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
