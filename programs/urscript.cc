#include "programs/urscript.h"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <map>
#include <set>

#include "core/text.h"
#include "programs/scanner.h"

namespace armsig::programs {

namespace {

using detail::Fail;
using detail::Token;
using Kind = Token::Kind;

bool IsIdentStart(char c) { return std::isalpha(static_cast<unsigned char>(c)) || c == '_'; }
bool IsIdentChar(char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '_'; }

// Tokens with an end of statement at every line break outside brackets (comments dropped).
std::vector<Token> Lex(const ProgramFile& file) {
  const std::string_view text = file.text;
  std::vector<Token> out;
  int line = 1, depth = 0;
  auto push = [&](Kind kind, std::size_t begin, std::size_t end) {
    out.push_back({kind, begin, end, line, text.substr(begin, end - begin)});
  };
  std::size_t i = 0;
  while (i < text.size()) {
    const char c = text[i];
    if (c == '\n') {
      if (depth == 0) push(Kind::kEndOfStatement, i, i);
      ++line;
      ++i;
    } else if (c == ' ' || c == '\t' || c == '\r' || c == '\f' || c == '\v') {
      ++i;
    } else if (c == '#') {
      while (i < text.size() && text[i] != '\n') ++i;
    } else if (c == '\\' && (text.substr(i + 1, 1) == "\n" || text.substr(i + 1, 2) == "\r\n")) {
      i = text.find('\n', i) + 1;  // a line continuation
      ++line;
    } else if (c == '"' || c == '\'') {
      std::size_t j = i + 1;
      while (j < text.size() && text[j] != c) {
        if (text[j] == '\n') Fail(file, i, "a string that does not end on its line");
        j += text[j] == '\\' && j + 1 < text.size() && text[j + 1] != '\n' ? 2 : 1;
      }
      if (j >= text.size()) Fail(file, i, "a string that never ends");
      push(Kind::kString, i, j + 1);
      i = j + 1;
    } else {
      const detail::Lexeme l = detail::ScanLexeme(text, i, IsIdentStart(c), IsIdentChar, {"==", "!=", "<=", ">="});
      if (c == '(' || c == '[' || c == '{') ++depth;
      if ((c == ')' || c == ']' || c == '}') && depth > 0) --depth;
      push(l.kind, i, l.end);
      i = l.end;
    }
  }
  push(Kind::kEndOfStatement, text.size(), text.size());
  return out;
}

// A range of tokens [begin, end).
struct Range {
  std::size_t begin = 0, end = 0;
  bool empty() const { return begin >= end; }
};

struct Assignment {
  std::string scope;  // "" global, else the function path "f" or "f/g"
  std::string name;
  Range value;
  int line = 0;
  bool local = false;  // declared `local`
  bool parameter = false;
};

struct Call {
  std::string scope;
  std::string name;
  std::vector<Range> positional;
  std::map<std::string, Range> keyword;
  int line = 0;
  std::size_t byte = 0;
};

const std::set<std::string> kMotions = {"movej", "movel", "movep", "movec", "optimovej", "optimovel"};

MotionType TypeOf(const std::string& name) {
  if (name == "movel" || name == "optimovel") return MotionType::kLinear;
  if (name == "movep") return MotionType::kProcess;
  if (name == "movec") return MotionType::kCircular;
  return MotionType::kJoint;
}

// The index of the bracket closing the one at `open`, within [open, end).
std::size_t Closing(const std::vector<Token>& t, std::size_t open, std::size_t end) {
  return ClosingBracket(t, open, end);
}

// Arguments between the parentheses at `open` and `close`: positional and name=value.
void SplitArguments(const std::vector<Token>& t, std::size_t open, std::size_t close,
                    std::vector<Range>* positional, std::map<std::string, Range>* keyword) {
  for (const auto& [first, last] : SplitTopLevel(t, open + 1, close, ",")) {
    if (last <= first) continue;
    if (last - first >= 2 && t[first].kind == Kind::kIdentifier && t[first + 1].Is("="))
      (*keyword)[std::string(t[first].text)] = {first + 2, last};
    else
      positional->push_back({first, last});
  }
}

class Parser {
 public:
  explicit Parser(ProgramFile file) {
    program_.language = Language::kUrScript;
    program_.files.push_back(std::move(file));
    tokens_ = Lex(program_.files[0]);
  }

  Program Run() {
    Collect();
    ResolveMotions();
    return std::move(program_);
  }

 private:
  const ProgramFile& file() const { return program_.files[0]; }

  // Every statement: blocks, assignments, calls.
  void Collect() {
    struct Block {
      bool function = false;
      std::string name;
      std::size_t at = 0;
    };
    std::vector<Block> blocks;
    auto scope = [&] {
      std::string s;
      for (const auto& b : blocks) {
        if (!b.function) continue;
        s += (s.empty() ? "" : "/") + b.name;
      }
      return s;
    };
    std::size_t start = 0;
    for (std::size_t k = 0; k < tokens_.size(); ++k) {
      if (tokens_[k].kind != Kind::kEndOfStatement) continue;
      const Range st{start, k};
      start = k + 1;
      if (st.empty()) continue;
      const Token& first = tokens_[st.begin];
      if ((first.IsWord("def") || first.IsWord("thread") || first.IsWord("sec")) &&
          st.end - st.begin >= 2 && tokens_[st.begin + 1].kind == Kind::kIdentifier) {
        blocks.push_back({true, std::string(tokens_[st.begin + 1].text), first.begin});
        Parameters(st, scope());
        continue;
      }
      if (first.IsWord("if") || first.IsWord("while") || first.IsWord("for")) {
        blocks.push_back({false, "", first.begin});
        Calls(st, scope());
        continue;
      }
      if (first.IsWord("elif") || first.IsWord("else")) {
        if (blocks.empty()) Fail(file(), first.begin, fmt::format("'{}' outside an if block", first.text));
        Calls(st, scope());
        continue;
      }
      if (first.IsWord("end") && st.end - st.begin == 1) {
        if (blocks.empty()) Fail(file(), first.begin, "'end' without a block to close");
        blocks.pop_back();
        continue;
      }
      Assignments(st, scope());
      Calls(st, scope());
    }
    if (!blocks.empty()) {
      Fail(file(), blocks.back().at,
           blocks.back().function ? fmt::format("def {} is never closed by 'end'", blocks.back().name)
                                  : std::string("a block never closed by 'end'"));
    }
  }

  void Parameters(const Range& st, const std::string& scope) {
    std::size_t open = st.begin + 2;
    if (open >= st.end || !tokens_[open].Is("(")) return;
    const std::size_t close = Closing(tokens_, open, st.end);
    std::vector<Range> positional;
    std::map<std::string, Range> keyword;
    SplitArguments(tokens_, open, close, &positional, &keyword);
    for (const auto& r : positional) {
      if (r.end - r.begin == 1 && tokens_[r.begin].kind == Kind::kIdentifier)
        assignments_.push_back({scope, std::string(tokens_[r.begin].text), {}, tokens_[r.begin].line, true, true});
    }
    for (const auto& [name, r] : keyword)
      assignments_.push_back({scope, name, {}, tokens_[r.begin > 0 ? r.begin - 1 : 0].line, true, true});
  }

  void Assignments(const Range& st, const std::string& scope) {
    const std::size_t eq = FindTopLevel(tokens_, st.begin, st.end, "=");
    if (eq == st.end || eq == st.begin) return;
    std::size_t k = st.begin;
    bool global = false, local = false;
    if (tokens_[k].IsWord("global")) global = true, ++k;
    else if (tokens_[k].IsWord("local")) local = true, ++k;
    if (k >= eq || tokens_[k].kind != Kind::kIdentifier) return;
    const std::string name(tokens_[k].text);
    if (k + 1 == eq) {
      assignments_.push_back({global ? "" : scope, name, {eq + 1, st.end}, tokens_[k].line, local, false});
    } else {
      modified_[name].push_back(tokens_[k].line);  // name[i] = …, name.f = …
    }
  }

  void Calls(const Range& st, const std::string& scope) {
    for (std::size_t k = st.begin; k + 1 < st.end; ++k) {
      if (tokens_[k].kind != Kind::kIdentifier || !tokens_[k + 1].Is("(")) continue;
      const std::string name(tokens_[k].text);
      if (!kMotions.count(name) && name != "set_tcp") continue;
      const std::size_t close = Closing(tokens_, k + 1, st.end);
      Call c{scope, name, {}, {}, tokens_[k].line, tokens_[k].begin};
      SplitArguments(tokens_, k + 1, close, &c.positional, &c.keyword);
      calls_.push_back(std::move(c));
    }
  }

  // ---- Evaluation ----

  struct Value {
    enum class Kind { kTarget, kStruct, kNone } kind = Kind::kNone;
    int target = -1;                       // kTarget
    std::map<std::string, Range> fields;   // kStruct: field ranges
    std::string struct_scope;              // where the struct's fields are evaluated
    std::string name;                      // the variable it came from
    std::string why;                       // kNone
  };

  static Value None(std::string why) {
    Value v;
    v.why = std::move(why);
    return v;
  }

  std::string Text(const Range& r) const {
    if (r.empty()) return "";
    const std::string_view all = file().text;
    return std::string(all.substr(tokens_[r.begin].begin, tokens_[r.end - 1].end - tokens_[r.begin].begin));
  }

  // A literal p[…] or […] of signed numbers as a target (one per literal, shared by every use).
  Value Literal(const Range& r, bool pose, const std::string& name) {
    std::size_t k = r.begin + (pose ? 1 : 0);
    const std::size_t close = Closing(tokens_, k, r.end);
    if (close + 1 != r.end) return None("an expression computed when the program runs");
    std::vector<NumberField> fields;
    ++k;
    while (k < close) {
      auto f = detail::SignedNumber(tokens_, &k);
      if (!f || (k < close && !tokens_[k].Is(","))) {
        return None(fmt::format("{} with an element computed when the program runs",
                                pose ? "p[…]" : "[…]"));
      }
      fields.push_back(*f);
      if (k < close) ++k;
    }
    if (pose && fields.size() != 6)
      return None(fmt::format("p[…] with {} numbers instead of 6", fields.size()));
    if (!pose && fields.size() < 2) return None("a list of fewer than two numbers");
    const std::size_t key = tokens_[r.begin].begin;
    auto found = literal_targets_.find(key);
    if (found == literal_targets_.end()) {
      Target t;
      t.layout = pose ? Layout::kUrPose : Layout::kUrJoints;
      t.name = name;
      t.place = {0, tokens_[r.begin].line};
      t.fields = std::move(fields);
      program_.targets.push_back(std::move(t));
      found = literal_targets_.emplace(key, static_cast<int>(program_.targets.size()) - 1).first;
    }
    Value v;
    v.kind = Value::Kind::kTarget;
    v.target = found->second;
    v.name = name;
    return v;
  }

  // The one assignment `name` can hold when used in `scope`, or why there is none.
  Value Variable(const std::string& name, const std::string& scope, int depth) {
    if (modified_.count(name)) {
      return None(fmt::format("{} is changed element by element (line {}): its value depends on "
                              "the program's flow", name, modified_[name].front()));
    }
    // Every assignment that may give `name` its value here: those of this scope and the ones
    // enclosing it, and a plain assignment in another function when the name is also global
    // (URScript lets a function write a global it does not declare local).
    bool global = false;
    for (const auto& a : assignments_) global = global || (a.name == name && a.scope.empty());
    std::vector<const Assignment*> found, own_local;
    for (const auto& a : assignments_) {
      if (a.name != name) continue;
      const bool visible = a.scope.empty() || scope == a.scope || scope.rfind(a.scope + "/", 0) == 0;
      if (visible || (global && !a.local && !a.parameter)) found.push_back(&a);
      if (a.scope == scope && !a.scope.empty() && (a.local || a.parameter)) own_local.push_back(&a);
    }
    if (found.empty())
      return None(fmt::format("{} is not assigned in the program (an installation variable or a "
                              "value from the controller)", name));
    const std::vector<const Assignment*>& use = own_local.empty() ? found : own_local;
    for (const Assignment* a : use) {
      if (a->parameter)
        return None(fmt::format("{} is a parameter of def {}: its value comes from the call", name, a->scope));
    }
    if (use.size() > 1) {
      std::string lines;
      for (const Assignment* a : use) lines += (lines.empty() ? "" : ", ") + std::to_string(a->line);
      return None(fmt::format("{} is assigned at lines {}: its value at the motion depends on the "
                              "program's flow", name, lines));
    }
    Value v = Evaluate(use[0]->value, use[0]->scope.empty() ? scope : use[0]->scope, depth + 1, name);
    if (v.kind == Value::Kind::kNone && v.why.rfind(name, 0) != 0)
      v.why = fmt::format("{} (line {}) is {}", name, use[0]->line, v.why);
    return v;
  }

  Value Evaluate(Range r, const std::string& scope, int depth, const std::string& name = "") {
    if (depth > 16) return None("a chain of variables too long to follow");
    while (!r.empty() && tokens_[r.begin].Is("(") && Closing(tokens_, r.begin, r.end) + 1 == r.end) {
      ++r.begin;
      --r.end;
    }
    if (r.empty()) return None("an empty expression");
    const Token& first = tokens_[r.begin];
    const std::size_t n = r.end - r.begin;
    if (first.kind == Kind::kIdentifier && first.text == "p" && n >= 2 && tokens_[r.begin + 1].Is("["))
      return Literal(r, true, name);
    if (first.Is("[")) return Literal(r, false, name);
    if (first.kind == Kind::kIdentifier && n == 1) return Variable(std::string(first.text), scope, depth);
    if (first.kind == Kind::kIdentifier && n == 3 && tokens_[r.begin + 1].Is(".") &&
        tokens_[r.begin + 2].kind == Kind::kIdentifier) {
      Value s = Variable(std::string(first.text), scope, depth);
      if (s.kind == Value::Kind::kNone) return s;
      if (s.kind != Value::Kind::kStruct) return None(fmt::format("{} is not a struct", first.text));
      const std::string field(tokens_[r.begin + 2].text);
      auto frame = s.fields.find("frame");
      if (frame != s.fields.end()) {
        const std::string f = Text(frame->second);
        if (f != "\"base\"" && f != "'base'")
          return None(fmt::format("{} is written in frame {}, not the base", first.text, f));
      }
      auto it = s.fields.find(field);
      if (it == s.fields.end()) return None(fmt::format("{} has no field {}", first.text, field));
      return Evaluate(it->second, s.struct_scope, depth + 1,
                      fmt::format("{}.{}", first.text, field));
    }
    if (first.kind == Kind::kIdentifier && n >= 2 && tokens_[r.begin + 1].Is("(") &&
        Closing(tokens_, r.begin + 1, r.end) + 1 == r.end) {
      std::vector<Range> positional;
      std::map<std::string, Range> keyword;
      SplitArguments(tokens_, r.begin + 1, r.end - 1, &positional, &keyword);
      if (first.text == "struct") {
        Value v;
        v.kind = Value::Kind::kStruct;
        v.fields = keyword;
        v.struct_scope = scope;
        v.name = name;
        return v;
      }
      if (first.text == "get_inverse_kin") return InverseKin(positional, keyword, scope, depth);
      return None(fmt::format("{}(…) is computed when the program runs", first.text));
    }
    return None("an expression computed when the program runs");
  }

  Value InverseKin(const std::vector<Range>& positional, const std::map<std::string, Range>& keyword,
                   const std::string& scope, int depth) {
    if (positional.empty()) return None("get_inverse_kin without a pose");
    if (keyword.count("tcp") || positional.size() >= 5)
      return None("get_inverse_kin with a TCP of its own (tcp=): not followed");
    Value pose = Evaluate(positional[0], scope, depth + 1);
    if (pose.kind != Value::Kind::kTarget) return pose;
    Target& t = program_.targets[static_cast<std::size_t>(pose.target)];
    if (t.kind() != TargetKind::kPose) return None("get_inverse_kin of a joint list");
    std::optional<Range> near;
    if (auto it = keyword.find("qnear"); it != keyword.end()) near = it->second;
    else if (positional.size() >= 2) near = positional[1];
    if (near) {
      Value q = Evaluate(*near, scope, depth + 1);
      if (q.kind == Value::Kind::kTarget &&
          program_.targets[static_cast<std::size_t>(q.target)].kind() == TargetKind::kJoints) {
        program_.targets[static_cast<std::size_t>(pose.target)].config.near_target = q.target;
      }
    }
    return pose;
  }

  // The TCP in force at byte `at`: the last set_tcp before it, the flange before any.
  FrameRef ToolAt(std::size_t at) {
    const Call* last = nullptr;
    for (const auto& c : calls_)
      if (c.name == "set_tcp" && c.byte < at) last = &c;
    FrameRef tool;
    if (!last) {
      tool.name = "the flange (no set_tcp before the motion)";
      tool.transform = Eigen::Isometry3d::Identity();
      return tool;
    }
    tool.name = fmt::format("set_tcp (line {})", last->line);
    if (last->positional.empty()) {
      tool.unknown_why = fmt::format("set_tcp at line {} has no pose", last->line);
      return tool;
    }
    const std::size_t targets_before = program_.targets.size();
    const auto before = literal_targets_;
    Value v = Evaluate(last->positional[0], last->scope, 0);
    if (v.kind == Value::Kind::kTarget &&
        program_.targets[static_cast<std::size_t>(v.target)].kind() == TargetKind::kPose) {
      tool.transform = PoseOf(program_.targets[static_cast<std::size_t>(v.target)]);
    } else {
      tool.unknown_why = fmt::format("the TCP set at line {} is not known: {}", last->line,
                                     v.kind == Value::Kind::kNone ? v.why : "not a pose");
    }
    // A TCP is no motion target: its literal is not rewritten.
    if (program_.targets.size() > targets_before) {
      program_.targets.resize(targets_before);
      literal_targets_ = before;
    }
    return tool;
  }

  void ResolveMotions() {
    for (const auto& c : calls_) {
      if (c.name == "set_tcp") continue;
      const std::size_t needed = c.name == "movec" ? 2 : 1;
      const TextPlace place{0, c.line};
      if (c.positional.size() < needed) {
        program_.not_evaluated.push_back({place, fmt::format("{} without its target", c.name)});
        continue;
      }
      Motion m;
      m.place = place;
      m.instruction = c.name;
      m.type = TypeOf(c.name);
      bool ok = true;
      for (std::size_t a = 0; a < needed && ok; ++a) {
        Value v = Evaluate(c.positional[a], c.scope, 0);
        if (v.kind == Value::Kind::kTarget) {
          m.targets.push_back(v.target);
        } else {
          ok = false;
          program_.not_evaluated.push_back(
              {place, fmt::format("{} target {}: {}", c.name, Quoted(Text(c.positional[a])),
                                  v.kind == Value::Kind::kStruct ? "a struct, not a pose" : v.why)});
        }
      }
      if (!ok) continue;
      m.tool = ToolAt(c.byte);
      m.base.name = "the robot base";
      m.base.transform = Eigen::Isometry3d::Identity();
      program_.motions.push_back(std::move(m));
    }
  }

  Program program_;
  std::vector<Token> tokens_;
  std::vector<Assignment> assignments_;
  std::map<std::string, std::vector<int>> modified_;
  std::vector<Call> calls_;
  std::map<std::size_t, int> literal_targets_;  // first byte of a literal -> target
};

}  // namespace

Program ParseUrScript(ProgramFile file) { return Parser(std::move(file)).Run(); }

}  // namespace armsig::programs
