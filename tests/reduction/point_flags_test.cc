#include "reduction/point_flags.h"

#include <gtest/gtest.h>

namespace armsig::reduction {

TEST(PointFlags, TextRoundTripsInOneOrder) {
  PointFlags flags;
  flags.Set(PointFlag::kBlunderRejected)
      .Set(PointFlag::kRepeatExceeded)
      .Set(PointFlag::kMissExceeded);
  EXPECT_EQ(ToString(flags), "miss_exceeded repeat_exceeded blunder_rejected");
  EXPECT_EQ(ParsePointFlags(ToString(flags)), flags);
  EXPECT_EQ(ToString(PointFlags{}), "");
  for (PointFlag f : {PointFlag::kBlunderRejected, PointFlag::kBlunderSuspected,
                      PointFlag::kMissExceeded, PointFlag::kRepeatExceeded, PointFlag::kOneRay,
                      PointFlag::kParallelRays, PointFlag::kNotConverged, PointFlag::kNonFinite,
                      PointFlag::kSigmaExceeded}) {
    EXPECT_EQ(ParsePointFlags(ToString(f)), PointFlags(f)) << ToString(f);
  }
  EXPECT_EQ(ToString(PointFlags(PointFlag::kSigmaExceeded).Set(PointFlag::kRepeatExceeded)),
            "repeat_exceeded sigma_exceeded");
}

TEST(PointFlags, ParsesWhatEarlierVersionsStored) {
  // Capture wrote a trailing space; triangulate "ok"; intersections "no_convergence".
  const auto capture = ParsePointFlags("miss_exceeded repeat_exceeded ");
  ASSERT_TRUE(capture);
  EXPECT_TRUE(capture->Has(PointFlag::kMissExceeded));
  EXPECT_TRUE(capture->Has(PointFlag::kRepeatExceeded));
  EXPECT_FALSE(capture->Has(PointFlag::kBlunderRejected));
  EXPECT_EQ(ParsePointFlags("ok"), PointFlags{});
  EXPECT_EQ(ParsePointFlags(""), PointFlags{});
  EXPECT_EQ(ParsePointFlags("no_convergence"), PointFlags(PointFlag::kNotConverged));
}

TEST(PointFlags, UnknownWordIsRefused) {
  EXPECT_FALSE(ParsePointFlags("miss_exceeded blunder").has_value());
}

TEST(PointFlags, FailedSolvesMapToTheirFlag) {
  EXPECT_TRUE(FlagsOf(SolveStatus{}).empty());
  EXPECT_EQ(FlagsOf({SolveCode::kTooFewObservations, ""}), PointFlags(PointFlag::kOneRay));
  EXPECT_EQ(FlagsOf({SolveCode::kDegenerate, ""}), PointFlags(PointFlag::kParallelRays));
  EXPECT_EQ(FlagsOf({SolveCode::kNotConverged, ""}), PointFlags(PointFlag::kNotConverged));
  EXPECT_EQ(FlagsOf({SolveCode::kNonFinite, ""}), PointFlags(PointFlag::kNonFinite));
}

}  // namespace armsig::reduction
