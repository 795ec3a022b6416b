// armsig import poses FILE (--preset ur-ipa | --joint-columns … --xyz-columns …) [--out POSES.csv] [--robot NAME]
// armsig import poses --points PTS.txt --joints LOG.csv [--match id|time] [--out …] [--robot NAME]
// armsig import gsi FILE --station ID --out OBS.csv
// armsig import observations OBS.csv --stations STATIONS.yaml: a file into a new session
#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <iostream>

#include "app/command.h"
#include "core/text.h"
#include "core/wording.h"
#include "workflows/import.h"
#include "workflows/reduce.h"

namespace armsig::app {

namespace {

void SetupImportObservations(CLI::App& import, const GlobalOptions& global, Runner& run) {
  auto o = std::make_shared<workflows::ImportObservationsOptions>();
  auto* sub = import.add_subcommand(
      "observations",
      "Angle observations CSV (optional 'pose' column) into a new session, with "
      "the stations' set-ups");
  sub->add_option("file", o->file, "Observations CSV")->required();
  sub->add_option("--stations", o->stations, "Stations YAML")->type_name("FILE")->required();
  NameOption(sub->add_option("--robot", o->robot, "Robot name"))->capture_default_str();
  NoteOption(sub->add_option("--note", o->note, "Session note"));
  sub->callback([&run, &global, o] {
    run = [&global, o] {
      db::Database database(global.DbPath());
      o->progress = TerminalReadProgress();
      const auto r = workflows::ImportObservations(database, *o);
      std::cout << fmt::format(
          "session {}: {}, {}, {} imported into {}\n", r.session,
          Count(r.observations, "observation"), Count(r.stations, "station"),
          Count(r.poses, "pose"), Printable(database.path()));
      return kOk;
    };
  });
}

}  // namespace

void SetupImportCommand(CLI::App& parent, const GlobalOptions& global, Runner& run) {
  auto* sub = parent.add_subcommand("import", "Import foreign files into armsig formats");
  sub->require_subcommand(1);
  SetupImportObservations(*sub, global, run);

  auto poses = std::make_shared<workflows::ImportPosesRequest>();
  auto* p = sub->add_subcommand(
      "poses",
      "A pose table with named columns (e.g. the IPA UR10 laser-tracker CSVs), or a laser "
      "tracker's point table joined with the robot's joint log, to armsig's poses CSV, or into "
      "the database as a session of a robot");
  p->add_option("file", poses->file,
                "Input: a poses CSV (pose,q1_deg,…,x_mm,y_mm,z_mm: no options needed), a pose "
                "table with --preset or --joint-columns/--xyz-columns, or give --points and "
                "--joints");
  OutputFile(p->add_option("--out", poses->out, "Output poses CSV"));
  NameOption(p->add_option(
      "--robot", poses->robot,
      "Store the poses as a new session of this registered robot (armsig robot add)"));
  ChoiceOption(p->add_option("--preset", poses->preset,
                "ur-ipa: ';', decimal comma, shoulder_pan_joint…wrist_3_joint (rad), "
                "measurement_x/y/z (mm), measurement_rx/ry/rz and measurement_std_rx/ry/rz "
                "(deg)"), {"ur-ipa"});
  p->add_option("--points", poses->points,
                "A laser tracker's point table (name, X, Y, Z [, sigmas, time]: the text/CSV "
                "export of SpatialAnalyzer, Leica, Metrolog, PolyWorks…)")
      ->check(CLI::ExistingFile);
  p->add_option("--joints", poses->joints,
                "The robot's joint log CSV (pose id and/or time column, q1_deg… or "
                "--joint-columns), joined with --points")
      ->check(CLI::ExistingFile);
  ChoiceOption(p->add_option("--match", poses->match,
                "Join points and joint readings by point/pose id, or by time stamp (the nearest "
                "within --time-tolerance-s)"), {"id", "time"})
      ->capture_default_str();
  // A day at most: joint readings and tracker points of one session.
  NumberOption(p->add_option("--time-tolerance-s", poses->time_tolerance_s,
                             "--match time: largest gap between a point's and its joint "
                             "reading's time"),
               1e-6, 86400.0)
      ->capture_default_str();
  ChoiceOption(p->add_option("--points-unit", poses->points_unit,
                "The point table's length unit when the file names none"), {"mm", "m", "inch"});
  p->add_option("--joint-columns", poses->joint_columns,
                "Joint columns in joint order, comma-separated");
  ChoiceOption(p->add_option("--joint-unit", poses->joint_unit,
                "Unit of joint columns without a _deg/_gon/_rad suffix: deg | gon | rad "
                "(default rad; a joint log: deg); a suffix it contradicts is refused"), {"deg", "gon", "rad"});
  p->add_option("--xyz-columns", poses->xyz_columns, "Measured x,y,z columns, comma-separated");
  p->add_option("--rotation-columns", poses->rotation_columns,
                "Measured orientation: the rx,ry,rz angle columns, comma-separated, "
                "R = Rx(rx)·Ry(ry)·Rz(rz) (a 6-DoF probe; default none: positions only)");
  p->add_option("--rotation-sigma-columns", poses->rotation_sigma_columns,
                "Standard deviations of rx,ry,rz, comma-separated, in their unit");
  ChoiceOption(p->add_option("--rotation-unit", poses->rotation_unit,
                "Unit of orientation columns without a _deg/_gon/_rad suffix: deg | gon | rad"),
               {"deg", "gon", "rad"});
  NumberOption(
      p->add_option("--length-scale", poses->length_scale, "Factor to mm (1000 for metres)"), 1e-6,
      1e6);
  p->add_option("--id", poses->id_column, "Pose id column (default: row number)");
  p->add_option("--delimiter", poses->delimiter, "Field delimiter: one character or 'tab'");
  p->add_flag("--decimal-comma", poses->decimal_comma, "Numbers use a decimal comma");
  EnumOption(p->add_option("--kind", poses->kind,
                           "What the session is for (with --robot): calibration (the nightly "
                           "job fits it) | check (a set is tried on it, never fitted) | test "
                           "(an ISO 9283 test, never fitted)"),
             {db::SessionKind::kCalibration, db::SessionKind::kCheck, db::SessionKind::kTest},
             db::SessionKind::kCalibration);
  p->add_flag("--allow-duplicate", poses->allow_duplicate,
              "Store the poses even when a session of the robot already holds exactly these "
              "joints and targets (default: nothing is stored, that session is named)");
  p->callback([&run, &global, poses] {
    run = [&global, poses] {
      workflows::ImportPosesRequest request = *poses;
      request.db_path = global.DbPath();
      request.progress = TerminalReadProgress();
      const auto r = workflows::ImportPosesFile(request);
      const std::string source = Printable(
          request.points.empty() ? request.file : request.points + " and " + request.joints);
      if (r.duplicate) {
        std::cout << fmt::format(
            "{} poses of robot {} from {}: already stored as session {} in {}; nothing stored\n",
            r.poses, request.robot, source, r.session, Printable(r.db_path));
      } else if (r.session > 0) {
        std::cout << fmt::format("session {}: {} poses of robot {} from {} stored in {}\n",
                                 r.session, r.poses, request.robot, source, Printable(r.db_path));
      }
      return kOk;
    };
  });

  auto gsi = std::make_shared<std::array<std::string, 3>>();  // file, station, out
  auto* g = sub->add_subcommand(
      "gsi", "A Leica GSI-8/GSI-16 file to angle observations (words 11, 21, 22, 31)");
  g->add_option("file", (*gsi)[0], "GSI file")->required();
  NameOption(g->add_option("--station", (*gsi)[1], "Station id for every observation"))->required();
  OutputFile(g->add_option("--out", (*gsi)[2], "Observations CSV to write"))->required();
  OnlyReads(g);
  g->callback([&run, gsi] {
    run = [gsi] {
      spdlog::info("{}", workflows::ImportGsiFile((*gsi)[0], (*gsi)[1], (*gsi)[2]));
      return kOk;
    };
  });
}

}  // namespace armsig::app
