// Theodolite observation model (SPEC "Theodolite frame"): z up along the standing
// axis, y towards circle zero, Hz clockwise seen from above, V the zenith angle.
#pragma once

#include <Eigen/Core>

#include "core/types.h"

namespace armsig::reduction {

// Face-II readings reduced to face I: Hz − 200 gon, 400 gon − V.
AngleReading ToFaceOne(const AngleReading& reading);

// Unit direction in the instrument frame of a face-I reading:
// (sin V sin Hz, sin V cos Hz, cos V).
Eigen::Vector3d DirectionInStation(const AngleReading& reading);

// Hz, V (face I) of a direction in the instrument frame.
AngleReading ReadingOf(const Eigen::Vector3d& direction_in_station);

// World from station for a levelled station: rotation about z by −azimuth.
Eigen::Matrix3d LevelledRotation(double azimuth_rad);

}  // namespace armsig::reduction
