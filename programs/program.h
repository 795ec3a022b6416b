// A robot program as the compensation sees it: its files, the targets its motions reach
// (each with the numbers that write it and where those numbers are), the motions with the
// tool and base they use, and the motion targets it could not evaluate. One parser per
// language builds it (programs/urscript.h, krl.h, rapid.h); programs/compensation.h changes
// the targets' numbers and nothing else. Pure text and geometry: no files are read here.
//
// Units inside: mm and rad. The numbers keep the file's own units (m for URScript, mm for
// KRL and RAPID; rad for URScript joints and rotation vectors, degrees for KRL and RAPID).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <cstddef>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace armsig::programs {

enum class Language { kUrScript, kKrl, kRapid };
const char* ToString(Language language);

// One text of a program: a .script; a .src and its .dat; a .mod.
struct ProgramFile {
  std::string name;  // for messages (the path as given)
  std::string text;
};

// A place in a program: files[file], 1-based line.
struct TextPlace {
  int file = 0;
  int line = 0;
};

// One number of a target as written: bytes [begin, end) of its file (the sign included).
struct NumberField {
  std::size_t begin = 0, end = 0;
  std::string text;    // as written
  double value = 0.0;  // in the file's unit
};

enum class TargetKind { kPose, kJoints };
const char* ToString(TargetKind kind);

// How a target's numbers are laid out, one layout per literal form of the three languages.
enum class Layout {
  kUrPose,       // x y z (m), rx ry rz: rotation vector (rad)
  kUrJoints,     // q1…qn (rad)
  kKrlFrame,     // X Y Z (mm), A B C (deg): R = Rz(A)·Ry(B)·Rx(C)
  kKrlAxis,      // A1…An (deg)
  kRapidPose,    // x y z (mm), q1 q2 q3 q4: unit quaternion (w, x, y, z)
  kRapidJoints,  // rax_1…rax_n (deg)
};
TargetKind KindOf(Layout layout);

// What a target says about the arm's configuration (the solution the controller picks).
struct StatedConfiguration {
  std::optional<int> kuka_status, kuka_turn;  // KRL E6POS / POS: S and T
  std::optional<std::array<int, 4>> abb_cf;   // RAPID robtarget: cf1, cf4, cf6, cfx
  // URScript: the joints the controller starts its solution from (get_inverse_kin's qnear,
  // a waypoint's q): the index of a kJoints target of the same program.
  std::optional<int> near_target;
};

struct Target {
  Layout layout = Layout::kUrPose;
  std::string name;  // the variable; empty for a literal written in the motion itself
  TextPlace place;   // where its numbers are written
  std::vector<NumberField> fields;  // in the layout's order
  StatedConfiguration config;
  TargetKind kind() const { return KindOf(layout); }
};

// A tool (the flange to the TCP) or a base (the robot's base frame to the frame a pose
// target is written in), as the program states it: a transform when the program (or the
// controller data given with it) defines it, otherwise why not.
struct FrameRef {
  std::optional<Eigen::Isometry3d> transform;  // mm
  std::string name;                            // "tool0", "TOOL_DATA[1]", "set_tcp (line 3)"
  std::string unknown_why;                     // when transform is empty
  bool known() const { return transform.has_value(); }
};

enum class MotionType { kJoint, kLinear, kCircular, kProcess };

struct Motion {
  TextPlace place;
  std::string instruction;  // as written: "movej", "PTP", "MoveL"
  MotionType type = MotionType::kJoint;
  // Indices into Program::targets: the end point last (a circular motion's via point first).
  std::vector<int> targets;
  FrameRef tool, base;
  std::string routine;  // the PROC / DEF / def it is in, as written ("" outside any)
};

// A place the parser names instead of guessing: a motion target behind an expression it
// cannot evaluate, or a target whose use it cannot tie to one tool and base.
struct NamedPlace {
  TextPlace place;
  std::string why;
};

// A fixed wait the program makes where it stands (RAPID WaitTime t; KRL WAIT SEC t), a number
// literal of seconds: what a virtual controller runs between the motions (the arm stands).
struct Wait {
  TextPlace place;
  double seconds = 0.0;
  std::string routine;  // the PROC / DEF it is in
};

struct Program {
  Language language = Language::kUrScript;
  std::vector<ProgramFile> files;
  std::vector<Target> targets;
  std::vector<Motion> motions;             // in file order
  std::vector<Wait> waits;                 // in file order (RAPID and KRL; the .src's)
  std::vector<NamedPlace> not_evaluated;   // motion targets left as they are, and why
  std::vector<NamedPlace> notes;           // what else a reader should know (an open fold, …)
};

// "file:line" of a place.
std::string Where(const Program& program, const TextPlace& place);

// ---- Values of a target ----

// The pose a kPose target writes (mm), in its base frame, of its tool's TCP.
Eigen::Isometry3d PoseOf(const Target& target);
// The joints a kJoints target writes (rad).
Eigen::VectorXd JointsOf(const Target& target);

// A replacement of bytes [begin, end) of files[file].
struct Edit {
  int file = 0;
  std::size_t begin = 0, end = 0;
  std::string text;
};

// The edits that write `pose` (mm) into a kPose target's numbers, or `joints` (rad) into a
// kJoints target's. Each number keeps the way it was written (leading zero, decimals: as
// many as it had, at least the unit's resolution: 1 nm, 1e-9 rad, 0.1 µm, 1e-5°); a number
// whose new value rounds to the old one at its own written precision is left as it is. A
// rotation is written in the representation nearest the one written (rotation vector of
// the nearer turn, quaternion of the same sign, A B C of the nearer branch).
std::vector<Edit> RewritePose(const Target& target, const Eigen::Isometry3d& pose);
std::vector<Edit> RewriteJoints(const Target& target, const Eigen::VectorXd& joints_rad);

// The files with the edits applied (edits of one file must not overlap: std::logic_error).
std::vector<std::string> ApplyEdits(const std::vector<ProgramFile>& files, std::vector<Edit> edits);

// `value` written like `original` (a number literal as it stands in a file, sign included)
// with at least `min_decimals` decimals, or `original` itself when `value` rounds to it.
std::string FormatLike(std::string_view original, double value, int min_decimals);

// ---- Rotation forms of the three languages ----

// KUKA A, B, C (rad): R = Rz(A)·Ry(B)·Rx(C); and back, the triple nearest `near` (rad)
// among the equivalent ones (±2π, and the other branch A+π, π−B, C+π).
Eigen::Matrix3d RotationFromKukaAbc(const Eigen::Vector3d& abc_rad);
Eigen::Vector3d KukaAbcFromRotation(const Eigen::Matrix3d& rotation, const Eigen::Vector3d& near_rad);
// A rotation vector (axis · angle) nearest `near` among r and r·(1 − 2π/|r|).
Eigen::Vector3d RotationVectorNear(const Eigen::Matrix3d& rotation, const Eigen::Vector3d& near);

}  // namespace armsig::programs
