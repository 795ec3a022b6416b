#include "io/network_io.h"

#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

#include <cmath>
#include <set>

#include "core/error.h"
#include "core/units.h"
#include "io/atomic_file.h"
#include "io/csv.h"
#include "reduction/observation.h"

namespace armsig::io {

std::vector<reduction::Observation> ReadObservationsCsv(const std::string& path) {
  const CsvTable t = ReadCsvFile(path);
  const int point = t.Column("point"), station = t.Column("station");
  const AngleColumn hz = t.AngleColumnOf("hz"), v = t.AngleColumnOf("v");
  const auto face = t.FindColumn("face");
  const auto distance = t.FindColumn("distance_mm");
  const auto s_hz = t.FindColumn("sigma_hz_arcsec"), s_v = t.FindColumn("sigma_v_arcsec");
  const auto s_d = t.FindColumn("sigma_distance_mm");
  std::vector<reduction::Observation> out;
  for (const CsvRow& row : t.rows()) {
    reduction::Observation o;
    o.point = t.Text(row, point);
    o.station = t.Text(row, station);
    if (o.point.empty()) throw InputError(t.Where(row, point), "expected a point id");
    if (o.station.empty()) throw InputError(t.Where(row, station), "expected a station id");
    o.reading.hz_rad = t.AngleRad(row, hz);
    o.reading.v_rad = t.AngleRad(row, v);
    if (o.reading.v_rad < 0 || o.reading.v_rad > 2 * kPi) {
      throw InputError(t.Where(row, v.index), "expected a zenith angle in [0, 400 gon)");
    }
    if (face && !t.Text(row, *face).empty()) {
      const int f = t.Integer(row, *face);
      if (f != 1 && f != 2) throw InputError(t.Where(row, *face), "expected face 1 or 2");
      o.reading.face = f;
    } else {
      o.reading.face = o.reading.v_rad > kPi ? 2 : 1;  // SPEC: V > 200 gon is face II
    }
    if (distance) {
      o.distance_mm = t.OptionalNumber(row, *distance);
      if (o.distance_mm && !(*o.distance_mm > 0)) {
        throw InputError(t.Where(row, *distance), "expected a positive distance");
      }
    }
    auto sigma = [&](std::optional<int> column, double unit) {
      if (!column) return std::numeric_limits<double>::quiet_NaN();
      const auto value = t.OptionalNumber(row, *column);
      if (!value) return std::numeric_limits<double>::quiet_NaN();
      if (!(*value > 0)) throw InputError(t.Where(row, *column), "expected a positive sigma");
      return *value * unit;
    };
    o.sigma_hz_rad = sigma(s_hz, kRadPerArcsec);
    o.sigma_v_rad = sigma(s_v, kRadPerArcsec);
    o.sigma_distance_mm = sigma(s_d, 1.0);
    o.source_line = row.line;
    out.push_back(std::move(o));
  }
  if (out.empty()) throw InputError({path, 0, 0, ""}, "no observations (expected data rows)");
  return out;
}

namespace {

SourceLocation Where(const std::string& path, const YAML::Node& node, const std::string& key) {
  return {path, node.Mark().line + 1, node.Mark().column + 1, key};
}

double YamlNumber(const std::string& path, const YAML::Node& node, const std::string& key) {
  double value = 0;
  if (!node || !node.IsScalar() || !YAML::convert<double>::decode(node, value) ||
      !std::isfinite(value)) {
    throw InputError(Where(path, node, key), "expected a finite number");
  }
  return value;
}

}  // namespace

std::vector<reduction::Station> ReadStationsYaml(const std::string& path) {
  YAML::Node root;
  try {
    root = YAML::Load(ReadWholeFile(path));
  } catch (const YAML::Exception& e) {
    throw InputError({path, e.mark.line + 1, e.mark.column + 1, ""}, "malformed YAML: " + e.msg);
  }
  const YAML::Node list = root["stations"];
  if (!list || !list.IsSequence()) {
    throw InputError({path, 1, 0, "stations"}, "expected 'stations:' with a list of stations");
  }
  std::vector<reduction::Station> out;
  std::set<std::string> ids;
  for (const YAML::Node& node : list) {
    reduction::Station s;
    if (!node["id"]) throw InputError(Where(path, node, "id"), "expected a station id");
    s.pose.id = node["id"].as<std::string>();
    if (!ids.insert(s.pose.id).second) {
      throw InputError(Where(path, node["id"], "id"), "duplicate station id '" + s.pose.id + "'");
    }
    const YAML::Node p = node["position_mm"];
    if (!p || !p.IsSequence() || p.size() != 3) {
      throw InputError(Where(path, p ? p : node, "position_mm"), "expected [x, y, z] in mm");
    }
    for (int k = 0; k < 3; ++k) s.pose.position_mm(k) = YamlNumber(path, p[k], "position_mm");
    bool oriented = false;
    for (AngleUnit unit : {AngleUnit::kGon, AngleUnit::kDeg, AngleUnit::kRad}) {
      const std::string key = "azimuth" + std::string(AngleUnitSuffix(unit));
      if (node[key]) {
        s.pose.levelled = true;
        s.pose.azimuth_rad = ToRad(YamlNumber(path, node[key], key), unit);
        s.pose.world_from_station = reduction::LevelledRotation(s.pose.azimuth_rad);
        oriented = true;
      }
    }
    if (const YAML::Node r = node["rotation"]) {
      if (oriented)
        throw InputError(Where(path, r, "rotation"), "give azimuth or rotation, not both");
      if (!r.IsSequence() || r.size() != 3) {
        throw InputError(Where(path, r, "rotation"), "expected a 3x3 row-major matrix");
      }
      for (int i = 0; i < 3; ++i) {
        if (!r[i].IsSequence() || r[i].size() != 3) {
          throw InputError(Where(path, r[i], "rotation"), "expected a row of 3 numbers");
        }
        for (int j = 0; j < 3; ++j)
          s.pose.world_from_station(i, j) = YamlNumber(path, r[i][j], "rotation");
      }
      const Eigen::Matrix3d& m = s.pose.world_from_station;
      if ((m.transpose() * m - Eigen::Matrix3d::Identity()).norm() > 1e-6 || m.determinant() < 0) {
        throw InputError(Where(path, r, "rotation"), "expected a rotation (orthonormal, det +1)");
      }
      s.pose.levelled = false;
      oriented = true;
    }
    if (!oriented) {
      throw InputError(Where(path, node, "azimuth_gon"),
                       "station " + s.pose.id + ": expected azimuth_gon/_deg/_rad or rotation");
    }
    if (node["sigma_hz_arcsec"])
      s.sigma_hz_rad = YamlNumber(path, node["sigma_hz_arcsec"], "sigma_hz_arcsec") * kRadPerArcsec;
    if (node["sigma_v_arcsec"])
      s.sigma_v_rad = YamlNumber(path, node["sigma_v_arcsec"], "sigma_v_arcsec") * kRadPerArcsec;
    out.push_back(std::move(s));
  }
  if (out.empty()) throw InputError({path, 1, 0, "stations"}, "no stations");
  return out;
}

std::string FormatStationsYaml(const std::vector<reduction::Station>& stations,
                               const std::string& header_comment) {
  std::string out;
  if (!header_comment.empty()) {
    size_t start = 0;
    while (start < header_comment.size()) {
      const size_t end = header_comment.find('\n', start);
      out += "# " + header_comment.substr(start, end - start) + "\n";
      if (end == std::string::npos) break;
      start = end + 1;
    }
  }
  out += "stations:\n";
  for (const auto& s : stations) {
    out += fmt::format("  - id: \"{}\"\n", s.pose.id);
    out += fmt::format("    position_mm: [{:.6f}, {:.6f}, {:.6f}]\n", s.pose.position_mm.x(),
                       s.pose.position_mm.y(), s.pose.position_mm.z());
    if (s.pose.levelled) {
      out += fmt::format("    azimuth_gon: {:.9f}\n", FromRad(s.pose.azimuth_rad, AngleUnit::kGon));
    } else {
      const auto& r = s.pose.world_from_station;
      out += "    rotation: [";
      for (int i = 0; i < 3; ++i) {
        out +=
            fmt::format("{}[{:.12f}, {:.12f}, {:.12f}]", i ? ", " : "", r(i, 0), r(i, 1), r(i, 2));
      }
      out += "]\n";
    }
    if (std::isfinite(s.sigma_hz_rad))
      out += fmt::format("    sigma_hz_arcsec: {:.4f}\n", s.sigma_hz_rad / kRadPerArcsec);
    if (std::isfinite(s.sigma_v_rad))
      out += fmt::format("    sigma_v_arcsec: {:.4f}\n", s.sigma_v_rad / kRadPerArcsec);
    out += fmt::format("    sigma_position_mm: [{:.6f}, {:.6f}, {:.6f}]\n", s.sigma_position_mm.x(),
                       s.sigma_position_mm.y(), s.sigma_position_mm.z());
    if (s.pose.levelled) {
      out += fmt::format("    sigma_azimuth_arcsec: {:.4f}\n", s.sigma_azimuth_rad / kRadPerArcsec);
    } else {
      out += fmt::format("    sigma_rotation_arcsec: [{:.4f}, {:.4f}, {:.4f}]\n",
                         s.sigma_rotation_rad.x() / kRadPerArcsec,
                         s.sigma_rotation_rad.y() / kRadPerArcsec,
                         s.sigma_rotation_rad.z() / kRadPerArcsec);
    }
  }
  return out;
}

std::vector<reduction::ControlPoint> ReadControlCsv(const std::string& path) {
  const CsvTable t = ReadCsvFile(path);
  const int point = t.Column("point");
  const int x = t.Column("x_mm"), y = t.Column("y_mm"), z = t.Column("z_mm");
  const auto sx = t.FindColumn("sx_mm"), sy = t.FindColumn("sy_mm"), sz = t.FindColumn("sz_mm");
  std::vector<reduction::ControlPoint> out;
  std::set<std::string> ids;
  for (const CsvRow& row : t.rows()) {
    reduction::ControlPoint c;
    c.id = t.Text(row, point);
    if (!ids.insert(c.id).second) {
      throw InputError(t.Where(row, point), "duplicate control point '" + c.id + "'");
    }
    c.position_mm = {t.Number(row, x), t.Number(row, y), t.Number(row, z)};
    if (sx && sy && sz && !t.Text(row, *sx).empty()) {
      c.sigma_mm = Eigen::Vector3d(t.Number(row, *sx), t.Number(row, *sy), t.Number(row, *sz));
      if (!(c.sigma_mm->minCoeff() > 0))
        throw InputError(t.Where(row, *sx), "expected positive sigmas");
    }
    out.push_back(std::move(c));
  }
  if (out.empty()) throw InputError({path, 0, 0, ""}, "no control points");
  return out;
}

reduction::ScaleBar ParseScaleBar(const std::string& text, double sigma_mm) {
  const size_t colon = text.find(':'), equals = text.find('=');
  if (colon == std::string::npos || equals == std::string::npos || colon > equals || colon == 0 ||
      equals == colon + 1) {
    throw InputError({"--scale-bar", 0, 0, ""},
                     "'" + text + "': expected A:B=LEN_MM, e.g. 1008:1180=1720.0");
  }
  reduction::ScaleBar bar;
  bar.from = text.substr(0, colon);
  bar.to = text.substr(colon + 1, equals - colon - 1);
  const auto length = ParseNumber(text.substr(equals + 1));
  if (!length || !(*length > 0)) {
    throw InputError({"--scale-bar", 0, 0, ""}, "'" + text + "': expected a positive length in mm");
  }
  bar.length_mm = *length;
  bar.sigma_mm = sigma_mm;
  return bar;
}

std::string FormatPointsCsv(const std::vector<TriangulatedPoint>& points) {
  std::string out =
      "point,x_mm,y_mm,z_mm,rays,sx_mm,sy_mm,sz_mm,sigma0,dof,rejected_rays,max_miss_mm,"
      "ellipsoid95_a_mm,ellipsoid95_b_mm,ellipsoid95_c_mm,max_abs_w,residuals_arcsec,status\n";
  for (const auto& p : points) {
    const auto& r = p.result;
    out += CsvEscape(p.id);
    if (r.status != reduction::IntersectionStatus::kOk) {
      out += fmt::format(",,,,{},,,,,,,,,,,,,{}: {}\n", r.rays.size(), ToString(r.status),
                         CsvEscape(r.reason));
      continue;
    }
    const auto e = reduction::EllipsoidOf(r.covariance_mm2);
    double max_w = 0.0;
    std::string residuals;
    for (const auto& ray : r.rays) {
      max_w = std::max({max_w, std::abs(ray.w_hz), std::abs(ray.w_v)});
      if (!residuals.empty()) residuals += ' ';
      residuals +=
          fmt::format("{:.2f}/{:.2f}{}", ray.hz_arcsec, ray.v_arcsec, ray.rejected ? "!" : "");
    }
    out += fmt::format(
        ",{:.6f},{:.6f},{:.6f},{},{:.6f},{:.6f},{:.6f},{:.4f},{},{},{:.6f},{:.6f},{:.6f},{:.6f},{:."
        "2f},{},{}\n",
        r.position_mm.x(), r.position_mm.y(), r.position_mm.z(), r.rays_used,
        std::sqrt(r.covariance_mm2(0, 0)), std::sqrt(r.covariance_mm2(1, 1)),
        std::sqrt(r.covariance_mm2(2, 2)), r.sigma0, r.dof, r.rejected, r.max_miss_mm,
        e.semi_axes_mm(0), e.semi_axes_mm(1), e.semi_axes_mm(2), max_w, residuals,
        r.blunder_suspected ? "blunder_suspected" : (r.rejected ? "blunder_rejected" : "ok"));
  }
  return out;
}

}  // namespace armsig::io
