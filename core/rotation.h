// A rotation given by three angles in files: the measured orientation of a 6-DoF target
// (docs/reference/conventions.md, "Measured orientation").
#pragma once

#include <Eigen/Core>

namespace armsig {

// R = Rx(rx)·Ry(ry)·Rz(rz): a turn about the frame's x axis, then about the new y, then
// about the newest z (intrinsic x-y′-z″; the same matrix as turns about the fixed z, y, x
// axes in that order). The convention of the poses CSV's rx_deg, ry_deg, rz_deg and of the
// Leica laser tracker's 6-DoF probe angles in the IPA UR10 files (found by testing every
// order against the arm's kinematics: bench/orientation_convention_explore.cc).
Eigen::Matrix3d RotationFromRxRyRz(const Eigen::Vector3d& angles_rad);

// The angles of a rotation in that convention: ry in [−π/2, π/2], rx and rz in [−π, π]. At
// ry = ±π/2 (gimbal lock: only rx ± rz is defined) rz is 0.
Eigen::Vector3d RxRyRzFromRotation(const Eigen::Matrix3d& rotation);

// How small changes of the three angles turn the frame, seen in the turned frame itself:
// R(a + da) ≈ R(a)·exp([J·da]×) with J the returned matrix (columns ∂ω/∂rx, ∂ω/∂ry,
// ∂ω/∂rz). The angles' standard deviations σ give the rotation's covariance J·diag(σ²)·Jᵀ.
Eigen::Matrix3d BodyRatesOfRxRyRz(const Eigen::Vector3d& angles_rad);

}  // namespace armsig
