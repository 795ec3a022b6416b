#include "simulation/rapid_module.h"

#include <fmt/format.h>

#include <cctype>
#include <regex>

#include "core/error.h"
#include "core/text.h"
#include "robots/rws_codec.h"
#include "simulation/shipped_abb_module.h"  // generated: kShippedAbbModule

namespace armsig::simulation {

namespace {

std::string Upper(std::string_view s) {
  std::string out(s);
  for (char& c : out) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  return out;
}

// The text without comments ('!' to the end of the line, outside string literals), lines kept.
std::string WithoutComments(std::string_view text) {
  std::string out;
  bool in_string = false, in_comment = false;
  for (char c : text) {
    if (c == '\n') {
      in_comment = false;
      in_string = false;
      out.push_back(c);
      continue;
    }
    if (in_comment) continue;
    if (c == '"') in_string = !in_string;
    if (c == '!' && !in_string) {
      in_comment = true;
      continue;
    }
    out.push_back(c);
  }
  return out;
}

double AsFloat(double v) { return static_cast<double>(static_cast<float>(v)); }

}  // namespace

std::string CanonicalValue(const RapidData& d, const std::string& text) {
  const std::string type = Upper(d.type);
  if (d.elements > 0) {
    std::vector<double> v = robots::rws::ParseRapidArray(text);
    if (static_cast<int>(v.size()) != d.elements) {
      throw robots::rws::DecodeError(fmt::format("{} has {} elements", d.name, d.elements));
    }
    if (type == "NUM") {
      for (double& x : v) x = AsFloat(x);
      return robots::rws::FormatRapidArray(v, 9);
    }
    return robots::rws::FormatRapidArray(v, 15);
  }
  if (type == "NUM") return robots::rws::FormatRapidNum(AsFloat(robots::rws::ParseRapidNum(text)));
  if (type == "DNUM") return robots::rws::FormatRapidArray({robots::rws::ParseRapidNum(text)}, 15).substr(1);
  if (type == "JOINTTARGET") {
    robots::rws::JointTarget t = robots::rws::ParseRapidJointTarget(text);
    for (double& x : t.robax_deg) x = AsFloat(x);
    for (double& x : t.extax) x = AsFloat(x);
    return robots::rws::FormatRapidJointTarget(t);
  }
  throw robots::rws::DecodeError("the simulator keeps no RAPID " + d.type);
}


const RapidData* RapidModule::Find(std::string_view name) const {
  const std::string wanted = Upper(name);
  for (const RapidData& d : data) {
    if (Upper(d.name) == wanted) return &d;
  }
  return nullptr;
}

RapidModule ParseRapidModule(std::string_view text, const std::string& source) {
  const std::string code = WithoutComments(text);
  RapidModule module;
  // Statements end with ';' or a line end for the block keywords; walk statement by
  // statement, keeping the line where each begins.
  static const std::regex kModule(R"(^\s*MODULE\s+([A-Za-z][A-Za-z0-9_]*)\s*(\([^)]*\))?\s*$)",
                                  std::regex::icase);
  static const std::regex kEndModule(R"(^\s*ENDMODULE\s*$)", std::regex::icase);
  static const std::regex kRoutine(
      R"(^\s*(LOCAL\s+)?(PROC|FUNC\s+[A-Za-z][A-Za-z0-9_]*|TRAP)\s+([A-Za-z][A-Za-z0-9_]*)\b.*$)",
      std::regex::icase);
  static const std::regex kEndRoutine(R"(^\s*END(PROC|FUNC|TRAP)\s*$)", std::regex::icase);
  static const std::regex kData(
      R"(^\s*(LOCAL\s+|TASK\s+)?(PERS|VAR|CONST)\s+([A-Za-z][A-Za-z0-9_]*)\s+([A-Za-z][A-Za-z0-9_]*)\s*(\{\s*([0-9]+)\s*\})?\s*(:=\s*([\s\S]*?))?\s*;\s*$)",
      std::regex::icase);

  int line = 1;
  size_t at = 0;
  bool in_module = false, ended = false;
  std::string in_routine;
  int routine_line = 0;
  std::string pending;  // a data declaration spanning lines
  int pending_line = 0;
  while (at <= code.size()) {
    const size_t end = code.find('\n', at);
    const std::string row =
        code.substr(at, end == std::string::npos ? std::string::npos : end - at);
    const std::string trimmed(Trim(row));
    at = end == std::string::npos ? code.size() + 1 : end + 1;
    const int this_line = line++;
    if (trimmed.empty() && pending.empty()) continue;
    std::smatch m;
    if (!in_routine.empty()) {
      if (std::regex_match(trimmed, kEndRoutine)) in_routine.clear();
      continue;
    }
    if (!pending.empty()) {
      pending += "\n" + row;
      if (trimmed.empty() || trimmed.back() != ';') continue;
    } else if (!in_module) {
      if (ended) throw InputError({source, this_line, 0, ""}, "text after ENDMODULE");
      if (!std::regex_match(trimmed, m, kModule)) {
        throw InputError({source, this_line, 0, ""}, "expected MODULE name, got " + Quoted(trimmed));
      }
      module.name = m[1];
      in_module = true;
      continue;
    } else if (std::regex_match(trimmed, kEndModule)) {
      in_module = false;
      ended = true;
      continue;
    } else if (std::regex_match(trimmed, m, kRoutine)) {
      module.routines.push_back(m[3]);
      in_routine = m[3];
      routine_line = this_line;
      continue;
    } else {
      pending = row;
      pending_line = this_line;
      if (trimmed.back() != ';') continue;
    }
    if (!std::regex_match(pending, m, kData)) {
      throw InputError({source, pending_line, 0, ""},
                       "expected a data declaration ([LOCAL] PERS|VAR|CONST type name [:= "
                       "value];), got " + Quoted(Trim(pending)));
    }
    RapidData d;
    d.storage = Upper(m[2].str());
    d.type = m[3];
    d.name = m[4];
    d.elements = m[6].matched ? std::stoi(m[6].str()) : 0;
    d.initial = m[8].matched ? std::string(Trim(m[8].str())) : "";
    d.line = pending_line;
    if (module.Find(d.name)) {
      throw InputError({source, pending_line, 0, ""}, "a second declaration of " + Quoted(d.name));
    }
    module.data.push_back(std::move(d));
    pending.clear();
  }
  if (!in_routine.empty()) {
    throw InputError({source, routine_line, 0, ""}, "routine " + in_routine + " has no END");
  }
  if (!pending.empty()) {
    throw InputError({source, pending_line, 0, ""}, "a declaration without its ';'");
  }
  if (!ended) throw InputError({source, 0, 0, ""}, "no MODULE … ENDMODULE");
  return module;
}

std::string_view ShippedAbbModule() { return kShippedAbbModule; }

}  // namespace armsig::simulation
