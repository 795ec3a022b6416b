// Is there a periodic joint-angle error left in the UR10's residual? An exploration program
// (not a benchmark), on series C's fixed split:
//  1. after the fit of the fit poses (the first 1,773 of the permutation), for each joint i
//     and order k the least-squares fit of one harmonic δθ_i = s sin kθ_i + c cos kθ_i
//     through the joint's lever (∂x/∂θ_i) to the position residuals: each joint's strongest
//     orders with their amplitude and the drop of the residual sum of squares;
//  2. joint error series on joints 1–5 fitted with the identified parameters (one
//     Gauss–Newton step), for several sizes, evaluated on the held-out 1,000 — or, with
//     INNER set, on the inner split (the first 1,273 fitted, the next 500 validated), which
//     is where the joint curves' knot count was chosen.
// Environment: SPLINE=1 periodic cubic B-splines (each size as knots per turn) instead of Fourier orders,
// LAMBDA their second-difference penalty, RIDGE a ridge, NOGEO=1 without the parameters,
// AMP=K print the Fourier amplitudes of order K.
//
// Usage: harmonics_explore [MAX_ORDER] [geometric|auto]
#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

#include "calibration/estimation.h"
#include "io/model_yaml.h"
#include "io/poses_csv.h"

using namespace armsig;
using namespace armsig::calibration;

namespace {
const std::string kSource = ARMSIG_SOURCE_DIR;
constexpr double kArcsec = 3.14159265358979323846 / 180.0 / 3600.0;
}  // namespace

int main(int argc, char** argv) {
  const int max_order = argc > 1 ? std::atoi(argv[1]) : 300;
  const std::string spec = argc > 2 ? argv[2] : "geometric";
  const RobotModel model = io::LoadRobotModel(kSource + "/models/ur10.yaml");
  const auto c = io::ImportPoses(kSource + "/tests/data/ur10-ipa/series_C-measurements_random_poses.csv",
                                 io::PoseImportOptions::UrIpa());
  std::ifstream file(kSource + "/tests/data/ur10-ipa-split/series_C-permutation.txt");
  std::vector<int> perm;
  for (int i; file >> i;) perm.push_back(i);
  const bool inner = std::getenv("INNER") != nullptr;  // 1,273 fitted, the next 500 validated
  const int fit_count = inner ? 1273 : 1773, end = inner ? 1773 : 2773;
  std::vector<MeasuredPose> fit;
  for (int k = 0; k < fit_count; ++k) fit.push_back(c[perm[k]]);
  EstimationOptions eo;
  eo.parameters = ParseParameterSpec(model, spec == "auto" ? "all" : "geometric");
  if (spec == "auto") eo.parameters = SelectTerms(model, fit, eo).parameters;
  const auto r = Estimate(model, fit, eo);
  std::printf("fit: mean %.4f mm, sigma0 %.4f mm\n", r.fit.mean_mm, r.sigma0_mm);
  Kinematics kin(model);
  const int m = static_cast<int>(fit.size());
  std::vector<Eigen::Matrix<double, 3, Eigen::Dynamic>> lever(m);
  double ssr = 0;
  for (int i = 0; i < m; ++i) {
    kin.Position(r.base_of(fit[i].frame), r.params, fit[i].joints_rad.data());
    lever[i] = kin.JointJacobian();
    ssr += r.fit_residuals[i].squaredNorm();
  }
  std::printf("SSR %.3f mm^2 over %d poses\n", ssr, m);
  for (int j = 0; j < 5; ++j) {
    struct Peak { int k; double drop, amp_arcsec; };
    std::vector<Peak> peaks;
    for (int k = 1; k <= max_order; ++k) {
      Eigen::Matrix2d ata = Eigen::Matrix2d::Zero();
      Eigen::Vector2d atb = Eigen::Vector2d::Zero();
      for (int i = 0; i < m; ++i) {
        const double t = fit[i].joints_rad(j);
        Eigen::Matrix<double, 3, 2> a;
        a.col(0) = lever[i].col(j) * std::sin(k * t);
        a.col(1) = lever[i].col(j) * std::cos(k * t);
        ata += a.transpose() * a;
        atb += a.transpose() * r.fit_residuals[i];
      }
      const Eigen::Vector2d x = ata.ldlt().solve(atb);
      peaks.push_back({k, x.dot(atb), x.norm() / kArcsec});
    }
    std::sort(peaks.begin(), peaks.end(), [](auto& a, auto& b) { return a.drop > b.drop; });
    if (peaks.empty()) continue;
    double median = peaks[peaks.size() / 2].drop;
    std::printf("joint %d (median drop %.3f mm^2):", j + 1, median);
    for (int p = 0; p < std::min<int>(8, peaks.size()); ++p) std::printf("  k=%d %.2f (%.1f\")", peaks[p].k, peaks[p].drop, peaks[p].amp_arcsec);
    std::printf("\n");
  }
  // Joint error series of orders 1…K on every joint, fitted jointly with the identified
  // parameters (one Gauss–Newton step from the fit), evaluated on the held-out 1,000.
  std::vector<MeasuredPose> held;
  for (int k = fit_count; k < end; ++k) held.push_back(c[perm[k]]);
  const auto& ident = r.identifiability.identified;
  const int np = std::getenv("NOGEO") ? 0 : static_cast<int>(ident.size());
  // The design: the identified parameters' columns, then `per_joint` columns for each of
  // joints 1–5, basis(angle, c) times the joint's lever; b the residuals (measured − model).
  auto rows = [&](const std::vector<MeasuredPose>& poses, int per_joint, const auto& basis,
                  Eigen::MatrixXd& a, Eigen::VectorXd& b) {
    const int n = static_cast<int>(poses.size());
    a.setZero(3 * n, np + 5 * per_joint);
    b.resize(3 * n);
    Eigen::Matrix<double, 3, Eigen::Dynamic> jac(3, model.num_parameters());
    for (int i = 0; i < n; ++i) {
      const Eigen::Vector3d x = kin.PositionAndJacobian(r.base_of(poses[i].frame), r.params,
                                                        poses[i].joints_rad.data(), jac);
      const auto jj = kin.JointJacobian();
      b.segment<3>(3 * i) = poses[i].target_in_world - x;
      for (int p = 0; p < np; ++p) a.block<3, 1>(3 * i, p) = jac.col(ident[p]);
      for (int j = 0; j < 5; ++j) {
        for (int c = 0; c < per_joint; ++c)
          a.block<3, 1>(3 * i, np + per_joint * j + c) = jj.col(j) * basis(poses[i].joints_rad(j), c);
      }
    }
  };
  // Fourier orders 1…K: columns sin kθ, cos kθ (k = c/2 + 1).
  auto fourier = [](double t, int c) {
    const int k = c / 2 + 1;
    return c % 2 == 0 ? std::sin(k * t) : std::cos(k * t);
  };
  auto bspline = [](double x) {
    x = std::abs(x);
    if (x < 1) return 2.0 / 3.0 - x * x + 0.5 * x * x * x;
    if (x < 2) return (2 - x) * (2 - x) * (2 - x) / 6.0;
    return 0.0;
  };
  const int mode_spline = std::getenv("SPLINE") ? std::atoi(std::getenv("SPLINE")) : 0;
  const double ridge = std::getenv("RIDGE") ? std::atof(std::getenv("RIDGE")) : 1e-6;
  for (int order : {0, 2, 5, 10, 15, 20, 25, 30, 40, 50, 60, 72, 90, 120, 180, 240, 360, 480, 720}) {
    Eigen::MatrixXd a, ah;
    Eigen::VectorXd b, bh;
    if (mode_spline) {
      if (order < 10) continue;
      // Periodic cubic B-splines: `order` bumps per turn.
      const double step = 2 * 3.14159265358979323846 / order;
      auto bump = [&](double t, int m) {
        return bspline(std::remainder(t / step - m, static_cast<double>(order)));
      };
      rows(fit, order, bump, a, b);
      rows(held, order, bump, ah, bh);
    } else {
      if (order > 50) continue;
      rows(fit, 2 * order, fourier, a, b);
      rows(held, 2 * order, fourier, ah, bh);
    }
    // Column scaling, then a tiny ridge against rank loss.
    Eigen::VectorXd s = a.colwise().norm().transpose().cwiseMax(1e-12).cwiseInverse();
    const Eigen::MatrixXd as = a * s.asDiagonal();
    Eigen::VectorXd x;
    if (mode_spline) {
      // P-spline: second differences of neighbouring bumps (periodic), penalty λ (mm² per rad²·…).
      Eigen::MatrixXd n = a.transpose() * a;
      const double lambda = std::getenv("LAMBDA") ? std::atof(std::getenv("LAMBDA")) : 0.0;
      const double rad2 = 1.0 / (kArcsec * kArcsec);
      for (int j = 0; j < 5; ++j) {
        for (int m = 0; m < order; ++m) {
          int i0 = np + order * j + m, i1 = np + order * j + (m + 1) % order, i2 = np + order * j + (m + 2) % order;
          int idx[3] = {i0, i1, i2};
          double w[3] = {1, -2, 1};
          for (int u = 0; u < 3; ++u)
            for (int v = 0; v < 3; ++v) n(idx[u], idx[v]) += lambda * rad2 * 1e-6 * w[u] * w[v];
          n(i0, i0) += ridge * rad2 * 1e-6;
        }
      }
      x = n.ldlt().solve(a.transpose() * b);
    } else {
      Eigen::MatrixXd n = as.transpose() * as;
      n.diagonal().array() += ridge;
      x = s.asDiagonal() * n.ldlt().solve(as.transpose() * b);
    }
    auto mean = [](const Eigen::VectorXd& e) {
      double sum = 0;
      for (int i = 0; i < e.size() / 3; ++i) sum += e.segment<3>(3 * i).norm();
      return sum / (e.size() / 3);
    };
    if (!mode_spline && std::getenv("AMP") && order == std::atoi(std::getenv("AMP"))) {
      for (int j = 0; j < 5; ++j) {
        std::printf("joint %d amplitudes (\"):", j + 1);
        for (int k = 1; k <= order; ++k)
          std::printf(" %d:%.0f", k, std::hypot(x(np + 2 * order * j + 2 * (k - 1)), x(np + 2 * order * j + 2 * (k - 1) + 1)) / kArcsec);
        std::printf("\n");
      }
    }
    std::printf("orders 1..%d: fit %.4f mm, held out %.4f mm\n", order, mean(b - a * x), mean(bh - ah * x));
  }
}
