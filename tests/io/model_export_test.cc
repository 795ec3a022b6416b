// URDF export of a corrected model.
#include "io/model_export.h"

#include <gtest/gtest.h>

#include <random>
#include <regex>

#include "calibration/compensation.h"
#include "calibration/synthetic.h"
#include "core/plausibility.h"
#include "io/model_yaml.h"
#include "test_support.h"

namespace armsig::testing {

// URDF: compose the joints' origins (xyz in m, rpy) and rotations about z; it must give
// the corrected model's positions.
TEST(Export, UrdfChainMatchesTheModel) {
  auto model = Puma();
  model.nongeometric.clear();
  std::mt19937 rng(11);
  const Eigen::VectorXd params = calibration::RandomParameters(model, 1.0, 2e-3, 0, rng);
  const auto corrected = calibration::CorrectedModel(model, params, Eigen::Isometry3d::Identity());
  std::string warning;
  const std::string urdf = io::FormatUrdf(corrected, &warning);
  EXPECT_TRUE(warning.empty());
  std::regex origin_re(
      "<origin xyz=\"([^ ]+) ([^ ]+) ([^\"]+)\" rpy=\"([^ ]+) ([^ ]+) ([^\"]+)\"/>");
  std::vector<Eigen::Isometry3d> origins;
  for (auto it = std::sregex_iterator(urdf.begin(), urdf.end(), origin_re);
       it != std::sregex_iterator(); ++it) {
    Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
    t.translation() =
        1000.0 * Eigen::Vector3d(std::stod((*it)[1]), std::stod((*it)[2]), std::stod((*it)[3]));
    t.linear() = (Eigen::AngleAxisd(std::stod((*it)[6]), Eigen::Vector3d::UnitZ()) *
                  Eigen::AngleAxisd(std::stod((*it)[5]), Eigen::Vector3d::UnitY()) *
                  Eigen::AngleAxisd(std::stod((*it)[4]), Eigen::Vector3d::UnitX()))
                     .toRotationMatrix();
    origins.push_back(t);
  }
  ASSERT_EQ(origins.size(), 7u);  // six joints and the tool point
  calibration::Kinematics kin(model);
  for (const auto& q : calibration::RandomConfigurations(model, 20, rng)) {
    Eigen::Isometry3d chain = Eigen::Isometry3d::Identity();
    for (int i = 0; i < 6; ++i)
      chain = chain * origins[i] * Eigen::AngleAxisd(q(i), Eigen::Vector3d::UnitZ());
    const Eigen::Vector3d urdf_x = (chain * origins[6]).translation();
    const Eigen::Vector3d model_x = kin.Position(Eigen::Isometry3d::Identity(), params, q.data());
    EXPECT_LT((urdf_x - model_x).norm(), 1e-5);
  }
}

// The model name went raw into <robot name="…"> and an XML comment.
TEST(Export, UrdfEscapesTheModelNameByConstruction) {
  const auto model = io::LoadRobotModel(DataPath("faults/model-name-injection.yaml"));
  const auto corrected = calibration::CorrectedModel(
      model, Eigen::VectorXd::Zero(model.num_parameters()), Eigen::Isometry3d::Identity());
  const std::string urdf = io::FormatUrdf(corrected);
  EXPECT_EQ(urdf.find("<link name=\"injected\"/>"), std::string::npos) << urdf;
  EXPECT_NE(
      urdf.find("<robot name=\"x&quot;&gt;&lt;link name=&quot;injected&quot;/&gt;&lt;!-- "
                "-calibrated\">"),
      std::string::npos)
      << urdf;
  // Links: base_link, link1, link2, link3, tool0: and nothing else.
  size_t links = 0;
  for (size_t at = 0; (at = urdf.find("<link ", at)) != std::string::npos; ++at) ++links;
  EXPECT_EQ(links, 5u) << urdf;
  // The comment holds no "--" (which would end it early or make the XML invalid).
  const size_t open = urdf.find("<!-- "), close = urdf.find(" -->", open);
  ASSERT_NE(close, std::string::npos);
  EXPECT_EQ(urdf.substr(open + 5, close - open - 5).find("--"), std::string::npos) << urdf;
}

TEST(Export, AnExportedModelWithALongNameLoadsAgain) {
  auto model = Puma();
  model.name = std::string(62, 'r') + "ä";  // 64 bytes, the longest name there is
  const auto corrected = calibration::CorrectedModel(
      model, Eigen::VectorXd::Zero(model.num_parameters()), Eigen::Isometry3d::Identity());
  EXPECT_LE(corrected.name.size(), plausible::kMaxNameLength);
  EXPECT_TRUE(corrected.name.ends_with("-calibrated")) << corrected.name;
  const auto back = io::ParseRobotModel(io::FormatRobotModelYaml(corrected, "export"), "e.yaml");
  EXPECT_EQ(back.name, corrected.name);
}

}  // namespace armsig::testing
