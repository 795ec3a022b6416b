// Why does a signature fitted on the UR10's series C lose accuracy on series B? An exploration
// program (not a benchmark) over the library as it is: each suspect is measured on its own.
//   - the set-up: how far B's measuring frame is from C's, and what placing it from 30 B poses
//     costs against placing it from all of them;
//   - the tool: whether the probe sits elsewhere on the flange in B;
//   - temperature: the series' logged temperatures, and the scale a rigid-plus-scale fit finds;
//   - extrapolation: B's configurations against C's (joint ranges, arm branches, the distance
//     to the nearest C configuration) and the error as a function of it;
//   - the map's support: B poses inside and outside it, and what the map does in each.
// Series B is read from ../shared/data/ur10-ipa (argument 1) unless tests/data has it.
//
// Usage: transfer_explore [joint | ten | smooth | weight | family] [SERIES_B.csv]
//   joint: the nightly path only; ten: 10 and 30 placing poses with and without their
//   orientations; smooth: the map cut at its support or applied everywhere, on B and D;
//   weight: fixed orientation weights against variance components, on B and D; family:
//   --params auto among every generated term or without the harmonics, on B and D.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <random>
#include <string>
#include <vector>

#include "calibration/compensation.h"
#include "calibration/estimation.h"
#include "calibration/residual_map.h"
#include "io/csv.h"
#include "io/model_yaml.h"
#include "io/poses_csv.h"

using namespace armsig;
using namespace armsig::calibration;

namespace {

const std::string kSource = ARMSIG_SOURCE_DIR;

struct Series {
  std::string name;
  std::vector<MeasuredPose> poses;
  std::vector<double> temperature_c;
};

// Positions only unless `orientation` (the T-Mac's measured orientations kept).
Series Load(const std::string& name, const std::string& path, bool orientation = false) {
  Series s;
  s.name = name;
  s.poses = io::ImportPoses(path, io::PoseImportOptions::UrIpa());
  if (!orientation) {
    for (auto& p : s.poses) p.orientation.reset();
  }
  io::CsvReader table(path);
  const int t = table.Column("measurement_temperature");
  for (io::CsvRow row; table.Next(row);) s.temperature_c.push_back(table.Number(row, t));
  return s;
}

std::vector<Eigen::VectorXd> JointsOf(const std::vector<MeasuredPose>& poses) {
  std::vector<Eigen::VectorXd> q;
  for (const auto& p : poses) q.push_back(p.joints_rad);
  return q;
}

// Error distances of the predictions (parametric, with the map where it applies).
struct Errors {
  std::vector<double> distance;
  std::vector<char> outside;  // the map exists and this pose is outside its support
  double Mean() const {
    double s = 0;
    for (double d : distance) s += d;
    return distance.empty() ? 0 : s / distance.size();
  }
};
Errors Evaluate(const RobotModel& model, const Eigen::Isometry3d& base, const Eigen::VectorXd& params,
                const ResidualMap* map, const std::vector<MeasuredPose>& poses) {
  const auto predicted = PredictPositions(model, base, params, map, JointsOf(poses));
  Errors e;
  for (size_t i = 0; i < poses.size(); ++i) {
    e.distance.push_back((predicted[i].position_mm - poses[i].target_in_world).norm());
    e.outside.push_back(predicted[i].extrapolated);
  }
  return e;
}

// A fitted signature: parameters, base, and the map (used or not).
// `count` rows spread through a file of n: ⌊(k + ½)·n/count⌋, k = 0…count−1 (or its first
// `count` rows: one line of the robot).
std::vector<char> Placing(int n, int count, bool first_rows = false) {
  std::vector<char> in(n, 0);
  for (int k = 0; k < count; ++k) in[first_rows ? k : static_cast<int>((k + 0.5) * n / count)] = 1;
  return in;
}

// The nightly path's two sessions: C's poses (frame 1) and the poses of `x` marked in
// `placing` (frame 2, the new set-up) to fit on; x's other poses to evaluate on.
struct Placed {
  std::vector<MeasuredPose> fit, rest;
};
Placed PlaceOn(const Series& c, const Series& x, const std::vector<char>& placing) {
  Placed out;
  out.fit = c.poses;
  for (auto& p : out.fit) p.frame = 1;
  for (size_t i = 0; i < x.poses.size(); ++i) {
    if (!placing[i]) {
      out.rest.push_back(x.poses[i]);
      continue;
    }
    MeasuredPose p = x.poses[i];
    p.frame = 2;
    out.fit.push_back(p);
  }
  return out;
}

struct Signature {
  std::string label;
  EstimationResult fit;
  ResidualMapFit map_fit;
  std::optional<ResidualMap> map;
};

Signature Fit(const RobotModel& model, const std::vector<MeasuredPose>& poses, const std::string& spec,
              bool with_map) {
  Signature s;
  s.label = spec;
  EstimationOptions o;
  o.parameters = ParseParameterSpec(model, spec == "auto" ? "all" : spec);
  if (spec == "auto") o.parameters = SelectTerms(model, poses, o).parameters;
  s.fit = Estimate(model, poses, o);
  if (with_map) {
    s.map_fit = FitResidualMap(model, s.fit, poses);
    if (s.map_fit.used) s.map.emplace(s.map_fit.map);
  }
  return s;
}

void PrintBaseDifference(const char* what, const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  const Eigen::Isometry3d d = a.inverse() * b;
  std::printf("  %s: translation %.3f mm, rotation %.4f mrad\n", what, d.translation().norm(),
              Eigen::AngleAxisd(d.linear()).angle() * 1e3);
}

// The smallest joint-space distance (rad, joints 1-5, angles wrapped) from q to any of `set`.
double NearestDistance(const Eigen::VectorXd& q, const std::vector<MeasuredPose>& set) {
  double best = 1e300;
  for (const auto& p : set) {
    double d2 = 0;
    for (int j = 0; j < 5; ++j) {
      const double d = std::remainder(q(j) - p.joints_rad(j), 2 * kPi);
      d2 += d * d;
    }
    best = std::min(best, d2);
  }
  return std::sqrt(best);
}

const char* Branch(const Eigen::VectorXd& q) {
  // Elbow (q3) and wrist (q5) signs: C has q3 ≥ 0 and q5 ≥ 0 throughout.
  static const char* names[4] = {"q3>=0 q5>=0", "q3>=0 q5<0", "q3<0 q5>=0", "q3<0 q5<0"};
  return names[(q(2) < 0) * 2 + (q(4) < 0)];
}

}  // namespace

// The nightly path only (C and the placing poses fitted together), positions only and with
// the measured orientations, for 30 and 10 placing poses of each layout.
int JointFits(const RobotModel& model, const std::string& b_path) {
  const std::string c_path = kSource + "/tests/data/ur10-ipa/series_C-measurements_random_poses.csv";
  for (bool orientation : {false, true}) {
    const Series c = Load("C", c_path, orientation), b = Load("B", b_path, orientation);
    const int n = static_cast<int>(b.poses.size());
    for (int count : {30, 10}) {
      for (int layout = 0; layout < 2; ++layout) {
        auto [both, rest] = PlaceOn(c, b, Placing(n, count, layout == 0));
        for (const char* spec : {"geometric", "auto"}) {
          const Signature s = Fit(model, both, spec, true);
          const Errors e = Evaluate(model, s.fit.base_of(2), s.fit.params, nullptr, rest);
          const Errors em = s.map ? Evaluate(model, s.fit.base_of(2), s.fit.params, &*s.map, rest) : e;
          std::printf("%s, %s %d, %-9s: parametric %.3f, with map %.3f (map used %d)\n",
                      orientation ? "6-DoF" : "positions", layout == 0 ? "first" : "spread", count, spec,
                      e.Mean(), em.Mean(), s.map.has_value());
          std::fflush(stdout);
        }
      }
    }
  }
  return 0;
}

// Ten placing poses with and without their orientations: where the joint fit's error comes
// from (the fitted base against one re-placed by all of B's positions).
int TenFits(const RobotModel& model, const std::string& b_path) {
  const std::string c_path = kSource + "/tests/data/ur10-ipa/series_C-measurements_random_poses.csv";
  const Series c = Load("C", c_path, true), b = Load("B", b_path, true);
  const int n = static_cast<int>(b.poses.size());
  for (int count : {10, 30}) {
    for (int variant = 0; variant < 4; ++variant) {
      // 0: all orientations; 1: B's placing poses without; 2: positions only; 3: C without, B with
      std::vector<char> in(n, 0);
      for (int k = 0; k < count; ++k) in[static_cast<int>((k + 0.5) * n / count)] = 1;
      std::vector<MeasuredPose> both = c.poses, rest;
      for (auto& p : both) {
        p.frame = 1;
        if (variant == 2 || variant == 3) p.orientation.reset();
      }
      for (int i = 0; i < n; ++i) {
        if (!in[i]) {
          rest.push_back(b.poses[i]);
          continue;
        }
        MeasuredPose p = b.poses[i];
        p.frame = 2;
        if (variant == 1 || variant == 2) p.orientation.reset();
        both.push_back(p);
      }
      const Signature s = Fit(model, both, "auto", false);
      const Errors e = Evaluate(model, s.fit.base_of(2), s.fit.params, nullptr, rest);
      std::vector<MeasuredPose> b_pos = b.poses;
      const auto base_all = *AlignBaseWithParams(model, s.fit.params, b_pos);
      const Errors ea = Evaluate(model, base_all, s.fit.params, nullptr, rest);
      const Eigen::Isometry3d d = base_all.inverse() * s.fit.base_of(2);
      std::printf("%d placing, variant %d: parametric %.3f, base re-placed by all B %.3f; base off by %.3f mm %.4f mrad; weight %.0f; k %d\n",
                  count, variant, e.Mean(), ea.Mean(), d.translation().norm(),
                  Eigen::AngleAxisd(d.linear()).angle() * 1e3, s.fit.orientation_weight_mm_per_rad,
                  static_cast<int>(s.fit.identifiability.rank));
      std::fflush(stdout);
    }
  }
  return 0;
}

// The map outside its support: cut (parametric there) or its GP mean applied everywhere
// (which falls to zero, the parametric model, away from its centres). C fitted with N placing
// poses of B or D (a new session), evaluated on that series' other poses.
int SmoothFits(const RobotModel& model, const std::string& b_path) {
  const std::string c_path = kSource + "/tests/data/ur10-ipa/series_C-measurements_random_poses.csv";
  const std::string d_path = kSource + "/tests/data/ur10-ipa/series_D-measurements_iso_cubes.csv";
  for (bool orientation : {false, true}) {
    const Series c = Load("C", c_path, orientation);
    for (const std::string& other : {b_path, d_path}) {
      const Series b = Load("X", other, orientation);
      const int n = static_cast<int>(b.poses.size());
      for (int count : {30, 10}) {
        auto [both, rest] = PlaceOn(c, b, Placing(n, count));
        const Signature s = Fit(model, both, "auto", true);
        const Errors e = Evaluate(model, s.fit.base_of(2), s.fit.params, nullptr, rest);
        double cut = e.Mean(), open = e.Mean();
        int outside = 0;
        double out_cut = 0, out_open = 0;
        if (s.map) {
          const Errors em = Evaluate(model, s.fit.base_of(2), s.fit.params, &*s.map, rest);
          ResidualMapData data = s.map->data();
          data.support_radius = 1e6;
          const ResidualMap everywhere(data);
          const Errors eo = Evaluate(model, s.fit.base_of(2), s.fit.params, &everywhere, rest);
          cut = em.Mean();
          open = eo.Mean();
          for (size_t i = 0; i < rest.size(); ++i) {
            if (!em.outside[i]) continue;
            ++outside;
            out_cut += em.distance[i];
            out_open += eo.distance[i];
          }
        }
        std::printf("%s %s %d placing: parametric %.4f, map cut %.4f, map everywhere %.4f; %d outside: cut %.4f everywhere %.4f\n",
                    orientation ? "6-DoF" : "positions", other == d_path ? "D" : "B", count, e.Mean(), cut, open,
                    outside, out_cut / std::max(outside, 1), out_open / std::max(outside, 1));
        std::fflush(stdout);
      }
    }
  }
  return 0;
}

// The orientation weight in a joint fit of all of C and N placing poses of B or D: variance
// components (0) against fixed, smaller weights (mm per rad), parametric error on the rest.
int WeightFits(const RobotModel& model, const std::string& b_path) {
  const std::string c_path = kSource + "/tests/data/ur10-ipa/series_C-measurements_random_poses.csv";
  const std::string d_path = kSource + "/tests/data/ur10-ipa/series_D-measurements_iso_cubes.csv";
  const Series c = Load("C", c_path, true);
  for (const std::string& other : {b_path, d_path}) {
    const Series b = Load("X", other, true);
    const int n = static_cast<int>(b.poses.size());
    for (int count : {10, 30}) {
      auto [both, rest] = PlaceOn(c, b, Placing(n, count));
      for (double w : {0.0, 150.0, 50.0}) {
        EstimationOptions o;
        o.parameters = ParseParameterSpec(model, "all");
        o.orientation_weight_mm_per_rad = w;
        o.parameters = SelectTermsByFTest(model, both, o, 0.01).parameters;
        const auto fit = Estimate(model, both, o);
        const Errors e = Evaluate(model, fit.base_of(2), fit.params, nullptr, rest);
        std::printf("%s %d placing, weight %.0f (used %.0f): parametric %.4f (k %d)\n", other == d_path ? "D" : "B",
                    count, w, fit.orientation_weight_mm_per_rad, e.Mean(), static_cast<int>(fit.identifiability.rank));
        std::fflush(stdout);
      }
    }
  }
  return 0;
}

// Which candidate terms transfer: --params auto choosing among every generated term, or
// among the paper's h-terms and the gravity compliances only (no harmonics), on all of C
// plus N placing poses of B or D; positions only and 6-DoF.
int FamilyFits(const RobotModel& model, const std::string& b_path) {
  const std::string c_path = kSource + "/tests/data/ur10-ipa/series_C-measurements_random_poses.csv";
  const std::string d_path = kSource + "/tests/data/ur10-ipa/series_D-measurements_iso_cubes.csv";
  std::string no_harmonics = "geometric,compliance";
  for (const auto& t : model.nongeometric)
    if (t.name.size() == 2 && t.name[0] == 'h') no_harmonics += "," + t.name;
  for (bool orientation : {false, true}) {
    const Series c = Load("C", c_path, orientation);
    for (const std::string& other : {b_path, d_path}) {
      const Series b = Load("X", other, orientation);
      const int n = static_cast<int>(b.poses.size());
      for (int count : {10, 30}) {
        auto [both, rest] = PlaceOn(c, b, Placing(n, count));
        for (const std::string& spec : {std::string("all"), no_harmonics}) {
          EstimationOptions o;
          o.parameters = ParseParameterSpec(model, spec);
          const auto selected = SelectTermsByFTest(model, both, o, 0.01);
          o.parameters = selected.parameters;
          const auto fit = Estimate(model, both, o);
          const Errors e = Evaluate(model, fit.base_of(2), fit.params, nullptr, rest);
          std::string terms;
          for (int p : o.parameters)
            if (p >= model.num_geometric()) terms += " " + model.ParameterNames()[p];
          std::printf("%s %s %d placing, candidates %s: parametric %.4f; terms%s\n", orientation ? "6-DoF" : "positions",
                      other == d_path ? "D" : "B", count, spec == "all" ? "all" : "no harmonics", e.Mean(), terms.c_str());
          std::fflush(stdout);
        }
      }
    }
  }
  return 0;
}

int main(int argc, char** argv) {
  const bool family = argc > 1 && std::string(argv[1]) == "family";
  if (family) {
    --argc;
    ++argv;
  }
  const bool weight = argc > 1 && std::string(argv[1]) == "weight";
  if (weight) {
    --argc;
    ++argv;
  }
  const bool smooth = argc > 1 && std::string(argv[1]) == "smooth";
  if (smooth) {
    --argc;
    ++argv;
  }
  const bool ten = argc > 1 && std::string(argv[1]) == "ten";
  if (ten) {
    --argc;
    ++argv;
  }
  const bool joint_only = argc > 1 && std::string(argv[1]) == "joint";
  if (joint_only) {
    --argc;
    ++argv;
  }
  const std::string b_path =
      argc > 1 ? argv[1]
      : std::filesystem::exists(kSource + "/tests/data/ur10-ipa/series_B-measurements_joint_configurations.csv")
          ? kSource + "/tests/data/ur10-ipa/series_B-measurements_joint_configurations.csv"
          : "/work/shared/data/ur10-ipa/series_B-measurements_joint_configurations.csv";
  const RobotModel model = io::LoadRobotModel(kSource + "/models/ur10.yaml");
  if (joint_only) return JointFits(model, b_path);
  if (ten) return TenFits(model, b_path);
  if (smooth) return SmoothFits(model, b_path);
  if (weight) return WeightFits(model, b_path);
  if (family) return FamilyFits(model, b_path);
  const Series c = Load("C", kSource + "/tests/data/ur10-ipa/series_C-measurements_random_poses.csv");
  const Series b = Load("B", b_path);
  const Series d = Load("D", kSource + "/tests/data/ur10-ipa/series_D-measurements_iso_cubes.csv");

  std::printf("== Series\n");
  for (const Series* s : {&c, &b, &d}) {
    double t = 0, lo = 1e9, hi = -1e9;
    for (double v : s->temperature_c) t += v / s->temperature_c.size(), lo = std::min(lo, v), hi = std::max(hi, v);
    std::printf("%s: %zu poses, temperature mean %.2f (%.2f … %.2f) °C; joints (deg):", s->name.c_str(),
                s->poses.size(), t, lo, hi);
    for (int j = 0; j < 6; ++j) {
      double a = 1e9, z = -1e9;
      for (const auto& p : s->poses) a = std::min(a, p.joints_rad(j)), z = std::max(z, p.joints_rad(j));
      std::printf(" q%d [%.0f, %.0f]", j + 1, a * 180 / kPi, z * 180 / kPi);
    }
    std::printf("\n");
    std::map<std::string, int> branches;
    for (const auto& p : s->poses) ++branches[Branch(p.joints_rad)];
    std::printf("   branches:");
    for (const auto& [name, n] : branches) std::printf(" %s: %d;", name.c_str(), n);
    std::printf("\n");
  }

  // B's placing poses and the rest. Series B measures each point from two arm branches, in
  // rows along lines through the work volume: its first 30 rows lie on one line (x 0…282 mm
  // at y ≈ −3,300, z ≈ −426), which leaves the rotation about that line to the model's
  // errors. Three choices: the first rows, rows evenly spread through the file, and a random
  // draw (fixed seed).
  struct Placing {
    std::string name;
    std::vector<int> rows;
  };
  auto placings = [&](int n) {
    std::vector<Placing> out(3);
    out[0].name = "first " + std::to_string(n);
    out[1].name = "spread " + std::to_string(n);
    out[2].name = "random " + std::to_string(n);
    const int m = static_cast<int>(b.poses.size());
    for (int k = 0; k < n; ++k) {
      out[0].rows.push_back(k);
      out[1].rows.push_back(static_cast<int>(std::lround((k + 0.5) * m / n - 0.5)));
    }
    std::vector<int> all(m);
    for (int k = 0; k < m; ++k) all[k] = k;
    std::mt19937 rng(1);
    std::shuffle(all.begin(), all.end(), rng);
    out[2].rows.assign(all.begin(), all.begin() + n);
    std::sort(out[2].rows.begin(), out[2].rows.end());
    return out;
  };
  auto split = [&](const Placing& p, std::vector<MeasuredPose>& place, std::vector<MeasuredPose>& rest) {
    std::vector<char> in(b.poses.size(), 0);
    for (int r : p.rows) in[r] = 1;
    for (size_t i = 0; i < b.poses.size(); ++i) (in[i] ? place : rest).push_back(b.poses[i]);
  };
  std::vector<MeasuredPose> b_place, b_rest;
  split(placings(30)[0], b_place, b_rest);

  std::vector<Signature> signatures;
  for (const char* spec : {"geometric", "auto"}) signatures.push_back(Fit(model, c.poses, spec, true));
  std::printf("\n== Fitted on all of C, used on B: mean error on the B poses not used to place it (mm)\n");
  std::printf("%-14s %9s %9s", "model", "C base", "B all pl.");
  for (int n : {30, 10})
    for (const auto& p : placings(n)) std::printf(" %10s", p.name.c_str());
  std::printf("\n");
  for (auto& s : signatures) {
    for (bool map : {false, true}) {
      if (map && !s.map) continue;
      const ResidualMap* m = map ? &*s.map : nullptr;
      const auto base_all = *AlignBaseWithParams(model, s.fit.params, b.poses);
      std::printf("%-14s %9.3f %9.3f", (s.label + (map ? "+map" : "")).c_str(),
                  Evaluate(model, s.fit.world_from_base, s.fit.params, m, b.poses).Mean(),
                  Evaluate(model, base_all, s.fit.params, m, b.poses).Mean());
      for (int n : {30, 10}) {
        for (const auto& p : placings(n)) {
          std::vector<MeasuredPose> place, rest;
          split(p, place, rest);
          const auto base = *AlignBaseWithParams(model, s.fit.params, place);
          std::printf(" %10.3f", Evaluate(model, base, s.fit.params, m, rest).Mean());
        }
      }
      std::printf("\n");
      if (!map) {
        PrintBaseDifference("B base (all B) against C's", s.fit.world_from_base, base_all);
        for (const auto& p : placings(30)) {
          std::vector<MeasuredPose> place, rest;
          split(p, place, rest);
          PrintBaseDifference(("B base (" + p.name + ") against all B").c_str(), base_all,
                              *AlignBaseWithParams(model, s.fit.params, place));
        }
      }
    }
  }
  // B's own floor: fitted on B's even rows, evaluated on the odd ones.
  std::vector<MeasuredPose> b_even, b_odd;
  for (size_t i = 0; i < b.poses.size(); ++i) (i % 2 ? b_odd : b_even).push_back(b.poses[i]);
  for (const char* spec : {"geometric", "auto"}) {
    const Signature own = Fit(model, b_even, spec, true);
    const Errors e = Evaluate(model, own.fit.world_from_base, own.fit.params, nullptr, b_odd);
    const Errors em = Evaluate(model, own.fit.world_from_base, own.fit.params, own.map ? &*own.map : nullptr, b_odd);
    std::printf("B's own %s fit (even rows, evaluated on odd): %.3f, with map %.3f\n", spec, e.Mean(), em.Mean());
  }

  // The nightly path: C and 30 placing poses fitted together, one base each (the placing
  // session is the reference frame), evaluated on the other B poses.
  std::printf("\n== Joint fit of C (frame 1) and 30 B poses (frame 2, the reference)\n");
  for (const auto& placing : placings(30)) {
    std::vector<MeasuredPose> place, rest;
    split(placing, place, rest);
    std::vector<MeasuredPose> both = c.poses;
    for (auto& p : both) p.frame = 1;
    for (auto p : place) {
      p.frame = 2;
      both.push_back(p);
    }
    for (const char* spec : {"geometric", "auto"}) {
      const Signature s = Fit(model, both, spec, true);
      const Errors e = Evaluate(model, s.fit.base_of(2), s.fit.params, nullptr, rest);
      const Errors em = s.map ? Evaluate(model, s.fit.base_of(2), s.fit.params, &*s.map, rest) : e;
      int outside = 0;
      for (char o : em.outside) outside += o;
      std::printf("%-10s %-10s parametric %.3f, with map %.3f (map used %d, %d outside)\n",
                  placing.name.c_str(), spec, e.Mean(), em.Mean(), s.map.has_value(), outside);
    }
  }

  // Extrapolation: the error of C's geometric fit on B (base from all of B: no placing noise)
  // by arm branch and by distance to the nearest C configuration.
  std::printf("\n== Extrapolation (C geometric, B placed by all its poses)\n");
  {
    const Signature& g = signatures[0];
    const auto base_all = *AlignBaseWithParams(model, g.fit.params, b.poses);
    const Errors e = Evaluate(model, base_all, g.fit.params, nullptr, b.poses);
    std::map<std::string, std::pair<double, int>> by_branch;
    for (size_t i = 0; i < b.poses.size(); ++i) {
      auto& [sum, n] = by_branch[Branch(b.poses[i].joints_rad)];
      sum += e.distance[i];
      ++n;
    }
    for (const auto& [name, v] : by_branch) std::printf("  %s: %d poses, mean %.3f mm\n", name.c_str(), v.second, v.first / v.second);
    const double edges[] = {0, 0.25, 0.5, 0.75, 1.0, 1.5, 2.0, 3.0, 10.0};
    std::vector<double> sum(8, 0.0);
    std::vector<int> count(8, 0);
    for (size_t i = 0; i < b.poses.size(); ++i) {
      const double dist = NearestDistance(b.poses[i].joints_rad, c.poses);
      for (int k = 0; k < 8; ++k) {
        if (dist >= edges[k] && dist < edges[k + 1]) sum[k] += e.distance[i], ++count[k];
      }
    }
    std::printf("  by distance to the nearest C configuration (rad, joints 1-5):\n");
    for (int k = 0; k < 8; ++k) {
      if (count[k]) std::printf("    [%.2f, %.2f): %4d poses, mean %.3f mm\n", edges[k], edges[k + 1], count[k], sum[k] / count[k]);
    }
    // B's own geometric fit on the same split, by branch (what the model can do there).
    const Signature own = Fit(model, b_even, "geometric", false);
    const Errors eo = Evaluate(model, own.fit.world_from_base, own.fit.params, nullptr, b_odd);
    std::map<std::string, std::pair<double, int>> own_branch;
    for (size_t i = 0; i < b_odd.size(); ++i) {
      auto& [s2, n2] = own_branch[Branch(b_odd[i].joints_rad)];
      s2 += eo.distance[i];
      ++n2;
    }
    for (const auto& [name, v] : own_branch) std::printf("  B's own geometric fit, %s: mean %.3f mm\n", name.c_str(), v.first / v.second);
    // Parameters C and B disagree on (geometric, both fitted alone): z of the difference.
    const Signature all_b = Fit(model, b.poses, "geometric", false);
    const auto names = model.ParameterNames();
    std::printf("  geometric parameters C and B disagree on (|z| > 5):\n");
    for (const auto& ch : CompareParameters(g.fit.params, g.fit.sigmas, all_b.fit.params, all_b.fit.sigmas)) {
      if (std::abs(ch.z) > 5)
        std::printf("    %-7s C %+.4g B %+.4g (z %.1f)\n", names[ch.parameter].c_str(), g.fit.params(ch.parameter),
                    all_b.fit.params(ch.parameter), ch.z);
    }
  }

  // Temperature and scale: a rigid fit with a scale of C's geometric model to each series.
  std::printf("\n== Temperature and scale (C geometric signature)\n");
  {
    const Signature& g = signatures[0];
    Kinematics kin(model);
    for (const Series* s : {&c, &b, &d}) {
      Eigen::Matrix3Xd from(3, s->poses.size()), to(3, s->poses.size());
      for (size_t i = 0; i < s->poses.size(); ++i) {
        from.col(i) = kin.Position(Eigen::Isometry3d::Identity(), g.fit.params, s->poses[i].joints_rad.data());
        to.col(i) = s->poses[i].target_in_world;
      }
      const Eigen::Matrix4d with_scale = Eigen::umeyama(from, to, true);
      const Eigen::Matrix4d rigid = Eigen::umeyama(from, to, false);
      double es = 0, er = 0, t = 0;
      for (size_t i = 0; i < s->poses.size(); ++i) {
        es += ((with_scale * from.col(i).homogeneous()).head<3>() - to.col(i)).norm() / s->poses.size();
        er += ((rigid * from.col(i).homogeneous()).head<3>() - to.col(i)).norm() / s->poses.size();
        t += s->temperature_c[i] / s->poses.size();
      }
      const double scale = with_scale.topLeftCorner<3, 3>().determinant();
      std::printf("  %s (%.2f °C): scale %+.1f ppm; rigid %.3f mm, with scale %.3f mm\n", s->name.c_str(), t,
                  (std::cbrt(scale) - 1) * 1e6, er, es);
    }
  }

  // Per-session terms: with C's signature folded in (its corrected model), what the 30
  // placing poses can re-fit besides the base, evaluated on the other B poses.
  std::printf("\n== Per-session terms from the 30 placing poses (C signature folded in)\n");
  for (const Signature* s : {&signatures[0], &signatures[1]}) {
    RobotModel corrected = CorrectedModel(model, s->fit.params, s->fit.world_from_base);
    corrected.base.reset();
    for (const char* spec : {"a1,b1,c1,alpha1,beta1,gamma1", "a1,b1,c1,alpha1,beta1,gamma1,a7,b7,c7",
                             "a1,b1,c1,alpha1,beta1,gamma1,gamma2,gamma3,gamma4,gamma5"}) {
      EstimationOptions o;
      o.parameters = ParseParameterSpec(corrected, spec);
      for (int n : {10, 30}) {
        for (const auto& placing : placings(n)) {
          std::vector<MeasuredPose> place, rest;
          split(placing, place, rest);
          const auto r = Estimate(corrected, place, o);
          const Errors e = Evaluate(corrected, r.world_from_base, r.params, nullptr, rest);
          std::printf("  %-9s %-9s re-fit %-50s: %.3f mm (rank %d)\n", s->label.c_str(),
                      placing.name.c_str(), spec, e.Mean(), r.identifiability.rank);
        }
      }
    }
  }
  return 0;
}
