// armsig orient: station set-up by bundle adjustment.
// armsig triangulate: intersection of every target point from oriented stations.
#include <spdlog/spdlog.h>

#include <iostream>

#include "app/command.h"
#include "core/plausibility.h"
#include "workflows/orient_triangulate.h"

namespace armsig::app {

void SetupOrientCommand(CLI::App& parent, const GlobalOptions&, Runner& run) {
  auto o = std::make_shared<workflows::OrientFilesOptions>();
  auto no_instrument_errors = std::make_shared<bool>(false);
  auto* sub = parent.add_subcommand("orient", "Orient the stations (bundle adjustment)");
  sub->add_option("--observations", o->observations, "Angle observations CSV")
      ->type_name("FILE")
      ->required();
  sub->add_option("--scale-bar", o->scale_bars, "A:B=LEN_MM, repeatable");
  NumberOption(sub->add_option("--scale-bar-sigma-mm", o->scale_bar_sigma_mm,
                               "Sigma of every scale-bar length"),
               plausible::kMinSigmaMm, plausible::kMaxSigmaMm)  // as every sigma
      ->capture_default_str();
  sub->add_option("--control", o->control, "Control points CSV: point,x_mm,y_mm,z_mm[,sx_mm,...]")
      ->type_name("FILE");
  NameOption(sub->add_option("--unlevelled", o->unlevelled,
                             "Stations whose rotation is free (not levelled)"));
  NameOption(sub->add_option("--datum-station", o->datum_station,
                             "Station at the origin (default: the first)"));
  sub->add_flag("--free-datum", o->free_datum,
                "Free network: precisions by inner constraints (minimum trace) over all points");
  NameOption(sub->add_option("--datum-points", o->datum_points,
                             "Free network over these points and stations only (implies "
                             "--free-datum)"))
      ->delimiter(',');
  NumberOption(sub->add_option("--max-sigma0", o->max_sigma0,
                               "Gate: sigma0 a posteriori above this writes nothing, exit 3 "
                               "(0: no gate)"),
               0.0, 1e12)
      ->capture_default_str();
  OutputFile(sub->add_option("--out", o->out, "Stations YAML to write"))->required();
  OutputFile(
      sub->add_option("--points", o->points_out, "Also write the adjusted target points (CSV)"));
  OutputFile(sub->add_option("--json", o->json_out,
                             "Also write the adjustment and its data snooping as JSON"));
  sub->add_flag("--no-instrument-errors", *no_instrument_errors,
                "Do not estimate and apply axis errors from two-face readings");
  auto no_reject = std::make_shared<bool>(false);
  sub->add_flag("--no-reject", *no_reject,
                "Test the observations for blunders and report them, but remove none");
  sub->add_option("--keep", o->keep,
                  "Never remove this observation: STATION->POINT (its Hz, V, distance), a scale "
                  "bar A:B or a control point's id; repeatable")
      ->check(CLI::Validator(
          [](const std::string& s) {
            return s.empty() ? std::string("expected STATION->POINT, A:B or a control point")
                             : std::string();
          },
          "OBS"));
  NumberOption(sub->add_option("--alpha", o->alpha,
                               "Significance level of the blunder tests for the whole adjustment "
                               "(the chance that a network without blunders loses a reading)"),
               1e-12, 0.5)
      ->capture_default_str();
  OnlyReads(sub);
  sub->callback([&run, o, no_instrument_errors, no_reject] {
    run = [o, no_instrument_errors, no_reject] {
      o->instrument_errors = !*no_instrument_errors;
      o->reject = !*no_reject;
      const auto result = workflows::OrientFiles(*o);
      std::cout << workflows::FormatOrientReport(result);
      if (!result.result.status.ok()) return kFailure;
      if (!result.gate_failure.empty()) {
        spdlog::error("orient: {}", result.gate_failure);
        return kQualityGate;
      }
      return kOk;
    };
  });
}

void SetupTriangulateCommand(CLI::App& parent, const GlobalOptions&, Runner& run) {
  auto o = std::make_shared<workflows::TriangulateFilesOptions>();
  auto no_reject = std::make_shared<bool>(false);
  auto no_instrument_errors = std::make_shared<bool>(false);
  auto* sub = parent.add_subcommand("triangulate", "Intersect the rays of every target point");
  sub->add_option("--stations", o->stations, "Stations YAML")->type_name("FILE")->required();
  sub->add_option("--observations", o->observations, "Angle observations CSV")
      ->type_name("FILE")
      ->required();
  OutputFile(sub->add_option("--out", o->out, "Points CSV to write"))->required();
  sub->add_flag("--no-reject", *no_reject, "Report blunders but keep every ray");
  sub->add_flag("--no-instrument-errors", *no_instrument_errors,
                "Do not estimate and apply axis errors from two-face readings");
  auto critical_w = std::make_shared<double>(0.0);
  auto* critical = NumberOption(
      sub->add_option("--critical-w", *critical_w,
                      "Critical standardised residual of every test (default: from a 0.1 % "
                      "significance level of each point's adjustment)"),
      1.0, 100.0);
  OnlyReads(sub);
  sub->callback([&run, o, no_reject, no_instrument_errors, critical_w, critical] {
    if (critical->count() > 0) o->critical_w = *critical_w;
    run = [o, no_reject, no_instrument_errors] {
      o->reject_blunders = !*no_reject;
      o->instrument_errors = !*no_instrument_errors;
      const auto result = workflows::TriangulateFiles(*o);
      std::cout << workflows::FormatTriangulateSummary(result, o->out);
      // Points that could not be intersected are named above; none at all is a failure.
      return result.intersected > 0 || result.points.empty() ? kOk : kFailure;
    };
  });
}

}  // namespace armsig::app
