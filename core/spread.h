// How a set of points spreads out in space: whether points given to a rigid alignment
// (Umeyama) fix its rotation, or lie on a line or in one spot.
#pragma once

#include <Eigen/Core>

namespace armsig {

// The root sums of squares of the points' distances from their centroid along their three
// principal axes, largest first: the singular values of the centred 3×N point matrix.
// Computed from its 3×3 scatter matrix (a symmetric eigenproblem): the same figures for any
// test of "on a line" (the second against the first) down to a ratio of about 1e-7.
Eigen::Vector3d PrincipalSpread(const Eigen::Matrix3Xd& points);

}  // namespace armsig
