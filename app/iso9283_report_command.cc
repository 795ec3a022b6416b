// armsig iso9283 report --robot NAME --session ID [--compensated-session ID]
//                       [--commanded PLAN.csv] [--align] --out DIR [--json F]
#include <iostream>

#include "app/command.h"
#include "core/error.h"
#include "core/text.h"
#include "io/atomic_file.h"
#include "iso9283/iso9283_report.h"

namespace armsig::app {

struct Iso9283ReportCommandOptions {
  iso9283::Iso9283ReportOptions report;
  double load_kg = -1.0, speed_percent = -1.0;  // < 0: not stated
  std::string json;
  std::vector<std::string> limits;  // KEY=MM
};

int RunIso9283Report(const Iso9283ReportCommandOptions& o, db::Database& db) {
  iso9283::Iso9283ReportOptions options = o.report;
  if (o.load_kg >= 0) options.load_kg = o.load_kg;
  if (o.speed_percent >= 0) options.speed_percent = o.speed_percent;
  for (const auto& limit : o.limits) iso9283::ParseIso9283Limit(limit, options.limits);
  if (!options.limits.source.empty() && !options.limits.any()) {
    throw InputError("--limits-from: names where limits come from, but no --limit KEY=MM is given");
  }
  const auto result = iso9283::RunIso9283Report(db, options);
  if (!o.json.empty()) io::WriteFileAtomically(o.json, JsonText(result.json, 2) + "\n");
  std::cout << result.text;
  // A test outside the stated limits is a gate that failed: the page and the JSON say which
  // figure, where and by how much.
  return result.pass ? kOk : kQualityGate;
}

void SetupIso9283ReportCommand(CLI::App& iso, const GlobalOptions& global, Runner& run) {
  auto o = std::make_shared<Iso9283ReportCommandOptions>();
  auto* sub = iso.add_subcommand(
      "report", "Evaluate an ISO 9283 test session: AP, RP, AD, RD, vAP and the certificate page");
  NameOption(sub->add_option("--robot", o->report.robot, "Robot name"))->required();
  NumberOption(sub->add_option("--session", o->report.session, "The test's session"), 1, kMaxId)
      ->required();
  NumberOption(sub->add_option("--compensated-session", o->report.compensated_session,
                               "The same test run with the compensated plan"),
               1, kMaxId);
  sub->add_option("--commanded", o->report.commanded_csv,
                  "The plan CSV, when the session's stored plan has no targets")
      ->type_name("FILE");
  sub->add_flag("--align", o->report.align,
                "Rigid best fit of the barycentres onto the commanded positions (reported) "
                "instead of the robot's frame");
  NumberOption(
      sub->add_option("--load-kg", o->load_kg, "Load during the test (stated on the page)"), 0.0,
      1e5);
  NumberOption(sub->add_option("--speed-percent", o->speed_percent,
                               "Speed during the test, % of rated (stated on the page)"),
               0.0, 1000.0);
  sub->add_option("--limit", o->limits,
                  "A stated limit, KEY=MM with KEY one of AP, RP, AD, RD (repeat it): every "
                  "point's (distance's) figure is judged against it; exit 3 when one is beyond")
      ->type_name("KEY=MM");
  NoteOption(sub->add_option("--limits-from", o->report.limits.source,
                             "Who states the limits (on the page): \"KR 16-2 data sheet\", "
                             "\"customer acceptance\"")
                 ->type_name("TEXT"));
  OutputDirectory(sub->add_option("--out", o->report.out_dir, "Folder of the HTML page"))
      ->required();
  OutputFile(sub->add_option("--json", o->json, "The figures as JSON"));
  OnDatabaseToRead(sub, global, run, [o](db::Database& db) { return RunIso9283Report(*o, db); });
}

}  // namespace armsig::app
