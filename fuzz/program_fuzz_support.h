// What the program parsers' fuzz targets check beyond "only InputError": a program read is
// written back byte for byte with no edit, and rewriting each target with its own values
// gives a program that reads again with the same targets.
#pragma once

#include <cstdio>
#include <cstdlib>

#include "programs/program.h"

namespace armsig::fuzz {

template <typename Parse>
void CheckProgramRoundTrip(const char* target, const programs::Program& program, Parse&& parse) {
  const auto same = programs::ApplyEdits(program.files, {});
  for (std::size_t f = 0; f < program.files.size(); ++f) {
    if (same[f] != program.files[f].text) {
      std::fprintf(stderr, "%s: the program did not come back byte for byte\n", target);
      std::abort();
    }
  }
  std::vector<programs::Edit> edits;
  for (const auto& t : program.targets) {
    const auto own = t.kind() == programs::TargetKind::kPose
                         ? programs::RewritePose(t, programs::PoseOf(t))
                         : programs::RewriteJoints(t, programs::JointsOf(t));
    edits.insert(edits.end(), own.begin(), own.end());
  }
  std::vector<programs::ProgramFile> files = program.files;
  const auto texts = programs::ApplyEdits(program.files, edits);
  for (std::size_t f = 0; f < files.size(); ++f) files[f].text = texts[f];
  const programs::Program again = parse(files);
  if (again.targets.size() != program.targets.size() || again.motions.size() != program.motions.size()) {
    std::fprintf(stderr, "%s: a program rewritten with its own values reads differently\n", target);
    std::abort();
  }
}

}  // namespace armsig::fuzz
