// A robot's stored arm signature, in the model's parameter order.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "programs/volume.h"
#include "calibration/drift.h"
#include "calibration/model.h"
#include "calibration/residual_map.h"
#include "calibration/validity.h"
#include "db/database.h"
#include "db/store.h"

namespace armsig::workflows {

struct Signature {
  int version = 0;
  Eigen::VectorXd params, sigmas;
  std::optional<Eigen::Isometry3d> world_from_base;  // the measuring frame of its data
  // The residual map stored with the set; null = parametric only.
  std::shared_ptr<const calibration::ResidualMap> map;
  // The 6-DoF target's rotation in the last link frame, for a set fitted to measured
  // orientations; predict then gives the target's orientation too.
  std::optional<Eigen::Matrix3d> tool_rotation;
  // The identified parameters (model indices) and their covariance (empty for a set stored
  // before covariances were): the parametric prediction's own uncertainty.
  std::vector<int> identified;
  Eigen::MatrixXd covariance;
  // Where the set holds and its held-out σ (calibration/validity.h); empty for a set stored
  // before schema v13 (its terms then apply everywhere, and no held-out σ is known).
  calibration::SetValidity validity;
};

Signature SignatureOf(const calibration::RobotModel& model, const db::StoredCalibration& stored);
// The stored set as two sets are compared (calibration::CompareModels): its parameters,
// its identified ones and their covariance (none for a set stored before covariances were).
calibration::FittedSet FittedSetOf(const calibration::RobotModel& model, const Signature& sig,
                                   const db::StoredCalibration& stored);

// The robot's model as the set uses it: its non-geometric terms held to the joint arcs the
// set was fitted on (RobotModel::term_support, when the set stored them).
struct ActiveSignature {
  calibration::RobotModel model;
  Signature signature;
  std::vector<int64_t> sessions;  // the sessions it was fitted and validated on (empty: not recorded)
};
// The session ids a stored set's inputs_json names (ids stored as text by older versions too).
std::vector<int64_t> InputSessions(const nlohmann::json& inputs);
// Throws InputError naming the robot when it is unknown or has no active set.
ActiveSignature LoadActiveSignature(db::Database& database, const std::string& robot);
// A stored set in use (`--set N`): version `version` of the robot, active or not; the
// active one when nullopt. InputError naming the versions there are for an unknown one.
ActiveSignature LoadSignature(db::Database& database, const std::string& robot,
                              std::optional<int> version);

// The frame positions are given in: "robot" (its aligned base, N1 = I) or "measurement"
// (the measuring frame of the data the set was fitted on). Throws InputError otherwise.
Eigen::Isometry3d FrameOf(const ActiveSignature& active, const std::string& frame);

// armsig predict: calibrated and nominal target positions for every row of a joints CSV
// (pose,q1_deg,…). Returns the positions CSV. With a residual map, the calibrated
// position includes its correction, and two columns say so: `map` (applied | outside:
// the configuration is outside the map's support and gets the parametric prediction |
// none) and `map_sigma_mm` (the map's predictive σ per coordinate, when `map_sigma` asks
// for it: about 30 µs a configuration; empty otherwise). `model_sigma_mm`: the parametric
// prediction's standard error per coordinate from the fitted parameters' covariance
// (ParametricSigmaMm; empty for a set stored without one). A set fitted to measured
// orientations adds the calibrated target frame's orientation, rx_deg,ry_deg,rz_deg
// (core/rotation.h; the map corrects positions only).
// The standard error per coordinate (mm, √(tr(J Σ Jᵀ)/3)) of the parametric prediction at
// `joints_rad`: Σ the identified parameters' covariance, J the position's derivatives by them.
// It grows where the fit poses did not constrain the parameters (extrapolation); it holds
// the parameters' noise only, not what the model cannot represent. NaN without a covariance.
double ParametricSigmaMm(const calibration::RobotModel& model, const Signature& signature,
                         const Eigen::VectorXd& joints_rad);

std::string PredictCsv(const ActiveSignature& active, const Eigen::Isometry3d& frame,
                       const std::string& joints_csv, bool map_sigma = false);

// armsig compensate: joints that make the calibrated robot reach each target of a CSV
// (point,x_mm,y_mm,z_mm[,q1_deg,… the nominal program]).
struct CompensationResult {
  std::string csv;  // point,q…_deg,nominal_q…_deg,residual_mm,status,model_sigma_mm
  int targets = 0;
  std::vector<std::string> unreachable;  // one message per target that could not be reached
  int outside_map = 0;  // reached with the parametric model only: outside the map's support
  // Reached with a joint outside the range the set's terms were fitted on (held there).
  int outside_fit = 0;
};
// `volume` (ValidatedVolumeOf): where the set was validated, robot frame. When no target
// lies in it and most (80 %) would read in metres or inches, the file is
// refused naming its unit (a target in metres in an mm column "compensated" as ok).
CompensationResult Compensate(const ActiveSignature& active, const Eigen::Isometry3d& frame,
                              const std::string& targets_csv,
                              const std::optional<Eigen::VectorXd>& seed_rad,
                              const programs::ValidatedVolume* volume = nullptr);

// armsig export: the active set as json | model (corrected model YAML) | urdf. The JSON
// carries the residual map; a model YAML or URDF cannot, and says so in `warning`.
struct ExportResult {
  std::string text;
  std::string warning;  // what a URDF or a model YAML cannot carry
};
ExportResult ExportSignature(const ActiveSignature& active, const std::string& robot,
                             const std::string& format, const std::string& frame_name);

}  // namespace armsig::workflows
