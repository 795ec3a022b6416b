// Poses (docs/reference/file-formats.md): pose,q1_deg,…,qn_deg,x_mm,y_mm,z_mm (any angle
// unit suffix, extra columns ignored) with the measured orientation rx_deg,ry_deg,rz_deg and
// its sigmas sigma_rx_arcsec,… when the target is a 6-DoF probe, and the import of foreign pose tables such as the
// IPA UR10 laser-tracker files (';', decimal comma, named columns).
#pragma once

#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "core/types.h"
#include "core/units.h"
#include "io/csv.h"

namespace armsig::io {

// The columns of a poses CSV: q1…qn, then the measured orientation rx, ry, rz
// (core/rotation.h) and its sigmas when the poses have them.
struct PosesCsvLayout {
  int num_joints = 0;
  bool orientation = false;         // rx_deg,ry_deg,rz_deg
  bool orientation_sigmas = false;  // sigma_rx_arcsec,sigma_ry_arcsec,sigma_rz_arcsec
};
// The most poses a command holds in memory to fit them (`calibrate --poses`, `--validate`):
// the fit's Jacobian alone takes 3 rows of 6n+3+k doubles per pose (1 kB for a six-joint
// robot), the solver several times that. A longer file is refused at the row past it,
// before the memory runs out; `import poses` streams a file of any length into the store.
inline constexpr int kMaxPosesInMemory = 100000;

// Reads poses for a robot of `num_joints` joints (−1: as many as the header's q1, q2, …
// columns), with their orientation where the file has rx, ry, rz (all three columns or
// none; in a row all three angles or none, and their sigmas likewise), row by row (CsvReader), each pose handed to `sink` as it is read (with its
// line): memory for
// one row and 16 bytes per row for the check that ids are unique (made when the file has
// been read: a repeated id then throws, and the caller drops what `sink` kept). Throws
// InputError (file, line, column) for a missing column, a malformed number, a duplicate
// pose id, or no rows.
// `joint_unit`: what the caller was told the joints are in; a q column whose suffix says
// otherwise is refused (InputError naming the column), never read in another unit.
// `layout`, when given, is set to the file's columns once its header is read (before the
// first pose reaches `sink`): a copy written row by row keeps them.
void ReadPosesStreamed(const std::string& path, int num_joints, std::optional<AngleUnit> joint_unit,
                       const std::function<void(const MeasuredPose&, int line)>& sink,
                       ReadProgressFn progress = nullptr, PosesCsvLayout* layout = nullptr);
// The same into memory, at most kMaxPosesInMemory poses (InputError at the row past it).
std::vector<MeasuredPose> ReadPosesCsv(const std::string& path, int num_joints,
                                       std::optional<AngleUnit> joint_unit = std::nullopt,
                                       ReadProgressFn progress = nullptr);

// The layout that holds every pose: `num_joints` q columns (−1: as many as the first pose
// has), orientation columns when a pose has an orientation, sigma columns when one has them.
PosesCsvLayout PosesCsvLayoutOf(const std::vector<MeasuredPose>& poses, int num_joints = -1);

// Writes the poses CSV (angles in degrees, full precision; sigmas in arc seconds). A pose
// without orientation in a file with orientation columns leaves them empty. `num_joints`: the q
// columns of the header (−1: as many as the first pose has), so that a file without a
// pose still has the full header.
std::string FormatPosesCsv(const std::vector<MeasuredPose>& poses, int num_joints = -1);
// Its header line and one row (both ending in a newline), for a file written row by row.
std::string PosesCsvHeader(const PosesCsvLayout& layout);
std::string PosesCsvRow(const MeasuredPose& pose, const PosesCsvLayout& layout);

struct PoseImportOptions {
  char delimiter = '\0';  // ',', ';' or '\t'; '\0' = detect (io/csv.h)
  // Decimal commas are read whenever the delimiter is ';' or tab (the one CSV rule);
  // true only asserts it: a comma-separated file is then refused.
  bool decimal_comma = false;
  std::vector<std::string> joint_columns;  // in joint order
  // The joint columns' unit. A column whose name ends in _deg, _gon or _rad is read in that
  // unit; a joint_unit that contradicts it is refused, never applied. Columns without a
  // suffix are read in joint_unit, else in rad.
  std::optional<AngleUnit> joint_unit;
  std::vector<std::string> xyz_columns;  // measured target x, y, z
  double length_scale_to_mm = 1.0;       // e.g. 1000 for metres
  // Optional: the target's measured orientation as the angles rx, ry, rz of
  // core/rotation.h (three columns or none), in `rotation_unit` unless a column's name has a
  // unit suffix, and their standard deviations (three columns or none, in the same unit
  // as their angles).
  std::vector<std::string> rotation_columns, rotation_sigma_columns;
  std::optional<AngleUnit> rotation_unit;
  std::string id_column;                 // empty = row number
  // Preset for the IPA UR10 laser-tracker CSVs (../shared/data/ur10-ipa).
  static PoseImportOptions UrIpa();
};

// A foreign pose table read row by row, as ReadPosesStreamed. Throws InputError as
// ImportPoses.
void ImportPosesStreamed(const std::string& path, const PoseImportOptions& options,
                         const std::function<void(const MeasuredPose&, int line)>& sink,
                         ReadProgressFn progress = nullptr, PosesCsvLayout* layout = nullptr);
// The whole table in memory.
std::vector<MeasuredPose> ImportPoses(const std::string& path, const PoseImportOptions& options);

}  // namespace armsig::io
