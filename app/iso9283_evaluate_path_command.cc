// armsig iso9283 evaluate-path --commanded PATH.csv --attained STREAM.csv --speed MM_S --json F
#include <iostream>

#include "app/command.h"
#include "core/text.h"
#include "io/atomic_file.h"
#include "iso9283/iso9283_path_files.h"

namespace armsig::app {

struct Iso9283EvaluatePathOptions {
  std::string commanded, attained, json;
  double speed_mm_s = 0.0;
};

int RunIso9283EvaluatePath(const Iso9283EvaluatePathOptions& o) {
  const auto figures = iso9283::EvaluatePathFiles(o.commanded, o.attained, o.speed_mm_s);
  io::WriteFileAtomically(o.json, JsonText(iso9283::PathJson(figures), 2) + "\n");
  std::cout << iso9283::FormatPathFigures(figures);
  return kOk;
}

void SetupIso9283EvaluatePathCommand(CLI::App& iso, const GlobalOptions&, Runner& run) {
  auto o = std::make_shared<Iso9283EvaluatePathOptions>();
  auto* sub = iso.add_subcommand(
      "evaluate-path",
      "ISO 9283 path characteristics (AT, RT, corners, velocity) from a commanded path and "
      "time-stamped attained cycles (a tracker's continuous export), in one frame");
  sub->add_option("--commanded", o->commanded, "CSV: [vertex,]x_mm,y_mm,z_mm, in path order")
      ->type_name("FILE")
      ->required();
  sub->add_option("--attained", o->attained, "CSV: cycle,t_s,x_mm,y_mm,z_mm")
      ->type_name("FILE")
      ->required();
  NumberOption(sub->add_option("--speed", o->speed_mm_s, "The commanded path speed, mm/s"), 1e-3,
               1e5)
      ->required();
  OutputFile(sub->add_option("--json", o->json, "The figures as JSON"))->required();
  sub->callback([&run, o] { run = [o] { return RunIso9283EvaluatePath(*o); }; });
}

}  // namespace armsig::app
