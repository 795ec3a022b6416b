#include "acquisition/lab.h"

#include <yaml-cpp/yaml.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "core/error.h"
#include "core/units.h"
#include "instruments/geocom_device.h"
#include "instruments/other_devices.h"
#include "io/model_yaml.h"
#include "reduction/observation.h"

namespace armsig::acquisition {

namespace {

class Reader {
 public:
  explicit Reader(std::string source) : source_(std::move(source)) {}
  SourceLocation Where(const YAML::Node& n, const std::string& key) const {
    return {source_, n.Mark().line + 1, n.Mark().column + 1, key};
  }
  [[noreturn]] void Fail(const YAML::Node& n, const std::string& key, const std::string& m) const {
    throw InputError(Where(n, key), m);
  }
  double Number(const YAML::Node& n, const std::string& key) const {
    double v = 0;
    if (!n || !n.IsScalar() || !YAML::convert<double>::decode(n, v) || !std::isfinite(v))
      Fail(n, key, "expected a number");
    return v;
  }
  std::string Text(const YAML::Node& n, const std::string& key) const {
    if (!n || !n.IsScalar()) Fail(n, key, "expected a text value for '" + key + "'");
    return n.Scalar();
  }
  bool Flag(const YAML::Node& n, const std::string& key) const {
    bool v = false;
    if (!n || !YAML::convert<bool>::decode(n, v)) Fail(n, key, "expected true or false");
    return v;
  }
  std::string Resolve(const std::string& path) const {
    if (path.empty() || path[0] == '/') return path;
    return (std::filesystem::path(source_).parent_path() / path).string();
  }
  const std::string& source() const { return source_; }

 private:
  std::string source_;
};

std::vector<reduction::Station> StationsFrom(const YAML::Node& list, const Reader& r) {
  std::vector<reduction::Station> out;
  for (const YAML::Node& node : list) {
    reduction::Station s;
    s.pose.id = r.Text(node["id"], "id");
    const YAML::Node p = node["position_mm"];
    if (!p || !p.IsSequence() || p.size() != 3)
      r.Fail(node, "position_mm", "expected [x, y, z] in mm");
    for (int k = 0; k < 3; ++k) s.pose.position_mm(k) = r.Number(p[k], "position_mm");
    bool oriented = false;
    for (AngleUnit unit : {AngleUnit::kGon, AngleUnit::kDeg, AngleUnit::kRad}) {
      const std::string key = "azimuth" + std::string(AngleUnitSuffix(unit));
      if (node[key]) {
        s.pose.azimuth_rad = ToRad(r.Number(node[key], key), unit);
        s.pose.world_from_station = reduction::LevelledRotation(s.pose.azimuth_rad);
        oriented = true;
      }
    }
    if (node["rotation"]) {
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
          s.pose.world_from_station(i, j) = r.Number(node["rotation"][i][j], "rotation");
      s.pose.levelled = false;
      oriented = true;
    }
    if (!oriented)
      r.Fail(node, "azimuth_gon", "station " + s.pose.id + ": expected azimuth_* or rotation");
    out.push_back(s);
  }
  return out;
}

}  // namespace

LabConfig ParseLab(const std::string& text, const std::string& source) {
  YAML::Node root;
  try {
    root = YAML::Load(text);
  } catch (const YAML::Exception& e) {
    throw InputError({source, e.mark.line + 1, e.mark.column + 1, ""}, "malformed YAML: " + e.msg);
  }
  const Reader r(source);
  LabConfig lab;
  lab.source = source;
  lab.text = text;
  if (!root.IsMap())
    r.Fail(root, "", "expected a mapping with robot, instruments, stations, tolerances");

  const YAML::Node robot = root["robot"];
  if (!robot) r.Fail(root, "robot", "missing 'robot' (model and controller)");
  lab.robot_model_path = r.Resolve(r.Text(robot["model"], "model"));
  {
    std::ifstream in(lab.robot_model_path);
    if (!in)
      throw InputError(r.Where(robot["model"], "model"),
                       "cannot read robot model " + lab.robot_model_path);
  }
  lab.model = io::LoadRobotModel(lab.robot_model_path);
  {
    std::ifstream in(lab.robot_model_path);
    std::stringstream text_stream;
    text_stream << in.rdbuf();
    lab.model_yaml = text_stream.str();
  }
  const YAML::Node controller = robot["controller"];
  if (!controller)
    r.Fail(robot, "controller", "missing 'controller' (protocol val, as or counter)");
  lab.controller.protocol = r.Text(controller["protocol"], "protocol");
  if (lab.controller.protocol != "val" && lab.controller.protocol != "as" &&
      lab.controller.protocol != "counter") {
    r.Fail(controller["protocol"], "protocol", "expected val, as or counter");
  }
  if (controller["port"]) lab.controller.port = r.Resolve(r.Text(controller["port"], "port"));
  if (controller["baud"])
    lab.controller.baud = static_cast<unsigned>(r.Number(controller["baud"], "baud"));
  if (controller["can_move"]) lab.controller.can_move = r.Flag(controller["can_move"], "can_move");
  if (lab.controller.protocol == "counter") {
    const YAML::Node ports = controller["ports"];
    if (!ports || !ports.IsSequence())
      r.Fail(controller, "ports", "counter: expected one port per joint");
    for (const auto& p : ports)
      lab.controller.counter_ports.push_back(r.Resolve(r.Text(p, "ports")));
    const int n = static_cast<int>(lab.controller.counter_ports.size());
    auto& e = lab.controller.encoders;
    e.counts_per_rad.resize(n);
    e.offset_rad = Eigen::VectorXd::Zero(n);
    e.coupling = Eigen::MatrixXd::Identity(n, n);
    const YAML::Node scale = controller["counts_per_deg"];
    if (!scale || !scale.IsSequence() || static_cast<int>(scale.size()) != n) {
      r.Fail(controller, "counts_per_deg", "counter: expected one counts_per_deg per joint");
    }
    for (int i = 0; i < n; ++i)
      e.counts_per_rad(i) = r.Number(scale[i], "counts_per_deg") / kRadPerDeg;
    if (const YAML::Node off = controller["offset_deg"]) {
      for (int i = 0; i < n; ++i) e.offset_rad(i) = r.Number(off[i], "offset_deg") * kRadPerDeg;
    }
    if (const YAML::Node c = controller["coupling"]) {
      for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j) e.coupling(i, j) = r.Number(c[i][j], "coupling");
    }
  } else if (lab.controller.port.empty()) {
    r.Fail(controller, "port", "missing controller port");
  }

  const YAML::Node instruments = root["instruments"];
  if (!instruments || !instruments.IsSequence() || instruments.size() == 0) {
    r.Fail(root, "instruments", "expected a list of instruments");
  }
  for (const YAML::Node& node : instruments) {
    InstrumentConfig c;
    c.station = r.Text(node["station"], "station");
    c.protocol = r.Text(node["protocol"], "protocol");
    if (c.protocol != "geocom" && c.protocol != "gsi")
      r.Fail(node["protocol"], "protocol", "expected geocom or gsi");
    if (node["port"]) c.port = r.Resolve(r.Text(node["port"], "port"));
    if (node["tcp"]) c.tcp = r.Text(node["tcp"], "tcp");
    if (c.port.empty() && c.tcp.empty())
      r.Fail(node, "port", "instrument " + c.station + ": expected port or tcp");
    if (node["baud"]) c.baud = static_cast<unsigned>(r.Number(node["baud"], "baud"));
    if (node["crc"]) c.crc = r.Flag(node["crc"], "crc");
    if (node["distance"]) c.distance = r.Flag(node["distance"], "distance");
    if (node["sigma_hz_arcsec"])
      c.sigma_hz_arcsec = r.Number(node["sigma_hz_arcsec"], "sigma_hz_arcsec");
    if (node["sigma_v_arcsec"])
      c.sigma_v_arcsec = r.Number(node["sigma_v_arcsec"], "sigma_v_arcsec");
    if (node["sigma_distance_mm"])
      c.sigma_distance_mm = r.Number(node["sigma_distance_mm"], "sigma_distance_mm");
    lab.instruments.push_back(c);
  }

  if (const YAML::Node stations = root["stations"]) {
    if (stations.IsScalar()) {
      const std::string path = r.Resolve(stations.Scalar());
      YAML::Node file;
      try {
        file = YAML::LoadFile(path);
      } catch (const YAML::Exception& e) {
        throw InputError({path, e.mark.line + 1, e.mark.column + 1, ""},
                         "cannot read stations: " + e.msg);
      }
      lab.stations = StationsFrom(file["stations"], Reader(path));
    } else {
      lab.stations = StationsFrom(stations, r);
    }
  }
  for (const auto& c : lab.instruments) {
    bool found = lab.stations.empty();
    for (const auto& s : lab.stations) found |= s.pose.id == c.station;
    if (!found)
      r.Fail(instruments, "station", "instrument station " + c.station + " is not in the stations");
  }

  if (const YAML::Node t = root["tolerances"]) {
    auto& tol = lab.tolerances;
    if (t["max_miss_mm"]) tol.max_miss_mm = r.Number(t["max_miss_mm"], "max_miss_mm");
    if (t["max_repeat_mm"]) tol.max_repeat_mm = r.Number(t["max_repeat_mm"], "max_repeat_mm");
    if (t["readings"]) tol.readings = static_cast<int>(r.Number(t["readings"], "readings"));
    if (t["max_remeasure"])
      tol.max_remeasure = static_cast<int>(r.Number(t["max_remeasure"], "max_remeasure"));
    if (t["settle_ms"]) tol.settle_ms = static_cast<int>(r.Number(t["settle_ms"], "settle_ms"));
    if (t["fault_retries"])
      tol.fault_retries = static_cast<int>(r.Number(t["fault_retries"], "fault_retries"));
    if (t["fault_retry_delay_ms"])
      tol.fault_retry_delay_ms =
          static_cast<int>(r.Number(t["fault_retry_delay_ms"], "fault_retry_delay_ms"));
    if (t["two_face"]) tol.two_face = r.Flag(t["two_face"], "two_face");
    if (t["timeout_ms"])
      lab.policy.timeout =
          std::chrono::milliseconds(static_cast<long>(r.Number(t["timeout_ms"], "timeout_ms")));
    if (tol.readings < 1) r.Fail(t["readings"], "readings", "expected at least 1");
  }
  return lab;
}

LabConfig LoadLab(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw InputError({path, 0, 0, ""}, "cannot open lab configuration");
  std::stringstream buffer;
  buffer << in.rdbuf();
  LabConfig lab = ParseLab(buffer.str(), path);
  return lab;
}

namespace {
std::unique_ptr<instruments::LineTransport> Transport(const std::string& port,
                                                      const std::string& tcp, unsigned baud) {
  if (!tcp.empty()) {
    const size_t colon = tcp.rfind(':');
    return instruments::MakeTcpTransport(
        tcp.substr(0, colon), static_cast<unsigned short>(std::stoi(tcp.substr(colon + 1))));
  }
  instruments::SerialSettings s;
  s.path = port;
  s.baud = baud;
  return instruments::MakeSerialTransport(s);
}
}  // namespace

std::vector<std::unique_ptr<instruments::DistanceInstrument>> OpenInstruments(
    const LabConfig& lab) {
  std::vector<std::unique_ptr<instruments::DistanceInstrument>> out;
  for (const auto& c : lab.instruments) {
    if (c.protocol == "geocom") {
      out.push_back(std::make_unique<instruments::GeoComDevice>(Transport(c.port, c.tcp, c.baud),
                                                                lab.policy, c.crc));
    } else {
      out.push_back(std::make_unique<instruments::GsiOnlineDevice>(Transport(c.port, c.tcp, c.baud),
                                                                   lab.policy));
    }
  }
  return out;
}

std::unique_ptr<instruments::RobotController> OpenController(const LabConfig& lab) {
  const auto& c = lab.controller;
  if (c.protocol == "counter") {
    std::vector<std::unique_ptr<instruments::LineTransport>> ports;
    for (const auto& p : c.counter_ports) ports.push_back(Transport(p, "", c.baud));
    return std::make_unique<instruments::CounterBox>(std::move(ports), c.encoders, lab.policy);
  }
  return std::make_unique<instruments::ValController>(Transport(c.port, "", c.baud), c.can_move,
                                                      lab.policy);
}

}  // namespace armsig::acquisition
