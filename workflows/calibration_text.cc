#include "workflows/calibration_text.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <vector>

#include "core/text_layout.h"
#include "core/units.h"
#include "core/wording.h"

namespace armsig::workflows {

namespace {

constexpr double kDegreesPerRad = 1.0 / kRadPerDeg;

// Fixed decimals without a "-0.000".
std::string Fixed(double value, int decimals) {
  std::string text = fmt::format("{:.{}f}", value, decimals);
  if (text.find_first_not_of("-0.") == std::string::npos && text[0] == '-') text.erase(0, 1);
  return text;
}

}  // namespace

std::string ParameterTableText(const calibration::RobotModel& model, const CalibrationRun& run,
                               bool sigmas) {
  const auto& est = run.estimate;
  const int n = model.num_joints();
  std::vector<char> identified(model.num_parameters(), 0), asked(model.num_parameters(), 0);
  for (int i : est.identifiability.identified) identified[i] = 1;
  for (int i : est.identifiability.candidates) asked[i] = 1;
  std::vector<std::string> header = {sigmas ? "sigma, i =" : "i ="};
  for (int i = 1; i <= n + 1; ++i) header.push_back(std::to_string(i));
  TextTable table(header);
  static const char* kRows[] = {"a_i (mm)",           "b_i (mm)",          "c_i (mm)",
                                "alpha_i (1e-3 rad)", "beta_i (1e-3 rad)", "gamma_i (1e-3 rad)"};
  for (int r = 0; r < 6; ++r) {
    std::vector<std::string> cells = {kRows[r]};
    for (int i = 0; i <= n; ++i) {
      // Links 1…n carry six parameters each; the tool (column n + 1) its three lengths and,
      // with a known mounting, the flange's turn alpha beta.
      const int index = model.GeometricIndex(i, r);
      const double scale = r < 3 ? 1.0 : 1e3;
      if (index < 0) {
        cells.push_back("");
      } else if (!asked[index]) {
        cells.push_back("off");
      } else if (!identified[index]) {
        cells.push_back("—");
      } else if (sigmas) {
        cells.push_back(Significant(est.sigmas(index) * scale, 2));
      } else {
        cells.push_back(Fixed(est.params(index) * scale, 3));
      }
    }
    table.AddRow(cells);
  }
  return table.Render(kTextWidth);
}

std::string NonGeometricText(const calibration::RobotModel& model, const CalibrationRun& run) {
  const auto& est = run.estimate;
  const auto names = model.ParameterNames();
  std::vector<char> identified(model.num_parameters(), 0), asked(model.num_parameters(), 0);
  for (int i : est.identifiability.identified) identified[i] = 1;
  for (int i : est.identifiability.candidates) asked[i] = 1;
  std::string out;
  for (int k = model.num_geometric(); k < model.num_parameters(); ++k) {
    if (!asked[k]) continue;
    if (identified[k]) {
      out += fmt::format("{} = {} × 10⁻³ rad  (σ {})\n", names[k], Fixed(est.params(k) * 1e3, 3),
                         Significant(est.sigmas(k) * 1e3, 2));
    } else {
      out += fmt::format("{} = —  (not identifiable)\n", names[k]);
    }
  }
  return out;
}

std::string IdentifiabilityText(const calibration::RobotModel& model, const CalibrationRun& run) {
  const auto& est = run.estimate;
  const auto& id = est.identifiability;
  const auto names = model.ParameterNames();
  std::string out;
  if (model.known_mounting()) {
    std::string held;
    for (int k : model.HeldParameters()) held += (held.empty() ? "" : " ") + names[k];
    out += fmt::format(
        "tool_mounting: known (the target sits at tool_mm: the flange's turn across the lever, "
        "{} {}, is fitted; its turn about the lever arm is not identifiable; held at zero: {})\n",
        names[model.flange_turn_index()], names[model.flange_turn_index() + 1], held);
  } else {
    out +=
        "tool_mounting: fitted (the offset at the target takes the flange's turn after the "
        "last joint and the probe's mounting together)\n";
  }
  if (id.structural_rank >= 0 && id.structural_rank != id.rank) {
    out +=
        fmt::format("warning: these data identify {}, the model {} on well-spread configurations\n",
                    Count(id.rank, "parameter"), id.structural_rank);
  }
  for (const auto& frozen : id.frozen_joints) {
    std::string affected;
    for (int p : frozen.affected) affected += (affected.empty() ? "" : " ") + names[p];
    out += fmt::format(
        "warning: joint {} never moves in these data (range {:.4f} deg); its motion would "
        "separate: {}\n",
        frozen.joint + 1, frozen.range_rad * 180.0 / std::numbers::pi, affected);
  }
  if (!id.dependencies.empty()) {
    out += "left out (depends on):";
    int shown = 0;
    for (const auto& dep : id.dependencies) {
      out += fmt::format("{}{}", shown++ % 4 == 0 ? "\n  " : "; ", names[dep.parameter]);
      std::string on;
      for (size_t k = 0; k < std::min<size_t>(3, dep.on.size()); ++k) {
        on += (k ? "," : "") + names[dep.on[k].first];
      }
      out += on.empty() ? " (no effect on the target)" : " (" + on + ")";
    }
    out += "\n";
  }
  out += fmt::format("condition number of the scaled Jacobian {:.3g}\n", id.condition_number);
  if (run.selection) {
    out += fmt::format(
        "selection: {} of {} configurations, D-optimal (greedy + {}), log det {:.2f}, O1 {:.4g}, "
        "condition number {:.3g}\n",
        run.selection->selected.size(), run.selection_candidates,
        Count(run.selection->exchanges, "exchange"), run.selection->log_det, run.selection->o1,
        run.selection->condition_number);
  }
  if (run.auto_terms) {
    for (const auto& t : run.auto_terms->tests) {
      out += fmt::format("F-test +{}: F({},{}) = {:.2f}, {}: {}\n", t.added, t.df_added,
                         t.df_residual, t.f, PValueText(t.p_value),
                         t.significant ? "significant" : "not significant");
    }
  }
  if (!est.downweighted.empty()) {
    std::string ids;
    for (int i : est.downweighted) ids += (ids.empty() ? "" : " ") + run.fit_pose_ids[i];
    out += fmt::format("blunder poses (robust loss down-weighted them): {}\n", ids);
  }
  out += fmt::format("fit: {} after {}, sigma0 {:.4f} mm per coordinate, redundancy {}\n",
                     est.status.ok() ? "converged" : "NOT converged",
                     Count(est.iterations, "iteration"), est.sigma0_mm, est.redundancy);
  if (est.orientation_poses > 0) {
    out += fmt::format(
        "orientations: {} measured; sigma0 {:.4f} deg per component, weighted {:.0f} mm per "
        "rad against the positions\n",
        Count(est.orientation_poses, "pose"), est.sigma0_rad * kDegreesPerRad,
        est.orientation_weight_mm_per_rad);
  }
  return WrapLines(out, kTextWidth);
}

std::string ErrorDistanceText(const CalibrationRun& run) {
  const auto& est = run.estimate;
  TextTable table({"error distance (mm)", "poses", "mean", "max", "rms"});
  auto line = [&](const char* label, const calibration::ErrorStats& s) {
    table.AddRow({label, std::to_string(s.poses), Fixed(s.mean_mm, 3), Fixed(s.max_mm, 3),
                  Fixed(s.rms_mm, 3)});
  };
  line("nominal, fit poses", est.nominal);
  line("calibrated, fit poses", est.fit);
  if (!run.validation_residuals.empty()) {
    line("nominal, validation", StatsOf(run.validation_nominal_residuals));
    if (run.map_used() && !run.validation_parametric_residuals.empty()) {
      line("parametric, validation", StatsOf(run.validation_parametric_residuals));
      line("with map, validation", StatsOf(run.validation_residuals));
    } else {
      line("calibrated, validation", StatsOf(run.validation_residuals));
    }
  }
  std::string out = table.Render(kTextWidth);
  if (est.orientation_poses > 0) {
    TextTable angles({"orientation error (deg)", "poses", "mean", "max", "rms"});
    auto angle_line = [&](const char* label, const calibration::AngleStats& a) {
      angles.AddRow({label, std::to_string(a.poses), Fixed(a.mean_rad * kDegreesPerRad, 4),
                     Fixed(a.max_rad * kDegreesPerRad, 4), Fixed(a.rms_rad * kDegreesPerRad, 4)});
    };
    angle_line("nominal, fit poses", est.nominal_angle);
    angle_line("calibrated, fit poses", est.fit_angle);
    if (!run.validation_orientation_residuals.empty()) {
      angle_line("calibrated, validation",
                 calibration::SummariseAngles(calibration::Angles(run.validation_orientation_residuals)));
    }
    out += angles.Render(kTextWidth);
  }
  if (run.residual_map) {
    const auto& m = *run.residual_map;
    out += fmt::format("residual map {}: {}", m.used ? "used" : "not used", m.decision);
    if (m.used && !m.map.centres_rad.empty()) {
      if (!m.map.curves.empty()) {
        out += fmt::format(" (joint curves: {} knots per turn, smoothing {:.3g};", m.map.curves.knots,
                           m.map.curves.smoothing);
      }
      out += fmt::format("{}length scale {:.3g}, regularisation {:.3g}, {})",
                         m.map.curves.empty() ? " (" : " kernel: ", m.map.length_scale,
                         m.map.regularisation, Count(m.map.centres_rad.size(), "centre"));
    }
    out += "\n";
    if (const auto v = run.map_validation(); run.map_used() && v.poses > 0) {
      out += fmt::format(
          "  validation: predictive sigma {:.4f} mm per coordinate on average; {} of {} poses "
          "outside the map's support (far from the fit poses, or a joint at an angle its curve had "
          "no data for: only what has data there applies; flagged)\n",
          v.mean_sigma_mm, v.outside, v.poses);
    }
  }
  return WrapLines(out, kTextWidth);
}

std::string FormatCalibrationReport(const calibration::RobotModel& model,
                                    const CalibrationRun& run) {
  const auto& id = run.estimate.identifiability;
  std::string out =
      fmt::format("Arm signature of {}: {} of {} parameters identified (params: {})\n\n",
                  model.name, id.rank, id.candidates.size(), run.params_spec);
  out += ParameterTableText(model, run, false);
  out += NonGeometricText(model, run);
  out += fmt::format(
      "— not identifiable from these data (kept at 0); off: not asked for (--params);\n"
      "i = {}: the tool (the target on the flange), {}\n\n",
      model.num_joints() + 1,
      model.known_mounting() ? "its lengths held at 0 (tool_mounting: known), alpha beta the "
                               "flange's turn across the lever"
                             : "lengths only");
  out += ParameterTableText(model, run, true);
  out += "\n";
  out += IdentifiabilityText(model, run);
  out += "\n";
  out += ErrorDistanceText(run);
  return WrapLines(out, kTextWidth);
}

}  // namespace armsig::workflows
