// Text from outside on its way into messages, logs, names and JSON (core/text.h): shown,
// never obeyed; cut when long; never a reason for an output to throw.
#include "core/text.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "core/error.h"
#include "core/plausibility.h"

namespace armsig {
namespace {

TEST(Text, Utf8ValidityFollowsTheUnicodeTable) {
  EXPECT_TRUE(IsValidUtf8("Ständer-Ost 東 😀"));
  EXPECT_FALSE(IsValidUtf8("r\xff"));
  EXPECT_FALSE(IsValidUtf8("\xc0\xaf"));          // overlong '/'
  EXPECT_FALSE(IsValidUtf8("\xed\xa0\x80"));      // a surrogate
  EXPECT_FALSE(IsValidUtf8("\xf4\x90\x80\x80"));  // beyond U+10FFFF
  EXPECT_FALSE(IsValidUtf8("ab\xe2\x82"));        // truncated
}

TEST(Text, PrintableEscapesWhatATerminalWouldObey) {
  EXPECT_EQ(Printable("a\nb"), "a\\nb");
  EXPECT_EQ(Printable("red\x1b[31m"), "red\\x1b[31m");
  EXPECT_EQ(Printable(std::string("n\0l", 3)), "n\\0l");
  EXPECT_EQ(Printable("r\xff"), "r\\xff");
  EXPECT_EQ(Printable("a\xe2\x80\xae"
                      "b"),
            "a\\u{202e}b");  // RLO
  EXPECT_EQ(Printable("Ständer"), "Ständer");
  EXPECT_TRUE(IsValidUtf8(Printable("\xc3\x28\xa0\xa1")));
}

TEST(Text, QuotedCutsLongValuesAtACharacterBoundaryAndSaysHowLong) {
  EXPECT_EQ(Quoted("abc"), "'abc'");
  const std::string huge(50'000'000, 'x');
  const std::string q = Quoted(huge);
  EXPECT_LT(q.size(), 120u);
  EXPECT_NE(q.find("(50000000 bytes)"), std::string::npos) << q;
  // 30 two-byte characters, cut at 59 bytes: 29 whole characters, never half of one.
  std::string umlauts;
  for (int i = 0; i < 40; ++i) umlauts += "ä";
  EXPECT_TRUE(IsValidUtf8(Quoted(umlauts, 59)));
  EXPECT_NE(Quoted("x\narmsig: info: forged").find("x\\narmsig"), std::string::npos);
}

TEST(Text, FileNamesInLocationsAreShownNotObeyed) {
  const InputError e({"a\narmsig: info: forged.csv", 3, 2, "col\x1b"}, "bad");
  EXPECT_EQ(std::string(e.what()).find('\n'), std::string::npos) << e.what();
  EXPECT_EQ(std::string(e.what()).find('\x1b'), std::string::npos) << e.what();
  EXPECT_NE(std::string(e.what()).find("a\\narmsig: info: forged.csv:3:2"), std::string::npos);
}

TEST(Text, JsonTextWritesInvalidUtf8AsReplacementCharacters) {
  const nlohmann::json j = {{"name", "r\xff"}};
  EXPECT_THROW((void)j.dump(), nlohmann::json::type_error);  // what every output used to do
  EXPECT_EQ(JsonText(j), "{\"name\":\"r\xef\xbf\xbd\"}");
}

// Every JSON armsig writes or stores goes through JsonText: a plain dump() in the sources
// was a real defect (robot list --json exit 1 on a name from the database).
TEST(Text, EveryJsonOutputGoesThroughJsonText) {
  const std::filesystem::path root(ARMSIG_SOURCE_DIR);
  std::vector<std::string> offenders;
  for (const char* module : {"acquisition", "app", "calibration", "core", "db", "instruments", "io",
                             "reduction", "simulation", "workflows", "fuzz", "bench"}) {
    for (const auto& entry : std::filesystem::recursive_directory_iterator(root / module)) {
      const auto ext = entry.path().extension();
      if (ext != ".cc" && ext != ".h") continue;
      if (entry.path().filename() == "text.h") continue;  // JsonText itself
      std::ifstream in(entry.path());
      std::stringstream text;
      text << in.rdbuf();
      if (text.str().find(".dump(") != std::string::npos) {
        offenders.push_back(entry.path().string());
      }
    }
  }
  EXPECT_TRUE(offenders.empty()) << "dump() outside JsonText in: "
                                 << ::testing::PrintToString(offenders);
}

TEST(Plausibility, NamesAreValidUtf8AndNotOnlyInvisible) {
  EXPECT_EQ(plausible::CheckName("Ständer-Ost"), std::nullopt);
  const auto bad = plausible::CheckName("r\xff");
  ASSERT_NE(bad, std::nullopt);
  EXPECT_NE(bad->find("0xff at byte 2 that is not UTF-8"), std::string::npos) << *bad;
  EXPECT_NE(plausible::CheckName("   "), std::nullopt);
  EXPECT_NE(plausible::CheckName("\xe2\x80\x8b\xe2\x80\x8b"), std::nullopt);  // zero-width spaces
  EXPECT_NE(plausible::CheckName("\xc2\xa0"), std::nullopt);                  // no-break space
  EXPECT_NE(plausible::CheckName("\xef\xbb\xbf"), std::nullopt);              // a lone BOM
  EXPECT_EQ(plausible::CheckName(" r1 "), std::nullopt);  // blanks around a visible name
  EXPECT_NE(plausible::CheckNote("n\xff"), std::nullopt);
  EXPECT_EQ(plausible::CheckNote("   "), std::nullopt);
}

TEST(Plausibility, CircleReadingsZenithAnglesAndDistancesHaveOneRule) {
  using plausible::Quantity;
  const auto gon = plausible::UnitOf(AngleUnit::kGon);
  EXPECT_EQ(plausible::Check(Quantity::kCircleReading, 0.0, gon), std::nullopt);
  EXPECT_EQ(plausible::Check(Quantity::kCircleReading, 400.0, gon), std::nullopt);
  EXPECT_NE(plausible::Check(Quantity::kCircleReading, -10.0, gon), std::nullopt);
  EXPECT_NE(plausible::Check(Quantity::kCircleReading, 401.0, gon), std::nullopt);
  EXPECT_NE(plausible::Check(Quantity::kCircleReading, 361.0, plausible::UnitOf(AngleUnit::kDeg)),
            std::nullopt);
  EXPECT_NE(plausible::Check(Quantity::kCircleReading, 7.0, plausible::UnitOf(AngleUnit::kRad)),
            std::nullopt);
  EXPECT_EQ(plausible::Check(Quantity::kZenithAngle, 400.0, gon), std::nullopt);
  EXPECT_NE(plausible::Check(Quantity::kZenithAngle, -0.001, gon), std::nullopt);
  EXPECT_NE(plausible::Check(Quantity::kDistance, 0.0, plausible::kMm), std::nullopt);
  EXPECT_NE(plausible::Check(Quantity::kDistance, -1500.0, plausible::kMm), std::nullopt);
  EXPECT_NE(plausible::Check(Quantity::kDistance, 1e16, plausible::kMm), std::nullopt);
  EXPECT_EQ(*plausible::Check(Quantity::kZenithAngle, 401, gon),
            "expected a zenith angle from 0 to 400 gon (face II above the half circle), got 401");
}

}  // namespace

// One Trim, each reader naming the characters its format allows around a value.
TEST(Trim, RemovesOnlyTheNamedCharactersAtBothEnds) {
  EXPECT_EQ(Trim("  a b \t\r\n"), "a b");
  EXPECT_EQ(Trim("\t 12.5 \t", " \t"), "12.5");
  EXPECT_EQ(Trim("\t12.5\r\n", " \r\n"), "\t12.5");  // a tab is a GSI line's content
  EXPECT_EQ(Trim(" \r\n "), "");
  EXPECT_EQ(Trim(""), "");
  EXPECT_EQ(Trim("x"), "x");
  EXPECT_EQ(Trim("\vx\f", " \t\n\v\f\r"), "x");
}

// One escape for the report's HTML and the URDF/XML export: each of the five characters
// markup reads as syntax becomes an entity both read, and nothing else changes.
TEST(EscapeMarkup, TurnsTheFiveMarkupCharactersIntoEntitiesBothLanguagesRead) {
  EXPECT_EQ(EscapeMarkup("a<b>&\"c'"), "a&lt;b&gt;&amp;&quot;c&#39;");
  EXPECT_EQ(EscapeMarkup("&amp;"), "&amp;amp;");  // escaped again, never taken as done
  EXPECT_EQ(EscapeMarkup("joint_1 \xce\xb1 \t2"), "joint_1 \xce\xb1 \t2");
  EXPECT_EQ(EscapeMarkup(""), "");
}

}  // namespace armsig
