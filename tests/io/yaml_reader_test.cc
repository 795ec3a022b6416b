#include "io/yaml_reader.h"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <limits>

#include "core/error.h"

namespace armsig::io {
namespace {

// Runs `read` and returns the InputError it throws (fails the test when it throws none).
InputError Refusal(const std::function<void()>& read) {
  try {
    read();
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()).find("yaml-cpp"), std::string::npos) << e.what();
    EXPECT_EQ(std::string(e.what()).find("bad conversion"), std::string::npos) << e.what();
    return e;
  }
  ADD_FAILURE() << "expected an InputError";
  return InputError("none");
}

YamlValue RootOf(const std::string& text) { return YamlDocument::Parse(text, "t.yaml").Root(); }

TEST(EditDistance, CountsInsertionsDeletionsAndSubstitutions) {
  EXPECT_EQ(EditDistance("kitten", "sitting"), 3);  // k→s, e→i, +g
  EXPECT_EQ(EditDistance("", "abc"), 3);
  EXPECT_EQ(EditDistance("abc", ""), 3);
  EXPECT_EQ(EditDistance("tool_mm", "tool_mm"), 0);
  EXPECT_EQ(EditDistance("tool_m", "tool_mm"), 1);
  EXPECT_EQ(EditDistance("flaw", "lawn"), 2);
}

TEST(EditDistance, NearestKeyOnlyWhenCloseEnough) {
  const std::vector<std::string_view> keys = {"name", "links", "tool_mm", "nongeometric"};
  EXPECT_EQ(NearestKey("tool_m", keys), "tool_mm");
  EXPECT_EQ(NearestKey("lnks", keys), "links");
  EXPECT_EQ(NearestKey("non_geometric", keys), "nongeometric");
  EXPECT_EQ(NearestKey("colour", keys), std::nullopt);
}

TEST(YamlReader, UnknownKeyNamesFileLineAndNearestKey) {
  const std::string text = "name: x\n\ntool_m: [0, 0, 109]\n";
  const InputError e = Refusal([&] { RootOf(text).Map({"name", "links", "tool_mm"}); });
  EXPECT_STREQ(e.what(), "t.yaml:3:1: unknown key 'tool_m' (did you mean 'tool_mm'?)");
}

TEST(YamlReader, UnknownKeyFarFromAnyListsTheValidKeys) {
  const InputError e = Refusal([] { RootOf("colour: red\n").Map({"name", "links"}); });
  EXPECT_STREQ(e.what(), "t.yaml:1:1: unknown key 'colour' (expected one of: name, links)");
}

TEST(YamlReader, UnknownKeyInANestedFlowMappingNamesItsColumn) {
  const std::string text = "robot:\n  controller: {protocol: as, prot: x}\n";
  const InputError e = Refusal([&] {
    RootOf(text)
        .Map({"robot"})
        .Required("robot", "")
        .Map({"controller"})
        .Required("controller", "")
        .Map({"protocol", "port"});
  });
  EXPECT_EQ(e.where().line, 2);
  EXPECT_EQ(e.where().column, 30);  // "prot" starts in column 30
  EXPECT_EQ(e.message(), "unknown key 'prot' (did you mean 'port'?)");
}

TEST(YamlReader, DuplicateKeyIsRefused) {
  const InputError e = Refusal([] { RootOf("a: 1\nb: 2\na: 3\n").Map({"a", "b"}); });
  EXPECT_EQ(e.where().line, 3);
  EXPECT_EQ(e.message(), "duplicate key 'a' (first given on line 1)");
}

TEST(YamlReader, ListWhereAMappingIsExpected) {
  const InputError e = Refusal([] {
    RootOf("tolerances:\n  - 1\n  - 2\n").Map({"tolerances"}).Required("tolerances", "").Map({"a"});
  });
  EXPECT_EQ(e.where().line, 2);
  EXPECT_EQ(e.where().column, 3);
  EXPECT_EQ(e.where().column_name, "tolerances");
  EXPECT_EQ(e.message(), "expected a mapping with a, got a list of 2");
}

TEST(YamlReader, ScalarItemWhereAListIsExpected) {
  const InputError e =
      Refusal([] { RootOf("m: [[1, 2], 3]\n").Map({"m"}).Required("m", "").Matrix(2, 2); });
  EXPECT_EQ(e.where().line, 1);
  EXPECT_EQ(e.where().column, 13);  // the '3'
  EXPECT_EQ(e.message(), "expected a row of 2 numbers, got '3'");
}

TEST(YamlReader, NonNumberNamesTheValueAndItsPosition) {
  const InputError e =
      Refusal([] { RootOf("p: [1, 2,  x3]\n").Map({"p"}).Required("p", "").Vector3(); });
  EXPECT_STREQ(e.what(), "t.yaml:1:12 (p): expected a finite number, got 'x3'");
  EXPECT_THROW(RootOf("p: .nan\n").Map({"p"}).Required("p", "").Number(), InputError);
}

TEST(YamlReader, WrongLengthIsRefused) {
  const InputError e =
      Refusal([] { RootOf("p: [1, 2]\n").Map({"p"}).Required("p", "").Vector3(); });
  EXPECT_EQ(e.message(), "expected a list of 3 numbers [x, y, z], got a list of 2");
  EXPECT_EQ(e.where().column, 4);
}

TEST(YamlReader, EmptyValueIsReportedAtItsKey) {
  const InputError e = Refusal([] {
    RootOf("a: 1\nb:\n").Map({"a", "b"}).Required("b", "").Text();
  });
  EXPECT_EQ(e.where().line, 2);
  EXPECT_EQ(e.where().column, 1);
  EXPECT_EQ(e.message(), "expected a text value, got nothing");
}

TEST(YamlReader, MissingKeyIsReportedAtItsMapping) {
  const InputError e = Refusal([] {
    RootOf("x: 0\nrobot: {model: m}\n")
        .Map({"x", "robot"})
        .Required("robot", "")
        .Map({"model", "controller"})
        .Required("controller", "a controller");
  });
  EXPECT_EQ(e.where().line, 2);
  EXPECT_EQ(e.where().column, 8);
  EXPECT_EQ(e.message(), "missing 'controller' (expected a controller)");
}

TEST(YamlReader, IntegersAndFlags) {
  const YamlMap map =
      RootOf("n: 3\nf: 2.5\nb: yes\nc: maybe\nbig: 99999999999\n").Map({"n", "f", "b", "c", "big"});
  EXPECT_EQ(map.Required("n", "").Integer(1, 10), 3);
  EXPECT_THROW(map.Required("n", "").Integer(4, 10), InputError);
  EXPECT_EQ(
      Refusal([&] { map.Required("f", "").Integer(0, std::numeric_limits<int>::max()); }).message(),
      "expected an integer ≥ 0, got '2.5'");
  EXPECT_THROW(map.Required("big", "").Integer(0, std::numeric_limits<int>::max()), InputError);
  EXPECT_TRUE(map.Required("b", "").Flag());
  EXPECT_EQ(Refusal([&] { map.Required("c", "").Flag(); }).message(),
            "expected true or false, got 'maybe'");
}

TEST(YamlReader, MalformedYamlNamesLineAndColumn) {
  const InputError e = Refusal([] { YamlDocument::Parse("a: [1, 2\nb: 3\n", "bad.yaml"); });
  EXPECT_EQ(e.where().file, "bad.yaml");
  EXPECT_GT(e.where().line, 0);
  EXPECT_GT(e.where().column, 0);
  EXPECT_EQ(e.message().rfind("malformed YAML: ", 0), 0u) << e.message();
}

TEST(YamlReader, UnreadableFileIsAnInputError) {
  EXPECT_THROW(YamlDocument::Load("/nonexistent/armsig.yaml"), InputError);
}

TEST(YamlNumber, EmitsTheShortestTextThatReadsBackExactly) {
  const std::vector<double> values = {0.1,  1.0 / 3.0, 1e-7, -0.5,           650.0,
                                      1e16, -0.0,      M_PI, 10000144.31191, 4.84813681109536e-6};
  YAML::Emitter out;
  out << YAML::Flow << YAML::BeginSeq;
  for (double v : values) out << YamlNumber(v);
  out << YAML::EndSeq;
  const std::string text = out.c_str();
  EXPECT_EQ(text.rfind("[0.1, ", 0), 0u) << text;  // not 0.10000000000000001
  const YAML::Node back = YAML::Load(text);
  ASSERT_EQ(back.size(), values.size());
  for (size_t i = 0; i < values.size(); ++i) {
    EXPECT_EQ(back[i].as<double>(), values[i]) << back[i].Scalar();
  }
}

}  // namespace
}  // namespace armsig::io
