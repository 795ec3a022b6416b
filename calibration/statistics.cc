#include "calibration/statistics.h"

#include <boost/math/distributions/chi_squared.hpp>
#include <boost/math/distributions/fisher_f.hpp>
#include <cmath>

namespace armsig::calibration {

double FisherFSurvival(double f, double d1, double d2) {
  if (!(f > 0.0)) return 1.0;
  if (std::isinf(f)) return 0.0;
  const boost::math::fisher_f_distribution<double> dist(d1, d2);
  return boost::math::cdf(boost::math::complement(dist, f));
}

double FisherFCritical(double alpha, double d1, double d2) {
  const boost::math::fisher_f_distribution<double> dist(d1, d2);
  return boost::math::quantile(boost::math::complement(dist, alpha));
}

double ChiSquareSurvival(double x, double dof) {
  if (!(x > 0.0)) return 1.0;
  if (std::isinf(x)) return 0.0;
  const boost::math::chi_squared_distribution<double> dist(dof);
  return boost::math::cdf(boost::math::complement(dist, x));
}

}  // namespace armsig::calibration
