#include "ekf_vislam/core/chi_square.h"

#include <cmath>
#include <limits>

namespace ekf_vislam {
namespace {

// Regularized lower incomplete gamma P(a, x): series for x < a + 1, continued fraction otherwise
// (Numerical Recipes 6.2).
double regularizedLowerGamma(double a, double x) {
  if (x <= 0.0) return 0.0;
  const double log_prefix = -x + a * std::log(x) - std::lgamma(a);
  if (x < a + 1.0) {
    double term = 1.0 / a, sum = term;
    for (int n = 1; n < 1000; ++n) {
      term *= x / (a + n);
      sum += term;
      if (std::fabs(term) < std::fabs(sum) * 1e-16) break;
    }
    return sum * std::exp(log_prefix);
  }
  const double tiny = 1e-300;
  double b = x + 1.0 - a, c = 1.0 / tiny, d = 1.0 / b, h = d;
  for (int i = 1; i < 1000; ++i) {
    const double an = -i * (i - a);
    b += 2.0;
    d = an * d + b;
    if (std::fabs(d) < tiny) d = tiny;
    c = b + an / c;
    if (std::fabs(c) < tiny) c = tiny;
    d = 1.0 / d;
    const double delta = d * c;
    h *= delta;
    if (std::fabs(delta - 1.0) < 1e-16) break;
  }
  return 1.0 - std::exp(log_prefix) * h;
}

}  // namespace

double chiSquareCdf(double x, int dof) {
  if (dof <= 0) return std::numeric_limits<double>::quiet_NaN();
  return regularizedLowerGamma(0.5 * dof, 0.5 * x);
}

double chiSquareQuantile(double probability, int dof) {
  if (dof <= 0 || !(probability > 0.0) || !(probability < 1.0)) {
    return std::numeric_limits<double>::quiet_NaN();
  }
  // Bracket, then bisection (monotone CDF; 200 halvings reach double precision).
  double lo = 0.0, hi = std::max(1.0, static_cast<double>(dof));
  while (chiSquareCdf(hi, dof) < probability) hi *= 2.0;
  for (int i = 0; i < 200 && hi - lo > 1e-12 * hi; ++i) {
    const double mid = 0.5 * (lo + hi);
    (chiSquareCdf(mid, dof) < probability ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

}  // namespace ekf_vislam
