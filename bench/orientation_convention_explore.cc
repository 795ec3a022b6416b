// Which rotation do the IPA UR10 files' `measurement_rx/ry/rz` (degrees) give? An exploration
// program (not a benchmark): each candidate reading of the three angles — the six orders of
// elementary rotations about x, y, z, each angle about the axis it is named after, as the
// tracker-from-probe rotation or its inverse — is tested against the nominal forward
// kinematics. The probe is screwed to the flange, so under the right reading the probe's
// rotation relative to the flange, R_flange_from_probe = R_base_from_flangeᵀ ·
// R_tracker_from_baseᵀ · R_tracker_from_probe, is one constant over every pose, up to the
// arm's own orientation errors (a few hundredths of a degree); a wrong reading scatters by
// tens of degrees. The tracker-from-base rotation comes from the positions alone (a rigid
// best fit of the nominal probe positions to the measured ones), so the test is independent
// of the angles it judges. The constant rotation is compared with the nominal probe-to-flange
// transform the data set ships (`series_*-Trafo_TM_F_init.txt`).
//
// Usage: orientation_convention_explore [POSES.csv (IPA format)] [TRAFO.txt]
#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

#include "calibration/compensation.h"
#include "calibration/model.h"
#include "io/csv.h"
#include "io/model_yaml.h"
#include "io/poses_csv.h"

using namespace armsig;

namespace {

constexpr double kDeg = 3.14159265358979323846 / 180.0;

Eigen::Matrix3d Elementary(char axis, double angle_rad) {
  const Eigen::Vector3d u = axis == 'x'   ? Eigen::Vector3d::UnitX()
                            : axis == 'y' ? Eigen::Vector3d::UnitY()
                                          : Eigen::Vector3d::UnitZ();
  return Eigen::AngleAxisd(angle_rad, u).toRotationMatrix();
}

// The rotation nearest (Frobenius) to the mean of rotations: the chordal mean.
Eigen::Matrix3d ChordalMean(const std::vector<Eigen::Matrix3d>& rotations) {
  Eigen::Matrix3d sum = Eigen::Matrix3d::Zero();
  for (const auto& r : rotations) sum += r;
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(sum, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d d = Eigen::Matrix3d::Identity();
  d(2, 2) = (svd.matrixU() * svd.matrixV().transpose()).determinant() < 0 ? -1.0 : 1.0;
  return svd.matrixU() * d * svd.matrixV().transpose();
}

double AngleDeg(const Eigen::Matrix3d& r) { return Eigen::AngleAxisd(r).angle() / kDeg; }

}  // namespace

int main(int argc, char** argv) {
  const std::string src = ARMSIG_SOURCE_DIR;
  const std::string path =
      argc > 1 ? argv[1] : src + "/tests/data/ur10-ipa/series_C-measurements_random_poses.csv";
  const std::string trafo_path =
      argc > 2 ? argv[2] : src + "/tests/data/ur10-ipa/series_C-Trafo_TM_F_init.txt";
  const calibration::RobotModel model = io::LoadRobotModel(src + "/models/ur10.yaml");
  const auto poses = io::ImportPoses(path, io::PoseImportOptions::UrIpa());

  // The three angles of every row, in the file's order (the importer keeps it).
  io::CsvReader table(path);
  const int rx = table.Column("measurement_rx"), ry = table.Column("measurement_ry"),
            rz = table.Column("measurement_rz");
  std::vector<Eigen::Vector3d> angles_deg;
  for (io::CsvRow row; table.Next(row);) {
    angles_deg.emplace_back(table.Number(row, rx), table.Number(row, ry), table.Number(row, rz));
  }
  if (angles_deg.size() != poses.size()) {
    std::fprintf(stderr, "%zu angle rows for %zu poses\n", angles_deg.size(), poses.size());
    return 1;
  }

  const Eigen::VectorXd nominal = Eigen::VectorXd::Zero(model.num_parameters());
  const auto tracker_from_base = calibration::AlignBaseWithParams(model, nominal, poses);
  if (!tracker_from_base) return 1;
  calibration::Kinematics kin(model);
  std::vector<Eigen::Matrix3d> base_from_flange;
  double position_mean = 0.0;
  for (const auto& p : poses) {
    position_mean +=
        (kin.Position(*tracker_from_base, nominal, p.joints_rad.data()) - p.target_in_world)
            .norm() /
        poses.size();
    base_from_flange.push_back(tracker_from_base->linear().transpose() * kin.LastRotation());
  }
  std::printf("%s: %zu poses, nominal position error after the rigid fit %.3f mm\n",
              path.c_str(), poses.size(), position_mean);

  // The shipped nominal transform: the flange in the probe frame (probe_from_flange).
  Eigen::Matrix4d trafo;
  std::ifstream trafo_file(trafo_path);
  for (int i = 0; i < 16; ++i) trafo_file >> trafo(i / 4, i % 4);
  const Eigen::Matrix3d flange_from_probe_nominal = trafo.topLeftCorner<3, 3>().transpose();

  std::printf("%-28s %9s %9s %9s %9s  %s\n", "candidate (R = ...)", "mean °", "rms °", "max °",
              "vs Trafo°", "flange_from_probe (rotation vector, deg)");
  const char* orders[] = {"xyz", "xzy", "yxz", "yzx", "zxy", "zyx"};
  for (const char* order : orders) {
    for (bool inverse : {false, true}) {
      std::vector<Eigen::Matrix3d> relative;
      for (size_t i = 0; i < poses.size(); ++i) {
        Eigen::Matrix3d r = Eigen::Matrix3d::Identity();
        for (int k = 0; k < 3; ++k) {
          const char axis = order[k];
          r = r * Elementary(axis, angles_deg[i](axis - 'x') * kDeg);
        }
        const Eigen::Matrix3d tracker_from_probe = inverse ? Eigen::Matrix3d(r.transpose()) : r;
        relative.push_back(base_from_flange[i].transpose() *
                           tracker_from_base->linear().transpose() * tracker_from_probe);
      }
      const Eigen::Matrix3d mean = ChordalMean(relative);
      double sum = 0.0, sum_sq = 0.0, worst = 0.0;
      for (const auto& r : relative) {
        const double a = AngleDeg(mean.transpose() * r);
        sum += a;
        sum_sq += a * a;
        worst = std::max(worst, a);
      }
      const Eigen::AngleAxisd aa(mean);
      const Eigen::Vector3d v = aa.angle() * aa.axis() / kDeg;
      // Name the product in the order of the factors, each about the axis it is named after.
      std::string label = inverse ? "[" : "";
      for (int k = 0; k < 3; ++k) {
        label += std::string(k ? "·" : "") + "R" + order[k] + "(r" + order[k] + ")";
      }
      label += inverse ? "]ᵀ" : "";
      std::printf("%-32s %9.4f %9.4f %9.4f %9.3f  (%.3f, %.3f, %.3f)\n", label.c_str(),
                  sum / relative.size(), std::sqrt(sum_sq / relative.size()), worst,
                  AngleDeg(flange_from_probe_nominal.transpose() * mean), v.x(), v.y(), v.z());
    }
  }
  return 0;
}
