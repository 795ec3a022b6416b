// Point tables as laser-tracker software exports them: every dialect of the fixtures
// (tests/data/tracker-exports, modelled on documented vendor layouts) gives the same points;
// what cannot be told apart is refused at its line.
#include "io/point_table.h"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <string>

#include "core/error.h"
#include "test_support.h"

namespace armsig::io {
namespace {

// The four points every fixture holds, in mm.
const Eigen::Vector3d kFixture[4] = {{1512.4031, -203.1187, 1034.5520},
                                     {1498.7725, 12.0390, 1102.7713},
                                     {1377.0051, 240.6624, 987.2209},
                                     {1620.1998, -412.5071, 856.4412}};

std::string Fixture(const std::string& name) {
  return testing::DataPath("tracker-exports/" + name);
}

void ExpectFixturePoints(const PointTable& t, double tolerance_mm, const std::string& prefix) {
  ASSERT_EQ(t.points.size(), 4u) << t.source;
  for (int k = 0; k < 4; ++k) {
    EXPECT_EQ(t.points[k].name,
              prefix.empty() ? std::to_string(k + 1) : fmt::format("{}{:03d}", prefix, k + 1));
    EXPECT_LT((t.points[k].position_mm - kFixture[k]).norm(), tolerance_mm)
        << t.source << " point " << k + 1 << ": " << t.points[k].position_mm.transpose();
  }
}

std::string PointTableRefusal(const std::string& text, const PointTableOptions& options = {}) {
  try {
    ParsePointTable(text, "pts.txt", options);
  } catch (const InputError& e) {
    return e.what();
  }
  return "(accepted)";
}

}  // namespace

TEST(PointTable, EveryExportDialectGivesTheSamePoints) {
  {
    // SpatialAnalyzer: // comments, Collection Group Target x y z, no unit in the file.
    PointTableOptions mm;
    mm.unit = LengthUnit::kMm;
    const auto t = ReadPointTable(Fixture("sa-collection-group-target.txt"), mm);
    ExpectFixturePoints(t, 1e-9, "P");
    EXPECT_EQ(t.delimiter, "whitespace");
    EXPECT_EQ(t.header_line, 0);
    EXPECT_EQ(t.unit_from, "--points-unit");
  }
  {
    // Leica: title lines, "Units: Meter", an aligned header with a code column.
    const auto t = ReadPointTable(Fixture("leica-ptid-east-north-height.txt"));
    ExpectFixturePoints(t, 1e-9, "P");
    EXPECT_EQ(t.header_line, 6);
    EXPECT_EQ(t.unit, LengthUnit::kM);
    EXPECT_NE(t.unit_from.find("line 4"), std::string::npos) << t.unit_from;
  }
  {
    // ';' with decimal commas, title lines, units in the header, ISO times, CR LF.
    const auto t = ReadPointTable(Fixture("semicolon-decimal-comma.csv"));
    ExpectFixturePoints(t, 1e-9, "P");
    EXPECT_EQ(t.delimiter, "semicolon");
    EXPECT_TRUE(t.decimal_comma);
    EXPECT_EQ(t.header_line, 4);
    ASSERT_TRUE(t.has_times);
    EXPECT_TRUE(t.points[0].time->absolute);
    EXPECT_NEAR(t.points[1].time->seconds - t.points[0].time->seconds, 11.75, 1e-6);
  }
  {
    // Tab-separated, a units line: inches for the coordinates, mm for the sigmas.
    const auto t = ReadPointTable(Fixture("tab-units-line-sigmas.txt"));
    ExpectFixturePoints(t, 2e-5, "P");  // six decimals of an inch: 2.5e-5 mm
    EXPECT_EQ(t.delimiter, "tab");
    EXPECT_EQ(t.unit, LengthUnit::kInch);
    ASSERT_TRUE(t.points[0].sigma_mm.has_value());
    EXPECT_NEAR(t.points[0].sigma_mm->x(), 0.0081, 1e-12);  // mm, not inches
    EXPECT_NEAR(t.points[3].sigma_mm->z(), 0.0110, 1e-12);
  }
  {
    // Numbered points with a code column, no header: positional.
    PointTableOptions mm;
    mm.unit = LengthUnit::kMm;
    ExpectFixturePoints(ReadPointTable(Fixture("numbered-points-with-codes.txt"), mm), 1e-9, "");
  }
}

TEST(PointTable, RefusesWhatItCannotTellApartAtItsLine) {
  PointTableOptions mm;
  mm.unit = LengthUnit::kMm;
  // Name, xyz, ijk, offset, tolerances: nine numbers, no header.
  try {
    ReadPointTable(Fixture("powerinspect-normals.txt"), mm);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(e.where().line, 1);
    EXPECT_NE(std::string(e.what()).find("cannot tell the columns apart"), std::string::npos)
        << e.what();
  }
  // No unit anywhere: never guessed.
  EXPECT_NE(PointTableRefusal("A B P1 1 2 3\nA B P2 4 5 6\n").find("give --points-unit"), std::string::npos);
  // Two units that disagree.
  PointTableOptions metres;
  metres.unit = LengthUnit::kM;
  const std::string conflict = PointTableRefusal("name,x [mm],y [mm],z [mm]\nP1,1,2,3\n", metres);
  EXPECT_NE(conflict.find("says mm but --points-unit says m"), std::string::npos) << conflict;
  EXPECT_NE(PointTableRefusal("name,x [mm],y [m],z [mm]\nP1,1,2,3\n").find("one length unit"),
            std::string::npos);
  // A number that is none: file:line:column (column name).
  EXPECT_NE(PointTableRefusal("name;x [mm];y [mm];z [mm]\nP1;1;2;3\nP2;4;5,5,5;6\n")
                .find("pts.txt:3:3 (y [mm]): expected a finite number, got '5,5,5'"),
            std::string::npos)
      << PointTableRefusal("name;x [mm];y [mm];z [mm]\nP1;1;2;3\nP2;4;5,5,5;6\n");
  // Implausible coordinates (a unit mix-up by 10^9).
  EXPECT_NE(PointTableRefusal("name,x [m],y [m],z [m]\nP1,1e9,2,3\n").find("pts.txt:2:2"), std::string::npos);
  // Duplicate names, with both lines.
  EXPECT_NE(PointTableRefusal("name x y z\nmm mm mm\nP1 1 2 3\nP2 4 5 6\nP1 7 8 9\n")
                .find("pts.txt:5:1 (name): duplicate point name 'P1' (also on line 3)"),
            std::string::npos)
      << PointTableRefusal("name x y z\nmm mm mm\nP1 1 2 3\nP2 4 5 6\nP1 7 8 9\n");
  // A row that does not fit the table, after the first point row.
  EXPECT_NE(PointTableRefusal("name,x_mm,y_mm,z_mm\nP1,1,2,3\nP2,4,5\n")
                .find("pts.txt:3: expected 4 fields (comma-separated)"),
            std::string::npos);
  // Text between the header and the points that is no units line.
  EXPECT_NE(PointTableRefusal("name,x_mm,y_mm,z_mm\nmeasured by hand\nP1,1,2,3\n")
                .find("pts.txt:2: expected a units line"),
            std::string::npos)
      << PointTableRefusal("name,x_mm,y_mm,z_mm\nmeasured by hand\nP1,1,2,3\n");
  // No point rows at all.
  EXPECT_NE(PointTableRefusal("just a title\n").find("no point rows"), std::string::npos);
  // A bad time stamp, at its column.
  EXPECT_NE(PointTableRefusal("name,x_mm,y_mm,z_mm,time\nP1,1,2,3,yesterday\n").find("pts.txt:2:5 (time)"),
            std::string::npos);
}

}  // namespace armsig::io
