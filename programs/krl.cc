#include "programs/krl.h"

#include <fmt/format.h>

#include <cctype>
#include <set>

#include "core/text.h"
#include "core/units.h"
#include "programs/scanner.h"

namespace armsig::programs {

namespace {

using detail::EqualsIgnoreCase;
using detail::Fail;
using detail::Token;
using detail::Upper;
using Kind = Token::Kind;

bool IsIdentStart(char c) { return std::isalpha(static_cast<unsigned char>(c)) || c == '_' || c == '$'; }
bool IsIdentChar(char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '$'; }

struct Lexed {
  std::vector<Token> tokens;
  std::vector<NamedPlace> notes;
};

// Tokens with an end of statement at every line break outside brackets. Comments (";" to
// the end of the line) are dropped, their folds checked: every ;FOLD closed by an ;ENDFOLD.
Lexed Lex(const ProgramFile& file, int file_index) {
  const std::string_view text = file.text;
  Lexed out;
  std::vector<int> folds;  // open fold lines
  int line = 1, depth = 0;
  bool line_start = true;
  auto push = [&](Kind kind, std::size_t begin, std::size_t end) {
    out.tokens.push_back({kind, begin, end, line, text.substr(begin, end - begin)});
  };
  std::size_t i = 0;
  while (i < text.size()) {
    const char c = text[i];
    if (c == '\n') {
      if (depth == 0) push(Kind::kEndOfStatement, i, i);
      ++line;
      ++i;
      line_start = true;
      continue;
    }
    if (c == ' ' || c == '\t' || c == '\r' || c == '\f' || c == '\v') {
      ++i;
      continue;
    }
    const bool at_line_start = line_start;
    line_start = false;
    if (c == '&' && at_line_start) {  // &ACCESS, &REL, &PARAM: the editor's header
      while (i < text.size() && text[i] != '\n') ++i;
    } else if (c == ';') {
      const std::size_t end = text.find('\n', i);
      std::string_view comment = text.substr(i + 1, (end == std::string_view::npos ? text.size() : end) - i - 1);
      while (!comment.empty() && (comment.front() == ' ' || comment.front() == '\t')) comment.remove_prefix(1);
      auto starts = [&](std::string_view word) {
        return comment.size() >= word.size() && EqualsIgnoreCase(comment.substr(0, word.size()), word) &&
               (comment.size() == word.size() || !IsIdentChar(comment[word.size()]));
      };
      if (starts("ENDFOLD")) {
        if (folds.empty())
          out.notes.push_back({{file_index, line}, ";ENDFOLD without a ;FOLD before it"});
        else
          folds.pop_back();
      } else if (starts("FOLD")) {
        folds.push_back(line);
      }
      i = end == std::string_view::npos ? text.size() : end;
    } else if (c == '"' || c == '\'') {
      std::size_t j = i + 1;
      while (j < text.size() && text[j] != c && text[j] != '\n') ++j;
      if (j >= text.size() || text[j] != c)
        Fail(file, i, c == '"' ? "a string that does not end on its line"
                               : "a literal ('H…', 'B…') that does not end on its line");
      push(Kind::kString, i, j + 1);
      i = j + 1;
    } else {
      const bool word = IsIdentStart(c) || (c == '#' && i + 1 < text.size() && IsIdentStart(text[i + 1]));
      const detail::Lexeme l = detail::ScanLexeme(text, i, word, IsIdentChar, {"==", "<>", "<=", ">="});
      if (c == '(' || c == '[' || c == '{') ++depth;
      if ((c == ')' || c == ']' || c == '}') && depth > 0) --depth;
      push(l.kind, i, l.end);
      i = l.end;
    }
  }
  if (depth > 0) Fail(file, text.size(), "a bracket or aggregate { … } that never closes");
  push(Kind::kEndOfStatement, text.size(), text.size());
  for (int open : folds)
    out.notes.push_back({{file_index, open}, ";FOLD never closed by an ;ENDFOLD"});
  return out;
}

struct Range {
  int file = 0;
  std::size_t begin = 0, end = 0;
  bool empty() const { return begin >= end; }
};

// A name given a value: a declaration with its value, an assignment, a parameter.
struct Definition {
  std::string name;   // upper case; "TOOL_DATA[1]" for an array element
  std::string type;   // declared type, upper case ("" when only assigned)
  std::string scope;  // "" for the .dat, the DEF's name in the .src
  Range value;        // empty: declared without a value
  int line = 0;
  int file = 0;
  bool parameter = false;
  bool declaration = false;
};

const std::set<std::string> kDataTypes = {"E6POS", "POS", "FRAME", "E6AXIS", "AXIS", "FDAT",
                                          "PDAT",  "LDAT", "INT",  "REAL",  "BOOL", "CHAR",
                                          "LOAD",  "SIGNAL"};
const std::set<std::string> kCartesianTypes = {"E6POS", "POS", "FRAME"};
const std::set<std::string> kAxisTypes = {"E6AXIS", "AXIS"};
const std::set<std::string> kMotions = {"PTP", "LIN", "CIRC", "SPTP", "SLIN", "SCIRC", "SPL"};
const std::set<std::string> kRelativeMotions = {"PTP_REL", "LIN_REL", "CIRC_REL", "SPTP_REL",
                                                "SLIN_REL", "SCIRC_REL"};
const std::set<std::string> kApproximation = {"C_PTP", "C_DIS", "C_VEL", "C_ORI", "C_SPL", "WITH", "CA"};

// Block openers and the word that closes each.
const std::map<std::string, std::string> kBlocks = {
    {"DEF", "END"},       {"DEFFCT", "ENDFCT"},   {"DEFDAT", "ENDDAT"}, {"IF", "ENDIF"},
    {"FOR", "ENDFOR"},    {"WHILE", "ENDWHILE"},  {"LOOP", "ENDLOOP"},  {"REPEAT", "UNTIL"},
    {"SWITCH", "ENDSWITCH"}, {"SPLINE", "ENDSPLINE"}, {"PTP_SPLINE", "ENDSPLINE"}};

class Parser {
 public:
  Parser(ProgramFile src, std::optional<ProgramFile> dat, const KrlControllerData* controller)
      : controller_(controller) {
    program_.language = Language::kKrl;
    program_.files.push_back(std::move(src));
    if (dat) program_.files.push_back(std::move(*dat));
  }

  Program Run() {
    for (int f = 0; f < static_cast<int>(program_.files.size()); ++f) {
      Lexed lexed = Lex(program_.files[static_cast<std::size_t>(f)], f);
      tokens_.push_back(std::move(lexed.tokens));
      for (auto& n : lexed.notes) program_.notes.push_back(std::move(n));
    }
    // The .dat first: its declarations are the program's data.
    for (int f = static_cast<int>(program_.files.size()) - 1; f >= 0; --f) Declarations(f);
    Motions();
    return std::move(program_);
  }

  // $config.dat: only TOOL_DATA[n] and BASE_DATA[n].
  static KrlControllerData ConfigDat(const ProgramFile& file) {
    Parser p(file, std::nullopt, nullptr);
    Lexed lexed = Lex(p.program_.files[0], 0);
    p.tokens_.push_back(std::move(lexed.tokens));
    p.Declarations(0);
    KrlControllerData data;
    data.source = file.name;
    for (const auto& d : p.definitions_) {
      for (const char* array : {"TOOL_DATA[", "BASE_DATA["}) {
        if (d.name.rfind(array, 0) != 0 || d.value.empty()) continue;
        const int index = std::atoi(d.name.c_str() + std::string_view(array).size());
        std::string why;
        auto frame = p.FrameLiteral(d.value, &why);
        if (!frame) continue;
        (array[0] == 'T' ? data.tools : data.bases)[index] = *frame;
      }
    }
    return data;
  }

 private:
  const std::vector<Token>& T(int f) const { return tokens_[static_cast<std::size_t>(f)]; }
  const ProgramFile& File(int f) const { return program_.files[static_cast<std::size_t>(f)]; }

  std::vector<Range> Statements(int f) const {
    std::vector<Range> out;
    std::size_t start = 0;
    for (std::size_t k = 0; k < T(f).size(); ++k) {
      if (T(f)[k].kind != Kind::kEndOfStatement) continue;
      if (k > start) out.push_back({f, start, k});
      start = k + 1;
    }
    return out;
  }

  std::size_t Closing(int f, std::size_t open, std::size_t end) const {
    return ClosingBracket(T(f), open, end);
  }

  // Top-level pieces of [begin, end) split at `sep`.
  std::vector<Range> Split(const Range& r, std::string_view sep) const {
    std::vector<Range> out;
    for (const auto& [first, last] : SplitTopLevel(T(r.file), r.begin, r.end, sep))
      out.push_back({r.file, first, last});
    return out;
  }

  std::string Word(int f, std::size_t k) const {
    return k < T(f).size() && T(f)[k].kind == Kind::kIdentifier ? Upper(T(f)[k].text) : std::string();
  }

  // ---- Pass 1: declarations, assignments, blocks ----

  void Declarations(int f) {
    struct Open {
      std::string word;
      std::size_t at;
    };
    std::vector<Open> blocks;
    std::string scope;
    for (const Range& st : Statements(f)) {
      std::size_t k = st.begin;
      std::string w = Word(f, k);
      if (w == "GLOBAL") w = Word(f, ++k);
      // Blocks.
      if (w == "DEF" || w == "DEFFCT") {
        std::size_t name = k + (w == "DEFFCT" ? 2 : 1);
        scope = Word(f, name);
        Parameters(f, name, st.end, scope);
      }
      if (kBlocks.count(w) && !(w == "IF" && !HasWord(st, "THEN"))) {
        blocks.push_back({w, T(f)[k].begin});
        if (w == "DEF" || w == "DEFFCT" || w == "DEFDAT") continue;
      } else {
        for (const auto& [open, close] : kBlocks) {
          if (w != close) continue;
          if (blocks.empty() || kBlocks.at(blocks.back().word) != close)
            Fail(File(f), T(f)[k].begin, fmt::format("{} without the block it closes", w));
          if (blocks.back().word == "DEF" || blocks.back().word == "DEFFCT") scope.clear();
          blocks.pop_back();
          break;
        }
      }
      // Declarations: DECL [GLOBAL] [CONST] TYPE NAME …, or TYPE NAME … for a built-in type.
      std::size_t d = k;
      bool declared = false;
      if (Word(f, d) == "DECL") ++d, declared = true;
      if (Word(f, d) == "GLOBAL") ++d;
      if (Word(f, d) == "CONST") ++d;
      const std::string type = Word(f, d);
      if (!type.empty() && (declared || kDataTypes.count(type)) && !Word(f, d + 1).empty() &&
          !T(f)[d + 1].Is("=")) {
        for (const Range& part : Split({f, d + 1, st.end}, ","))
          Declaration(part, type, scope);
        continue;
      }
      // Assignments: NAME = value; NAME[…] = value; NAME.F = value.
      Assignment(st, scope);
    }
    if (!blocks.empty()) {
      Fail(File(f), blocks.back().at,
           fmt::format("{} never closed by {}", blocks.back().word, kBlocks.at(blocks.back().word)));
    }
  }

  bool HasWord(const Range& r, std::string_view word) const {
    for (std::size_t k = r.begin; k < r.end; ++k)
      if (T(r.file)[k].IsWord(word)) return true;
    return false;
  }

  void Parameters(int f, std::size_t name, std::size_t end, const std::string& scope) {
    const std::size_t open = name + 1;
    if (open >= end || !T(f)[open].Is("(")) return;
    const std::size_t close = Closing(f, open, end);
    for (const Range& p : Split({f, open + 1, close}, ",")) {
      if (p.empty() || T(f)[p.begin].kind != Kind::kIdentifier) continue;
      Definition def;
      def.name = Upper(T(f)[p.begin].text);
      def.scope = scope;
      def.line = T(f)[p.begin].line;
      def.file = f;
      def.parameter = true;
      definitions_.push_back(std::move(def));
    }
  }

  void Declaration(const Range& part, const std::string& type, const std::string& scope) {
    if (part.empty() || T(part.file)[part.begin].kind != Kind::kIdentifier) return;
    Definition def;
    def.name = Upper(T(part.file)[part.begin].text);
    def.type = type;
    def.scope = scope;
    def.line = T(part.file)[part.begin].line;
    def.file = part.file;
    def.declaration = true;
    for (std::size_t k = part.begin; k < part.end; ++k) {
      if (T(part.file)[k].Is("=")) {
        def.value = {part.file, k + 1, part.end};
        break;
      }
    }
    definitions_.push_back(std::move(def));
  }

  void Assignment(const Range& st, const std::string& scope) {
    const int f = st.file;
    const std::size_t eq = FindTopLevel(T(f), st.begin, st.end, "=");
    if (eq == st.end || T(f)[st.begin].kind != Kind::kIdentifier) return;
    // Not a condition (IF a = …) or a loop head (FOR i = 1 TO …).
    const std::string first = Word(f, st.begin);
    if (first == "IF" || first == "FOR" || first == "WHILE" || first == "UNTIL" || first == "WAIT" ||
        first == "INTERRUPT" || first == "TRIGGER" || first == "GLOBAL" || kMotions.count(first))
      return;
    std::string name = first;
    if (eq == st.begin + 4 && T(f)[st.begin + 1].Is("[") && T(f)[st.begin + 2].kind == Kind::kNumber &&
        T(f)[st.begin + 3].Is("]")) {
      name += "[" + std::string(T(f)[st.begin + 2].text) + "]";  // TOOL_DATA[1] = {…}
    } else if (eq != st.begin + 1) {
      modified_.emplace(name, T(f)[st.begin].line);  // NAME.X = …, NAME[i] = …
      return;
    }
    Definition def;
    def.name = name;
    def.scope = scope;
    def.value = {f, eq + 1, st.end};
    def.line = T(f)[st.begin].line;
    def.file = f;
    definitions_.push_back(std::move(def));
  }

  // ---- Values ----

  struct Aggregate {
    std::map<std::string, NumberField> numbers;  // field name -> its number
    std::map<std::string, std::string> others;   // field name -> its text (enums, strings)
    bool ok = false;
    std::string why;
  };

  Aggregate ParseAggregate(const Range& r) const {
    Aggregate a;
    const int f = r.file;
    if (r.empty() || !T(f)[r.begin].Is("{") || Closing(f, r.begin, r.end) + 1 != r.end) {
      a.why = "not an aggregate { … }";
      return a;
    }
    std::size_t begin = r.begin + 1;
    // An optional type prefix: {E6POS: X 1, …}.
    if (begin + 1 < r.end - 1 && T(f)[begin].kind == Kind::kIdentifier && T(f)[begin + 1].Is(":"))
      begin += 2;
    for (const Range& e : Split({f, begin, r.end - 1}, ",")) {
      if (e.empty()) continue;
      if (T(f)[e.begin].kind != Kind::kIdentifier) {
        a.why = "an aggregate entry without a name";
        return a;
      }
      std::string name = Upper(T(f)[e.begin].text);
      std::size_t k = e.begin + 1;
      if (k + 1 < e.end && T(f)[k].Is("[") && T(f)[k + 1].Is("]")) k += 2;  // POINT2[] " "
      std::size_t at = k;
      auto n = detail::SignedNumber(T(f), &at);
      if (n && at == e.end) {
        a.numbers[name] = *n;
      } else {
        const std::string_view all = File(f).text;
        a.others[name] = k < e.end ? std::string(all.substr(T(f)[k].begin, T(f)[e.end - 1].end - T(f)[k].begin))
                                   : std::string();
      }
    }
    a.ok = true;
    return a;
  }

  std::optional<Eigen::Isometry3d> FrameLiteral(const Range& r, std::string* why) const {
    const Aggregate a = ParseAggregate(r);
    if (!a.ok) {
      *why = a.why;
      return std::nullopt;
    }
    Eigen::Matrix<double, 6, 1> v = Eigen::Matrix<double, 6, 1>::Zero();
    const char* names[6] = {"X", "Y", "Z", "A", "B", "C"};
    for (int i = 0; i < 6; ++i) {
      auto it = a.numbers.find(names[i]);
      if (it == a.numbers.end()) {
        *why = fmt::format("a frame without {}", names[i]);
        return std::nullopt;
      }
      v(i) = it->second.value;
    }
    Eigen::Isometry3d frame = Eigen::Isometry3d::Identity();
    frame.translation() = v.head<3>();
    frame.linear() = RotationFromKukaAbc(v.tail<3>() * kRadPerDeg);
    return frame;
  }

  // The one definition of `written` (any case) with a value, or why there is none.
  const Definition* Lookup(const std::string& written, const std::string& scope, std::string* why) const {
    const std::string name = Upper(written);
    if (auto m = modified_.find(name); m != modified_.end()) {
      *why = fmt::format("{} is changed field by field (line {}): its value depends on the "
                         "program's flow", written, m->second);
      return nullptr;
    }
    std::vector<const Definition*> valued;
    bool declared = false;
    for (const auto& d : definitions_) {
      if (d.name != name) continue;
      if (d.parameter && (d.scope == scope || scope.empty())) {
        *why = fmt::format("{} is a parameter of {}: its value comes from the call", written, d.scope);
        return nullptr;
      }
      declared = declared || d.declaration;
      if (!d.value.empty()) valued.push_back(&d);
    }
    if (valued.empty()) {
      *why = declared ? fmt::format("{} is declared without a value", written)
                      : fmt::format("{} has no value in the program (declared elsewhere: another "
                                    "module's data list or $config.dat)", written);
      return nullptr;
    }
    if (valued.size() > 1) {
      std::string lines;
      for (const Definition* d : valued)
        lines += (lines.empty() ? "" : ", ") + fmt::format("{}:{}", File(d->file).name, d->line);
      *why = fmt::format("{} is given a value at {}: its value at the motion depends on the "
                         "program's flow", written, lines);
      return nullptr;
    }
    return valued[0];
  }

  std::string DeclaredType(const std::string& name) const {
    for (const auto& d : definitions_)
      if (d.name == name && !d.type.empty()) return d.type;
    return "";
  }

  // A motion target: an aggregate or a variable holding one. -1 and why when not evaluable.
  int Evaluate(const Range& r, const std::string& scope, std::string* why) {
    if (r.empty()) {
      *why = "a motion without its target";
      return -1;
    }
    const Token& first = T(r.file)[r.begin];
    if (first.Is("{")) return AggregateTarget(r, "", "", why);
    if (r.end - r.begin == 1 && first.kind == Kind::kIdentifier) {
      const std::string name = Upper(first.text);
      if (name[0] == '$') {
        *why = fmt::format("{} is the controller's (the robot's position when the program runs)", first.text);
        return -1;
      }
      const Definition* d = Lookup(std::string(first.text), scope, why);
      if (!d) return -1;
      const int t = AggregateTarget(d->value, std::string(first.text), DeclaredType(name), why);
      if (t < 0) *why = fmt::format("{} ({}:{}): {}", first.text, File(d->file).name, d->line, *why);
      return t;
    }
    for (std::size_t k = r.begin; k < r.end; ++k) {
      if (T(r.file)[k].Is(":")) {
        *why = "a frame composition (the geometric operator ':') computed when the program runs";
        return -1;
      }
    }
    *why = "an expression computed when the program runs";
    return -1;
  }

  int AggregateTarget(const Range& r, const std::string& name, const std::string& type, std::string* why) {
    const Aggregate a = ParseAggregate(r);
    if (!a.ok) {
      *why = a.why;
      return -1;
    }
    const bool cartesian = kCartesianTypes.count(type) || (type.empty() && (a.numbers.count("X") || a.numbers.count("A")));
    const bool axis = kAxisTypes.count(type) || (type.empty() && a.numbers.count("A1"));
    Target t;
    t.name = name;
    t.place = {r.file, T(r.file)[r.begin].line};
    std::vector<std::string> fields;
    if (axis) {
      t.layout = Layout::kKrlAxis;
      for (int i = 1; i <= 12; ++i) {
        const std::string n = fmt::format("A{}", i);
        if (a.numbers.count(n) || a.others.count(n)) fields.push_back(n);
      }
    } else if (cartesian) {
      t.layout = Layout::kKrlFrame;
      fields = {"X", "Y", "Z", "A", "B", "C"};
    } else {
      *why = type.empty() ? "an aggregate that is neither a position nor axis angles"
                          : fmt::format("a {} is not a motion target", type);
      return -1;
    }
    std::string missing;
    for (const auto& n : fields) {
      auto it = a.numbers.find(n);
      if (it == a.numbers.end()) {
        missing += (missing.empty() ? "" : ", ") + n;
        continue;
      }
      t.fields.push_back(it->second);
    }
    if (axis && fields.size() < 2) missing = "A1 … A6";
    if (!missing.empty()) {
      *why = fmt::format("an aggregate without {}: taken from the robot's position when the program "
                         "runs", missing);
      return -1;
    }
    if (auto s = a.numbers.find("S"); s != a.numbers.end()) t.config.kuka_status = static_cast<int>(s->second.value);
    if (auto s = a.numbers.find("T"); s != a.numbers.end()) t.config.kuka_turn = static_cast<int>(s->second.value);
    const std::pair<int, std::size_t> key{r.file, T(r.file)[r.begin].begin};
    auto found = literal_targets_.find(key);
    if (found != literal_targets_.end()) return found->second;
    program_.targets.push_back(std::move(t));
    const int index = static_cast<int>(program_.targets.size()) - 1;
    literal_targets_[key] = index;
    return index;
  }

  // A tool or base: $TOOL / $BASE's value, TOOL_DATA[n], an aggregate, a FRAME variable.
  FrameRef EvaluateFrame(const Range& r, bool tool, const std::string& scope) const {
    FrameRef frame;
    const int f = r.file;
    const std::string_view all = File(f).text;
    frame.name = r.empty() ? std::string("?")
                           : std::string(all.substr(T(f)[r.begin].begin, T(f)[r.end - 1].end - T(f)[r.begin].begin));
    if (r.empty()) {
      frame.unknown_why = "no value";
      return frame;
    }
    const std::string w = Word(f, r.begin);
    if (r.end - r.begin == 1 && (w == "$NULLFRAME" || (!tool && (w == "$WORLD" || w == "$ROBROOT")))) {
      frame.transform = Eigen::Isometry3d::Identity();
      return frame;
    }
    if (r.end - r.begin == 4 && (w == "TOOL_DATA" || w == "BASE_DATA") && T(f)[r.begin + 1].Is("[") &&
        T(f)[r.begin + 2].kind == Kind::kNumber && T(f)[r.begin + 3].Is("]")) {
      return Numbered(w == "TOOL_DATA", std::atoi(std::string(T(f)[r.begin + 2].text).c_str()));
    }
    if (T(f)[r.begin].Is("{")) {
      std::string why;
      frame.transform = FrameLiteral(r, &why);
      if (!frame.transform) frame.unknown_why = why;
      return frame;
    }
    if (r.end - r.begin == 1 && !w.empty()) {
      std::string why;
      const Definition* d = Lookup(std::string(T(f)[r.begin].text), scope, &why);
      if (d) {
        FrameRef inner = EvaluateFrame(d->value, tool, d->scope);
        inner.name = frame.name;
        return inner;
      }
      frame.unknown_why = why;
      return frame;
    }
    frame.unknown_why = "a frame computed when the program runs";
    return frame;
  }

  FrameRef Numbered(bool tool, int n) const {
    FrameRef frame;
    frame.name = fmt::format("{}[{}]", tool ? "TOOL_DATA" : "BASE_DATA", n);
    if (n == 0) {  // tool 0: the flange ($NULLFRAME); base 0: $WORLD
      frame.transform = Eigen::Isometry3d::Identity();
      frame.name = tool ? "tool 0 (the flange)" : "base 0 ($WORLD)";
      return frame;
    }
    if (controller_) {
      const auto& table = tool ? controller_->tools : controller_->bases;
      if (auto it = table.find(n); it != table.end()) {
        frame.transform = it->second;
        return frame;
      }
    }
    std::string why;
    if (const Definition* d = Lookup(frame.name, "", &why)) {
      FrameRef inner = EvaluateFrame(d->value, tool, "");
      inner.name = frame.name;
      return inner;
    }
    frame.unknown_why =
        controller_ ? fmt::format("{} is not in {}", frame.name, controller_->source)
                    : fmt::format("{} is defined in the robot's $config.dat (KRC:\\R1\\System): give "
                                  "it with --config-dat", frame.name);
    return frame;
  }

  // ---- Pass 2: the motions of the .src, in file order, with the tool and base in use ----

  void Motions() {
    const int f = 0;
    FrameRef tool, base;
    tool.name = base.name = "the one active when the program starts";
    tool.unknown_why = "the program does not set the tool before this motion ($TOOL = …, "
                       "BAS(#TOOL, n) or an inline form's tool)";
    base.unknown_why = "the program does not set the base before this motion ($BASE = …, "
                       "BAS(#BASE, n) or an inline form's base)";
    std::optional<std::pair<FrameRef, FrameRef>> pending;  // an FDAT's tool and base
    std::string scope;
    for (const Range& st : Statements(f)) {
      std::size_t k = st.begin;
      std::string w = Word(f, k);
      if (w == "GLOBAL") w = Word(f, ++k);
      if (w == "DEF" || w == "DEFFCT") {
        scope = Word(f, k + (w == "DEFFCT" ? 2 : 1));
        continue;
      }
      if (w == "$TOOL" || w == "$BASE") {
        if (k + 1 < st.end && T(f)[k + 1].Is("=")) {
          (w == "$TOOL" ? tool : base) = EvaluateFrame({f, k + 2, st.end}, w == "$TOOL", scope);
        }
        continue;
      }
      if (w == "FDAT_ACT" && k + 2 < st.end && T(f)[k + 1].Is("=")) {
        pending = Fdat({f, k + 2, st.end}, scope);
        continue;
      }
      if (w == "BAS" && k + 3 < st.end && T(f)[k + 1].Is("(")) {
        const std::string what = Word(f, k + 2);
        const auto args = Split({f, k + 2, Closing(f, k + 1, st.end)}, ",");
        if ((what == "#TOOL" || what == "#BASE") && args.size() == 2 && args[1].end - args[1].begin == 1 &&
            T(f)[args[1].begin].kind == Kind::kNumber) {
          const int n = std::atoi(std::string(T(f)[args[1].begin].text).c_str());
          (what == "#TOOL" ? tool : base) = Numbered(what == "#TOOL", n);
        } else if (pending && (what == "#PTP_PARAMS" || what == "#CP_PARAMS" || what == "#FRAMES" ||
                               what == "#PTP_DAT" || what == "#CP_DAT" || what == "#SPL_PARAMS")) {
          tool = pending->first;
          base = pending->second;
        }
        continue;
      }
      if (kRelativeMotions.count(w)) {
        program_.not_evaluated.push_back(
            {{f, T(f)[k].line}, fmt::format("{}: a relative motion, its target depends on where the "
                                            "robot is", T(f)[k].text)});
        continue;
      }
      if (w == "WAIT" && Word(f, k + 1) == "SEC") {  // WAIT SEC t, t a number: the program stands
        std::size_t n = k + 2;
        if (auto s = detail::SignedNumber(T(f), &n); s && n == st.end) program_.waits.push_back({{f, T(f)[k].line}, s->value, scope});
        continue;
      }
      if (!kMotions.count(w)) continue;
      AddMotion(st, k, w, scope, tool, base);
    }
  }

  std::pair<FrameRef, FrameRef> Fdat(const Range& r, const std::string& scope) const {
    FrameRef tool, base;
    tool.name = base.name = "FDAT " + (r.empty() ? std::string("?") : std::string(T(r.file)[r.begin].text));
    std::string why;
    const Definition* d = nullptr;
    if (r.end - r.begin == 1 && T(r.file)[r.begin].kind == Kind::kIdentifier)
      d = Lookup(std::string(T(r.file)[r.begin].text), scope, &why);
    else if (!r.empty() && T(r.file)[r.begin].Is("{"))
      why.clear();
    Range value = d ? d->value : r;
    const Aggregate a = ParseAggregate(value);
    if (!a.ok) {
      tool.unknown_why = base.unknown_why = fmt::format("{}: {}", tool.name, why.empty() ? a.why : why);
      return {tool, base};
    }
    if (auto ipo = a.others.find("IPO_FRAME"); ipo != a.others.end() && Upper(ipo->second) == "#TCP") {
      tool.unknown_why = base.unknown_why =
          fmt::format("{}: IPO_FRAME #TCP, a tool that stands still (external TCP): not followed", tool.name);
      return {tool, base};
    }
    auto tool_no = a.numbers.find("TOOL_NO");
    auto base_no = a.numbers.find("BASE_NO");
    if (tool_no == a.numbers.end() || base_no == a.numbers.end()) {
      tool.unknown_why = base.unknown_why = fmt::format("{} without TOOL_NO or BASE_NO", tool.name);
      return {tool, base};
    }
    return {Numbered(true, static_cast<int>(tool_no->second.value)),
            Numbered(false, static_cast<int>(base_no->second.value))};
  }

  void AddMotion(const Range& st, std::size_t k, const std::string& word, const std::string& scope,
                 FrameRef tool, FrameRef base) {
    const int f = st.file;
    // The target(s): up to an approximation word or WITH; CIRC's first piece is the via point.
    std::size_t end = st.end;
    for (std::size_t j = k + 1; j < st.end; ++j) {
      if (kApproximation.count(Word(f, j))) {
        end = j;
        break;
      }
    }
    std::vector<Range> pieces = Split({f, k + 1, end}, ",");
    while (!pieces.empty() && pieces.back().empty()) pieces.pop_back();
    const bool circular = word == "CIRC" || word == "SCIRC";
    const std::size_t needed = circular ? 2 : 1;
    Motion m;
    m.place = {f, T(f)[k].line};
    m.instruction = std::string(T(f)[k].text);
    m.routine = scope;
    m.type = circular ? MotionType::kCircular
             : (word == "PTP" || word == "SPTP") ? MotionType::kJoint
                                                 : MotionType::kLinear;
    if (pieces.size() < needed) {
      program_.not_evaluated.push_back({m.place, fmt::format("{} without its target", m.instruction)});
      return;
    }
    for (std::size_t p = 0; p < needed; ++p) {
      std::string why;
      const int t = Evaluate(pieces[p], scope, &why);
      if (t < 0) {
        program_.not_evaluated.push_back({m.place, fmt::format("{}: {}", m.instruction, why)});
        return;
      }
      m.targets.push_back(t);
    }
    // WITH $TOOL = …, $BASE = … for this motion alone (the spline inline forms).
    for (std::size_t j = end; j < st.end; ++j) {
      if (!T(f)[j].IsWord("WITH")) continue;
      for (const Range& a : Split({f, j + 1, st.end}, ",")) {
        if (a.end - a.begin < 3 || !T(f)[a.begin + 1].Is("=")) continue;
        const std::string var = Word(f, a.begin);
        if (var == "$TOOL") tool = EvaluateFrame({f, a.begin + 2, a.end}, true, scope);
        if (var == "$BASE") base = EvaluateFrame({f, a.begin + 2, a.end}, false, scope);
      }
      break;
    }
    m.tool = std::move(tool);
    m.base = std::move(base);
    program_.motions.push_back(std::move(m));
  }

  Program program_;
  const KrlControllerData* controller_;
  std::vector<std::vector<Token>> tokens_;
  std::vector<Definition> definitions_;
  std::map<std::string, int> modified_;
  std::map<std::pair<int, std::size_t>, int> literal_targets_;  // (file, first byte) -> target
};

}  // namespace

KrlControllerData ParseKrlConfigDat(const ProgramFile& config_dat) { return Parser::ConfigDat(config_dat); }

Program ParseKrl(ProgramFile src, std::optional<ProgramFile> dat, const KrlControllerData* controller) {
  return Parser(std::move(src), std::move(dat), controller).Run();
}

}  // namespace armsig::programs
