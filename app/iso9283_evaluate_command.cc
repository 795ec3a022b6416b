// armsig iso9283 evaluate --commanded C.csv --attained A.csv [--align] --json F
#include <iostream>

#include "app/command.h"
#include "core/text.h"
#include "io/atomic_file.h"
#include "iso9283/iso9283.h"

namespace armsig::app {

struct Iso9283EvaluateOptions {
  std::string commanded, attained, json;
  bool align = false;
};

int RunIso9283Evaluate(const Iso9283EvaluateOptions& o) {
  const auto e = iso9283::EvaluateIso9283Files(o.commanded, o.attained, o.align);
  io::WriteFileAtomically(o.json, JsonText(iso9283::Iso9283Json(e), 2) + "\n");
  std::cout << iso9283::FormatIso9283Figures(e);
  return kOk;
}

void SetupIso9283EvaluateCommand(CLI::App& iso, const GlobalOptions&, Runner& run) {
  auto o = std::make_shared<Iso9283EvaluateOptions>();
  auto* sub = iso.add_subcommand(
      "evaluate", "ISO 9283 figures from files: commanded and attained poses from anywhere");
  sub->add_option("--commanded", o->commanded, "CSV: point,x_mm,y_mm,z_mm[,a_deg,b_deg,c_deg]")
      ->type_name("FILE")
      ->required();
  sub->add_option("--attained", o->attained,
                  "CSV: point,cycle,x_mm,y_mm,z_mm[,a_deg,b_deg,c_deg][,approach]")
      ->type_name("FILE")
      ->required();
  sub->add_flag("--align", o->align,
                "Rigid best fit of the measuring frame onto the commanded one (reported)");
  OutputFile(sub->add_option("--json", o->json, "The figures as JSON"))->required();
  sub->callback([&run, o] { run = [o] { return RunIso9283Evaluate(*o); }; });
}

}  // namespace armsig::app
