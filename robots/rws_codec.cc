#include "robots/rws_codec.h"

#include <boost/property_tree/ptree.hpp>
#include <boost/property_tree/xml_parser.hpp>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <functional>
#include <nlohmann/json.hpp>
#include <sstream>

#include "core/text.h"

namespace armsig::robots::rws {

namespace {

namespace pt = boost::property_tree;
using nlohmann::json;

// ---- XHTML ----

// A guard before the XML parser, which recurses once per element: refuses a body whose
// elements nest deeper than kMaxDepth (counting opening and closing tags).
void CheckXmlDepth(std::string_view body) {
  int depth = 0;
  for (size_t i = 0; i + 1 < body.size(); ++i) {
    if (body[i] != '<') continue;
    const char next = body[i + 1];
    if (next == '/') {
      depth = std::max(0, depth - 1);
      continue;
    }
    if (next == '?' || next == '!') continue;
    const size_t close = body.find('>', i);
    if (close == std::string_view::npos) return;  // the parser reports it
    if (body[close - 1] != '/' && ++depth > kMaxDepth) {
      throw DecodeError("the reply nests deeper than " + std::to_string(kMaxDepth) +
                        " elements: no RWS page does");
    }
    i = close;
  }
}

std::string Attribute(const pt::ptree& node, const char* name) {
  const auto attributes = node.get_child_optional("<xmlattr>");
  if (!attributes) return "";
  const auto value = attributes->get_child_optional(name);
  return value ? value->data() : "";
}

int64_t StatusCode(std::string_view text) {
  text = Trim(text);
  int64_t code = 0;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), code);
  if (ec != std::errc() || end != text.data() + text.size() || text.empty()) {
    throw DecodeError("an error status whose code is no integer: " + Quoted(text));
  }
  return code;
}

void Collect(const pt::ptree& tree, Resource* parent, Document& doc) {
  for (const auto& [name, child] : tree) {
    if (name == "<xmlattr>" || name == "<xmlcomment>") continue;
    if (name == "li") {
      Resource r;
      r.type = Attribute(child, "class");
      r.title = Attribute(child, "title");
      Collect(child, &r, doc);
      (parent ? parent->children : doc.resources).push_back(std::move(r));
    } else if (name == "span" && parent) {
      parent->fields.emplace_back(Attribute(child, "class"), child.data());
    } else if (name == "div" && Attribute(child, "class") == "status") {
      Status status;
      bool has_code = false;
      for (const auto& [n, span] : child) {
        if (n != "span") continue;
        const std::string cls = Attribute(span, "class");
        if (cls == "code") {
          status.code = StatusCode(span.data());
          has_code = true;
        } else if (cls == "msg") {
          status.message = span.data();
        }
      }
      if (!has_code) throw DecodeError("an error status without a code");
      doc.status = std::move(status);
    } else {
      Collect(child, parent, doc);
    }
  }
}

// ---- JSON ----

std::string ScalarText(const json& value) {
  if (value.is_string()) return value.get<std::string>();
  if (value.is_boolean()) return value.get<bool>() ? "true" : "false";
  if (value.is_number_integer()) return std::to_string(value.get<int64_t>());
  if (value.is_number_unsigned()) return std::to_string(value.get<uint64_t>());
  if (value.is_number_float()) return FormatRapidNum(value.get<double>());
  return "";
}

Resource FromJson(const json& object) {
  Resource r;
  for (const auto& [key, value] : object.items()) {
    if (key == "_links") continue;
    if (key == "_type" || key == "_title") {
      if (!value.is_string()) throw DecodeError("\"" + key + "\" is not a string");
      (key == "_type" ? r.type : r.title) = value.get<std::string>();
    } else if (value.is_array()) {
      for (const json& item : value) {
        if (item.is_object()) r.children.push_back(FromJson(item));
      }
    } else if (value.is_object()) {
      if (value.contains("_type")) r.children.push_back(FromJson(value));
    } else if (!value.is_null()) {
      r.fields.emplace_back(key, ScalarText(value));
    }
  }
  return r;
}

Status StatusFromJson(const json& object) {
  if (!object.is_object() || !object.contains("code")) {
    throw DecodeError("an error status without a code");
  }
  Status s;
  const json& code = object["code"];
  if (code.is_number_integer()) {
    s.code = code.get<int64_t>();
  } else if (code.is_string()) {
    s.code = StatusCode(code.get<std::string>());
  } else {
    throw DecodeError("an error status whose code is no integer");
  }
  if (object.contains("msg") && object["msg"].is_string()) s.message = object["msg"];
  return s;
}

void AddArray(const json& parent, const char* key, Document& doc) {
  if (!parent.contains(key)) return;
  const json& list = parent[key];
  if (!list.is_array()) throw DecodeError(std::string("\"") + key + "\" is not a list");
  for (const json& item : list) {
    if (!item.is_object()) throw DecodeError(std::string("an item of \"") + key +
                                             "\" is not an object");
    doc.resources.push_back(FromJson(item));
  }
}

// ---- Typed decoding ----

const Resource& Require(const Document& doc, std::string_view type) {
  const Resource* r = doc.Find(type);
  if (!r) throw DecodeError("the reply has no " + std::string(type) + " resource");
  return *r;
}

const std::string& RequireField(const Resource& r, std::string_view name) {
  const std::string* value = r.Field(name);
  if (!value) throw DecodeError(r.type + " without " + std::string(name));
  return *value;
}

// ---- RAPID literals ----

class LiteralReader {
 public:
  explicit LiteralReader(std::string_view text) : text_(text) {}
  void Spaces() {
    while (at_ < text_.size() && (text_[at_] == ' ' || text_[at_] == '\t' || text_[at_] == '\r' ||
                                  text_[at_] == '\n'))
      ++at_;
  }
  void Expect(char c) {
    Spaces();
    if (at_ >= text_.size() || text_[at_] != c) {
      throw DecodeError(std::string("expected '") + c + "' in the RAPID value " + Quoted(text_));
    }
    ++at_;
  }
  bool Next(char c) {
    Spaces();
    if (at_ < text_.size() && text_[at_] == c) {
      ++at_;
      return true;
    }
    return false;
  }
  double Number() {
    Spaces();
    const size_t start = at_;
    while (at_ < text_.size() && std::string_view("+-.0123456789eE").find(text_[at_]) !=
                                     std::string_view::npos)
      ++at_;
    return ParseRapidNum(text_.substr(start, at_ - start));
  }
  std::vector<double> Array() {
    std::vector<double> out;
    Expect('[');
    if (Next(']')) return out;
    do {
      out.push_back(Number());
      if (out.size() > 1024) throw DecodeError("a RAPID array of more than 1024 values");
    } while (Next(','));
    Expect(']');
    return out;
  }
  void End() {
    Spaces();
    if (at_ != text_.size()) throw DecodeError("text after the RAPID value " + Quoted(text_));
  }

 private:
  std::string_view text_;
  size_t at_ = 0;
};

std::string Symbol(Version v, const SymbolPath& s) {
  const std::string path = "RAPID/" + s.task + "/" + s.module + "/" + s.name;
  return v == Version::kRws1 ? "/rw/rapid/symbol/data/" + path : "/rw/rapid/symbol/" + path + "/data";
}

Request Get(std::string target) { return {"GET", std::move(target), "", ""}; }
Request Post(std::string target, std::string body = "") {
  return {"POST", std::move(target), std::move(body), ""};
}

}  // namespace

const char* VersionName(Version version) {
  return version == Version::kRws1 ? "RWS 1.0" : "RWS 2.0";
}

const std::string* Resource::Field(std::string_view name) const {
  for (const auto& [n, v] : fields) {
    if (n == name) return &v;
  }
  return nullptr;
}

const Resource* Document::Find(std::string_view type) const {
  std::function<const Resource*(const std::vector<Resource>&)> find =
      [&](const std::vector<Resource>& list) -> const Resource* {
    for (const Resource& r : list) {
      if (r.type == type) return &r;
      if (const Resource* c = find(r.children)) return c;
    }
    return nullptr;
  };
  return find(resources);
}

Document ParseXhtml(std::string_view body) {
  if (body.size() > kMaxBodyBytes) throw DecodeError("the reply is larger than 1 MiB");
  CheckXmlDepth(body);
  pt::ptree tree;
  try {
    std::istringstream in{std::string(body)};
    pt::read_xml(in, tree, pt::xml_parser::trim_whitespace | pt::xml_parser::no_comments);
  } catch (const pt::ptree_error& e) {
    throw DecodeError(std::string("the reply is no XHTML: ") + e.what());
  }
  Document doc;
  Collect(tree, nullptr, doc);
  return doc;
}

Document ParseJson(std::string_view body) {
  if (body.size() > kMaxBodyBytes) throw DecodeError("the reply is larger than 1 MiB");
  json j;
  try {
    j = json::parse(body, [](int depth, json::parse_event_t, json&) {
      if (depth > kMaxDepth) throw DecodeError("the reply nests deeper than the RWS pages do");
      return true;
    });
  } catch (const json::exception& e) {
    throw DecodeError(std::string("the reply is no JSON: ") + e.what());
  }
  if (!j.is_object()) throw DecodeError("the reply is no JSON object");
  Document doc;
  AddArray(j, "state", doc);  // RWS 2.0
  if (j.contains("status")) doc.status = StatusFromJson(j["status"]);
  if (j.contains("_embedded")) {
    const json& embedded = j["_embedded"];
    if (!embedded.is_object()) throw DecodeError("\"_embedded\" is not an object");
    AddArray(embedded, "_state", doc);    // RWS 1.0
    AddArray(embedded, "resources", doc);  // collections
    if (embedded.contains("status")) doc.status = StatusFromJson(embedded["status"]);
  }
  return doc;
}

Document Parse(std::string_view body, std::string_view content_type) {
  const bool is_json = content_type.find("json") != std::string_view::npos ||
                       (content_type.empty() && !Trim(body).empty() && Trim(body)[0] == '{');
  return is_json ? ParseJson(body) : ParseXhtml(body);
}

// ---- Writing ----

namespace {

void WriteLi(const Resource& r, std::string& out) {
  out += "<li class=\"" + EscapeMarkup(r.type) + "\" title=\"" + EscapeMarkup(r.title) + "\">\n";
  for (const auto& [name, value] : r.fields) {
    out += "<span class=\"" + EscapeMarkup(name) + "\">" + EscapeMarkup(value) + "</span>\n";
  }
  if (!r.children.empty()) {
    out += "<ul>\n";
    for (const Resource& c : r.children) WriteLi(c, out);
    out += "</ul>\n";
  }
  out += "</li>\n";
}

json ToJson(const Resource& r) {
  json o = json::object();
  o["_type"] = r.type;
  o["_title"] = r.title;
  for (const auto& [name, value] : r.fields) o[name] = value;
  if (!r.children.empty()) {
    json list = json::array();
    for (const Resource& c : r.children) list.push_back(ToJson(c));
    o["attrib"] = std::move(list);
  }
  return o;
}

json StateList(const Document& document) {
  json list = json::array();
  for (const Resource& r : document.resources) list.push_back(ToJson(r));
  return list;
}

json StatusJson(const Status& s) { return json{{"code", s.code}, {"msg", s.message}}; }

}  // namespace

std::string FormatXhtml(const Document& document, std::string_view service,
                        std::string_view base) {
  std::string out =
      "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
      "<html xmlns=\"http://www.w3.org/1999/xhtml\">\n<head>\n<title>" +
      EscapeMarkup(service) + "</title>\n<base href=\"" + EscapeMarkup(base) +
      "\"/>\n</head>\n<body>\n";
  if (document.status) {
    out += "<div class=\"status\">\n<span class=\"code\">" + std::to_string(document.status->code) +
           "</span>\n<span class=\"msg\">" + EscapeMarkup(document.status->message) +
           "</span>\n</div>\n";
  }
  out += "<div class=\"state\">\n<a href=\"\" rel=\"self\"/>\n<ul>\n";
  for (const Resource& r : document.resources) WriteLi(r, out);
  out += "</ul>\n</div>\n</body>\n</html>\n";
  return out;
}

std::string FormatJson1(const Document& document, std::string_view base) {
  json j;
  j["_links"] = {{"base", {{"href", std::string(base)}}}};
  j["_embedded"] = {{"_state", StateList(document)}};
  if (document.status) j["_embedded"]["status"] = StatusJson(*document.status);
  return JsonText(j);
}

std::string FormatHalJson(const Document& document, std::string_view base) {
  json j;
  j["_links"] = {{"base", {{"href", std::string(base)}}}};
  if (document.status) j["status"] = StatusJson(*document.status);
  j["state"] = StateList(document);
  return JsonText(j);
}

std::string Format(const Document& document, Representation representation,
                   std::string_view service, std::string_view base) {
  switch (representation) {
    case Representation::kXhtml:
      return FormatXhtml(document, service, base);
    case Representation::kJson1:
      return FormatJson1(document, base);
    case Representation::kHalJson:
      return FormatHalJson(document, base);
  }
  return "";
}

const char* MediaType(Representation representation) {
  switch (representation) {
    case Representation::kXhtml:
      return "application/xhtml+xml";
    case Representation::kJson1:
      return "application/json";
    case Representation::kHalJson:
      return "application/hal+json;v=2.0";
  }
  return "";
}

// ---- States ----

namespace {
constexpr std::pair<ControllerState, const char*> kControllerStates[] = {
    {ControllerState::kInit, "init"},
    {ControllerState::kMotorsOn, "motoron"},
    {ControllerState::kMotorsOff, "motoroff"},
    {ControllerState::kGuardStop, "guardstop"},
    {ControllerState::kEmergencyStop, "emergencystop"},
    {ControllerState::kEmergencyStopReset, "emergencystopreset"},
    {ControllerState::kSystemFailure, "sysfail"},
};
constexpr std::pair<OperationMode, const char*> kModes[] = {
    {OperationMode::kInit, "INIT"},         {OperationMode::kAutoChange, "AUTO_CH"},
    {OperationMode::kManualFullChange, "MANF_CH"}, {OperationMode::kManualReduced, "MANR"},
    {OperationMode::kManualFull, "MANF"},   {OperationMode::kAuto, "AUTO"},
    {OperationMode::kUndefined, "UNDEF"},
};
constexpr std::pair<ExecutionState, const char*> kExecution[] = {
    {ExecutionState::kRunning, "running"},
    {ExecutionState::kStopped, "stopped"},
};

template <typename E, size_t N>
const char* TextOf(const std::pair<E, const char*> (&table)[N], E value) {
  for (const auto& [v, t] : table) {
    if (v == value) return t;
  }
  return "?";
}
template <typename E, size_t N>
std::optional<E> FromText(const std::pair<E, const char*> (&table)[N], std::string_view text) {
  for (const auto& [v, t] : table) {
    if (text == t) return v;
  }
  return std::nullopt;
}
}  // namespace

const char* Text(ControllerState state) { return TextOf(kControllerStates, state); }
std::optional<ControllerState> ControllerStateFromText(std::string_view text) {
  return FromText(kControllerStates, text);
}
const char* Text(OperationMode mode) { return TextOf(kModes, mode); }
std::optional<OperationMode> OperationModeFromText(std::string_view text) {
  return FromText(kModes, text);
}
const char* Text(ExecutionState state) { return TextOf(kExecution, state); }
std::optional<ExecutionState> ExecutionStateFromText(std::string_view text) {
  // IRC5 has been seen answering "stop" where the manual says "stopped".
  if (text == "stop") return ExecutionState::kStopped;
  return FromText(kExecution, text);
}

ControllerState DecodeControllerState(const Document& document) {
  const std::string& text = RequireField(Require(document, "pnl-ctrlstate"), "ctrlstate");
  const auto state = ControllerStateFromText(text);
  if (!state) throw DecodeError("an unknown controller state " + Quoted(text));
  return *state;
}

OperationMode DecodeOperationMode(const Document& document) {
  const std::string& text = RequireField(Require(document, "pnl-opmode"), "opmode");
  const auto mode = OperationModeFromText(text);
  if (!mode) throw DecodeError("an unknown operation mode " + Quoted(text));
  return *mode;
}

ExecutionState DecodeExecutionState(const Document& document) {
  const std::string& text = RequireField(Require(document, "rap-execution"), "ctrlexecstate");
  const auto state = ExecutionStateFromText(text);
  if (!state) throw DecodeError("an unknown RAPID execution state " + Quoted(text));
  return *state;
}

Identity DecodeIdentity(const Document& document) {
  // RWS 2.0 names it ctrl-identity-info, the /ctrl listing ctrl-identity-info-li.
  const Resource* r = document.Find("ctrl-identity-info");
  if (!r) r = document.Find("ctrl-identity-info-li");
  if (!r) throw DecodeError("the reply has no ctrl-identity-info resource");
  Identity id;
  id.name = RequireField(*r, "ctrl-name");
  if (const std::string* t = r->Field("ctrl-type")) id.type = *t;
  if (const std::string* i = r->Field("ctrl-id")) id.id = *i;
  return id;
}

SystemInfo DecodeSystemInfo(const Document& document) {
  const Resource& r = Require(document, "sys-system-li");
  SystemInfo s;
  s.rwversion = RequireField(r, "rwversion");
  if (const std::string* v = r.Field("name")) s.name = *v;
  if (const std::string* v = r.Field("rwversionname")) s.rwversionname = *v;
  if (const std::string* v = r.Field("sysid")) s.sysid = *v;
  return s;
}

std::vector<std::string> DecodeRobotTypes(const Document& document) {
  std::vector<std::string> out;
  std::function<void(const std::vector<Resource>&)> walk = [&](const std::vector<Resource>& list) {
    for (const Resource& r : list) {
      if (r.type == "sys-robottype") {
        if (const std::string* t = r.Field("robot-type")) out.push_back(*t);
      }
      walk(r.children);
    }
  };
  walk(document.resources);
  if (out.empty()) throw DecodeError("the reply names no robot type (sys-robottype)");
  return out;
}

std::string DecodeRobotSerial(const Document& document, std::string_view instance) {
  std::function<const Resource*(const std::vector<Resource>&)> find =
      [&](const std::vector<Resource>& list) -> const Resource* {
    for (const Resource& r : list) {
      if (r.type == "cfg-dt-instance-li" && r.title == instance) return &r;
      if (const Resource* c = find(r.children)) return c;
    }
    return nullptr;
  };
  const Resource* inst = find(document.resources);
  if (!inst) {
    throw DecodeError("the reply has no ROBOT_SERIAL_NUMBER instance " + Quoted(instance));
  }
  std::string high, low;
  for (const Resource& a : inst->children) {
    const std::string* value = a.Field("value");
    if (!value) continue;
    if (a.title == "robot_serial_number_high_part") high = std::string(Trim(*value));
    if (a.title == "robot_serial_number_low_part") low = std::string(Trim(*value));
  }
  if (high.empty() && low.empty()) throw DecodeError("the robot's serial number is empty");
  return high + "-" + low;
}

Eigen::VectorXd DecodeJointTargetDeg(const Document& document) {
  const Resource& r = Require(document, "ms-jointtarget");
  Eigen::VectorXd q(6);
  for (int i = 0; i < 6; ++i) {
    q(i) = ParseRapidNum(RequireField(r, "rax_" + std::to_string(i + 1)));
  }
  return q;
}

std::string DecodeSymbolValue(const Document& document) {
  return RequireField(Require(document, "rap-data"), "value");
}

// ---- RAPID literals ----

double ParseRapidNum(std::string_view text) {
  text = Trim(text);
  if (!text.empty() && text[0] == '+') text.remove_prefix(1);
  const bool starts_ok = !text.empty() && (std::isdigit(static_cast<unsigned char>(text[0])) ||
                                           text[0] == '-' || text[0] == '.');
  double value = 0.0;
  const char* end = text.data() + text.size();
  const auto [stop, ec] =
      starts_ok ? std::from_chars(text.data(), end, value) : std::from_chars_result{nullptr, std::errc::invalid_argument};
  if (!starts_ok || ec != std::errc() || stop != end || !std::isfinite(value)) {
    throw DecodeError("expected a RAPID number, got " + Quoted(text));
  }
  return value;
}

std::string FormatRapidNum(double value) {
  if (!std::isfinite(value)) throw std::invalid_argument("a RAPID number must be finite");
  if (value == 0.0) return "0";
  char buffer[40];
  std::snprintf(buffer, sizeof buffer, "%.9G", value);
  return buffer;
}

std::vector<double> ParseRapidArray(std::string_view text) {
  LiteralReader in(text);
  std::vector<double> out = in.Array();
  in.End();
  return out;
}

std::string FormatRapidArray(const std::vector<double>& values, int significant_digits) {
  std::string out = "[";
  char buffer[48];
  for (size_t i = 0; i < values.size(); ++i) {
    if (!std::isfinite(values[i])) throw std::invalid_argument("a RAPID number must be finite");
    std::snprintf(buffer, sizeof buffer, "%.*G", significant_digits, values[i] == 0.0 ? 0.0 : values[i]);
    if (i > 0) out += ",";
    out += buffer;
  }
  return out + "]";
}

JointTarget ParseRapidJointTarget(std::string_view text) {
  LiteralReader in(text);
  in.Expect('[');
  const std::vector<double> robax = in.Array();
  in.Expect(',');
  const std::vector<double> extax = in.Array();
  in.Expect(']');
  in.End();
  if (robax.size() != 6 || extax.size() != 6) {
    throw DecodeError("a jointtarget has 6 robot and 6 external axes, got " +
                      std::to_string(robax.size()) + " and " + std::to_string(extax.size()));
  }
  JointTarget t;
  std::copy(robax.begin(), robax.end(), t.robax_deg.begin());
  std::copy(extax.begin(), extax.end(), t.extax.begin());
  return t;
}

std::string FormatRapidJointTarget(const JointTarget& target) {
  std::string out = "[[";
  for (size_t i = 0; i < 6; ++i) out += (i ? "," : "") + FormatRapidNum(target.robax_deg[i]);
  out += "],[";
  for (size_t i = 0; i < 6; ++i) out += (i ? "," : "") + FormatRapidNum(target.extax[i]);
  return out + "]]";
}

// ---- Requests ----

Request GetIdentity(Version) { return Get("/ctrl/identity"); }
Request GetSystem(Version) { return Get("/rw/system"); }
Request GetRobotType(Version) { return Get("/rw/system/robottype"); }
Request GetRobotSerial(Version) { return Get("/rw/cfg/moc/ROBOT_SERIAL_NUMBER/instances"); }
Request GetControllerState(Version v) {
  return Get(v == Version::kRws1 ? "/rw/panel/ctrlstate" : "/rw/panel/ctrl-state");
}
Request GetOperationMode(Version) { return Get("/rw/panel/opmode"); }
Request GetExecution(Version) { return Get("/rw/rapid/execution"); }
Request GetJointTarget(Version, std::string_view mechunit) {
  return Get("/rw/motionsystem/mechunits/" + std::string(mechunit) + "/jointtarget");
}
Request GetSymbol(Version v, const SymbolPath& symbol) { return Get(Symbol(v, symbol)); }
Request SetSymbol(Version v, const SymbolPath& symbol, std::string_view value) {
  const std::string body = "value=" + FormEncode(value);
  return v == Version::kRws1 ? Post(Symbol(v, symbol) + "?action=set", body)
                             : Post(Symbol(v, symbol), body);
}
Request RequestMastership(Version v) {
  return Post(v == Version::kRws1 ? "/rw/mastership/rapid?action=request"
                                  : "/rw/mastership/edit/request");
}
Request ReleaseMastership(Version v) {
  return Post(v == Version::kRws1 ? "/rw/mastership/rapid?action=release"
                                  : "/rw/mastership/edit/release");
}
Request StartExecution(Version v, std::string_view cycle) {
  const std::string body = "regain=continue&execmode=continue&cycle=" + FormEncode(cycle) +
                           "&condition=none&stopatbp=disabled&alltaskbytsp=false";
  return Post(v == Version::kRws1 ? "/rw/rapid/execution?action=start"
                                  : "/rw/rapid/execution/start",
              body);
}
Request StopExecution(Version v) {
  return v == Version::kRws1 ? Post("/rw/rapid/execution?action=stop", "stopmode=stop")
                             : Post("/rw/rapid/execution/stop", "stopmode=stop&usetsp=normal");
}
Request Logout(Version) { return Get("/logout"); }

Request UploadFile(Version v, std::string_view path, std::string text) {
  Request r{"PUT", "/fileservice/" + std::string(path), std::move(text), ""};
  r.content_type = v == Version::kRws1 ? "text/plain" : "text/plain;v=2.0";
  return r;
}
Request LoadModule(Version v, std::string_view task, std::string_view path, bool replace) {
  const std::string at = "/rw/rapid/tasks/" + std::string(task);
  const std::string body = "modulepath=" + FormEncode(path) + "&replace=" + (replace ? "true" : "false");
  return Post(v == Version::kRws1 ? at + "?action=loadmod" : at + "/loadmod", body);
}
Request UnloadModule(Version v, std::string_view task, std::string_view module) {
  const std::string at = "/rw/rapid/tasks/" + std::string(task);
  return Post(v == Version::kRws1 ? at + "?action=unloadmod" : at + "/unloadmod", "module=" + FormEncode(module));
}
Request SetProgramPointer(Version v, std::string_view task, std::string_view module, std::string_view routine) {
  const std::string at = "/rw/rapid/tasks/" + std::string(task) + "/pcp";
  const std::string body = "module=" + FormEncode(module) + "&routine=" + FormEncode(routine) + "&userlevel=false";
  return Post(v == Version::kRws1 ? at + "?action=set-pp-routine" : at + "/routine?mastership=implicit", body);
}
Request ResetProgramPointer(Version v) {
  return Post(v == Version::kRws1 ? "/rw/rapid/execution?action=resetpp" : "/rw/rapid/execution/resetpp");
}

std::string TargetFor(const Request& request, Version version, Representation representation) {
  if (version != Version::kRws1 || representation != Representation::kJson1) {
    return request.target;
  }
  return request.target + (request.target.find('?') == std::string::npos ? "?" : "&") + "json=1";
}

const char* AcceptHeader(Representation representation) { return MediaType(representation); }

const char* FormContentType(Version version) {
  return version == Version::kRws1 ? "application/x-www-form-urlencoded"
                                   : "application/x-www-form-urlencoded;v=2.0";
}

std::string FormEncode(std::string_view text) {
  static constexpr char kHex[] = "0123456789ABCDEF";
  std::string out;
  for (unsigned char c : text) {
    if (std::isalnum(c) || c == '-' || c == '.' || c == '_' || c == '~') {
      out.push_back(static_cast<char>(c));
    } else {
      out.push_back('%');
      out.push_back(kHex[c >> 4]);
      out.push_back(kHex[c & 15]);
    }
  }
  return out;
}

std::optional<std::string> FormDecode(std::string_view text) {
  std::string out;
  for (size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (c == '+') {
      out.push_back(' ');
    } else if (c == '%') {
      if (i + 2 >= text.size() || !std::isxdigit(static_cast<unsigned char>(text[i + 1])) ||
          !std::isxdigit(static_cast<unsigned char>(text[i + 2]))) {
        return std::nullopt;
      }
      unsigned value = 0;
      std::from_chars(text.data() + i + 1, text.data() + i + 3, value, 16);
      out.push_back(static_cast<char>(value));
      i += 2;
    } else {
      out.push_back(c);
    }
  }
  return out;
}

std::vector<std::pair<std::string, std::string>> ParseForm(std::string_view body) {
  std::vector<std::pair<std::string, std::string>> out;
  while (!body.empty()) {
    const size_t amp = body.find('&');
    const std::string_view pair = body.substr(0, amp);
    if (!pair.empty()) {
      const size_t eq = pair.find('=');
      const auto name = FormDecode(pair.substr(0, eq));
      const auto value = FormDecode(eq == std::string_view::npos ? "" : pair.substr(eq + 1));
      if (!name || !value) throw DecodeError("a malformed %-escape in " + Quoted(pair));
      out.emplace_back(*name, *value);
    }
    body = amp == std::string_view::npos ? std::string_view() : body.substr(amp + 1);
  }
  return out;
}

}  // namespace armsig::robots::rws
