// The one vocabulary of a reduced point's flags, shared by capture, `reduce` and
// `triangulate`, and stored as text in the points table ("miss_exceeded blunder_rejected").
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

#include "core/error.h"

namespace armsig::reduction {

enum class PointFlag : uint32_t {
  kBlunderRejected = 1u << 0,   // a ray failed the data snooping test and was left out
  kBlunderSuspected = 1u << 1,  // a ray fails the test but too few rays remain to reject it
  kMissExceeded = 1u << 2,      // largest ray miss distance above the tolerance
  kRepeatExceeded = 1u << 3,    // repeated measurements spread more than the tolerance
  kOneRay = 1u << 4,            // one ray and no distance (or none): no point
  kParallelRays = 1u << 5,      // rays nearly parallel: no point
  kNotConverged = 1u << 6,      // the least squares did not converge: no point
  kNonFinite = 1u << 7,         // an input or the estimate is not finite: no point
  // A polar instrument (laser tracker) stated a sigma above the tolerance for a reading
  // (turbulent air, a dirty or tilted reflector).
  kSigmaExceeded = 1u << 8,
};

// A set of flags; its text is the words in the order of PointFlag, space-separated.
class PointFlags {
 public:
  PointFlags() = default;
  PointFlags(PointFlag flag) : bits_(static_cast<uint32_t>(flag)) {}  // NOLINT: implicit

  bool Has(PointFlag flag) const { return (bits_ & static_cast<uint32_t>(flag)) != 0; }
  PointFlags& Set(PointFlag flag, bool on = true) {
    if (on)
      bits_ |= static_cast<uint32_t>(flag);
    else
      bits_ &= ~static_cast<uint32_t>(flag);
    return *this;
  }
  PointFlags& operator|=(PointFlags other) {
    bits_ |= other.bits_;
    return *this;
  }
  bool empty() const { return bits_ == 0; }
  uint32_t bits() const { return bits_; }
  bool operator==(const PointFlags&) const = default;

 private:
  uint32_t bits_ = 0;
};

const char* ToString(PointFlag flag);
// "" for no flag, else e.g. "miss_exceeded repeat_exceeded blunder_rejected".
std::string ToString(PointFlags flags);
// The stored text back (words separated by white space, any order; "ok" and "" are no
// flag; "no_convergence" is the old word for not_converged). nullopt on an unknown word.
std::optional<PointFlags> ParsePointFlags(std::string_view text);

// The flag of a failed solve (one_ray, parallel_rays, not_converged, non_finite); none
// when ok.
PointFlags FlagsOf(const SolveStatus& status);

}  // namespace armsig::reduction
