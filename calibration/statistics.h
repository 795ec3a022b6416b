// Distributions for the statistical tests of the calibration.
#pragma once

namespace armsig::calibration {

// Regularised incomplete beta function I_x(a, b) (continued fraction, Lentz).
double RegularizedIncompleteBeta(double a, double b, double x);

// Upper tail P(F > f) of Fisher's F distribution with (d1, d2) degrees of freedom.
double FisherFSurvival(double f, double d1, double d2);

}  // namespace armsig::calibration
