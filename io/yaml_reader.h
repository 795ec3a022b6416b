// The one YAML reader: every YAML file armsig reads (robot model, lab file, stations file)
// goes through it. It wraps yaml-cpp nodes with their source so that every refusal is an
// InputError "file:line:column (key): what was expected, what was found", and it refuses
// keys a mapping does not know, naming the nearest valid one:
//   lab.yaml:7:3: unknown key 'tool_m' (did you mean 'tool_mm'?)
//
//   const YamlDocument doc = YamlDocument::Load(path);
//   const YamlMap root = doc.Root().Map({"name", "links", "tool_mm"});
//   const Eigen::Vector3d tool = root.Required("tool_mm").Vector3();
//   if (auto name = root.Find("name")) model.name = name->Text();
#pragma once

#include "core/text.h"

#include <yaml-cpp/yaml.h>

#include <Eigen/Core>
#include <initializer_list>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "core/error.h"
#include "core/plausibility.h"

namespace armsig::io {

class YamlMap;

// A node of a document together with where it is and the key it was found under.
class YamlValue {
 public:
  // `mark` is used when the node itself has no position (a missing or empty value).
  YamlValue(YAML::Node node, std::string source, std::string key, YAML::Mark mark);

  const YAML::Node& node() const { return node_; }
  const std::string& key() const { return key_; }
  const std::string& source() const { return source_; }
  SourceLocation Where() const;
  [[noreturn]] void Fail(const std::string& message) const;
  // "a list", "a mapping", "'abc'", "nothing": for "expected …, got …" messages.
  std::string Describe() const;

  bool IsScalar() const { return node_.IsScalar(); }
  bool IsList() const { return node_.IsSequence(); }
  bool IsMap() const { return node_.IsMap(); }

  // Scalars.
  std::string Text() const;             // a non-empty scalar
  std::string Name() const;             // a name: ≤ 64 bytes, no control characters
  double Number() const;                // finite
  double PositiveNumber() const;        // finite, > 0
  double NonNegativeNumber() const;     // finite, ≥ 0
  int Integer(int min, int max) const;  // an integer within [min, max]
  bool Flag() const;                    // true / false (yaml-cpp's yes/no/on/off too)
  // A finite number that is a plausible `quantity` given in `unit` (core/plausibility.h),
  // returned as given; refused naming the range otherwise.
  double Plausible(plausible::Quantity quantity, plausible::Unit unit = plausible::kMm) const;

  // A list; refused when not a list or shorter than `min_size`.
  std::vector<YamlValue> List(size_t min_size = 0) const;
  // A list of exactly `size` numbers, and a rows×cols matrix as a list of rows.
  std::vector<double> Numbers(size_t size) const;
  Eigen::Vector3d Vector3() const;
  // [x, y, z], each a plausible `quantity` in mm (kLength, kCoordinate).
  Eigen::Vector3d Vector3(plausible::Quantity quantity) const;
  Eigen::MatrixXd Matrix(int rows, int cols) const;

  // A mapping whose keys must be among `allowed` (each at most once); anything else is
  // refused naming the key, its line and the nearest allowed key.
  YamlMap Map(std::initializer_list<std::string_view> allowed) const;
  YamlMap Map(const std::vector<std::string_view>& allowed) const;  // a list made at run time

 private:
  [[noreturn]] void Expected(const std::string& what) const;

  YAML::Node node_;
  std::string source_;
  std::string key_;
  YAML::Mark mark_;
};

// A mapping whose keys have been checked against the allowed set.
class YamlMap {
 public:
  const YamlValue& value() const { return value_; }
  [[noreturn]] void Fail(const std::string& message) const { value_.Fail(message); }

  bool Has(std::string_view key) const;
  std::optional<YamlValue> Find(std::string_view key) const;
  // Refused as "missing 'key' (expected …)" at the mapping's position when absent.
  YamlValue Required(std::string_view key, const std::string& expected) const;

 private:
  friend class YamlValue;
  explicit YamlMap(YamlValue value) : value_(std::move(value)) {}

  YamlValue value_;
};

// A parsed YAML text and its source name (a file path, or e.g. "stored lab file of
// session 4"). Malformed YAML is an InputError at yaml-cpp's line and column.
class YamlDocument {
 public:
  static YamlDocument Parse(const std::string& text, const std::string& source);
  static YamlDocument Load(const std::string& path);  // InputError when unreadable

  YamlValue Root() const;
  const std::string& source() const { return source_; }

  // Runs a reader on the root: `read(Root())`. Every reader of a YAML file goes through
  // here, so that no yaml-cpp exception escapes untranslated: one that a reader lets
  // through (a node of a shape it did not expect) becomes an InputError at yaml-cpp's
  // line and column, naming the file.
  template <typename Reader>
  auto Read(Reader&& read) const -> decltype(read(std::declval<YamlValue>())) {
    try {
      return read(Root());
    } catch (const YAML::Exception& e) {
      throw Translate(e);
    }
  }

 private:
  YamlDocument(YAML::Node root, std::string source)
      : root_(std::move(root)), source_(std::move(source)) {}
  InputError Translate(const YAML::Exception& e) const;

  YAML::Node root_;
  std::string source_;
};


// Numbers for YAML::Emitter: the shortest text that reads back to the same double
// (yaml-cpp 0.7 itself writes 17 significant digits: 0.1 → 0.10000000000000001).
class YamlNumber {
 public:
  explicit YamlNumber(double value) : value_(value) {}
  double value() const { return value_; }

 private:
  double value_;
};
YAML::Emitter& operator<<(YAML::Emitter& out, YamlNumber number);

}  // namespace armsig::io
