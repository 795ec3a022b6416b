// Network files (docs/reference/file-formats.md): angle observations CSV, stations YAML,
// control points CSV, scale bars ("A:B=LEN_MM"). Readers throw InputError with file, line
// and column.
#pragma once

#include <string>
#include <vector>

#include "io/csv.h"
#include "io/yaml_reader.h"
#include "reduction/intersection.h"
#include "reduction/network.h"
#include "reduction/orientation.h"

namespace armsig::io {

// point,station,hz_*,v_*[,face,distance_mm,sigma_hz_arcsec,sigma_v_arcsec,sigma_distance_mm].
// V > 200 gon without a face column is face II (docs/reference/conventions.md). Read row by
// row (io::CsvReader): the memory is the observations'. `pose_labels`: each row's `pose`
// column (a name), when the file has one; else left empty.
std::vector<reduction::Observation> ReadObservationsCsv(
    const std::string& path, std::vector<std::string>* pose_labels = nullptr,
    ReadProgressFn progress = nullptr);

// stations: [{id, position_mm, azimuth_* | rotation, sigma_hz_arcsec?, sigma_v_arcsec?,
//             sigma_position_mm?, sigma_azimuth_arcsec? | sigma_rotation_arcsec?}]
// The one stations reader: a stations file and a lab file's `stations:` go through
// ParseStationsList, so both refuse the same things (unknown keys, duplicate ids, a
// rotation that is not one, azimuth and rotation together, an empty list).
std::vector<reduction::Station> ReadStationsYaml(const std::string& path);
std::vector<reduction::Station> ParseStationsYaml(const std::string& text,
                                                  const std::string& source);
std::vector<reduction::Station> ParseStationsList(const YamlValue& list);
// Written with YAML::Emitter; ReadStationsYaml reads it back to the same doubles. The
// observations data snooping removed from the orientation follow the stations as
// `removed_observations: [{station, point, kind, error_arcsec | error_mm, w, line}]`
// (kind hz, v, distance, scale_bar or control; a scale bar's point is "A:B").
std::string FormatStationsYaml(const std::vector<reduction::Station>& stations,
                               const std::string& header_comment,
                               const std::vector<reduction::RemovedObservation>& removed = {});
// "hz", "v", "distance", "scale_bar", "control": the kind's key in files.
std::string KindKey(reduction::ResidualReport::Kind kind);

// point,x_mm,y_mm,z_mm[,sx_mm,sy_mm,sz_mm] (sigmas make the point weighted, else fixed).
std::vector<reduction::ControlPoint> ReadControlCsv(const std::string& path);

// "A:B=1720.0" (sigma from the caller).
reduction::ScaleBar ParseScaleBar(const std::string& text, double sigma_mm);

// One intersected point per row of POINTS.csv.
struct TriangulatedPoint {
  std::string id;
  reduction::IntersectionResult result;
  std::vector<int> observations;  // indices into the observation list, in ray order
};
std::string FormatPointsCsv(const std::vector<TriangulatedPoint>& points);

}  // namespace armsig::io
