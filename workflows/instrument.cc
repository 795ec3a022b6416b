#include "workflows/instrument.h"

#include <fmt/format.h>

#include <nlohmann/json.hpp>

#include "acquisition/lab.h"
#include "core/error.h"
#include "core/text.h"
#include "core/units.h"

namespace armsig::workflows {

namespace {

nlohmann::json ReadingJson(const instruments::Reading& r, const std::string& device) {
  nlohmann::json j = {
      {"instrument", device},
      {"hz_rad", r.angles.hz_rad},
      {"v_rad", r.angles.v_rad},
      {"distance_mm", r.distance_mm ? nlohmann::json(*r.distance_mm) : nlohmann::json(nullptr)},
      {"face", r.angles.face},
      {"return_code", r.return_code},
      {"warning", r.note.empty() ? nlohmann::json(nullptr) : nlohmann::json(r.note)}};
  // What a laser tracker reports besides (absent for theodolites).
  if (const auto& p = r.point_in_instrument_mm)
    j.update({{"x_mm", p->x()}, {"y_mm", p->y()}, {"z_mm", p->z()}});
  if (const auto& s = r.sigma) {
    j.update({{"sigma_hz_rad", s->hz_rad},
              {"sigma_v_rad", s->v_rad},
              {"sigma_distance_mm", s->distance_mm}});
  }
  if (const auto& e = r.environment) {
    j.update({{"temperature_c", e->temperature_c},
              {"pressure_hpa", e->pressure_hpa},
              {"humidity_percent", e->humidity_percent}});
  }
  return j;
}

std::string ReadController(const InstrumentRequest& o, const instruments::RetryPolicy& policy) {
  io::ControllerConfig config;
  config.protocol = o.protocol;
  config.port = o.port;
  config.baud = o.baud;
  const auto robot = acquisition::OpenController(config, policy);
  const Eigen::VectorXd q = robot->ReadJointsRad();
  if (o.json) {
    std::vector<double> joints(q.data(), q.data() + q.size());
    return JsonText(nlohmann::json{{"controller", robot->name()}, {"joints_rad", joints}}) + "\n";
  }
  std::string text = fmt::format("{}: {} joints (deg):", Printable(robot->name()), q.size());
  for (int i = 0; i < q.size(); ++i) text += fmt::format(" {:.3f}", q(i) / kRadPerDeg);
  return text + "\n";
}

}  // namespace

std::string QueryInstrument(const InstrumentRequest& o) {
  if (o.port.empty() && o.tcp.empty())
    throw InputError({"--port", 0, 0, ""}, "give --port PATH or --tcp HOST:PORT");
  instruments::RetryPolicy policy;
  policy.timeout = std::chrono::milliseconds(o.timeout_ms);
  if (o.protocol == "val" || o.protocol == "as") return ReadController(o, policy);
  io::InstrumentConfig config;
  config.protocol = o.protocol;
  config.port = o.port;
  config.tcp = o.tcp;
  config.baud = o.baud;
  config.crc = o.crc;
  const auto device = acquisition::OpenInstrument(config, policy);
  if (o.action == "probe") {
    const auto info = device->Identify();
    if (o.json) {
      return JsonText(nlohmann::json{{"port", device->name()},
                                     {"name", info.name},
                                     {"serial", info.serial},
                                     {"firmware", info.firmware}}) +
             "\n";
    }
    // What a device says is shown, never obeyed (an escape sequence in its name).
    return fmt::format("{}: {} serial {} firmware {}\n", Printable(device->name()),
                       Printable(info.name), Printable(info.serial), Printable(info.firmware));
  }
  const bool distance = o.distance || o.protocol == "emscon";  // a tracker always has one
  const auto r = distance ? device->MeasureDistanceAndAngles() : device->MeasureAngles();
  if (o.json) return JsonText(ReadingJson(r, device->name())) + "\n";
  return fmt::format("{}: Hz {:.5f} gon  V {:.5f} gon  face {}{}{}\n", Printable(device->name()),
                     FromRad(r.angles.hz_rad, AngleUnit::kGon),
                     FromRad(r.angles.v_rad, AngleUnit::kGon), r.angles.face,
                     r.distance_mm ? fmt::format("  distance {:.3f} mm", *r.distance_mm) : "",
                     r.note.empty() ? "" : "  (" + Printable(r.note) + ")");
}

}  // namespace armsig::workflows
