// The drawing pieces of the report pages (report/figures.h): a legend or a note never
// covers the plotting area, its ticks or the axis titles, and stays within the image.
#include "report/figures.h"

#include <gtest/gtest.h>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

namespace armsig::report::figures {
namespace {

Plot Drawn(bool legend, bool note) {
  Plot p(600, 300, "A figure", LinearAxis(0, 10, 5), LinearAxis(0, 1, 4), "the x axis title (mm)",
         "mm");
  DrawMarker(p.image, p.At(5, 0.5), Marker::kCircle, kBlue, 4);
  DrawMarker(p.image, p.At(9.5, 0.95), Marker::kSquare, kRed, 4);
  if (legend) {
    p.Legend({{Marker::kCircle, kBlue, "largest difference against the version before"},
              {Marker::kSquare, kRed, "drift flagged against the set active before"},
              {Marker::kLine, kRed, "tolerance 0.05 mm"},
              {Marker::kDiamond, kGreen, "a fourth entry with a long text"}});
  }
  if (note) {
    p.Note(
        "a note under the axis title that is longer than the figure is wide, so that it "
        "has to wrap onto a second row and a third one too if the words need it");
  }
  return p;
}

bool White(const cv::Mat& image, const cv::Rect& region) {
  cv::Mat grey;
  cv::cvtColor(image(region), grey, cv::COLOR_BGR2GRAY);
  double lo = 0.0;
  cv::minMaxLoc(grey, &lo);
  return lo == 255.0;
}

}  // namespace

TEST(Plot, LegendRowsAndNotesLeaveTheAreaTicksAndAxisTitlesAsTheyWere) {
  const Plot plain = Drawn(false, false), dressed = Drawn(true, true);
  // Four long entries do not fit one 600-pixel row: the area moved down a row or more.
  const int extra = dressed.area.y - plain.area.y;
  EXPECT_GE(extra, 18);
  EXPECT_EQ(dressed.area.height, plain.area.height);
  // From the area's top to the bottom of the plain figure (data, ticks, the x axis title):
  // the same pixels, moved down by the legend's rows.
  const cv::Rect below_plain(0, plain.area.y, plain.image.cols, plain.image.rows - plain.area.y);
  const cv::Rect below_dressed(0, dressed.area.y, dressed.image.cols, below_plain.height);
  ASSERT_LE(below_dressed.y + below_dressed.height, dressed.image.rows);
  EXPECT_EQ(cv::norm(plain.image(below_plain), dressed.image(below_dressed), cv::NORM_INF), 0.0);
  // The title row is where it was; the notes are below everything else.
  const cv::Rect title(0, 0, plain.image.cols, 24);
  EXPECT_EQ(cv::norm(plain.image(title), dressed.image(title), cv::NORM_INF), 0.0);
  EXPECT_GE(dressed.image.rows, plain.image.rows + extra + 2 * 18);  // the note took two rows
  // Nothing drawn in the right margin (the legend wrapped inside the image).
  EXPECT_TRUE(White(dressed.image, cv::Rect(dressed.image.cols - 6, 0, 6, dressed.area.y)));
}

TEST(Plot, ACaptionSurvivesTheLegendsRows) {
  Plot p(600, 300, "A figure", LinearAxis(0, 10, 5), LinearAxis(0, 1, 4), "x", "mm");
  p.Caption("ring: chosen");
  const cv::Mat before = p.image(cv::Rect(0, 0, p.image.cols, 24)).clone();
  p.Legend({{Marker::kCircle, kBlue, "an entry long enough to need a row of its own here"},
            {Marker::kSquare, kRed, "and another entry that is just as long as the first"}});
  EXPECT_GT(p.area.y, 56);
  EXPECT_EQ(cv::norm(before, p.image(cv::Rect(0, 0, p.image.cols, 24)), cv::NORM_INF), 0.0);
}

}  // namespace armsig::report::figures
