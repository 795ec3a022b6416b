#include "instruments/gsi_codec.h"

#include <gtest/gtest.h>

#include <cmath>

#include "test_support.h"

namespace armsig::instruments::gsi {
namespace {

constexpr double kGon = M_PI / 200.0, kDeg = M_PI / 180.0;

FileResult Load(const std::string& name) {
  return ParseFile(testing::ReadText(testing::DataPath("gsi/" + name)));
}

const Word* Find(const Block& b, int wi) {
  for (const auto& w : b.words) {
    if (w.wi == wi) return &w;
  }
  return nullptr;
}

}  // namespace

// The worked examples of the protocol notes and GeoComPy's word table.
TEST(GsiCodec, DecodesEveryUnit) {
  auto w = ParseWord("21.102+11545200", false);
  ASSERT_TRUE(w);
  EXPECT_NEAR(*AngleRad(*w), 115.452 * kGon, 1e-12);
  EXPECT_NEAR(*AngleRad(*ParseWord("21...3+18000000", false)), M_PI, 1e-12);
  EXPECT_NEAR(*AngleRad(*ParseWord("21.024+0000000003545100", true)),
              (35 + 45 / 60.0 + 10.0 / 3600) * kDeg, 1e-12);
  EXPECT_NEAR(*AngleRad(*ParseWord("21.324+0000000024943030", true)),
              (249 + 43 / 60.0 + 3.0 / 3600) * kDeg, 1e-12);
  EXPECT_NEAR(*AngleRad(*ParseWord("21...5+32000000", false)), M_PI, 1e-12);  // 3200 mil
  EXPECT_NEAR(*LengthMm(*ParseWord("31..00+00005165", false)), 5165.0, 1e-9);
  EXPECT_NEAR(*LengthMm(*ParseWord("31...8+0000012312345600", true)), 123123456.0, 1e-6);
  EXPECT_NEAR(*LengthMm(*ParseWord("31..06+0000000000073493", true)), 7349.3, 1e-9);
  EXPECT_NEAR(*LengthMm(*ParseWord("81..06-0000000000068507", true)), -6850.7, 1e-9);
  EXPECT_NEAR(*LengthMm(*ParseWord("31...1+00001000", false)), 304.8, 1e-9);     // 1 ft
  EXPECT_NEAR(*LengthMm(*ParseWord("31...7+00010000", false)), 304.8, 1e-9);     // 1 ft
  EXPECT_NEAR(*LengthMm(*ParseWord("590..6+01234560", false)), 123456.0, 1e-9);  // 123.456
  EXPECT_EQ(Identifier(*ParseWord("11....+000000P1", false)), "P1");
  EXPECT_EQ(BlockNumber(*ParseWord("110002+00000000GDEM5415", true)), 2);
  std::string why;
  EXPECT_FALSE(AngleRad(*ParseWord("31..00+00005165", false), &why));
  EXPECT_NE(why.find("not an angle unit"), std::string::npos);
  EXPECT_FALSE(ParseWord("21.102x11545200", false, &why));
}

TEST(GsiCodec, EncodersRoundTrip) {
  const double hz = 1.2345678;
  EXPECT_NEAR(*AngleRad(*ParseWord(EncodeAngleWord(21, hz, false), false)), hz, 1e-7);
  EXPECT_NEAR(*AngleRad(*ParseWord(EncodeAngleWord(21, hz, true, '4'), true)), hz, 3e-7);
  EXPECT_NEAR(*LengthMm(*ParseWord(EncodeLengthWord(31, 4321.27, true, '8'), true)), 4321.27, 1e-9);
}

// Total Open Station asserts E 515.836, N 525.871, H 3.079 for the first point,
// named "1", and H 2.553 for the fourth.
TEST(GsiRealFiles, Gsi8Ertola) {
  const auto f = Load("tos-leica_gsi8_ertola.gsi");
  ASSERT_FALSE(f.error) << f.error->message;
  const Block& first = f.blocks.at(0);
  EXPECT_EQ(Identifier(*Find(first, 11)), "1");
  EXPECT_NEAR(*LengthMm(*Find(first, 81)), 515836.0, 1e-6);
  EXPECT_NEAR(*LengthMm(*Find(first, 82)), 525871.0, 1e-6);
  EXPECT_NEAR(*LengthMm(*Find(first, 83)), 3079.0, 1e-6);
  EXPECT_NEAR(*LengthMm(*Find(f.blocks.at(3), 83)), 2553.0, 1e-6);
  EXPECT_EQ(Identifier(*Find(f.blocks.at(1), 11)), "2");
  EXPECT_NEAR(*AngleRad(*Find(first, 21)), 34.96940 * kGon, 1e-12);
}

// Total Open Station computes the first point of this GSI-16 file (DMS angles) as
// x 8.0757244, y 11.21674196, z −0.2890493 m: polar from SD, Hz, V and the instrument
// (88) and reflector (87) heights. Recomputed here from our decoded words.
TEST(GsiRealFiles, Gsi16GurobPolarPointMatchesTotalOpenStation) {
  const auto f = Load("tos-leica_gsi16_gurob.gsi");
  ASSERT_FALSE(f.error) << f.error->message;
  const Block& b = f.blocks.at(0);
  EXPECT_TRUE(b.gsi16);
  EXPECT_EQ(Identifier(*Find(b, 11)), "GDEM5415");
  EXPECT_EQ(BlockNumber(*Find(b, 11)), 2);
  EXPECT_EQ(Identifier(*Find(f.blocks.at(1), 11)), "GDEM5416");
  const double hz = *AngleRad(*Find(b, 21)), v = *AngleRad(*Find(b, 22));
  const double sd = *LengthMm(*Find(b, 31)) / 1000.0;
  const double reflector = *LengthMm(*Find(b, 87)) / 1000.0,
               instrument = *LengthMm(*Find(b, 88)) / 1000.0;
  EXPECT_NEAR(sd * std::sin(v) * std::sin(hz), 8.0757244, 1e-6);
  EXPECT_NEAR(sd * std::sin(v) * std::cos(hz), 11.21674196, 1e-6);
  EXPECT_NEAR(sd * std::cos(v) + instrument - reflector, -0.2890493, 1e-6);
}

// CR-only blocks with a leading CR; Total Open Station expects point 3 to be "102".
TEST(GsiRealFiles, RilievoCrSeparated) {
  const auto f = Load("tos-RILIEVO.gsi");
  ASSERT_FALSE(f.error) << f.error->message;
  ASSERT_GE(f.blocks.size(), 3u);
  EXPECT_EQ(Identifier(*Find(f.blocks.at(2), 11)), "102");
  EXPECT_NEAR(*AngleRad(*Find(f.blocks.at(0), 21)), 115.452 * kGon, 1e-12);
  EXPECT_NEAR(*LengthMm(*Find(f.blocks.at(2), 31)), 5165.0, 1e-9);
}

// GeoComPy: 8 blocks in the mixed TPS file, 7 in the DNA file, no unknown words.
TEST(GsiRealFiles, GeoComPyTpsAndDnaFiles) {
  const auto tps = Load("geocompy-tps_data.gsi");
  ASSERT_FALSE(tps.error) << tps.error->message;
  EXPECT_EQ(tps.blocks.size(), 8u);
  EXPECT_EQ(Identifier(*Find(tps.blocks.at(0), 11)), "P0001");
  EXPECT_NEAR(*AngleRad(*Find(tps.blocks.at(0), 21)), (249 + 43 / 60.0 + 3.0 / 3600) * kDeg, 1e-12);
  EXPECT_NEAR(*LengthMm(*Find(tps.blocks.at(0), 31)), 7349.3, 1e-9);
  const auto dna = Load("geocompy-dna_data.gsi");
  ASSERT_FALSE(dna.error) << dna.error->message;
  EXPECT_EQ(dna.blocks.size(), 7u);
  EXPECT_NEAR(*LengthMm(*Find(dna.blocks.at(2), 32)), 22752.33, 1e-9);
  EXPECT_NEAR(*LengthMm(*Find(dna.blocks.at(2), 331)), 1261.39, 1e-9);
}

TEST(GsiCodec, MalformedFileNamesLineAndColumn) {
  const auto f = ParseFile("110001+00000001 21.322+03496940\n110002+00000002 21.32X+0349694\n");
  ASSERT_TRUE(f.error);
  EXPECT_EQ(f.error->line, 2);
  EXPECT_EQ(f.error->column, 17);
}

}  // namespace armsig::instruments::gsi
