// Distributions for the statistical tests of the calibration (Boost.Math).
#pragma once

namespace armsig::calibration {

// Upper tail P(F > f) of Fisher's F distribution with (d1, d2) degrees of freedom
// (boost::math::fisher_f). f ≤ 0 gives 1, f = +∞ gives 0.
double FisherFSurvival(double f, double d1, double d2);

// The critical value F(1 − alpha; d1, d2): P(F > value) = alpha.
double FisherFCritical(double alpha, double d1, double d2);

// Upper tail P(X > x) of the chi-square distribution with `dof` degrees of freedom
// (boost::math::chi_squared): the global test of an adjustment is
// ChiSquareSurvival(σ0² · dof, dof). x ≤ 0 gives 1, x = +∞ gives 0.
double ChiSquareSurvival(double x, double dof);

}  // namespace armsig::calibration
