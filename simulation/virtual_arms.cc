#include "simulation/virtual_arms.h"

#include "core/units.h"

namespace armsig::simulation {

calibration::RobotModel DhArm(const std::string& name, const std::vector<DhRow>& rows,
                              const std::vector<std::pair<double, double>>& limits_deg) {
  auto transform = [](const DhRow& r) {
    Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
    t.rotate(Eigen::AngleAxisd(r.theta_deg * kRadPerDeg, Eigen::Vector3d::UnitZ()));
    t.translate(Eigen::Vector3d(0, 0, r.d_mm));
    t.translate(Eigen::Vector3d(r.a_mm, 0, 0));
    t.rotate(Eigen::AngleAxisd(r.alpha_deg * kRadPerDeg, Eigen::Vector3d::UnitX()));
    return t;
  };
  calibration::RobotModel m;
  m.name = name;
  for (std::size_t i = 0; i + 1 < rows.size(); ++i) m.links.push_back(transform(rows[i]));
  m.flange = transform(rows.back());
  m.tool_mm = m.flange.translation();
  for (const auto& [lo, hi] : limits_deg) {
    m.joint_min_rad.push_back(lo * kRadPerDeg);
    m.joint_max_rad.push_back(hi * kRadPerDeg);
  }
  return m;
}

calibration::RobotModel KukaKr16Like() {
  return DhArm("kr16-like",
               {{0, 675, 260, -90}, {0, 0, 680, 0}, {-90, 0, 35, -90}, {0, 670, 0, 90}, {0, 0, 0, -90}, {0, 158, 0, 0}},
               {{-185, 185}, {-155, 35}, {-130, 154}, {-350, 350}, {-130, 130}, {-350, 350}});
}

calibration::RobotModel AbbIrb4600Like() {
  return DhArm("irb4600-like",
               {{0, 495, 175, -90}, {-90, 0, 900, 0}, {0, 0, 175, -90}, {0, 960, 0, 90}, {0, 0, 0, -90}, {0, 135, 0, 0}},
               {{-180, 180}, {-90, 150}, {-180, 75}, {-400, 400}, {-125, 120}, {-400, 400}});
}

}  // namespace armsig::simulation
