// GSI files to observations: a circle reading outside its circle (a negative zenith
// angle, Hz beyond 400 gon) is an input error naming file, line, column and the range.
#include "io/gsi_import.h"

#include <gtest/gtest.h>

#include <filesystem>

#include "core/error.h"
#include "test_support.h"

namespace armsig::io {

TEST(GsiImport, NegativeZenithAngleIsAnInputErrorNamingLineAndRange) {
  testing::TempDir dir;
  testing::WriteText(dir.File("v.gsi"),
                     "110001+00000001 21.322+03496940 22.322+09364360\r\n"
                     "110002+00000002 21.322+02179330 22.322-09442590\r\n");
  try {
    ImportGsi(dir.File("v.gsi"), "S1");
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_EQ(e.where().line, 2);
    EXPECT_EQ(e.where().column, 33);
    EXPECT_EQ(e.where().column_name, "WI22");
    EXPECT_NE(std::string(e.what()).find("v.gsi:2:33 (WI22): expected a zenith angle from 0 to "
                                         "400 gon (face II above the half circle), got -94.4259"),
              std::string::npos)
        << e.what();
  }
}

TEST(GsiImport, HzBeyondTheCircleInItsOwnUnitIsAnInputError) {
  testing::TempDir dir;
  // Decimal degrees (unit 3): 361.5° is past the full circle.
  testing::WriteText(dir.File("hz.gsi"), "110001+00000001 21.323+36150000 22.323+09000000\r\n");
  try {
    ImportGsi(dir.File("hz.gsi"), "S1");
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(
        std::string(e.what()).find(":1:17 (WI21): expected a horizontal circle reading from 0 "
                                   "to 360 deg, got 361.5"),
        std::string::npos)
        << e.what();
  }
  // Zero and a face-II zenith angle just under 400 gon are readings.
  testing::WriteText(dir.File("ok.gsi"), "110001+00000001 21.322+00000000 22.322+39999000\r\n");
  const auto ok = ImportGsi(dir.File("ok.gsi"), "S1");
  ASSERT_EQ(ok.observations.size(), 1u);
  EXPECT_EQ(ok.observations[0].reading.face, 2);
}

// Through the command line: exit 2, the message names the place, nothing is written.
TEST(GsiImport, CommandRefusesANegativeZenithAngleWithExitTwo) {
  testing::TempDir dir;
  testing::WriteText(dir.File("v.gsi"), "110001+00000001 21.322+03496940 22.322-00000100\r\n");
  const auto r = testing::RunArmsig("import gsi '" + dir.File("v.gsi") + "' --station S1 --out '" +
                                    dir.File("o.csv") + "'");
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_NE(r.err.find("v.gsi:1:33 (WI22): expected a zenith angle from 0 to 400 gon"),
            std::string::npos)
      << r.err;
  EXPECT_NE(r.err.find("got -0.001"), std::string::npos) << r.err;
  EXPECT_FALSE(std::filesystem::exists(dir.File("o.csv")));
}

}  // namespace armsig::io
