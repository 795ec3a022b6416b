#include "io/network_files.h"

#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

#include <cmath>
#include <map>
#include <set>

#include "core/error.h"
#include "core/text.h"
#include "core/units.h"
#include "io/atomic_file.h"
#include "io/csv.h"
#include "io/yaml_reader.h"
#include "reduction/observation.h"

namespace armsig::io {

std::vector<reduction::Observation> ReadObservationsCsv(const std::string& path,
                                                        std::vector<std::string>* pose_labels,
                                                        ReadProgressFn progress) {
  CsvReader t(path, {}, std::move(progress));
  t.RefuseUnreadUnits({"point", "station", "hz_*", "v_*", "face", "distance_mm", "sigma_hz_arcsec",
                       "sigma_v_arcsec", "sigma_distance_mm"});
  const int point = t.Column("point"), station = t.Column("station");
  const AngleColumn hz = t.AngleColumnOf("hz"), v = t.AngleColumnOf("v");
  const auto face = t.FindColumn("face");
  const auto distance = t.FindColumn("distance_mm");
  const auto s_hz = t.FindColumn("sigma_hz_arcsec"), s_v = t.FindColumn("sigma_v_arcsec");
  const auto s_d = t.FindColumn("sigma_distance_mm");
  const auto pose = pose_labels ? t.FindColumn("pose") : std::nullopt;
  std::vector<reduction::Observation> out;
  for (CsvRow row; t.Next(row);) {
    if (pose) pose_labels->push_back(t.Name(row, *pose));
    reduction::Observation o;
    if (t.Text(row, point).empty()) throw InputError(t.Where(row, point), "expected a point id");
    if (t.Text(row, station).empty()) {
      throw InputError(t.Where(row, station), "expected a station id");
    }
    o.point = t.Name(row, point);
    o.station = t.Name(row, station);
    using plausible::Quantity;
    // One rule for circle readings (core/plausibility.h), as in GSI files and from drivers.
    o.reading.hz_rad = t.AngleRad(row, hz, Quantity::kCircleReading);
    o.reading.v_rad = t.AngleRad(row, v, Quantity::kZenithAngle);
    if (face && !t.Text(row, *face).empty()) {
      const int f = t.Integer(row, *face);
      if (f != 1 && f != 2) {
        throw InputError(t.Where(row, *face), "expected face 1 or 2, got " + std::to_string(f));
      }
      o.reading.face = f;
    } else {
      o.reading.face = FaceOfZenithAngle(o.reading.v_rad);  // V > 200 gon is face II
    }
    if (distance) {
      o.distance_mm = t.OptionalNumber(row, *distance, Quantity::kDistance);
    }
    auto sigma = [&](std::optional<int> column, Quantity quantity, plausible::Unit unit) {
      if (!column) return std::numeric_limits<double>::quiet_NaN();
      const auto value = t.OptionalNumber(row, *column, quantity, unit);
      return value ? *value : std::numeric_limits<double>::quiet_NaN();
    };
    o.sigma_hz_rad = sigma(s_hz, Quantity::kSigmaAngle, plausible::kArcsec);
    o.sigma_v_rad = sigma(s_v, Quantity::kSigmaAngle, plausible::kArcsec);
    o.sigma_distance_mm = sigma(s_d, Quantity::kSigmaLength, plausible::kMm);
    o.source_line = row.line;
    o.source_station_column = station + 1;
    out.push_back(std::move(o));
  }
  if (out.empty()) throw InputError({path, 0, 0, ""}, "no observations (expected data rows)");
  return out;
}

namespace {

// Rotation matrices given in a file are accepted within this of orthonormal.
constexpr double kRotationTolerance = 1e-6;
// Control points closer than this are one point given twice (a µm is below any survey).
constexpr double kSameControlPositionMm = 1e-3;

// One station; `ids` holds the ids of the stations before it (duplicates are refused).
reduction::Station StationFrom(const YamlValue& value, std::set<std::string>& ids) {
  const YamlMap map =
      value.Map({"id", "position_mm", "azimuth_gon", "azimuth_deg", "azimuth_rad", "rotation",
                 "sigma_hz_arcsec", "sigma_v_arcsec", "sigma_position_mm", "sigma_azimuth_arcsec",
                 "sigma_rotation_arcsec", "orientation"});
  reduction::Station s;
  const YamlValue id = map.Required("id", "the station id");
  s.pose.id = id.Name();
  if (!ids.insert(s.pose.id).second) id.Fail("duplicate station id " + Quoted(s.pose.id));
  s.pose.position_mm =
      map.Required("position_mm", "[x, y, z] in mm").Vector3(plausible::Quantity::kCoordinate);

  std::optional<YamlValue> orientation;  // the key that oriented the station
  for (AngleUnit unit : {AngleUnit::kGon, AngleUnit::kDeg, AngleUnit::kRad}) {
    const std::string key = "azimuth" + std::string(AngleUnitSuffix(unit));
    if (const auto azimuth = map.Find(key)) {
      if (orientation) {
        azimuth->Fail("station " + s.pose.id +
                      ": give one of azimuth_gon, azimuth_deg, azimuth_rad");
      }
      s.pose.levelled = true;
      s.pose.azimuth_rad =
          ToRad(azimuth->Plausible(plausible::Quantity::kAngle, plausible::UnitOf(unit)), unit);
      s.pose.world_from_station = reduction::LevelledRotation(s.pose.azimuth_rad);
      orientation = azimuth;
    }
  }
  if (const auto rotation = map.Find("rotation")) {
    if (orientation) {
      rotation->Fail("station " + s.pose.id + ": give azimuth or rotation, not both");
    }
    const Eigen::Matrix3d m = rotation->Matrix(3, 3);
    if ((m.transpose() * m - Eigen::Matrix3d::Identity()).norm() > kRotationTolerance ||
        m.determinant() < 0) {
      rotation->Fail("station " + s.pose.id + ": expected a rotation (orthonormal, det +1)");
    }
    s.pose.world_from_station = m;
    s.pose.levelled = false;
    orientation = rotation;
  }
  if (!orientation) {
    map.Fail("station " + s.pose.id +
             ": expected azimuth_gon, azimuth_deg, azimuth_rad or rotation");
  }

  using plausible::Quantity;
  if (const auto v = map.Find("sigma_hz_arcsec"))
    s.sigma_hz_rad = v->Plausible(Quantity::kSigmaAngle, plausible::kArcsec) * kRadPerArcsec;
  if (const auto v = map.Find("sigma_v_arcsec"))
    s.sigma_v_rad = v->Plausible(Quantity::kSigmaAngle, plausible::kArcsec) * kRadPerArcsec;
  // The precision an orientation reported (FormatStationsYaml writes it).
  if (const auto v = map.Find("sigma_position_mm")) {
    s.sigma_position_mm = v->Vector3(Quantity::kLength);
    if (!(s.sigma_position_mm.minCoeff() >= 0)) v->Fail("expected sigmas ≥ 0");
  }
  if (const auto v = map.Find("sigma_azimuth_arcsec")) {
    s.sigma_azimuth_rad = v->NonNegativeNumber() * kRadPerArcsec;
  }
  if (const auto v = map.Find("sigma_rotation_arcsec")) {
    s.sigma_rotation_rad = v->Vector3() * kRadPerArcsec;
    if (!(s.sigma_rotation_rad.minCoeff() >= 0)) v->Fail("expected sigmas ≥ 0");
  }
  // The adjustment that oriented the station (FormatStationsYaml writes what orient found).
  if (const auto v = map.Find("orientation")) {
    const YamlMap o = v->Map({"sigma0", "dof", "method"});
    s.orientation_sigma0 = o.Required("sigma0", "σ0 a posteriori").NonNegativeNumber();
    if (const auto dof = o.Find("dof")) s.orientation_dof = dof->Integer(0, 1000000000);
    if (const auto method = o.Find("method")) s.orientation_method = method->Name();
  }
  return s;
}

}  // namespace

std::vector<reduction::Station> ParseStationsList(const YamlValue& list) {
  std::vector<reduction::Station> out;
  std::set<std::string> ids;
  for (const YamlValue& item : list.List(1)) out.push_back(StationFrom(item, ids));
  return out;
}

std::vector<reduction::Station> ParseStationsYaml(const std::string& text,
                                                  const std::string& source) {
  return YamlDocument::Parse(text, source).Read([](const YamlValue& root) {
    // Not a mapping: refused as "expected a mapping with stations" (what a file must have).
    const YamlMap map = root.IsMap() ? root.Map({"stations", "removed_observations"})
                                     : root.Map({"stations"});
    // What the orientation removed (FormatStationsYaml): checked, not needed to use the
    // stations.
    if (const auto removed = map.Find("removed_observations")) {
      for (const YamlValue& item : removed->List()) {
        const YamlMap r =
            item.Map({"station", "point", "kind", "error_arcsec", "error_mm", "w", "line"});
        r.Required("point", "the observation's point").Text();
        const std::string kind = r.Required("kind", "hz, v, distance, scale_bar or control").Name();
        if (kind != "hz" && kind != "v" && kind != "distance" && kind != "scale_bar" &&
            kind != "control")
          r.Required("kind", "").Fail("expected hz, v, distance, scale_bar or control");
        if (const auto w = r.Find("w")) w->Number();
      }
    }
    return ParseStationsList(map.Required("stations", "a list of stations"));
  });
}

std::vector<reduction::Station> ReadStationsYaml(const std::string& path) {
  return ParseStationsYaml(ReadWholeFile(path, kYamlFileLimit), path);
}

std::string KindKey(reduction::ResidualReport::Kind kind) {
  static const char* kKeys[] = {"hz", "v", "distance", "scale_bar", "control"};
  return kKeys[static_cast<int>(kind)];
}

std::string FormatStationsYaml(const std::vector<reduction::Station>& stations,
                               const std::string& header_comment,
                               const std::vector<reduction::RemovedObservation>& removed) {
  YAML::Emitter out;
  if (!header_comment.empty()) out << YAML::Comment(header_comment);
  out << YAML::BeginMap << YAML::Key << "stations" << YAML::Value << YAML::BeginSeq;
  auto vector = [&out](const Eigen::Vector3d& v, double scale) {
    out << YAML::Flow << YAML::BeginSeq;
    for (int k = 0; k < 3; ++k) out << YamlNumber(v(k) * scale);
    out << YAML::EndSeq;
  };
  for (const auto& s : stations) {
    out << YAML::BeginMap;
    out << YAML::Key << "id" << YAML::Value << YAML::DoubleQuoted << s.pose.id;
    out << YAML::Key << "position_mm" << YAML::Value;
    vector(s.pose.position_mm, 1.0);
    if (s.pose.levelled) {
      out << YAML::Key << "azimuth_gon" << YAML::Value
          << YamlNumber(FromRad(s.pose.azimuth_rad, AngleUnit::kGon));
    } else {
      const Eigen::Matrix3d& r = s.pose.world_from_station;
      out << YAML::Key << "rotation" << YAML::Value << YAML::Flow << YAML::BeginSeq;
      for (int i = 0; i < 3; ++i) vector(r.row(i).transpose(), 1.0);
      out << YAML::EndSeq;
    }
    if (s.sigma_hz_rad) {
      out << YAML::Key << "sigma_hz_arcsec" << YAML::Value
          << YamlNumber(*s.sigma_hz_rad / kRadPerArcsec);
    }
    if (s.sigma_v_rad) {
      out << YAML::Key << "sigma_v_arcsec" << YAML::Value
          << YamlNumber(*s.sigma_v_rad / kRadPerArcsec);
    }
    out << YAML::Key << "sigma_position_mm" << YAML::Value;
    vector(s.sigma_position_mm, 1.0);
    if (s.pose.levelled) {
      out << YAML::Key << "sigma_azimuth_arcsec" << YAML::Value
          << YamlNumber(s.sigma_azimuth_rad / kRadPerArcsec);
    } else {
      out << YAML::Key << "sigma_rotation_arcsec" << YAML::Value;
      vector(s.sigma_rotation_rad, 1.0 / kRadPerArcsec);
    }
    if (s.orientation_sigma0) {
      out << YAML::Key << "orientation" << YAML::Value << YAML::Flow << YAML::BeginMap;
      out << YAML::Key << "sigma0" << YAML::Value << YamlNumber(*s.orientation_sigma0);
      out << YAML::Key << "dof" << YAML::Value << s.orientation_dof;
      if (!s.orientation_method.empty())
        out << YAML::Key << "method" << YAML::Value << YAML::DoubleQuoted << s.orientation_method;
      out << YAML::EndMap;
    }
    out << YAML::EndMap;
  }
  out << YAML::EndSeq;
  if (!removed.empty()) {
    out << YAML::Key << "removed_observations" << YAML::Value << YAML::BeginSeq;
    for (const auto& r : removed) {
      using Kind = reduction::ResidualReport::Kind;
      const bool angle = r.kind == Kind::kHz || r.kind == Kind::kV;
      out << YAML::Flow << YAML::BeginMap;
      if (!r.station.empty())
        out << YAML::Key << "station" << YAML::Value << YAML::DoubleQuoted << r.station;
      out << YAML::Key << "point" << YAML::Value << YAML::DoubleQuoted << r.point;
      out << YAML::Key << "kind" << YAML::Value << KindKey(r.kind);
      out << YAML::Key << (angle ? "error_arcsec" : "error_mm") << YAML::Value
          << YamlNumber(r.error);
      out << YAML::Key << "w" << YAML::Value << YamlNumber(r.w);
      if (r.line > 0) out << YAML::Key << "line" << YAML::Value << r.line;
      out << YAML::EndMap;
    }
    out << YAML::EndSeq;
  }
  out << YAML::EndMap;
  return std::string(out.c_str()) + "\n";
}

std::vector<reduction::ControlPoint> ReadControlCsv(const std::string& path) {
  const CsvTable t = ReadCsvFile(path);
  t.RefuseUnreadUnits({"point", "x_mm", "y_mm", "z_mm", "sx_mm", "sy_mm", "sz_mm"});
  const int point = t.Column("point");
  const int x = t.Column("x_mm"), y = t.Column("y_mm"), z = t.Column("z_mm");
  const auto sx = t.FindColumn("sx_mm"), sy = t.FindColumn("sy_mm"), sz = t.FindColumn("sz_mm");
  const int sigma_columns = int{sx.has_value()} + int{sy.has_value()} + int{sz.has_value()};
  if (sigma_columns != 0 && sigma_columns != 3) {
    throw InputError({path, t.header_line(), 0, ""},
                     "give all of sx_mm, sy_mm, sz_mm (a weighted control point) or none");
  }
  std::vector<reduction::ControlPoint> out;
  std::map<std::string, int> line_of;  // id → its line
  for (const CsvRow& row : t.rows()) {
    reduction::ControlPoint c;
    c.id = t.Name(row, point);
    if (const auto [it, inserted] = line_of.emplace(c.id, row.line); !inserted) {
      throw InputError(t.Where(row, point), "duplicate control point " + Quoted(c.id) +
                                                " (first given on line " +
                                                std::to_string(it->second) + ")");
    }
    using plausible::Quantity;
    c.position_mm = {t.Number(row, x, Quantity::kCoordinate),
                     t.Number(row, y, Quantity::kCoordinate),
                     t.Number(row, z, Quantity::kCoordinate)};
    // Two control points cannot stand in one place: a copied row, not a survey.
    for (const auto& other : out) {
      if ((other.position_mm - c.position_mm).norm() < kSameControlPositionMm) {
        throw InputError(t.Where(row, x),
                         "control point " + Quoted(c.id) + " has the position of control point " +
                             Quoted(other.id) + " (line " + std::to_string(line_of.at(other.id)) +
                             "): expected distinct points");
      }
    }
    if (sx && sy && sz && !t.Text(row, *sx).empty()) {
      c.sigma_mm = Eigen::Vector3d(t.Number(row, *sx, Quantity::kSigmaLength),
                                   t.Number(row, *sy, Quantity::kSigmaLength),
                                   t.Number(row, *sz, Quantity::kSigmaLength));
    }
    out.push_back(std::move(c));
  }
  if (out.empty()) throw InputError({path, 0, 0, ""}, "no control points");
  return out;
}

reduction::ScaleBar ParseScaleBar(const std::string& text, double sigma_mm) {
  const SourceLocation where{"--scale-bar", 0, 0, ""};
  const size_t colon = text.find(':'), equals = text.find('=');
  if (colon == std::string::npos || equals == std::string::npos || colon > equals || colon == 0 ||
      equals == colon + 1) {
    throw InputError(where, Quoted(text) + ": expected A:B=LEN_MM, e.g. 1008:1180=1720.0");
  }
  reduction::ScaleBar bar;
  bar.from = text.substr(0, colon);
  bar.to = text.substr(colon + 1, equals - colon - 1);
  for (const std::string* end : {&bar.from, &bar.to}) {
    if (auto why = plausible::CheckName(*end)) {
      throw InputError(where, Quoted(text) + ": point " + Quoted(*end) + ": " + *why);
    }
  }
  if (bar.from == bar.to) {
    // A length from a point to itself measures nothing (and gave Ceres one parameter
    // block twice, which it answers with an abort).
    throw InputError(where, Quoted(text) + ": both ends are point " + Quoted(bar.from) +
                                ": expected two different points");
  }
  const auto length = ParseNumber(text.substr(equals + 1));
  if (!length || !(*length > 0) || !plausible::IsPlausible(plausible::Quantity::kLength, *length)) {
    throw InputError(where, Quoted(text) + ": expected a positive length in mm (at most 1 km)");
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
    if (!r.status.ok()) {
      out += fmt::format(",,,,{},,,,,,,,,,,,,{}: {}\n", r.rays.size(), ToString(r.flags),
                         CsvEscape(r.status.message));
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
        r.flags.empty() ? std::string("ok") : ToString(r.flags));
  }
  return out;
}

}  // namespace armsig::io
