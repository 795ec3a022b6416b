#include "programs/rapid.h"

#include <fmt/format.h>

#include <cctype>
#include <map>
#include <set>

#include "core/text.h"
#include "programs/scanner.h"

namespace armsig::programs {

namespace {

using detail::Fail;
using detail::Token;
using detail::Upper;
using Kind = Token::Kind;

bool IsIdentStart(char c) { return std::isalpha(static_cast<unsigned char>(c)); }
bool IsIdentChar(char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '_'; }

// Tokens; comments and the %%% header dropped. Statements end at ";" (a punctuation token).
std::vector<Token> Lex(const ProgramFile& file) {
  const std::string_view text = file.text;
  std::vector<Token> out;
  int line = 1;
  std::size_t i = 0;
  auto push = [&](Kind kind, std::size_t begin, std::size_t end) {
    out.push_back({kind, begin, end, line, text.substr(begin, end - begin)});
  };
  while (i < text.size()) {
    const char c = text[i];
    if (c == '\n') {
      ++line;
      ++i;
    } else if (c == ' ' || c == '\t' || c == '\r' || c == '\f' || c == '\v') {
      ++i;
    } else if (c == '!') {
      while (i < text.size() && text[i] != '\n') ++i;
    } else if (text.substr(i, 3) == "%%%") {  // the header of a saved module
      const std::size_t end = text.find("%%%", i + 3);
      if (end == std::string_view::npos) Fail(file, i, "a %%% header that never closes");
      for (std::size_t j = i; j < end; ++j) line += text[j] == '\n' ? 1 : 0;
      i = end + 3;
    } else if (c == '"') {
      std::size_t j = i + 1;
      for (;;) {
        if (j >= text.size() || text[j] == '\n') Fail(file, i, "a string that does not end on its line");
        if (text[j] == '"') {
          if (j + 1 < text.size() && text[j + 1] == '"') {  // "" is a quote inside the string
            j += 2;
            continue;
          }
          break;
        }
        ++j;
      }
      push(Kind::kString, i, j + 1);
      i = j + 1;
    } else {
      const detail::Lexeme l = detail::ScanLexeme(text, i, IsIdentStart(c), IsIdentChar, {":=", "<>", "<=", ">="});
      push(l.kind, i, l.end);
      i = l.end;
    }
  }
  return out;
}

struct Range {
  std::size_t begin = 0, end = 0;
  bool empty() const { return begin >= end; }
};

struct Definition {
  std::string name;   // upper case
  std::string type;   // upper case; "" when only assigned
  std::string scope;  // "" module data, else the routine
  Range value;
  int line = 0;
  bool parameter = false;
  bool array = false;
};

// A motion instruction: how many targets it takes and where its tool is among the
// positional arguments.
struct MotionForm {
  int targets;
  std::size_t tool;
  MotionType type;
  bool joints;
};

const std::map<std::string, MotionForm> kMotions = {
    {"MOVEJ", {1, 3, MotionType::kJoint, false}},     {"MOVEL", {1, 3, MotionType::kLinear, false}},
    {"MOVEC", {2, 4, MotionType::kCircular, false}},  {"MOVEABSJ", {1, 3, MotionType::kJoint, true}},
    {"MOVEJDO", {1, 3, MotionType::kJoint, false}},   {"MOVELDO", {1, 3, MotionType::kLinear, false}},
    {"MOVECDO", {2, 4, MotionType::kCircular, false}}, {"MOVEJSYNC", {1, 3, MotionType::kJoint, false}},
    {"MOVELSYNC", {1, 3, MotionType::kLinear, false}}, {"MOVECSYNC", {2, 4, MotionType::kCircular, false}},
    {"MOVEJAO", {1, 3, MotionType::kJoint, false}},   {"MOVELAO", {1, 3, MotionType::kLinear, false}},
    {"MOVECAO", {2, 4, MotionType::kCircular, false}}, {"MOVEJGO", {1, 3, MotionType::kJoint, false}},
    {"MOVELGO", {1, 3, MotionType::kLinear, false}},   {"MOVECGO", {2, 4, MotionType::kCircular, false}},
    {"TRIGGJ", {1, 4, MotionType::kJoint, false}},    {"TRIGGL", {1, 4, MotionType::kLinear, false}},
    {"TRIGGC", {2, 5, MotionType::kCircular, false}},
};

const std::map<std::string, std::string> kBlocks = {
    {"MODULE", "ENDMODULE"}, {"PROC", "ENDPROC"},   {"FUNC", "ENDFUNC"},   {"TRAP", "ENDTRAP"},
    {"RECORD", "ENDRECORD"}, {"IF", "ENDIF"},       {"FOR", "ENDFOR"},     {"WHILE", "ENDWHILE"},
    {"TEST", "ENDTEST"}};

class Parser {
 public:
  explicit Parser(ProgramFile file) {
    program_.language = Language::kRapid;
    program_.files.push_back(std::move(file));
    t_ = Lex(program_.files[0]);
  }

  Program Run() {
    Structure();
    for (const auto& s : motions_) AddMotion(s);
    return std::move(program_);
  }

 private:
  const ProgramFile& file() const { return program_.files[0]; }
  std::string Word(std::size_t k) const {
    return k < t_.size() && t_[k].kind == Kind::kIdentifier ? Upper(t_[k].text) : std::string();
  }
  std::string Text(const Range& r) const {
    if (r.empty()) return "";
    return std::string(file().text.substr(t_[r.begin].begin, t_[r.end - 1].end - t_[r.begin].begin));
  }
  // The first `what` at bracket depth 0 from k, or t_.size().
  std::size_t Find(std::size_t k, std::string_view what, bool word = false) const {
    int depth = 0;
    for (; k < t_.size(); ++k) {
      const Token& t = t_[k];
      if (depth == 0 && (word ? t.IsWord(what) : t.Is(what))) return k;
      if (OpensBracket(t)) ++depth;
      if (ClosesBracket(t) && depth > 0) --depth;
    }
    return t_.size();
  }
  std::size_t Closing(std::size_t open, std::size_t end) const { return ClosingBracket(t_, open, end); }
  std::vector<Range> Split(const Range& r, std::string_view sep) const {
    std::vector<Range> out;
    for (const auto& [first, last] : SplitTopLevel(t_, r.begin, r.end, sep)) out.push_back({first, last});
    return out;
  }

  // ---- Structure: blocks, declarations, assignments, motions ----

  struct Statement {
    Range r;
    std::string scope;
  };

  void Structure() {
    struct Open {
      std::string word;
      std::size_t at;
    };
    std::vector<Open> blocks;
    std::string scope;
    std::size_t k = 0;
    auto close = [&](const std::string& word) {
      if (blocks.empty() || kBlocks.at(blocks.back().word) != word)
        Fail(file(), t_[k].begin, fmt::format("{} without the block it closes", t_[k].text));
      if (blocks.back().word == "PROC" || blocks.back().word == "FUNC" || blocks.back().word == "TRAP")
        scope.clear();
      blocks.pop_back();
    };
    while (k < t_.size()) {
      std::string w = Word(k);
      if (t_[k].Is(";")) {  // an empty statement
        ++k;
        continue;
      }
      bool is_close = false;
      for (const auto& [open, closer] : kBlocks) is_close = is_close || w == closer;
      if (is_close) {
        close(w);
        ++k;
        continue;
      }
      if (w == "MODULE") {
        blocks.push_back({w, t_[k].begin});
        k += 2;
        if (k < t_.size() && t_[k].Is("(")) k = Closing(k, t_.size()) + 1;
        continue;
      }
      std::size_t head = k;
      if (w == "LOCAL" || w == "TASK") w = Word(++head);
      if (w == "PROC" || w == "FUNC" || w == "TRAP") {
        const std::size_t name = head + (w == "FUNC" ? 2 : 1);
        blocks.push_back({w, t_[k].begin});
        scope = name < t_.size() ? std::string(t_[name].text) : std::string();
        k = name + 1;
        if (k < t_.size() && t_[k].Is("(")) {
          const std::size_t end = Closing(k, t_.size());
          Parameters({k + 1, end}, scope);
          k = end + 1;
        }
        continue;
      }
      if (w == "RECORD") {
        blocks.push_back({w, t_[k].begin});
        k += 2;
        continue;
      }
      if (w == "ERROR" || w == "UNDO" || w == "BACKWARD") {
        ++k;
        if (k < t_.size() && t_[k].Is("(")) k = Closing(k, t_.size()) + 1;
        continue;
      }
      if (w == "ELSE") {
        ++k;
        continue;
      }
      if (w == "ELSEIF") {
        k = std::min(Find(k, "THEN", true), t_.size() - 1) + 1;
        continue;
      }
      if (w == "IF") {
        const std::size_t then = Find(k, "THEN", true), semicolon = Find(k, ";");
        if (then < semicolon) {
          blocks.push_back({w, t_[k].begin});
          k = then + 1;
        } else {  // IF condition statement;  — the statement may be a motion
          Statements({k + 1, semicolon}, scope, /*compact_if=*/true);
          k = semicolon + 1;
        }
        continue;
      }
      if (w == "FOR" || w == "WHILE") {
        blocks.push_back({w, t_[k].begin});
        k = std::min(Find(k, "DO", true), t_.size() - 1) + 1;
        continue;
      }
      if (w == "TEST") {
        blocks.push_back({w, t_[k].begin});
        std::size_t j = k + 1;
        while (j < t_.size() && !t_[j].IsWord("CASE") && !t_[j].IsWord("DEFAULT") && !t_[j].IsWord("ENDTEST")) ++j;
        k = j;
        continue;
      }
      if (w == "CASE" || w == "DEFAULT") {
        k = std::min(Find(k, ":"), t_.size() - 1) + 1;
        continue;
      }
      if (t_[k].kind == Kind::kIdentifier && k + 1 < t_.size() && t_[k + 1].Is(":")) {  // a label
        k += 2;
        continue;
      }
      const std::size_t semicolon = Find(k, ";");
      if (semicolon == t_.size()) Fail(file(), t_[k].begin, "a statement without its ';'");
      Statements({k, semicolon}, scope, false);
      k = semicolon + 1;
    }
    if (!blocks.empty())
      Fail(file(), blocks.back().at,
           fmt::format("{} never closed by {}", blocks.back().word, kBlocks.at(blocks.back().word)));
  }

  void Parameters(const Range& r, const std::string& scope) {
    for (const Range& group : Split(r, ",")) {
      for (const Range& p : Split(group, "|")) {  // alternatives: \switch | \other
        // [\] [VAR | PERS | INOUT] type name [{*}]: the name is the last word before any {.
        std::size_t stop = p.end;
        for (std::size_t k = p.begin; k < p.end; ++k) {
          if (t_[k].Is("{")) {
            stop = k;
            break;
          }
        }
        if (stop == p.begin || t_[stop - 1].kind != Kind::kIdentifier) continue;
        Definition d;
        d.name = Upper(t_[stop - 1].text);
        d.scope = scope;
        d.line = t_[stop - 1].line;
        d.parameter = true;
        definitions_.push_back(std::move(d));
      }
    }
  }

  void Statements(const Range& r, const std::string& scope, bool compact_if) {
    if (r.empty()) return;
    std::size_t k = r.begin;
    std::string w = Word(k);
    if (!compact_if) {
      // Data: [LOCAL | TASK] (CONST | PERS | VAR) type name [{dims}] [:= value]
      std::size_t d = k;
      if (w == "LOCAL" || w == "TASK") w = Word(++d);
      if ((w == "CONST" || w == "PERS" || w == "VAR") && d + 2 < r.end + 1) {
        Declaration({d + 1, r.end}, scope);
        return;
      }
      // Assignment: name [{…}] [.component] := value (a ":=" after a "\" is an optional argument's)
      const std::size_t assign = Assignment(r);
      if (assign < r.end && t_[k].kind == Kind::kIdentifier) {
        const std::string name = Upper(t_[k].text);
        if (assign == k + 1) {
          Definition def;
          def.name = name;
          def.scope = scope;
          def.value = {assign + 1, r.end};
          def.line = t_[k].line;
          definitions_.push_back(std::move(def));
        } else {
          modified_.emplace(name, t_[k].line);
        }
        return;
      }
    } else {
      // IF condition statement;: an assignment there changes its data conditionally.
      const std::size_t assign = Assignment(r);
      if (assign < r.end) {
        std::size_t base = assign;
        while (base > r.begin && !(t_[base - 1].kind == Kind::kIdentifier &&
                                   (base - 1 == r.begin || !t_[base - 2].Is(".")) &&
                                   (base - 1 == r.begin || t_[base - 2].kind != Kind::kIdentifier)))
          --base;
        if (base > r.begin) modified_.emplace(Upper(t_[base - 1].text), t_[base - 1].line);
        return;
      }
      // The statement of IF condition statement;: from the first motion word on.
      while (k < r.end && !kMotions.count(Word(k))) ++k;
      if (k == r.end) return;
      w = Word(k);
    }
    if (kMotions.count(w)) motions_.push_back({{k, r.end}, scope});
    // WaitTime [\InPos,] t; with t a number: the time the program stands there.
    if (w == "WAITTIME") {
      std::size_t n = k + 1;
      if (n + 2 < r.end && t_[n].Is("\\") && Word(n + 1) == "INPOS" && t_[n + 2].Is(",")) n += 3;
      if (auto f = detail::SignedNumber(t_, &n); f && n == r.end)
        program_.waits.push_back({{0, t_[k].line}, f->value, scope});
    }
  }

  // The ":=" of an assignment in r, or r.end: the first at depth 0 before any "\".
  std::size_t Assignment(const Range& r) const {
    const std::size_t assign = Find(r.begin, ":=");
    const std::size_t option = Find(r.begin, "\\");
    return assign < r.end && assign < option ? assign : r.end;
  }

  void Declaration(const Range& r, const std::string& scope) {
    // type name [{dims}] [:= value]
    if (r.end - r.begin < 2) return;
    Definition d;
    d.type = Word(r.begin);
    d.name = Word(r.begin + 1);
    d.scope = scope;
    d.line = t_[r.begin + 1].line;
    std::size_t k = r.begin + 2;
    if (k < r.end && t_[k].Is("{")) {
      d.array = true;
      k = Closing(k, r.end) + 1;
    }
    if (k < r.end && t_[k].Is(":=")) d.value = {k + 1, r.end};
    definitions_.push_back(std::move(d));
  }

  // ---- Values ----

  // The items of a [a, b, …] literal; nullopt when r is not one.
  std::optional<std::vector<Range>> Items(const Range& r) const {
    if (r.empty() || !t_[r.begin].Is("[") || Closing(r.begin, r.end) + 1 != r.end) return std::nullopt;
    auto items = Split({r.begin + 1, r.end - 1}, ",");
    if (items.size() == 1 && items[0].empty()) items.clear();
    return items;
  }

  // n signed numbers in a [..] literal.
  std::optional<std::vector<NumberField>> Numbers(const Range& r, std::size_t n) const {
    auto items = Items(r);
    if (!items || items->size() != n) return std::nullopt;
    std::vector<NumberField> out;
    for (const Range& item : *items) {
      std::size_t k = item.begin;
      auto f = detail::SignedNumber(t_, &k);
      if (!f || k != item.end) return std::nullopt;
      out.push_back(*f);
    }
    return out;
  }

  std::optional<Eigen::Isometry3d> Pose(const Range& r) const {  // [[x,y,z],[q1,q2,q3,q4]]
    auto items = Items(r);
    if (!items || items->size() != 2) return std::nullopt;
    auto trans = Numbers((*items)[0], 3);
    auto rot = Numbers((*items)[1], 4);
    if (!trans || !rot) return std::nullopt;
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    pose.translation() = Eigen::Vector3d((*trans)[0].value, (*trans)[1].value, (*trans)[2].value);
    Eigen::Quaterniond q((*rot)[0].value, (*rot)[1].value, (*rot)[2].value, (*rot)[3].value);
    if (!(q.norm() > 1e-9)) return std::nullopt;
    pose.linear() = q.normalized().toRotationMatrix();
    return pose;
  }

  // The one definition of `written` (any case) with a value, or why there is none.
  const Definition* Lookup(const std::string& written, const std::string& scope, const std::string& type,
                           std::string* why) const {
    const std::string name = Upper(written);
    if (auto m = modified_.find(name); m != modified_.end()) {
      *why = fmt::format("{} is changed component by component (line {}): its value depends on the "
                         "program's flow", written, m->second);
      return nullptr;
    }
    std::vector<const Definition*> valued;
    bool declared = false, module_data = false;
    for (const auto& d : definitions_) module_data = module_data || (d.name == name && d.scope.empty());
    for (const auto& d : definitions_) {
      // A routine's own data, the module's, and assignments anywhere to the module's data.
      const bool assignment = d.type.empty() && !d.parameter;
      if (d.name != name || (!d.scope.empty() && d.scope != scope && !(assignment && module_data))) continue;
      if (d.parameter) {
        *why = fmt::format("{} is a parameter of {}: its value comes from the call", written, d.scope);
        return nullptr;
      }
      declared = declared || !d.type.empty();
      if (!d.value.empty()) valued.push_back(&d);
    }
    if (valued.empty()) {
      *why = declared ? fmt::format("{} is declared without a value", written)
                      : fmt::format("{} is not declared in this module{}", written,
                                    type.empty() ? "" : fmt::format(" (a {} of another module)", type));
      return nullptr;
    }
    if (valued.size() > 1) {
      std::string lines;
      for (const Definition* d : valued) lines += (lines.empty() ? "" : ", ") + std::to_string(d->line);
      *why = fmt::format("{} is given a value at lines {}: its value at the motion depends on the "
                         "program's flow", written, lines);
      return nullptr;
    }
    return valued[0];
  }

  // A motion target: -1 and why when it cannot be evaluated.
  int Evaluate(const Range& r, const std::string& scope, bool joints, std::string* why) {
    if (r.empty()) {
      *why = "no target";
      return -1;
    }
    if (t_[r.begin].Is("[")) return Literal(r, "", joints, why);
    if (t_[r.begin].kind != Kind::kIdentifier) {
      *why = "an expression computed when the program runs";
      return -1;
    }
    const std::string name(t_[r.begin].text);
    const std::string type = joints ? "jointtarget" : "robtarget";
    if (r.end - r.begin == 1) {
      const Definition* d = Lookup(name, scope, type, why);
      if (!d) return -1;
      if (d->array) {
        *why = fmt::format("{} is an array", t_[r.begin].text);
        return -1;
      }
      const int t = Literal(d->value, std::string(t_[r.begin].text), joints, why);
      if (t < 0) *why = fmt::format("{} (line {}): {}", t_[r.begin].text, d->line, *why);
      return t;
    }
    if (t_[r.begin + 1].Is("{")) {  // an array element
      const std::size_t close = Closing(r.begin + 1, r.end);
      if (close + 1 == r.end && close == r.begin + 3 && t_[r.begin + 2].kind == Kind::kNumber) {
        const Definition* d = Lookup(name, scope, type, why);
        if (!d) return -1;
        auto items = Items(d->value);
        const std::size_t index = static_cast<std::size_t>(std::atoi(std::string(t_[r.begin + 2].text).c_str()));
        if (!d->array || !items || index < 1 || index > items->size()) {
          *why = fmt::format("{} has no element {} in its declaration", t_[r.begin].text, index);
          return -1;
        }
        return Literal((*items)[index - 1], fmt::format("{}{{{}}}", t_[r.begin].text, index), joints, why);
      }
      *why = fmt::format("an element of {} picked when the program runs", t_[r.begin].text);
      return -1;
    }
    if (t_[r.begin + 1].Is("(")) {
      *why = fmt::format("{}(…) is computed when the program runs", t_[r.begin].text);
      return -1;
    }
    *why = "an expression computed when the program runs";
    return -1;
  }

  int Literal(const Range& r, const std::string& name, bool joints, std::string* why) {
    auto items = Items(r);
    Target t;
    t.name = name;
    t.place = {0, r.empty() ? 0 : t_[r.begin].line};
    if (joints) {
      auto rax = items && items->size() == 2 ? Numbers((*items)[0], 6) : std::nullopt;
      if (!rax) {
        *why = "not a jointtarget literal [[rax_1 … rax_6], [eax_a … eax_f]]";
        return -1;
      }
      t.layout = Layout::kRapidJoints;
      t.fields = *rax;
    } else {
      std::optional<std::vector<NumberField>> trans, rot, conf;
      if (items && items->size() == 4) {
        trans = Numbers((*items)[0], 3);
        rot = Numbers((*items)[1], 4);
        conf = Numbers((*items)[2], 4);
      }
      if (!trans || !rot || !conf) {
        *why = "not a robtarget literal [[x,y,z], [q1,q2,q3,q4], [cf1,cf4,cf6,cfx], [eax…]]";
        return -1;
      }
      t.layout = Layout::kRapidPose;
      t.fields = *trans;
      t.fields.insert(t.fields.end(), rot->begin(), rot->end());
      std::array<int, 4> cf{};
      for (int i = 0; i < 4; ++i) cf[static_cast<std::size_t>(i)] = static_cast<int>((*conf)[static_cast<std::size_t>(i)].value);
      t.config.abb_cf = cf;
    }
    const std::size_t key = t_[r.begin].begin;
    if (auto found = literal_targets_.find(key); found != literal_targets_.end()) return found->second;
    program_.targets.push_back(std::move(t));
    literal_targets_[key] = static_cast<int>(program_.targets.size()) - 1;
    return literal_targets_[key];
  }

  FrameRef Tool(const Range& r, const std::string& scope) const {
    FrameRef tool;
    tool.name = Text(r);
    if (r.end - r.begin != 1 || t_[r.begin].kind != Kind::kIdentifier) {
      tool.unknown_why = fmt::format("the tool {} is computed when the program runs", Quoted(tool.name));
      return tool;
    }
    const std::string name(t_[r.begin].text);
    if (Upper(name) == "TOOL0") {
      tool.transform = Eigen::Isometry3d::Identity();
      return tool;
    }
    std::string why;
    const Definition* d = Lookup(name, scope, "tooldata", &why);
    auto items = d ? Items(d->value) : std::nullopt;
    if (!d) {
      tool.unknown_why = why;
    } else if (!items || items->size() != 3) {
      tool.unknown_why = fmt::format("{} (line {}) is not a tooldata literal", tool.name, d->line);
    } else if (!(*items)[0].empty() && !t_[(*items)[0].begin].IsWord("TRUE")) {
      tool.unknown_why = fmt::format("{} is a stationary tool (robhold FALSE): not followed", tool.name);
    } else if (auto frame = Pose((*items)[1])) {
      tool.transform = *frame;
    } else {
      tool.unknown_why = fmt::format("{} (line {}) has no tframe of numbers", tool.name, d->line);
    }
    return tool;
  }

  FrameRef WorkObject(const std::optional<Range>& r, const std::string& scope) const {
    FrameRef base;
    if (!r) {
      base.name = "wobj0";
      base.transform = Eigen::Isometry3d::Identity();
      return base;
    }
    base.name = Text(*r);
    if (r->end - r->begin != 1 || t_[r->begin].kind != Kind::kIdentifier) {
      base.unknown_why = fmt::format("the work object {} is computed when the program runs", Quoted(base.name));
      return base;
    }
    const std::string name(t_[r->begin].text);
    if (Upper(name) == "WOBJ0") {
      base.transform = Eigen::Isometry3d::Identity();
      return base;
    }
    std::string why;
    const Definition* d = Lookup(name, scope, "wobjdata", &why);
    auto items = d ? Items(d->value) : std::nullopt;
    if (!d) {
      base.unknown_why = why;
      return base;
    }
    if (!items || items->size() != 5) {
      base.unknown_why = fmt::format("{} (line {}) is not a wobjdata literal", base.name, d->line);
      return base;
    }
    if (!(*items)[0].empty() && t_[(*items)[0].begin].IsWord("TRUE")) {
      base.unknown_why = fmt::format("{}: a work object the robot holds (robhold TRUE): not followed", base.name);
      return base;
    }
    if (!(*items)[1].empty() && t_[(*items)[1].begin].IsWord("FALSE")) {
      base.unknown_why =
          fmt::format("{}: a user frame a mechanical unit moves (ufprog FALSE): not followed", base.name);
      return base;
    }
    auto uframe = Pose((*items)[3]);
    auto oframe = Pose((*items)[4]);
    if (!uframe || !oframe) {
      base.unknown_why = fmt::format("{} (line {}) has no uframe and oframe of numbers", base.name, d->line);
      return base;
    }
    base.transform = *uframe * *oframe;
    return base;
  }

  void AddMotion(const Statement& s) {
    const std::string w = Word(s.r.begin);
    const MotionForm& form = kMotions.at(w);
    Motion m;
    m.place = {0, t_[s.r.begin].line};
    m.instruction = std::string(t_[s.r.begin].text);
    m.type = form.type;
    m.routine = s.scope;
    // Positional arguments, each cut at its first "\"; the optional ones collected.
    std::vector<Range> positional;
    std::map<std::string, std::optional<Range>> optional;
    for (const Range& chunk : Split({s.r.begin + 1, s.r.end}, ",")) {
      std::size_t k = chunk.begin;
      const std::size_t first_switch = std::min(Find(chunk.begin, "\\"), chunk.end);
      if (first_switch > chunk.begin) positional.push_back({chunk.begin, first_switch});
      k = first_switch;
      while (k < chunk.end) {  // \Name or \Name:=value
        const std::size_t next = std::min(Find(k + 1, "\\"), chunk.end);
        const std::string name = Word(k + 1);
        if (k + 2 < next && t_[k + 2].Is(":="))
          optional[name] = Range{k + 3, next};
        else
          optional[name] = std::nullopt;
        k = next;
      }
    }
    if (positional.size() < static_cast<std::size_t>(form.targets)) {
      program_.not_evaluated.push_back({m.place, fmt::format("{} without its target", m.instruction)});
      return;
    }
    for (int i = 0; i < form.targets; ++i) {
      std::string why;
      const int t = Evaluate(positional[static_cast<std::size_t>(i)], s.scope, form.joints, &why);
      if (t < 0) {
        program_.not_evaluated.push_back({m.place, fmt::format("{} {}: {}", m.instruction,
                                                               Quoted(Text(positional[static_cast<std::size_t>(i)])), why)});
        return;
      }
      m.targets.push_back(t);
    }
    if (positional.size() > form.tool) {
      m.tool = Tool(positional[form.tool], s.scope);
    } else {
      m.tool.name = "?";
      m.tool.unknown_why = fmt::format("{} without its tool argument", m.instruction);
    }
    std::optional<Range> wobj;
    if (auto it = optional.find("WOBJ"); it != optional.end() && it->second) wobj = it->second;
    m.base = WorkObject(wobj, s.scope);
    program_.motions.push_back(std::move(m));
  }

  Program program_;
  std::vector<Token> t_;
  std::vector<Definition> definitions_;
  std::map<std::string, int> modified_;
  std::vector<Statement> motions_;
  std::map<std::size_t, int> literal_targets_;
};

}  // namespace

Program ParseRapid(ProgramFile module) { return Parser(std::move(module)).Run(); }

}  // namespace armsig::programs
