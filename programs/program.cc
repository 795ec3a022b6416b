#include "programs/program.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <stdexcept>

#include "core/units.h"

namespace armsig::programs {

const char* ToString(Language language) {
  switch (language) {
    case Language::kUrScript:
      return "URScript";
    case Language::kKrl:
      return "KRL";
    case Language::kRapid:
      return "RAPID";
  }
  return "?";
}

const char* ToString(TargetKind kind) { return kind == TargetKind::kPose ? "pose" : "joints"; }

TargetKind KindOf(Layout layout) {
  switch (layout) {
    case Layout::kUrPose:
    case Layout::kKrlFrame:
    case Layout::kRapidPose:
      return TargetKind::kPose;
    case Layout::kUrJoints:
    case Layout::kKrlAxis:
    case Layout::kRapidJoints:
      break;
  }
  return TargetKind::kJoints;
}

std::string Where(const Program& program, const TextPlace& place) {
  const std::string& name =
      place.file >= 0 && place.file < static_cast<int>(program.files.size())
          ? program.files[place.file].name
          : std::string("?");
  return fmt::format("{}:{}", name, place.line);
}

namespace {

double Field(const Target& t, int i) { return t.fields.at(static_cast<std::size_t>(i)).value; }

void RequireFields(const Target& t, std::size_t count) {
  if (t.fields.size() != count)
    throw std::logic_error(fmt::format("target {} has {} numbers, its layout {}", t.name,
                                       t.fields.size(), count));
}

Eigen::Matrix3d RotationOfVector(const Eigen::Vector3d& r) {
  const double angle = r.norm();
  if (angle < 1e-300) return Eigen::Matrix3d::Identity();
  return Eigen::AngleAxisd(angle, r / angle).toRotationMatrix();
}

// Decimals written after the point (before an exponent), and whether the number is
// written with an exponent.
struct WrittenStyle {
  int decimals = 0;
  bool exponent = false;
  bool bare_point = false;  // ".5", "-.5": no zero before the point
  bool plus = false;        // "+5"
};

WrittenStyle StyleOf(std::string_view text) {
  WrittenStyle s;
  std::size_t i = 0;
  while (i < text.size() && (text[i] == '+' || text[i] == '-' || text[i] == ' ' || text[i] == '\t')) {
    if (text[i] == '+') s.plus = true;
    ++i;
  }
  s.bare_point = i < text.size() && text[i] == '.';
  const std::size_t point = text.find('.', i);
  const std::size_t exp = text.find_first_of("eE", i);
  s.exponent = exp != std::string_view::npos;
  if (point != std::string_view::npos && (exp == std::string_view::npos || point < exp)) {
    const std::size_t end = exp == std::string_view::npos ? text.size() : exp;
    s.decimals = static_cast<int>(end - point - 1);
  }
  return s;
}

double ValueOf(std::string_view text) {
  std::string compact;
  for (char c : text)
    if (c != ' ' && c != '\t') compact += c;
  return std::strtod(compact.c_str(), nullptr);
}

// Minimum decimals of the numbers of each layout (the unit's resolution).
constexpr int kMetreDecimals = 9;      // 1 nm
constexpr int kRadianDecimals = 9;     // 1e-9 rad
constexpr int kMillimetreDecimals = 4; // 0.1 µm
constexpr int kDegreeDecimals = 5;     // 1e-5° = 0.17 µrad
constexpr int kQuaternionDecimals = 9;

void Push(std::vector<Edit>& edits, const Target& t, int i, double value, int min_decimals) {
  const NumberField& f = t.fields.at(static_cast<std::size_t>(i));
  std::string text = FormatLike(f.text, value, min_decimals);
  if (text != f.text) edits.push_back({t.place.file, f.begin, f.end, std::move(text)});
}

}  // namespace

std::string FormatLike(std::string_view original, double value, int min_decimals) {
  const WrittenStyle style = StyleOf(original);
  const double old = ValueOf(original);
  const int decimals = std::max(style.decimals, min_decimals);
  if (fmt::format("{:.{}f}", value, decimals) == fmt::format("{:.{}f}", old, decimals))
    return std::string(original);
  std::string s = fmt::format("{:.{}f}", value, decimals);
  // Trailing zeros beyond what the original wrote.
  const std::size_t point = s.find('.');
  if (point != std::string::npos) {
    const std::size_t keep = point + 1 + static_cast<std::size_t>(style.decimals);
    while (s.size() > keep && s.back() == '0') s.pop_back();
    if (s.back() == '.') s.pop_back();
  }
  if (s.find_first_not_of("-0.") == std::string::npos && s[0] == '-') s.erase(0, 1);  // no -0
  if (style.bare_point) {
    if (s.rfind("0.", 0) == 0) s.erase(0, 1);
    else if (s.rfind("-0.", 0) == 0) s.erase(1, 1);
  }
  if (style.plus && s[0] != '-') s = "+" + s;
  return s;
}

Eigen::Matrix3d RotationFromKukaAbc(const Eigen::Vector3d& abc) {
  return (Eigen::AngleAxisd(abc.x(), Eigen::Vector3d::UnitZ()) *
          Eigen::AngleAxisd(abc.y(), Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(abc.z(), Eigen::Vector3d::UnitX()))
      .toRotationMatrix();
}

Eigen::Vector3d KukaAbcFromRotation(const Eigen::Matrix3d& r, const Eigen::Vector3d& near) {
  // R = Rz(A)·Ry(B)·Rx(C): r20 = −sin B, r21 = cos B sin C, r22 = cos B cos C,
  // r10 = sin A cos B, r00 = cos A cos B.
  const double b = std::atan2(-r(2, 0), std::hypot(r(0, 0), r(1, 0)));
  double a, c;
  if (std::hypot(r(0, 0), r(1, 0)) > 1e-9) {
    a = std::atan2(r(1, 0), r(0, 0));
    c = std::atan2(r(2, 1), r(2, 2));
  } else {  // gimbal lock: only A ∓ C is defined; keep A where it was
    a = near.x();
    const Eigen::Matrix3d rest = Eigen::AngleAxisd(-a, Eigen::Vector3d::UnitZ()) * r;
    c = std::atan2(-rest(1, 2), rest(1, 1));
  }
  const Eigen::Vector3d candidates[2] = {{a, b, c}, {a + kPi, kPi - b, c + kPi}};
  Eigen::Vector3d best = candidates[0];
  double best_distance = INFINITY;
  for (Eigen::Vector3d v : candidates) {
    for (int k = 0; k < 3; ++k) v(k) = near(k) + WrapPi(v(k) - near(k));
    const double d = (v - near).norm();
    if (d < best_distance) {
      best_distance = d;
      best = v;
    }
  }
  return best;
}

Eigen::Vector3d RotationVectorNear(const Eigen::Matrix3d& rotation, const Eigen::Vector3d& near) {
  const Eigen::AngleAxisd aa(rotation);
  const Eigen::Vector3d r = aa.angle() * aa.axis();
  const double angle = r.norm();
  if (angle < 1e-12) {
    // The identity: 0, or a full turn about the direction written.
    const double n = near.norm();
    if (n > kPi && n > 1e-12) return near / n * (2 * kPi);
    return Eigen::Vector3d::Zero();
  }
  const Eigen::Vector3d other = r * (1.0 - 2 * kPi / angle);
  return (other - near).norm() < (r - near).norm() ? other : r;
}

Eigen::Isometry3d PoseOf(const Target& t) {
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  switch (t.layout) {
    case Layout::kUrPose:
      RequireFields(t, 6);
      pose.translation() = 1000.0 * Eigen::Vector3d(Field(t, 0), Field(t, 1), Field(t, 2));
      pose.linear() = RotationOfVector({Field(t, 3), Field(t, 4), Field(t, 5)});
      return pose;
    case Layout::kKrlFrame:
      RequireFields(t, 6);
      pose.translation() = Eigen::Vector3d(Field(t, 0), Field(t, 1), Field(t, 2));
      pose.linear() = RotationFromKukaAbc(
          Eigen::Vector3d(Field(t, 3), Field(t, 4), Field(t, 5)) * kRadPerDeg);
      return pose;
    case Layout::kRapidPose: {
      RequireFields(t, 7);
      pose.translation() = Eigen::Vector3d(Field(t, 0), Field(t, 1), Field(t, 2));
      Eigen::Quaterniond q(Field(t, 3), Field(t, 4), Field(t, 5), Field(t, 6));
      if (!(q.norm() > 1e-12)) q = Eigen::Quaterniond::Identity();
      pose.linear() = q.normalized().toRotationMatrix();
      return pose;
    }
    default:
      throw std::logic_error("PoseOf: a joint target");
  }
}

Eigen::VectorXd JointsOf(const Target& t) {
  if (t.kind() != TargetKind::kJoints) throw std::logic_error("JointsOf: a pose target");
  Eigen::VectorXd q(static_cast<Eigen::Index>(t.fields.size()));
  const double scale = t.layout == Layout::kUrJoints ? 1.0 : kRadPerDeg;
  for (std::size_t i = 0; i < t.fields.size(); ++i) q(static_cast<Eigen::Index>(i)) = t.fields[i].value * scale;
  return q;
}

std::vector<Edit> RewritePose(const Target& t, const Eigen::Isometry3d& pose) {
  std::vector<Edit> edits;
  const Eigen::Vector3d x = pose.translation();
  switch (t.layout) {
    case Layout::kUrPose: {
      RequireFields(t, 6);
      for (int k = 0; k < 3; ++k) Push(edits, t, k, x(k) / 1000.0, kMetreDecimals);
      const Eigen::Vector3d r =
          RotationVectorNear(pose.linear(), {Field(t, 3), Field(t, 4), Field(t, 5)});
      for (int k = 0; k < 3; ++k) Push(edits, t, 3 + k, r(k), kRadianDecimals);
      break;
    }
    case Layout::kKrlFrame: {
      RequireFields(t, 6);
      for (int k = 0; k < 3; ++k) Push(edits, t, k, x(k), kMillimetreDecimals);
      const Eigen::Vector3d abc =
          KukaAbcFromRotation(pose.linear(),
                              Eigen::Vector3d(Field(t, 3), Field(t, 4), Field(t, 5)) * kRadPerDeg) /
          kRadPerDeg;
      for (int k = 0; k < 3; ++k) Push(edits, t, 3 + k, abc(k), kDegreeDecimals);
      break;
    }
    case Layout::kRapidPose: {
      RequireFields(t, 7);
      for (int k = 0; k < 3; ++k) Push(edits, t, k, x(k), kMillimetreDecimals);
      Eigen::Quaterniond q(pose.linear());
      const Eigen::Vector4d old(Field(t, 3), Field(t, 4), Field(t, 5), Field(t, 6));
      Eigen::Vector4d v(q.w(), q.x(), q.y(), q.z());
      if (v.dot(old) < 0) v = -v;
      for (int k = 0; k < 4; ++k) Push(edits, t, 3 + k, v(k), kQuaternionDecimals);
      break;
    }
    default:
      throw std::logic_error("RewritePose: a joint target");
  }
  return edits;
}

std::vector<Edit> RewriteJoints(const Target& t, const Eigen::VectorXd& joints_rad) {
  if (t.kind() != TargetKind::kJoints) throw std::logic_error("RewriteJoints: a pose target");
  RequireFields(t, static_cast<std::size_t>(joints_rad.size()));
  std::vector<Edit> edits;
  const bool radians = t.layout == Layout::kUrJoints;
  for (int k = 0; k < joints_rad.size(); ++k) {
    Push(edits, t, k, radians ? joints_rad(k) : joints_rad(k) / kRadPerDeg,
         radians ? kRadianDecimals : kDegreeDecimals);
  }
  return edits;
}

std::vector<std::string> ApplyEdits(const std::vector<ProgramFile>& files, std::vector<Edit> edits) {
  std::sort(edits.begin(), edits.end(), [](const Edit& a, const Edit& b) {
    return a.file != b.file ? a.file < b.file : a.begin < b.begin;
  });
  std::vector<std::string> out;
  out.reserve(files.size());
  std::size_t e = 0;
  for (int f = 0; f < static_cast<int>(files.size()); ++f) {
    const std::string& text = files[static_cast<std::size_t>(f)].text;
    std::string result;
    result.reserve(text.size() + 64);
    std::size_t at = 0;
    for (; e < edits.size() && edits[e].file == f; ++e) {
      const Edit& edit = edits[e];
      if (edit.begin < at || edit.end < edit.begin || edit.end > text.size())
        throw std::logic_error(fmt::format("overlapping or misplaced edit at byte {} of {}",
                                           edit.begin, files[static_cast<std::size_t>(f)].name));
      result.append(text, at, edit.begin - at);
      result += edit.text;
      at = edit.end;
    }
    result.append(text, at, std::string::npos);
    out.push_back(std::move(result));
  }
  if (e != edits.size()) throw std::logic_error("an edit names a file the program does not have");
  return out;
}

}  // namespace armsig::programs
