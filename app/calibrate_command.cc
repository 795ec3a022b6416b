// armsig calibrate --model MODEL.yaml --poses POSES.csv [--params …] [--select N]
//                  [--validate HOLDOUT.csv] [--json OUT.json]
#include <iostream>

#include "app/command.h"
#include "core/plausibility.h"
#include "core/text.h"
#include "io/atomic_file.h"
#include "io/model_yaml.h"
#include "io/poses_csv.h"
#include "workflows/calibration_run.h"
#include "workflows/calibration_text.h"

namespace armsig::app {

struct CalibrateOptions {
  std::string model;
  std::string poses;
  std::string validate;
  std::string json;
  workflows::CalibrateSettings settings;
};

int RunCalibrate(const CalibrateOptions& options, const GlobalOptions&) {
  // Read and check every input before computing or writing anything.
  const calibration::RobotModel model = io::LoadRobotModel(options.model);
  workflows::ParamsOf(model, options.settings.params);  // a typo is refused before the data
  const auto poses =
      io::ReadPosesCsv(options.poses, model.num_joints(), std::nullopt, TerminalReadProgress());
  std::vector<MeasuredPose> holdout;
  if (!options.validate.empty())
    holdout = io::ReadPosesCsv(options.validate, model.num_joints(), std::nullopt,
                               TerminalReadProgress());

  const workflows::CalibrationRun run =
      workflows::RunCalibration(model, poses, holdout, options.settings);
  std::cout << workflows::FormatCalibrationReport(model, run);
  if (!options.json.empty()) {
    io::WriteFileAtomically(options.json,
                            JsonText(workflows::CalibrationJson(model, run), 2) + "\n");
  }
  return run.estimate.status.ok() ? kOk : kFailure;
}

void SetupCalibrateCommand(CLI::App& parent, const GlobalOptions& global, Runner& run) {
  auto options = std::make_shared<CalibrateOptions>();
  auto* sub = parent.add_subcommand(
      "calibrate", "Fit the robot's error parameters to measured poses (paper eq. 8-15)");
  sub->add_option("--model", options->model, "Robot model YAML")->type_name("FILE")->required();
  sub->add_option("--poses", options->poses, "Poses CSV: pose,q1_deg,...,x_mm,y_mm,z_mm")
      ->type_name("FILE")
      ->required();
  sub->add_option("--params", options->settings.params,
                  "geometric | all | auto | list such as geometric,h3,h4")
      ->capture_default_str();
  NumberOption(
      sub->add_option("--select", options->settings.select,
                      "Keep the N best-spread poses (D-optimal) for the fit, validate on the rest"),
      0, kMaxPoses);
  sub->add_option("--validate", options->validate, "Held-out poses CSV to validate on")
      ->type_name("FILE");
  ChoiceOption(sub->add_option("--residual-model", options->settings.residual_model,
                  "auto: a cross-validated residual map after the parametric fit, used only "
                  "when it clearly helps; off: parametric only"), {"auto", "off"})
      ->capture_default_str();
  ChoiceOption(sub->add_option("--orientation", options->settings.orientation,
                  "auto: poses with a measured orientation (rx_deg,ry_deg,rz_deg: a 6-DoF "
                  "probe) fit it too; off: positions only"), {"auto", "off"})
      ->capture_default_str();
  NumberOption(sub->add_option("--orientation-weight", options->settings.orientation_weight_mm_per_rad,
                               "mm of position error one rad of orientation error counts as "
                               "(0: estimated by variance components)"),
               0, 1e9)
      ->type_name("MM_PER_RAD");
  OutputFile(sub->add_option("--json", options->json, "Write the result as JSON"));
  NumberOption(sub->add_option("--robust", options->settings.robust_threshold_mm,
                               "Huber threshold (mm) on each pose's error distance: blunder poses "
                               "are down-weighted and reported (0: off)"),
               0, plausible::kMaxLengthMm);
  NumberOption(sub->add_option("--alpha", options->settings.alpha,
                               "Significance level of the F-tests of --params auto"),
               1e-12, 0.5)
      ->capture_default_str();
  NumberOption(
      sub->add_option("--rank-tolerance", options->settings.rank_tolerance,
                      "Relative pivot below which a scaled Jacobian column counts as dependent"),
      1e-15, 0.1)
      ->capture_default_str();
  OnlyReads(sub);
  sub->callback([&run, &global, options] {
    run = [&global, options] { return RunCalibrate(*options, global); };
  });
}

}  // namespace armsig::app
