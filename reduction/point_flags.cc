#include "reduction/point_flags.h"

#include <array>
#include <utility>

namespace armsig::reduction {

namespace {

constexpr std::array<std::pair<PointFlag, const char*>, 9> kWords = {{
    {PointFlag::kMissExceeded, "miss_exceeded"},
    {PointFlag::kRepeatExceeded, "repeat_exceeded"},
    {PointFlag::kSigmaExceeded, "sigma_exceeded"},
    {PointFlag::kBlunderRejected, "blunder_rejected"},
    {PointFlag::kBlunderSuspected, "blunder_suspected"},
    {PointFlag::kOneRay, "one_ray"},
    {PointFlag::kParallelRays, "parallel_rays"},
    {PointFlag::kNotConverged, "not_converged"},
    {PointFlag::kNonFinite, "non_finite"},
}};

}  // namespace

const char* ToString(PointFlag flag) {
  for (const auto& [f, word] : kWords) {
    if (f == flag) return word;
  }
  return "?";
}

std::string ToString(PointFlags flags) {
  std::string out;
  for (const auto& [f, word] : kWords) {
    if (!flags.Has(f)) continue;
    if (!out.empty()) out += ' ';
    out += word;
  }
  return out;
}

std::optional<PointFlags> ParsePointFlags(std::string_view text) {
  PointFlags flags;
  size_t pos = 0;
  while (pos < text.size()) {
    const size_t begin = text.find_first_not_of(" \t\r\n", pos);
    if (begin == std::string_view::npos) break;
    size_t end = text.find_first_of(" \t\r\n", begin);
    if (end == std::string_view::npos) end = text.size();
    const std::string_view word = text.substr(begin, end - begin);
    pos = end;
    if (word == "ok") continue;
    if (word == "no_convergence") {
      flags.Set(PointFlag::kNotConverged);
      continue;
    }
    bool known = false;
    for (const auto& [f, w] : kWords) {
      if (word == w) {
        flags.Set(f);
        known = true;
      }
    }
    if (!known) return std::nullopt;
  }
  return flags;
}

PointFlags FlagsOf(const SolveStatus& status) {
  switch (status.code) {
    case SolveCode::kOk:
      return {};
    case SolveCode::kTooFewObservations:
      return PointFlag::kOneRay;
    case SolveCode::kDegenerate:
      return PointFlag::kParallelRays;
    case SolveCode::kNonFinite:
      return PointFlag::kNonFinite;
    case SolveCode::kNotConverged:
    case SolveCode::kOutOfRange:
      return PointFlag::kNotConverged;
  }
  return PointFlag::kNotConverged;
}

}  // namespace armsig::reduction
