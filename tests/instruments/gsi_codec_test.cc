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

// Value → word → text → word → value, for every unit, both word widths, negative
// values and the largest value a GSI-8 word holds. Tolerance: half the unit's last digit.
TEST(GsiCodec, AngleWordsRoundTripInEveryUnit) {
  struct Case {
    char unit;
    double rad;
    bool gsi16;
    double half_digit_rad;
  };
  const double gon = kGon, deg = kDeg;
  const Case cases[] = {
      {'2', 1.2345678, false, 0.5e-5 * gon},   {'2', -1.2345678, true, 0.5e-5 * gon},
      {'2', 0.0, false, 0.5e-5 * gon},         {'2', 999.99999 * gon, false, 0.5e-5 * gon},
      {'3', 2.5, false, 0.5e-5 * deg},         {'3', -0.001, true, 0.5e-5 * deg},
      {'4', 1.2345678, true, 0.05 / 3600 * deg}, {'4', -3.0, false, 0.05 / 3600 * deg},
      {'4', 359.99 * deg, false, 0.05 / 3600 * deg},
      {'5', 1.0, false, 0.5e-4 * 2 * M_PI / 6400}, {'5', -6.0, true, 0.5e-4 * 2 * M_PI / 6400},
  };
  for (const auto& c : cases) {
    const Word w = AngleWord(21, c.rad, c.gsi16, c.unit);
    const std::string text = FormatWord(w);
    EXPECT_EQ(text.size(), c.gsi16 ? 24u : 16u) << text;
    EXPECT_EQ(text.back(), ' ');
    const auto parsed = ParseWord(text, c.gsi16);
    ASSERT_TRUE(parsed) << text;
    EXPECT_EQ(*parsed, w) << text;
    EXPECT_EQ(parsed->sign, c.rad < 0 ? '-' : '+') << text;
    EXPECT_NEAR(*AngleRad(*parsed), c.rad, c.half_digit_rad * 1.0001) << text;
  }
}

TEST(GsiCodec, LengthWordsRoundTripInEveryUnit) {
  struct Case {
    char unit;
    double mm;
    bool gsi16;
    double half_digit_mm;
  };
  const Case cases[] = {
      {'0', 5165.0, false, 0.5},      {'0', -6850.0, true, 0.5},
      {'1', 304.8, false, 0.1524},    {'6', 7349.3, true, 0.05},
      {'6', -1.25, false, 0.05},      {'7', 1234.5, true, 0.01524},
      {'8', 4321.27, true, 0.005},    {'8', 999999.99, false, 0.005},  // GSI-8 maximum
      {'8', 123123456.0, true, 0.005},
  };
  for (const auto& c : cases) {
    const Word w = LengthWord(31, c.mm, c.gsi16, c.unit);
    const std::string text = FormatWord(w);
    const auto parsed = ParseWord(text, c.gsi16);
    ASSERT_TRUE(parsed) << text;
    EXPECT_EQ(*parsed, w);
    EXPECT_NEAR(*LengthMm(*parsed), c.mm, c.half_digit_mm * 1.0001) << text;
  }
}

TEST(GsiCodec, FormatterRefusesWhatDoesNotFit) {
  EXPECT_THROW(LengthWord(31, 1000000.0, false, '8'), std::out_of_range);  // 9 digits
  EXPECT_NO_THROW(LengthWord(31, 1000000.0, true, '8'));
  EXPECT_THROW(LengthWord(31, 1.0, false, '2'), std::invalid_argument);   // not a length unit
  EXPECT_THROW(AngleWord(21, 1.0, false, '0'), std::invalid_argument);    // not an angle unit
  EXPECT_THROW(AngleWord(21, NAN, false), std::out_of_range);
  EXPECT_THROW(TextWord(11, "TOOLONGID", false), std::out_of_range);
}

// The documented words of the protocol notes, parsed and formatted back byte for byte.
TEST(GsiCodec, DocumentedWordsFormatBackVerbatim) {
  const std::pair<const char*, bool> words[] = {
      {"21.102+11545200 ", false},          {"31..00+00005165 ", false},
      {"110002+00000000GDEM5415 ", true},   {"21.024+0000000003545100 ", true},
      {"51....+000000000017+000 ", true},   {"81..06-0000000000068507 ", true},
      {"11....+000000P1 ", false},          {"590..6+01234560 ", false},
  };
  for (const auto& [text, gsi16] : words) {
    const auto w = ParseWord(text, gsi16);
    ASSERT_TRUE(w) << text;
    EXPECT_EQ(FormatWord(*w), text);
  }
}

TEST(GsiCodec, IdentifierWordsRoundTrip) {
  for (bool gsi16 : {false, true}) {
    for (const char* id : {"P1", "T2002", "GDEM5415", "1"}) {
      const Word w = TextWord(11, id, gsi16);
      const auto parsed = ParseWord(FormatWord(w), gsi16);
      ASSERT_TRUE(parsed);
      EXPECT_EQ(Identifier(*parsed), id);
      EXPECT_EQ(BlockNumber(*parsed), 1);
    }
  }
  EXPECT_EQ(Identifier(*ParseWord(FormatWord(TextWord(590, "3.04", false)), false)), "3.04");
}

// A file of mixed GSI-16 / GSI-8 blocks survives format → parse unchanged.
TEST(GsiCodec, FilesRoundTrip) {
  Block a;
  a.gsi16 = true;
  a.line = 1;
  a.words = {TextWord(11, "P0001", true), AngleWord(21, 1.5, true, '4'),
             AngleWord(22, 1.6, false, '2'), LengthWord(31, 7349.3, true, '6')};
  Block b;
  b.line = 2;
  b.words = {TextWord(11, "2", false), LengthWord(81, -6850.7, false, '6')};
  const std::string text = FormatFile({a, b});
  const auto file = ParseFile(text);
  ASSERT_FALSE(file.error) << file.error->message;
  ASSERT_EQ(file.blocks.size(), 2u);
  for (size_t i = 0; i < 2; ++i) {
    const Block& expected = i == 0 ? a : b;
    ASSERT_EQ(file.blocks[i].words.size(), expected.words.size());
    EXPECT_EQ(file.blocks[i].gsi16, expected.gsi16);
    for (size_t k = 0; k < expected.words.size(); ++k) {
      Word w = file.blocks[i].words[k];
      EXPECT_GT(w.column, 0);
      w.column = 0;  // the position in the line is not part of the word
      EXPECT_EQ(w, expected.words[k]) << "block " << i << " word " << k;
    }
  }
}

TEST(GsiOnline, RequestsRoundTrip) {
  const OnlineRequest requests[] = {
      {OnlineRequest::Kind::kGet, 'M', 21, 0, 0},
      {OnlineRequest::Kind::kGet, 'I', 590, 0, 0},
      {OnlineRequest::Kind::kGet, 'C', 31, 0, 0},
      {OnlineRequest::Kind::kSet, 'I', 0, 137, 1},
  };
  for (const auto& q : requests) {
    const std::string text = FormatOnlineRequest(q);
    EXPECT_EQ(text.substr(text.size() - 2), "\r\n");
    EXPECT_EQ(ParseOnlineRequest(text), q) << text;
  }
  EXPECT_EQ(FormatOnlineRequest({OnlineRequest::Kind::kGet, 'M', 21, 0, 0}), "GET/M/WI21\r\n");
  std::string why;
  EXPECT_FALSE(ParseOnlineRequest("GET/X/WI21", &why));
  EXPECT_NE(why.find("mode I, M or C"), std::string::npos) << why;
  EXPECT_FALSE(ParseOnlineRequest("GET/M/WIxx", &why));
  EXPECT_NE(why.find("word index"), std::string::npos) << why;
  EXPECT_FALSE(ParseOnlineRequest("PUT/11", &why));
}

TEST(GsiOnline, RepliesRoundTrip) {
  OnlineReply word16;
  word16.word = AngleWord(21, 2.0, true);
  OnlineReply word8;
  word8.word = LengthWord(31, 12345.67, false, '8');
  const OnlineReply replies[] = {word16, word8, {OnlineReply::Kind::kAck, {}, 0},
                                 {OnlineReply::Kind::kWarning, {}, 427},
                                 {OnlineReply::Kind::kError, {}, 139}};
  for (const auto& r : replies) {
    const std::string text = FormatOnlineReply(r);
    EXPECT_EQ(ParseOnlineReply(text.substr(0, text.size() - 2)), r) << text;
  }
  EXPECT_EQ(FormatOnlineReply(word16).front(), '*');  // GSI-16 replies start with '*'
  EXPECT_EQ(FormatOnlineReply({OnlineReply::Kind::kError, {}, 139}), "@E139\r\n");
  std::string why;
  EXPECT_FALSE(ParseOnlineReply("@Exyz", &why));
  EXPECT_NE(why.find("expected a number after @E"), std::string::npos) << why;
  EXPECT_FALSE(ParseOnlineReply("#garbage", &why));
  EXPECT_FALSE(ParseOnlineReply("   ", &why));
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
