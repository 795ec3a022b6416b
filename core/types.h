// Value types shared by several modules. Eigen only.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace armsig {

// One theodolite reading, as observed (face I or II), in the theodolite frame of
// docs/reference/conventions.md.
struct AngleReading {
  double hz_rad = 0.0;  // clockwise from circle zero
  double v_rad = 0.0;   // zenith angle
  int face = 1;         // 1 or 2
};

// The face a reading is on when the file or device does not say: "a reading with V > 200
// gon is face II" (docs/reference/conventions.md). The nadir itself (V = 200 gon given in
// gon or deg, which converts to π plus a rounding ulp) is face I, as is anything within
// 1e-12 rad of it.
inline int FaceOfZenithAngle(double v_rad) {
  return v_rad > 3.14159265358979323846 + 1e-12 ? 2 : 1;
}

// The measured orientation of the target frame (a 6-DoF probe on the flange): the rotation
// from the target frame into the measurement frame. Files give it by three angles
// (core/rotation.h), with their a-priori standard deviations when the instrument reports
// them.
struct MeasuredOrientation {
  Eigen::Matrix3d world_from_target = Eigen::Matrix3d::Identity();
  std::optional<Eigen::Vector3d> sigma_rad = std::nullopt;  // of rx, ry, rz; nullopt: not given
};

// A robot configuration with its measured target position (measurement frame).
struct MeasuredPose {
  std::string id;
  Eigen::VectorXd joints_rad;       // encoder angles θ̄, zero at the null configuration
  Eigen::Vector3d target_in_world;  // measured target position, mm, in frame `frame`
  // The measurement frame `target_in_world` is given in: one per set-up of the instruments
  // (a capture session, an imported file; the database uses the session id). Poses of
  // different frames are fitted with one robot base each (calibration::Estimate).
  int64_t frame = 0;
  // The target frame's measured orientation in the same frame; nullopt for a position-only
  // measurement (a reflector, a theodolite intersection).
  std::optional<MeasuredOrientation> orientation = std::nullopt;
  // The position equations' weight relative to a point measured standing (1): a point paired
  // from a sweep's streams (measuring on the move) weighs σ² / (σ² + σ_sync²), σ the
  // instrument's, σ_sync its speed × the clock's uncertainty (calibration::Estimate).
  double weight = 1.0;
};

// Station pose: world point = position + R · instrument point (docs/reference/conventions.md).
struct StationPose {
  std::string id;
  Eigen::Vector3d position_mm = Eigen::Vector3d::Zero();
  Eigen::Matrix3d world_from_station = Eigen::Matrix3d::Identity();
  bool levelled = true;
  double azimuth_rad = 0.0;  // meaningful when levelled
};

}  // namespace armsig
