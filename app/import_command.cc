// armsig import poses FILE (--preset ur-ipa | --joints … --xyz …) [--out POSES.csv] [--robot NAME]
// armsig import gsi FILE --station ID --out OBS.csv
#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <iostream>
#include <sstream>

#include "app/command.h"
#include "app/reduce_command.h"
#include "core/error.h"
#include "io/atomic_file.h"
#include "io/gsi_import.h"
#include "io/poses_csv.h"
#include "workflows/lifecycle.h"

namespace armsig::app {

struct ImportPosesOptions {
  std::string file, out, robot, preset, joints, xyz, id_column, delimiter, joint_unit = "rad";
  bool decimal_comma = false;
  double length_scale = 1.0;
};

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

}  // namespace

int RunImportPoses(const ImportPosesOptions& options, const GlobalOptions& global) {
  if (options.out.empty() && options.robot.empty())
    throw InputError({"--out", 0, 0, ""}, "give --out FILE.csv, --robot NAME, or both");
  if (!options.out.empty()) io::CheckOutputFile(options.out, "--out");
  io::PoseImportOptions import;
  if (options.preset == "ur-ipa") {
    import = io::PoseImportOptions::UrIpa();
  } else if (!options.preset.empty()) {
    throw InputError({"--preset", 0, 0, ""},
                     "unknown preset '" + options.preset + "' (expected ur-ipa)");
  }
  if (!options.joints.empty()) import.joint_columns = SplitList(options.joints);
  if (!options.xyz.empty()) import.xyz_columns = SplitList(options.xyz);
  if (!options.id_column.empty()) import.id_column = options.id_column;
  if (!options.delimiter.empty()) {
    if (options.delimiter == "tab") {
      import.delimiter = '\t';
    } else if (options.delimiter.size() == 1) {
      import.delimiter = options.delimiter[0];
    } else {
      throw InputError({"--delimiter", 0, 0, ""}, "expected one character or 'tab'");
    }
  }
  if (options.decimal_comma) import.decimal_comma = true;
  if (options.preset.empty() || options.joint_unit != "rad") {
    if (options.joint_unit == "deg")
      import.joint_unit = AngleUnit::kDeg;
    else if (options.joint_unit == "gon")
      import.joint_unit = AngleUnit::kGon;
    else if (options.joint_unit == "rad")
      import.joint_unit = AngleUnit::kRad;
    else
      throw InputError({"--joint-unit", 0, 0, ""}, "expected deg, gon or rad");
  }
  if (options.length_scale != 1.0) import.length_scale_to_mm = options.length_scale;
  const auto poses = io::ImportPoses(options.file, import);
  if (!options.robot.empty()) {
    db::Database database(global.DbPath(), db::OpenMode::kMustExist);
    const int64_t session =
        workflows::StorePosesSession(database, options.robot, poses, options.file);
    std::cout << fmt::format("session {}: {} poses of robot {} from {} stored in {}\n", session,
                             poses.size(), options.robot, options.file, database.path());
  }
  if (!options.out.empty()) {
    io::WriteFileAtomically(options.out, io::FormatPosesCsv(poses));
    spdlog::info("import poses: {} poses from {} to {}", poses.size(), options.file, options.out);
  }
  return kOk;
}

struct ImportGsiOptions {
  std::string file, station, out;
};

int RunImportGsi(const ImportGsiOptions& options) {
  const auto imported = io::ImportGsi(options.file, options.station);
  io::WriteFileAtomically(options.out, io::FormatObservationsCsv(imported.observations));
  spdlog::info("import gsi: {} observations from {} blocks ({} without Hz and V skipped) -> {}",
               imported.observations.size(), imported.blocks, imported.skipped_blocks, options.out);
  return kOk;
}

void SetupImportCommand(CLI::App& parent, const GlobalOptions& global, Runner& run) {
  auto* sub = parent.add_subcommand("import", "Import foreign files into armsig formats");
  sub->require_subcommand(1);
  SetupImportObservations(*sub, global, run);

  auto poses = std::make_shared<ImportPosesOptions>();
  auto* p = sub->add_subcommand(
      "poses",
      "A pose table with named columns (e.g. the IPA UR10 laser-tracker CSVs) to the "
      "SPEC poses CSV");
  p->add_option("file", poses->file, "Input CSV")->required();
  OutputFile(p->add_option("--out", poses->out, "Output poses CSV"));
  NameOption(p->add_option(
      "--robot", poses->robot,
      "Store the poses as a new session of this registered robot (armsig robot add)"));
  p->add_option("--preset", poses->preset,
                "ur-ipa: ';', decimal comma, shoulder_pan_joint…wrist_3_joint (rad), "
                "measurement_x/y/z (mm)");
  p->add_option("--joints", poses->joints, "Joint columns in joint order, comma-separated");
  p->add_option("--joint-unit", poses->joint_unit, "deg | gon | rad")->capture_default_str();
  p->add_option("--xyz", poses->xyz, "Measured x,y,z columns, comma-separated");
  p->add_option("--length-scale", poses->length_scale, "Factor to mm (1000 for metres)");
  p->add_option("--id", poses->id_column, "Pose id column (default: row number)");
  p->add_option("--delimiter", poses->delimiter, "Field delimiter: one character or 'tab'");
  p->add_flag("--decimal-comma", poses->decimal_comma, "Numbers use a decimal comma");
  p->callback([&run, &global, poses] {
    run = [&global, poses] { return RunImportPoses(*poses, global); };
  });

  auto gsi = std::make_shared<ImportGsiOptions>();
  auto* g = sub->add_subcommand(
      "gsi", "A Leica GSI-8/GSI-16 file to angle observations (words 11, 21, 22, 31)");
  g->add_option("file", gsi->file, "GSI file")->required();
  NameOption(g->add_option("--station", gsi->station, "Station id for every observation"))
      ->required();
  OutputFile(g->add_option("--out", gsi->out, "Observations CSV to write"))->required();
  g->callback([&run, gsi] { run = [gsi] { return RunImportGsi(*gsi); }; });
}

}  // namespace armsig::app
