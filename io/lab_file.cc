#include "io/lab_file.h"

#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>

#include "core/enum_words.h"
#include "core/error.h"
#include "core/text.h"
#include "core/units.h"
#include "io/atomic_file.h"
#include "io/model_yaml.h"
#include "io/network_files.h"
#include "io/yaml_reader.h"

namespace armsig::io {

namespace {

// A path in the lab file is relative to the lab file's folder.
std::string Resolve(const std::string& source, const std::string& path) {
  if (path.empty() || path[0] == '/') return path;
  return (std::filesystem::path(source).parent_path() / path).string();
}

// One of `choices`, refused as "expected a, b or c, got 'x'".
std::string Choice(const YamlValue& value, const std::vector<std::string>& choices) {
  const std::string text = value.Text();
  if (std::find(choices.begin(), choices.end(), text) != choices.end()) return text;
  std::string list;
  for (size_t i = 0; i < choices.size(); ++i) {
    list += (i == 0 ? "" : i + 1 == choices.size() ? " or " : ", ") + choices[i];
  }
  value.Fail("expected " + list + ", got " + Quoted(text));
}

// Plausible maximums of a lab's settings: far beyond any real lab, far below a number that
// makes a session run for ever (2,000,000,000 retries of a failing instrument, a billion
// readings per pointing).
constexpr int kMaxBaud = 4000000;
constexpr int kMaxReadings = 100;        // readings per pointing
constexpr int kMaxRemeasure = 100;       // re-measurements of a configuration
constexpr int kMaxRetries = 100;         // tries of a failing instrument call
constexpr int kMaxDelayMs = 10 * 60000;  // settle and retry delays: 10 min
constexpr int kMaxTimeoutMs = 3600000;   // one device call: 1 h
constexpr double kMaxGateMm = plausible::kMaxLengthMm;

}  // namespace

const std::vector<NetworkControllerProtocol>& NetworkControllerProtocols() {
  static const std::vector<NetworkControllerProtocol> protocols = {
      {ControllerProtocol::kUr,
       "ur",
       "Universal Robots (CB3 from 3.4, e-Series)",
       {{"rtde_port", 30004}, {"primary_port", 30001}, {"secondary_port", 30002},
        {"dashboard_port", 29999}},
       "dashboard_port",
       false,
       {}},
      // Robot Web Services: rws_port 0 is the generation's own (80 for RWS 1.0, 443 for 2.0).
      {ControllerProtocol::kAbb,
       "abb",
       "ABB IRC5 (RobotWare 6, RWS 1.0) and OmniCore (RobotWare 7, RWS 2.0)",
       {{"rws_port", 0}},
       "rws_port",
       true,
       {"rws", "certificate_sha256", "ca_file", "task", "module", "mechunit", "speed_percent",
        "representation"}},
      {ControllerProtocol::kKuka,
       "kuka",
       "KUKA KR C4 / KR C5 (a variable server, KukaVarProxy or C3 Bridge, and ARMSIG.src)",
       {{"variable_server_port", 7000}},
       "variable_server_port",
       false,  // a variable server has no authentication: the cell network is the guard
       {"velocity_percent", "acceleration_percent"}},
  };
  return protocols;
}

const NetworkControllerProtocol* FindNetworkControllerProtocol(const std::string& name) {
  for (const auto& p : NetworkControllerProtocols()) {
    if (p.name == name) return &p;
  }
  return nullptr;
}

const NetworkControllerProtocol* FindNetworkControllerProtocol(ControllerProtocol protocol) {
  for (const auto& p : NetworkControllerProtocols()) {
    if (p.id == protocol) return &p;
  }
  return nullptr;
}

namespace {
constexpr EnumWord<ControllerProtocol> kControllerProtocols[] = {
    {ControllerProtocol::kValII, "val"}, {ControllerProtocol::kKawasakiAs, "as"},
    {ControllerProtocol::kCounter, "counter"}, {ControllerProtocol::kUr, "ur"},
    {ControllerProtocol::kAbb, "abb"}, {ControllerProtocol::kKuka, "kuka"},
};
}  // namespace

const char* NameOf(ControllerProtocol protocol) { return WordOf(kControllerProtocols, protocol); }
std::optional<ControllerProtocol> ControllerProtocolNamed(const std::string& name) {
  return ValueNamed(kControllerProtocols, name);
}

unsigned short ControllerConfig::Port(const std::string& key) const {
  if (const auto it = ports.find(key); it != ports.end()) return it->second;
  if (const auto* p = FindNetworkControllerProtocol(protocol)) {
    for (const auto& [name, port] : p->ports) {
      if (name == key) return port;
    }
  }
  return 0;
}

std::string HostPort::Text() const { return host + ":" + std::to_string(port); }

namespace {
constexpr EnumWord<InstrumentProtocol> kInstrumentProtocols[] = {
    {InstrumentProtocol::kGeoCom, "geocom"},
    {InstrumentProtocol::kGsi, "gsi"},
    {InstrumentProtocol::kEmScon, "emscon"},
};
}  // namespace

const char* NameOf(InstrumentProtocol protocol) { return WordOf(kInstrumentProtocols, protocol); }
std::optional<InstrumentProtocol> InstrumentProtocolNamed(const std::string& name) {
  return ValueNamed(kInstrumentProtocols, name);
}

std::optional<HostPort> SplitHostPort(const std::string& text) {
  const size_t colon = text.rfind(':');
  if (colon == std::string::npos || colon == 0) return std::nullopt;
  const char* first = text.data() + colon + 1;
  const char* last = text.data() + text.size();
  unsigned port = 0;
  const auto [end, error] = std::from_chars(first, last, port);
  if (error != std::errc() || end != last || first == last || port < 1 || port > 65535) {
    return std::nullopt;
  }
  return HostPort{text.substr(0, colon), static_cast<unsigned short>(port)};
}

namespace {

unsigned Baud(const YamlValue& value) { return static_cast<unsigned>(value.Integer(50, kMaxBaud)); }

// A positive length in mm within a robot cell.
double PositiveMm(const YamlValue& value) {
  const double mm = value.PositiveNumber();
  if (mm > kMaxGateMm) value.Fail("expected at most 1000000 mm (1 km), got " + value.Describe());
  return mm;
}

// Which protocols a controller key belongs to, for "'host' belongs to protocol ur, not val".
std::vector<std::string> OwnersOf(const std::string& key) {
  if (key == "port") return {"val", "as"};
  if (key == "baud") return {"val", "as", "counter"};
  if (key == "ports" || key == "counts_per_deg" || key == "offset_deg" || key == "coupling")
    return {"counter"};
  std::vector<std::string> owners;
  for (const auto& p : NetworkControllerProtocols()) {
    bool takes = key == "host" || (key == "credentials" && p.credentials);
    for (const auto& [name, port] : p.ports) takes |= name == key;
    for (const auto& name : p.settings) takes |= name == key;
    if (takes) owners.push_back(p.name);
  }
  return owners;
}

// "val, as or counter"
std::string OrList(const std::vector<std::string>& items) {
  std::string list;
  for (size_t i = 0; i < items.size(); ++i) {
    list += (i == 0 ? "" : i + 1 == items.size() ? " or " : ", ") + items[i];
  }
  return list;
}

// A controller's address: a host name or an IP address, no blanks or control characters.
std::string HostOf(const YamlValue& value) {
  const std::string host = value.Text();
  const bool bad = host.size() > 253 || std::any_of(host.begin(), host.end(), [](char ch) {
                     return static_cast<unsigned char>(ch) <= ' ' || ch == 0x7f;
                   });
  if (bad) value.Fail("expected a host name or an IP address, got " + value.Describe());
  return host;
}

// A controller on the network: its host, its protocol's ports (defaults filled in), its
// credentials file and settings.
void NetworkControllerFrom(const YamlMap& map, const NetworkControllerProtocol& protocol,
                           const std::string& source, ControllerConfig& c) {
  c.host = HostOf(map.Required("host", "the controller's address (host name or IP address)"));
  std::map<unsigned short, std::string> taken;  // port → its key
  for (const auto& [key, default_port] : protocol.ports) {
    unsigned short port = default_port;
    const auto given = map.Find(key);
    if (given) port = static_cast<unsigned short>(given->Integer(1, 65535));
    c.ports[key] = port;
    const auto [other, inserted] = taken.emplace(port, key);
    if (!inserted) {
      const std::string message = fmt::format("{} and {} are both port {}: each interface of the "
                                              "controller has its own",
                                              other->second, key, port);
      if (given) given->Fail(message);
      map.Fail(message);
    }
  }
  if (const auto v = map.Find("credentials")) c.credentials_path = Resolve(source, v->Text());
  for (const auto& key : protocol.settings) {
    const auto v = map.Find(key);
    if (!v) continue;
    // A setting naming a file (ca_file) is found beside the lab file, as credentials are.
    const bool file = key.size() > 5 && key.compare(key.size() - 5, 5, "_file") == 0;
    c.settings[key] = file ? Resolve(source, v->Text()) : v->Text();
  }
}

ControllerConfig ControllerFrom(const YamlValue& value, const std::string& source,
                                SourceLocation* ports_where) {
  // Every key some protocol takes, so that a misspelt one is refused naming the nearest.
  std::vector<std::string> owned = {"protocol", "port", "baud", "can_move", "ports",
                                    "counts_per_deg", "offset_deg", "coupling", "host",
                                    "credentials"};
  std::vector<std::string> choices = {"val", "as", "counter"};
  for (const auto& p : NetworkControllerProtocols()) {
    choices.push_back(p.name);
    for (const auto& [key, port] : p.ports) owned.push_back(key);
    for (const auto& key : p.settings) owned.push_back(key);
  }
  std::sort(owned.begin() + 10, owned.end());
  owned.erase(std::unique(owned.begin() + 10, owned.end()), owned.end());
  const YamlMap map = value.Map(std::vector<std::string_view>(owned.begin(), owned.end()));
  ControllerConfig c;
  const std::string name = Choice(map.Required("protocol", OrList(choices)), choices);
  c.protocol = *ControllerProtocolNamed(name);
  if (const auto can_move = map.Find("can_move")) c.can_move = can_move->Flag();
  // A key of another protocol is refused, naming whose it is.
  for (const auto& key : owned) {
    if (key == "protocol" || key == "can_move") continue;
    const auto v = map.Find(key);
    if (!v) continue;
    const auto owners = OwnersOf(key);
    if (std::find(owners.begin(), owners.end(), name) != owners.end()) continue;
    if (key == "port" && c.protocol == ControllerProtocol::kCounter)
      v->Fail("counter: give 'ports' (one per joint), not 'port'");
    if (key == "port" || key == "baud") {
      v->Fail(name + ": the controller is reached over the network: give 'host' (and its "
              "ports), not " + Quoted(key));
    }
    if (owners.empty()) v->Fail(Quoted(key) + " is no setting of protocol " + name);
    v->Fail(Quoted(key) + " belongs to protocol " + OrList(owners) + ", not " + name);
  }
  if (const auto* network = FindNetworkControllerProtocol(c.protocol)) {
    NetworkControllerFrom(map, *network, source, c);
    return c;
  }
  if (const auto baud = map.Find("baud")) c.baud = Baud(*baud);
  if (c.protocol != ControllerProtocol::kCounter) {
    c.port = Resolve(source, map.Required("port", "the controller's serial port").Text());
    return c;
  }
  const YamlValue ports = map.Required("ports", "one serial port per joint");
  *ports_where = ports.Where();
  for (const YamlValue& p : ports.List(1)) {
    c.counter_ports.push_back(Resolve(source, p.Text()));
  }
  const int n = static_cast<int>(c.counter_ports.size());
  auto& e = c.encoders;
  e.counts_per_rad.resize(n);
  e.offset_rad = Eigen::VectorXd::Zero(n);
  e.coupling = Eigen::MatrixXd::Identity(n, n);
  const YamlValue scale = map.Required("counts_per_deg", "one counts_per_deg per joint");
  for (int i = 0; const YamlValue& v : scale.List()) {
    const double counts_per_deg = v.Number();
    if (counts_per_deg == 0.0 || std::abs(counts_per_deg) > 1e9) {
      v.Fail("expected a non-zero counts_per_deg within ±1e9, got " + v.Describe());
    }
    if (i < n) e.counts_per_rad(i) = counts_per_deg / kRadPerDeg;
    ++i;
  }
  if (static_cast<int>(scale.node().size()) != n) {
    scale.Fail("expected " + std::to_string(n) + " counts_per_deg (one per port), got " +
               scale.Describe());
  }
  if (const auto offset = map.Find("offset_deg")) {
    const std::vector<double> deg = offset->Numbers(n);
    for (const YamlValue& item : offset->List()) {
      item.Plausible(plausible::Quantity::kJointAngle, plausible::UnitOf(AngleUnit::kDeg));
    }
    for (int i = 0; i < n; ++i) e.offset_rad(i) = deg[i] * kRadPerDeg;
  }
  if (const auto coupling = map.Find("coupling")) e.coupling = coupling->Matrix(n, n);
  return c;
}

InstrumentConfig InstrumentFrom(const YamlValue& value, const std::string& source,
                                SourceLocation* station_where) {
  const YamlMap map =
      value.Map({"station", "protocol", "port", "tcp", "baud", "crc", "distance", "sigma_hz_arcsec",
                 "sigma_v_arcsec", "sigma_distance_mm", "measurement_time_ms"});
  InstrumentConfig c;
  const YamlValue station = map.Required("station", "the id of the station it stands on");
  c.station = station.Name();
  *station_where = station.Where();
  c.protocol = *InstrumentProtocolNamed(
      Choice(map.Required("protocol", "geocom, gsi or emscon"), {"geocom", "gsi", "emscon"}));
  const auto port = map.Find("port");
  const auto tcp = map.Find("tcp");
  if (c.protocol == InstrumentProtocol::kEmScon) {
    // A laser tracker behind an emScon server: binary packets over TCP, always distances.
    for (const char* key : {"port", "baud", "crc"}) {
      if (const auto v = map.Find(key)) {
        v->Fail("instrument " + c.station + ": '" + key +
                "' is no emscon setting (a laser tracker is reached over tcp: HOST:PORT)");
      }
    }
    if (!tcp) map.Fail("instrument " + c.station + ": protocol emscon needs tcp: HOST:PORT");
    c.distance = true;
    if (const auto d = map.Find("distance"); d && !d->Flag()) {
      d->Fail("instrument " + c.station + ": a laser tracker always measures the distance");
    }
    if (const auto v = map.Find("measurement_time_ms")) {
      c.measurement_time_ms = static_cast<int>(v->Integer(1, 100000));
    }
  } else if (const auto v = map.Find("measurement_time_ms")) {
    v->Fail(std::string("'measurement_time_ms' belongs to protocol emscon, not ") + NameOf(c.protocol));
  }
  if (port && tcp) tcp->Fail("instrument " + c.station + ": give port or tcp, not both");
  if (port) c.port = Resolve(source, port->Text());
  if (tcp) {
    c.tcp = SplitHostPort(tcp->Text());
    if (!c.tcp) tcp->Fail("expected HOST:PORT with a port from 1 to 65535, got " + Quoted(tcp->Text()));
  }
  if (!port && !tcp) map.Fail("instrument " + c.station + ": missing 'port' or 'tcp'");
  if (const auto v = map.Find("baud")) c.baud = Baud(*v);
  if (const auto v = map.Find("crc")) c.crc = v->Flag();
  if (const auto v = map.Find("distance"); v && c.protocol != InstrumentProtocol::kEmScon) c.distance = v->Flag();
  using plausible::Quantity;
  if (const auto v = map.Find("sigma_hz_arcsec"))
    c.sigma_hz_arcsec = v->Plausible(Quantity::kSigmaAngle, plausible::kArcsec);
  if (const auto v = map.Find("sigma_v_arcsec"))
    c.sigma_v_arcsec = v->Plausible(Quantity::kSigmaAngle, plausible::kArcsec);
  if (const auto v = map.Find("sigma_distance_mm"))
    c.sigma_distance_mm = v->Plausible(Quantity::kSigmaLength);
  return c;
}

void TolerancesFrom(const YamlValue& value, Tolerances& tol, instruments::RetryPolicy& policy) {
  const YamlMap map =
      value.Map({"max_miss_mm", "max_repeat_mm", "readings", "max_remeasure", "settle_ms",
                 "fault_retries", "fault_retry_delay_ms", "two_face", "timeout_ms", "max_sigma_mm",
                 "max_repeat_sigma", "max_base_fit_rms_mm", "max_joint_error_deg"});
  if (const auto v = map.Find("max_miss_mm")) tol.max_miss_mm = PositiveMm(*v);
  if (const auto v = map.Find("max_repeat_mm")) tol.max_repeat_mm = PositiveMm(*v);
  if (const auto v = map.Find("max_sigma_mm")) tol.max_sigma_mm = PositiveMm(*v);
  if (const auto v = map.Find("max_repeat_sigma")) tol.max_repeat_sigma = v->PositiveNumber();
  if (const auto v = map.Find("max_base_fit_rms_mm")) tol.max_base_fit_rms_mm = PositiveMm(*v);
  if (const auto v = map.Find("max_joint_error_deg")) {
    tol.max_joint_error_deg = v->PositiveNumber();
    if (tol.max_joint_error_deg > 360.0) v->Fail("expected at most 360 deg, got " + v->Describe());
  }
  if (const auto v = map.Find("readings")) tol.readings = v->Integer(1, kMaxReadings);
  if (const auto v = map.Find("max_remeasure")) tol.max_remeasure = v->Integer(0, kMaxRemeasure);
  if (const auto v = map.Find("settle_ms")) tol.settle_ms = v->Integer(0, kMaxDelayMs);
  if (const auto v = map.Find("fault_retries")) tol.fault_retries = v->Integer(0, kMaxRetries);
  if (const auto v = map.Find("fault_retry_delay_ms")) {
    tol.fault_retry_delay_ms = v->Integer(0, kMaxDelayMs);
  }
  if (const auto v = map.Find("two_face")) tol.two_face = v->Flag();
  if (const auto v = map.Find("timeout_ms")) {
    policy.timeout = std::chrono::milliseconds(v->Integer(1, kMaxTimeoutMs));
  }
}

RecalibrationSettings RecalibrationFrom(const YamlValue& value) {
  const YamlMap map = value.Map({"max_validation_mean_mm", "max_validation_max_mm", "tolerance_mm",
                                 "drift_sigma", "drift_mm", "window"});
  RecalibrationSettings r;
  if (const auto v = map.Find("max_validation_mean_mm")) r.max_validation_mean_mm = PositiveMm(*v);
  if (const auto v = map.Find("max_validation_max_mm")) r.max_validation_max_mm = PositiveMm(*v);
  if (const auto v = map.Find("tolerance_mm")) {
    r.tolerance_mm = v->NonNegativeNumber();
    if (r.tolerance_mm > kMaxGateMm) PositiveMm(*v);
  }
  if (const auto v = map.Find("drift_sigma")) {
    r.drift_sigma = v->PositiveNumber();
    if (r.drift_sigma > 1e6) v->Fail("expected at most 1000000 sigmas, got " + v->Describe());
  }
  if (const auto v = map.Find("drift_mm")) {
    r.drift_mm = v->NonNegativeNumber();
    if (r.drift_mm > kMaxGateMm) PositiveMm(*v);
  }
  if (const auto w = map.Find("window")) {
    const YamlMap window = w->Map({"sessions", "days"});
    if (const auto v = window.Find("sessions")) r.window_sessions = v->Integer(0, 100000);
    if (const auto v = window.Find("days")) r.window_days = v->Integer(0, 100000);
  }
  return r;
}

// The settings and where the parts ParseLab still has to check stand in the text.
struct ParsedLab {
  LabSettings settings;
  SourceLocation model_where, ports_where, stations_where;
  std::vector<SourceLocation> instrument_station_where;  // per instrument
};

// Every instrument stands on a known station (when the lab gives stations at all).
void CheckInstrumentStations(const ParsedLab& parsed,
                             const std::vector<reduction::Station>& stations) {
  if (stations.empty()) return;
  for (size_t i = 0; i < parsed.settings.instruments.size(); ++i) {
    const std::string& id = parsed.settings.instruments[i].station;
    const bool found = std::any_of(stations.begin(), stations.end(),
                                   [&](const auto& s) { return s.pose.id == id; });
    if (!found) {
      throw InputError(parsed.instrument_station_where[i],
                       "instrument station " + Quoted(id) + " is not in the stations");
    }
  }
}

ParsedLab ParseRoot(const YamlValue& root_value, const std::string& source) {
  const YamlMap root =
      root_value.Map({"robot", "instruments", "stations", "tolerances", "recalibration"});
  ParsedLab parsed;
  LabSettings& lab = parsed.settings;

  const YamlMap robot =
      root.Required("robot", "model and controller").Map({"model", "controller", "base"});
  const YamlValue model = robot.Required("model", "the robot model file");
  lab.robot_model_path = Resolve(source, model.Text());
  parsed.model_where = model.Where();
  if (const auto base = robot.Find("base")) {
    lab.robot_base = io::ReadRigidTransform(*base, plausible::Quantity::kCoordinate);
  }
  lab.controller =
      ControllerFrom(robot.Required("controller", "{protocol: val | as | counter, port, …} or {protocol: ur, host, …}"),
                     source, &parsed.ports_where);

  for (const YamlValue& item : root.Required("instruments", "a list of instruments").List(1)) {
    lab.instruments.push_back(
        InstrumentFrom(item, source, &parsed.instrument_station_where.emplace_back()));
  }

  if (const auto stations = root.Find("stations")) {
    parsed.stations_where = stations->Where();
    if (stations->IsScalar()) {
      lab.stations_path = Resolve(source, stations->Text());
    } else if (stations->IsList()) {
      lab.inline_stations = io::ParseStationsList(*stations);
    } else {
      stations->Fail("expected a stations file name or a list of stations, got " +
                     stations->Describe());
    }
  }
  if (const auto tolerances = root.Find("tolerances")) {
    TolerancesFrom(*tolerances, lab.tolerances, lab.policy);
  }
  if (const auto recalibration = root.Find("recalibration")) {
    lab.recalibration = RecalibrationFrom(*recalibration);
  }
  CheckInstrumentStations(parsed, lab.inline_stations);
  return parsed;
}

ParsedLab Parse(const std::string& text, const std::string& source) {
  return io::YamlDocument::Parse(text, source).Read([&](const YamlValue& root) {
    return ParseRoot(root, source);
  });
}

// A file the lab names, refused at the lab file's key when it cannot be read.
std::string ReadNamedFile(const std::string& path, const SourceLocation& where,
                          const std::string& what) {
  try {
    return io::ReadWholeFile(path, io::kYamlFileLimit);
  } catch (const InputError& e) {
    throw InputError(where, "cannot read " + what + " " + Quoted(path) + ": " + e.message());
  }
}

}  // namespace

LabSettings ParseLabSettings(const std::string& text, const std::string& source) {
  return Parse(text, source).settings;
}

std::optional<LabSettings> StoredLabSettings(const std::string& lab_yaml, int64_t session,
                                             const std::string& db_path) {
  if (lab_yaml.empty()) return std::nullopt;
  return ParseLabSettings(lab_yaml,
                          fmt::format("lab file stored with session {} in {}", session, db_path));
}

LabConfig ParseLab(const std::string& text, const std::string& source) {
  const ParsedLab parsed = Parse(text, source);
  const LabSettings& settings = parsed.settings;
  LabConfig lab;
  lab.source = source;
  lab.text = text;
  lab.robot_model_path = settings.robot_model_path;
  lab.model_yaml = ReadNamedFile(settings.robot_model_path, parsed.model_where, "robot model");
  lab.model = io::ParseRobotModel(lab.model_yaml, settings.robot_model_path);
  lab.robot_base = settings.robot_base;
  lab.controller = settings.controller;
  if (lab.controller.protocol == ControllerProtocol::kCounter &&
      static_cast<int>(lab.controller.counter_ports.size()) != lab.model.num_joints()) {
    throw InputError(parsed.ports_where, "counter: the controller gives " +
                                             std::to_string(lab.controller.counter_ports.size()) +
                                             " ports, the robot model has " +
                                             std::to_string(lab.model.num_joints()) + " joints");
  }
  lab.instruments = settings.instruments;
  if (!settings.stations_path.empty()) {
    lab.stations = io::ParseStationsYaml(
        ReadNamedFile(settings.stations_path, parsed.stations_where, "stations file"),
        settings.stations_path);
    CheckInstrumentStations(parsed, lab.stations);
  } else {
    lab.stations = settings.inline_stations;
  }
  lab.tolerances = settings.tolerances;
  lab.policy = settings.policy;
  lab.recalibration = settings.recalibration;
  return lab;
}

LabConfig LoadLab(const std::string& path) {
  return ParseLab(io::ReadWholeFile(path, io::kYamlFileLimit), path);
}

std::string FormatLabYaml(const LabFile& lab) {
  const InstrumentConfig default_instrument;
  const ControllerConfig default_controller;
  YAML::Emitter out;
  // 15 significant digits: 0.1 reads 0.1 (not 0.10000000000000001), and a base or a sigma
  // keeps far more than any instrument resolves.
  out << YAML::DoublePrecision(15);
  out << YAML::BeginMap << YAML::Key << "robot" << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "model" << YAML::Value << lab.model_path;
  const ControllerConfig& c = lab.controller;
  out << YAML::Key << "controller" << YAML::Value << YAML::Flow << YAML::BeginMap;
  out << YAML::Key << "protocol" << YAML::Value << NameOf(c.protocol);
  if (const auto* network = FindNetworkControllerProtocol(c.protocol)) {
    out << YAML::Key << "host" << YAML::Value << c.host;
    for (const auto& [key, default_port] : network->ports) {
      if (c.Port(key) != default_port) out << YAML::Key << key << YAML::Value << c.Port(key);
    }
    if (!c.credentials_path.empty())
      out << YAML::Key << "credentials" << YAML::Value << c.credentials_path;
    for (const auto& [key, text] : c.settings) out << YAML::Key << key << YAML::Value << text;
  } else {
    if (!c.port.empty()) out << YAML::Key << "port" << YAML::Value << c.port;
    if (c.baud != default_controller.baud) out << YAML::Key << "baud" << YAML::Value << c.baud;
  }
  out << YAML::Key << "can_move" << YAML::Value << c.can_move;
  out << YAML::EndMap;
  if (lab.robot_base) {
    out << YAML::Key << "base" << YAML::Value << YAML::Flow << YAML::BeginSeq;
    for (int r = 0; r < 4; ++r) {
      out << YAML::Flow << YAML::BeginSeq;
      for (int k = 0; k < 4; ++k) out << lab.robot_base->matrix()(r, k);
      out << YAML::EndSeq;
    }
    out << YAML::EndSeq;
  }
  out << YAML::EndMap;
  out << YAML::Key << "instruments" << YAML::Value << YAML::BeginSeq;
  for (const auto& i : lab.instruments) {
    out << YAML::Flow << YAML::BeginMap << YAML::Key << "station" << YAML::Value << i.station
        << YAML::Key << "protocol" << YAML::Value << NameOf(i.protocol);
    if (!i.port.empty()) out << YAML::Key << "port" << YAML::Value << i.port;
    if (i.tcp) out << YAML::Key << "tcp" << YAML::Value << i.tcp->Text();
    if (i.baud != default_instrument.baud) out << YAML::Key << "baud" << YAML::Value << i.baud;
    if (i.protocol == InstrumentProtocol::kEmScon) {  // the tracker states its sigmas with every reading
      if (i.measurement_time_ms != default_instrument.measurement_time_ms) {
        out << YAML::Key << "measurement_time_ms" << YAML::Value << i.measurement_time_ms;
      }
      out << YAML::EndMap;
      continue;
    }
    if (i.crc) out << YAML::Key << "crc" << YAML::Value << true;
    if (i.distance) out << YAML::Key << "distance" << YAML::Value << true;
    out << YAML::Key << "sigma_hz_arcsec" << YAML::Value << i.sigma_hz_arcsec << YAML::Key
        << "sigma_v_arcsec" << YAML::Value << i.sigma_v_arcsec;
    if (i.distance) out << YAML::Key << "sigma_distance_mm" << YAML::Value << i.sigma_distance_mm;
    out << YAML::EndMap;
  }
  out << YAML::EndSeq << YAML::Key << "stations" << YAML::Value << lab.stations_path;
  const Tolerances& t = lab.tolerances;
  out << YAML::Key << "tolerances" << YAML::Value << YAML::Flow << YAML::BeginMap << YAML::Key
      << "max_miss_mm" << YAML::Value << t.max_miss_mm << YAML::Key << "max_repeat_mm"
      << YAML::Value << t.max_repeat_mm << YAML::Key << "readings" << YAML::Value << t.readings
      << YAML::Key << "max_remeasure" << YAML::Value << t.max_remeasure << YAML::Key << "settle_ms"
      << YAML::Value << t.settle_ms << YAML::Key << "fault_retries" << YAML::Value
      << t.fault_retries << YAML::Key << "fault_retry_delay_ms" << YAML::Value
      << t.fault_retry_delay_ms << YAML::Key << "two_face" << YAML::Value << t.two_face << YAML::Key
      << "timeout_ms" << YAML::Value << lab.timeout_ms << YAML::Key << "max_sigma_mm" << YAML::Value
      << t.max_sigma_mm << YAML::Key << "max_repeat_sigma" << YAML::Value << t.max_repeat_sigma
      << YAML::Key << "max_base_fit_rms_mm" << YAML::Value << t.max_base_fit_rms_mm << YAML::Key
      << "max_joint_error_deg" << YAML::Value << t.max_joint_error_deg << YAML::EndMap
      << YAML::EndMap;
  return std::string(out.c_str()) + "\n";
}

}  // namespace armsig::io
