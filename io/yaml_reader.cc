#include "io/yaml_reader.h"

#include <fmt/format.h>
#include <yaml-cpp/eventhandler.h>
#include <yaml-cpp/parser.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <numeric>
#include <sstream>

#include "core/text.h"
#include "io/atomic_file.h"

namespace armsig::io {

namespace {

bool HasPosition(const YAML::Mark& mark) { return mark.line >= 0; }

std::string KeyList(const std::vector<std::string_view>& keys) {
  std::string out;
  for (const auto& key : keys) out += (out.empty() ? "" : ", ") + std::string(key);
  return out;
}

}  // namespace

// --- YamlValue

YamlValue::YamlValue(YAML::Node node, std::string source, std::string key, YAML::Mark mark)
    : node_(std::move(node)), source_(std::move(source)), key_(std::move(key)), mark_(mark) {
  // A missing node has no position and an empty value's is past its key: keep the
  // caller's (the key's or the enclosing mapping's) for those.
  if (node_.IsDefined() && !node_.IsNull() && HasPosition(node_.Mark())) mark_ = node_.Mark();
}

SourceLocation YamlValue::Where() const {
  return {source_, HasPosition(mark_) ? mark_.line + 1 : 0,
          HasPosition(mark_) ? mark_.column + 1 : 0, key_};
}

void YamlValue::Fail(const std::string& message) const { throw InputError(Where(), message); }

std::string YamlValue::Describe() const {
  if (!node_.IsDefined() || node_.IsNull()) return "nothing";
  if (node_.IsSequence()) return fmt::format("a list of {}", node_.size());
  if (node_.IsMap()) return "a mapping";
  return Quoted(node_.Scalar());
}

void YamlValue::Expected(const std::string& what) const {
  Fail("expected " + what + ", got " + Describe());
}

std::string YamlValue::Text() const {
  if (!IsScalar() || node_.Scalar().empty()) Expected("a text value");
  return node_.Scalar();
}

std::string YamlValue::Name() const {
  std::string text = Text();
  if (auto why = plausible::CheckName(text)) Fail(*why);
  return text;
}

double YamlValue::Number() const {
  double value = 0.0;
  if (!IsScalar() || !YAML::convert<double>::decode(node_, value) || !std::isfinite(value)) {
    Expected("a finite number");
  }
  return value;
}

double YamlValue::PositiveNumber() const {
  const double value = Number();
  if (!(value > 0)) Expected("a positive number");
  return value;
}

double YamlValue::NonNegativeNumber() const {
  const double value = Number();
  if (!(value >= 0)) Expected("a number ≥ 0");
  return value;
}

int YamlValue::Integer(int min, int max) const {
  long long value = 0;
  if (!IsScalar() || !YAML::convert<long long>::decode(node_, value) || value < min ||
      value > max) {
    Expected(max == std::numeric_limits<int>::max()
                 ? fmt::format("an integer ≥ {}", min)
                 : fmt::format("an integer from {} to {}", min, max));
  }
  return static_cast<int>(value);
}

double YamlValue::Plausible(plausible::Quantity quantity, plausible::Unit unit) const {
  const double value = Number();
  if (auto why = plausible::Check(quantity, value, unit)) Fail(*why);
  return value;
}

bool YamlValue::Flag() const {
  bool value = false;
  if (!IsScalar() || !YAML::convert<bool>::decode(node_, value)) Expected("true or false");
  return value;
}

std::vector<YamlValue> YamlValue::List(size_t min_size) const {
  if (!IsList()) Expected("a list");
  if (node_.size() < min_size) {
    Expected(min_size == 1 ? std::string("a non-empty list")
                           : fmt::format("a list of at least {}", min_size));
  }
  std::vector<YamlValue> items;
  items.reserve(node_.size());
  for (const YAML::Node& item : node_) items.emplace_back(item, source_, key_, mark_);
  return items;
}

std::vector<double> YamlValue::Numbers(size_t size) const {
  if (!IsList() || node_.size() != size) Expected(fmt::format("a list of {} numbers", size));
  std::vector<double> out;
  for (const YamlValue& item : List()) out.push_back(item.Number());
  return out;
}

Eigen::Vector3d YamlValue::Vector3() const {
  if (!IsList() || node_.size() != 3) Expected("a list of 3 numbers [x, y, z]");
  const std::vector<double> v = Numbers(3);
  return {v[0], v[1], v[2]};
}

Eigen::Vector3d YamlValue::Vector3(plausible::Quantity quantity) const {
  if (!IsList() || node_.size() != 3) Expected("a list of 3 numbers [x, y, z]");
  const std::vector<YamlValue> items = List();
  Eigen::Vector3d v;
  for (int k = 0; k < 3; ++k) v(k) = items[k].Plausible(quantity);
  return v;
}

Eigen::MatrixXd YamlValue::Matrix(int rows, int cols) const {
  if (!IsList() || static_cast<int>(node_.size()) != rows) {
    Expected(fmt::format("a {}x{} matrix as a list of {} rows", rows, cols, rows));
  }
  Eigen::MatrixXd m(rows, cols);
  const std::vector<YamlValue> row_values = List();
  for (int r = 0; r < rows; ++r) {
    const YamlValue& row = row_values[r];
    if (!row.IsList() || static_cast<int>(row.node().size()) != cols) {
      row.Expected(fmt::format("a row of {} numbers", cols));
    }
    const std::vector<YamlValue> entries = row.List();
    for (int c = 0; c < cols; ++c) m(r, c) = entries[c].Number();
  }
  return m;
}

YamlMap YamlValue::Map(std::initializer_list<std::string_view> allowed) const {
  return Map(std::vector<std::string_view>(allowed));
}

YamlMap YamlValue::Map(const std::vector<std::string_view>& keys) const {
  if (!IsMap()) Expected("a mapping with " + KeyList(keys));
  std::map<std::string, int, std::less<>> seen;  // key → its line
  for (auto it = node_.begin(); it != node_.end(); ++it) {
    const YamlValue key(it->first, source_, "", mark_);
    if (!key.IsScalar()) key.Expected("a key (a text)");
    const std::string& name = it->first.Scalar();
    if (std::find(keys.begin(), keys.end(), name) == keys.end()) {
      const auto nearest = NearestKey(name, keys);
      key.Fail("unknown key " + Quoted(name) + " " +
               (nearest ? "(did you mean " + Quoted(*nearest) + "?)"
                        : "(expected one of: " + KeyList(keys) + ")"));
    }
    const auto [previous, inserted] = seen.emplace(name, key.Where().line);
    if (!inserted) {
      key.Fail(
          fmt::format("duplicate key {} (first given on line {})", Quoted(name), previous->second));
    }
  }
  return YamlMap(*this);
}

// --- YamlMap

bool YamlMap::Has(std::string_view key) const { return Find(key).has_value(); }

std::optional<YamlValue> YamlMap::Find(std::string_view key) const {
  // Iterate rather than node[key]: the key node's position is the fallback for an empty value.
  const YAML::Node& map = value_.node();
  for (auto it = map.begin(); it != map.end(); ++it) {
    if (it->first.Scalar() == key) {
      return YamlValue(it->second, value_.source(), std::string(key), it->first.Mark());
    }
  }
  return std::nullopt;
}

YamlValue YamlMap::Required(std::string_view key, const std::string& expected) const {
  if (auto found = Find(key)) return *found;
  YamlValue where(value_.node(), value_.source(), std::string(key), YAML::Mark::null_mark());
  where.Fail("missing " + Quoted(std::string(key)) + " (expected " + expected + ")");
}

// --- YamlDocument

namespace {

// Refuses the first alias (*name) of a document. yaml-cpp resolves an alias to the anchored
// node itself, so an error in an aliased value would be reported at the anchor, far from
// where the value is used; and a few aliases of aliases make a reader walk a tree of
// billions of nodes (the "billion laughs"). armsig's files need neither: write the value out.
class AliasRefusal final : public YAML::EventHandler {
 public:
  explicit AliasRefusal(const std::string& source) : source_(source) {}
  void OnAlias(const YAML::Mark& mark, YAML::anchor_t) override {
    throw InputError({source_, mark.line + 1, mark.column + 1, ""},
                     "YAML aliases (*name) are not accepted in armsig files: write the value out "
                     "where it is used");
  }
  void OnDocumentStart(const YAML::Mark&) override {}
  void OnDocumentEnd() override {}
  void OnNull(const YAML::Mark&, YAML::anchor_t) override {}
  void OnScalar(const YAML::Mark&, const std::string&, YAML::anchor_t,
                const std::string&) override {}
  void OnSequenceStart(const YAML::Mark&, const std::string&, YAML::anchor_t,
                       YAML::EmitterStyle::value) override {}
  void OnSequenceEnd() override {}
  void OnMapStart(const YAML::Mark&, const std::string&, YAML::anchor_t,
                  YAML::EmitterStyle::value) override {}
  void OnMapEnd() override {}

 private:
  const std::string& source_;
};

}  // namespace

YamlDocument YamlDocument::Parse(const std::string& text, const std::string& source) {
  try {
    {
      std::istringstream stream(text);
      YAML::Parser parser(stream);
      AliasRefusal refusal(source);
      parser.HandleNextDocument(refusal);
    }
    return YamlDocument(YAML::Load(text), source);
  } catch (const YAML::Exception& e) {
    const bool at = HasPosition(e.mark);
    throw InputError({source, at ? e.mark.line + 1 : 0, at ? e.mark.column + 1 : 0, ""},
                     "malformed YAML: " + e.msg);
  }
}

YamlDocument YamlDocument::Load(const std::string& path) {
  return Parse(ReadWholeFile(path, kYamlFileLimit), path);
}

InputError YamlDocument::Translate(const YAML::Exception& e) const {
  const bool at = HasPosition(e.mark);
  return InputError({source_, at ? e.mark.line + 1 : 0, at ? e.mark.column + 1 : 0, ""},
                    "unexpected YAML structure here (expected the shape this file's format "
                    "gives: a mapping of known keys, lists where lists belong): " +
                        e.msg);
}

YamlValue YamlDocument::Root() const {
  return YamlValue(root_, source_, "", YAML::Mark::null_mark());
}

// --- Key suggestions


// --- Emitting

YAML::Emitter& operator<<(YAML::Emitter& out, YamlNumber number) {
  const double v = number.value();
  if (std::isnan(v)) return out << ".nan";
  if (std::isinf(v)) return out << (v > 0 ? ".inf" : "-.inf");
  return out << fmt::format("{}", v);  // shortest round-trip form
}

}  // namespace armsig::io
