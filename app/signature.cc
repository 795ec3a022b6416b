#include "app/signature.h"

#include <nlohmann/json.hpp>

#include "core/error.h"
#include "io/model_yaml.h"

namespace armsig::app {

Signature SignatureOf(const calibration::RobotModel& model, const db::StoredCalibration& stored) {
  Signature s;
  s.version = stored.version;
  s.params = Eigen::VectorXd::Zero(model.num_parameters());
  s.sigmas = Eigen::VectorXd::Constant(model.num_parameters(), NAN);
  for (const auto& p : stored.parameters) {
    const int k = model.IndexOf(p.name);
    if (k < 0) continue;
    s.params(k) = p.value;
    if (p.identified) s.sigmas(k) = p.sigma;
  }
  if (!stored.report_json.empty()) {
    const auto j = nlohmann::json::parse(stored.report_json);
    if (j.contains("base")) {
      Eigen::Isometry3d base = Eigen::Isometry3d::Identity();
      for (int r = 0; r < 4; ++r)
        for (int c = 0; c < 4; ++c) base.matrix()(r, c) = j["base"][r][c].get<double>();
      s.world_from_base = base;
    }
  }
  return s;
}

ActiveSignature LoadActiveSignature(db::Database& database, const std::string& robot) {
  const auto id = db::FindRobot(database, robot);
  if (!id)
    throw InputError({database.path(), 0, 0, "--robot"},
                     "no robot '" + robot + "' in the database");
  const auto active = db::ActiveCalibration(database, *id);
  if (!active) {
    throw InputError(
        {database.path(), 0, 0, "--robot"},
        "robot '" + robot + "' has no active parameter set (run armsig recalibrate first)");
  }
  ActiveSignature out{
      io::ParseRobotModel(db::RobotModelYaml(database, *id), "model of robot " + robot), {}};
  out.signature = SignatureOf(out.model, *active);
  return out;
}

}  // namespace armsig::app
