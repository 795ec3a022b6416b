#include "io/network_files.h"

#include <gtest/gtest.h>

#include <filesystem>

#include "core/error.h"
#include "core/units.h"
#include "reduction/observation.h"
#include "test_support.h"

namespace armsig::io {
namespace {

InputError StationsRefusal(const std::string& text) {
  try {
    ParseStationsYaml(text, "st.yaml");
  } catch (const InputError& e) {
    return e;
  }
  ADD_FAILURE() << "expected an InputError for\n" << text;
  return InputError("none");
}

TEST(StationsYaml, EveryStationsFileInTestDataLoads) {
  int files = 0;
  for (const auto& entry :
       std::filesystem::recursive_directory_iterator(testing::DataPath("networks"))) {
    if (entry.path().filename() != "stations.yaml") continue;
    ++files;
    EXPECT_FALSE(ReadStationsYaml(entry.path().string()).empty()) << entry.path();
  }
  EXPECT_EQ(files, 3);
  // k06 station 2 as the file writes it.
  const auto k06 = ReadStationsYaml(testing::DataPath("networks/k06/stations.yaml"));
  ASSERT_EQ(k06.size(), 4u);
  EXPECT_EQ(k06[1].pose.id, "2");
  EXPECT_EQ(k06[1].pose.position_mm, Eigen::Vector3d(1727.52902, 2195.82746, 47.17223));
  EXPECT_NEAR(k06[1].pose.azimuth_rad, 289.7748467 * kPi / 200.0, 1e-15);
  EXPECT_NEAR(k06[1].sigma_hz_rad.value(), 2.5920 * kRadPerArcsec, 1e-18);
  EXPECT_TRUE(k06[1].pose.levelled);
}

TEST(StationsYaml, FormattedStationsReadBackToTheSameNumbers) {
  reduction::Station levelled;
  levelled.pose.id = "141";  // a numeric-looking id stays the text "141"
  levelled.pose.position_mm = {-2046.95645, 1.0 / 3.0, 113.1462};
  levelled.pose.azimuth_rad = 0.7063927311;
  levelled.pose.world_from_station = reduction::LevelledRotation(levelled.pose.azimuth_rad);
  levelled.sigma_hz_rad = 1.296 * kRadPerArcsec;
  levelled.sigma_position_mm = {0.011, 0.012, 0.0135};
  levelled.sigma_azimuth_rad = 0.8 * kRadPerArcsec;
  reduction::Station tilted;
  tilted.pose.id = "T2: north";
  tilted.pose.position_mm = {10000144.31191, 2006751.03954, -0.1};
  tilted.pose.levelled = false;
  tilted.pose.world_from_station =
      Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  tilted.sigma_v_rad = 0.5 * kRadPerArcsec;
  tilted.sigma_rotation_rad = Eigen::Vector3d(1.5, 2.5, 3.5) * kRadPerArcsec;

  const std::string text = FormatStationsYaml({levelled, tilted}, "line one\nline two");
  EXPECT_EQ(text.rfind("# line one\n# line two\n", 0), 0u) << text;
  const auto back = ParseStationsYaml(text, "st.yaml");
  ASSERT_EQ(back.size(), 2u) << text;

  EXPECT_EQ(back[0].pose.id, "141");
  EXPECT_EQ(back[0].pose.position_mm, levelled.pose.position_mm);
  EXPECT_TRUE(back[0].pose.levelled);
  EXPECT_NEAR(back[0].pose.azimuth_rad, levelled.pose.azimuth_rad, 1e-15);  // via gon
  EXPECT_NEAR(back[0].sigma_hz_rad.value(), *levelled.sigma_hz_rad, 1e-20);
  EXPECT_FALSE(back[0].sigma_v_rad);  // not given, not invented
  EXPECT_EQ(back[0].sigma_position_mm, levelled.sigma_position_mm);
  EXPECT_NEAR(back[0].sigma_azimuth_rad, levelled.sigma_azimuth_rad, 1e-20);

  EXPECT_EQ(back[1].pose.id, "T2: north");
  EXPECT_FALSE(back[1].pose.levelled);
  EXPECT_EQ(back[1].pose.position_mm, tilted.pose.position_mm);
  EXPECT_EQ(back[1].pose.world_from_station, tilted.pose.world_from_station);  // exactly
  EXPECT_FALSE(back[1].sigma_hz_rad);
  EXPECT_NEAR(back[1].sigma_v_rad.value(), *tilted.sigma_v_rad, 1e-20);
  EXPECT_LT((back[1].sigma_rotation_rad - tilted.sigma_rotation_rad).norm(), 1e-20);
}

TEST(StationsYaml, MisspeltKeyIsRefusedWithLineAndSuggestion) {
  const InputError e = StationsRefusal(
      "stations:\n"
      "  - id: A\n"
      "    position_mm: [0, 0, 0]\n"
      "    azimuth_gn: 12.5\n");
  EXPECT_STREQ(e.what(), "st.yaml:4:5: unknown key 'azimuth_gn' (did you mean 'azimuth_gon'?)");
  EXPECT_STREQ(StationsRefusal("station:\n  - {id: A}\n").what(),
               "st.yaml:1:1: unknown key 'station' (did you mean 'stations'?)");
}

// The observations orient's data snooping removed travel with the stations: written after
// them, read back (checked) with them.
TEST(StationsYaml, RemovedObservationsAreWrittenAndReadBack) {
  reduction::Station a;
  a.pose.id = "1";
  reduction::RemovedObservation hz;
  hz.kind = reduction::ResidualReport::Kind::kHz;
  hz.station = "1";
  hz.point = "202";
  hz.error = 328.6;
  hz.w = -63.85;
  hz.line = 4;
  reduction::RemovedObservation bar;
  bar.kind = reduction::ResidualReport::Kind::kScaleBar;
  bar.point = "2007:2046";
  bar.error = 0.47;
  bar.w = -8.3;
  const std::string text = FormatStationsYaml({a}, "", {hz, bar});
  EXPECT_NE(text.find("removed_observations:\n  - {station: \"1\", point: \"202\", kind: hz, "
                      "error_arcsec: 328.6, w: -63.85, line: 4}\n  - {point: \"2007:2046\", kind: "
                      "scale_bar, error_mm: 0.47, w: -8.3}"),
            std::string::npos)
      << text;
  EXPECT_EQ(ParseStationsYaml(text, "st.yaml").size(), 1u);
  EXPECT_EQ(FormatStationsYaml({a}, "").find("removed_observations"), std::string::npos);
  const InputError e = StationsRefusal(
      "stations:\n  - {id: A, position_mm: [0, 0, 0], azimuth_gon: 0}\n"
      "removed_observations:\n  - {point: P, kind: hz, wrong: 1}\n");
  EXPECT_NE(std::string(e.what()).find("st.yaml:4:"), std::string::npos) << e.what();
  EXPECT_NE(std::string(e.what()).find("unknown key 'wrong'"), std::string::npos) << e.what();
}

TEST(StationsYaml, RefusesWhatIsNotAStationSetUp) {
  const std::string head = "stations:\n  - {id: A, position_mm: [0, 0, 0], azimuth_gon: 1}\n";
  {
    const InputError e =
        StationsRefusal(head + "  - {id: A, position_mm: [1, 0, 0], azimuth_gon: 2}\n");
    EXPECT_EQ(e.where().line, 3);
    EXPECT_EQ(e.message(), "duplicate station id 'A'");
  }
  {
    const InputError e = StationsRefusal(
        head +
        "  - {id: B, position_mm: [1, 0, 0], rotation: [[1, 0, 0], [0, 1, 0], [0, 0, 2]]}\n");
    EXPECT_EQ(e.where().line, 3);
    EXPECT_EQ(e.message(), "station B: expected a rotation (orthonormal, det +1)");
  }
  {
    const InputError e = StationsRefusal(
        head +
        "  - {id: B, position_mm: [1, 0, 0], azimuth_gon: 3, rotation: [[1, 0, 0], [0, 1, 0], [0, "
        "0, 1]]}\n");
    EXPECT_EQ(e.message(), "station B: give azimuth or rotation, not both");
  }
  {
    const InputError e = StationsRefusal(
        head + "  - {id: B, position_mm: [1, 0, 0], azimuth_gon: 3, azimuth_deg: 3}\n");
    EXPECT_EQ(e.message(), "station B: give one of azimuth_gon, azimuth_deg, azimuth_rad");
  }
  {
    const InputError e =
        StationsRefusal(head + "  - {id: B, position_mm: [1, 0], azimuth_gon: 3}\n");
    EXPECT_EQ(e.where().line, 3);
    EXPECT_EQ(e.where().column, 26);  // the '['
    EXPECT_EQ(e.where().column_name, "position_mm");
    EXPECT_EQ(e.message(), "expected a list of 3 numbers [x, y, z], got a list of 2");
  }
  {
    const InputError e = StationsRefusal(head + "  - {id: B, position_mm: [1, 0, 0]}\n");
    EXPECT_EQ(e.message(), "station B: expected azimuth_gon, azimuth_deg, azimuth_rad or rotation");
  }
  EXPECT_EQ(StationsRefusal("stations: []\n").message(),
            "expected a non-empty list, got a list of 0");
  EXPECT_EQ(StationsRefusal("stations: {id: A}\n").message(), "expected a list, got a mapping");
  EXPECT_EQ(StationsRefusal("# nothing\n").message(),
            "expected a mapping with stations, got nothing");
}

}  // namespace
}  // namespace armsig::io
