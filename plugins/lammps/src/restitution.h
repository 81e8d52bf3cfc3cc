/* -*- c++ -*- ----------------------------------------------------------
   geocontact: the coefficient of restitution of the plugin's viscous damping (docs/dem.md,
   "Damping as a coefficient of restitution").

   The pair and the walls damp the normal motion at a fraction beta of critical,
   F_n = F(delta) + 2 beta sqrt(m_eff k) d(delta)/dt with k = dF/d(delta) (contact_forces.h),
   and F_n >= 0. On an elastic Hertz impact (F = K delta^3/2, k = 3/2 K delta^1/2) the damping
   force scales as delta^1/4 like Tsuji et al.'s (1992), so the coefficient of restitution e
   depends on beta alone, not on the impact speed, the masses or the modulus: with
   delta = X x, t = T s, X = (m v0^2 / K)^2/5, T = X / v0,

       x'' = -x^3/2 - 2 beta sqrt(3/2) x^1/4 x',   x(0) = 0, x'(0) = 1,

   and e = -x' when F_n falls to zero (the grains part; after it the force would pull, which the
   contact never does). e(beta) falls from 1 (beta = 0) through 0.73 (0.1), 0.27 (0.5) and
   0.12 (1.0); `restitution e` is converted to beta once, at the keyword, by bisection.
------------------------------------------------------------------------- */

#ifndef GEOCONTACT_RESTITUTION_H
#define GEOCONTACT_RESTITUTION_H

#include <cmath>

namespace LAMMPS_NS {
namespace geocontact_forces {

// the range `restitution` accepts: below 0.01 the damping is over 30x critical and the
// impact is not a bounce any more
constexpr double kMinRestitution = 0.01;
constexpr double kMaxDampingForRestitution = 100.0;

// e of a Hertz impact damped at the fraction beta of critical (header comment); classical
// Runge-Kutta in the dimensionless time, the parting point interpolated within the last step
inline double restitution_of_damping(double beta)
{
  if (!(beta > 0.0)) return 1.0;
  const double c = 2.0 * beta * std::sqrt(1.5);
  const double h = 2e-4 / (1.0 + beta);
  auto force = [c](double x, double v) {
    const double xp = x > 0.0 ? x : 0.0;
    return xp * std::sqrt(xp) + c * std::sqrt(std::sqrt(xp)) * v;
  };
  double x = 0.0, v = 1.0, f = 0.0;
  for (long step = 0; step < 100000000L; ++step) {
    const double k1x = v, k1v = -force(x, v);
    const double k2x = v + 0.5 * h * k1v, k2v = -force(x + 0.5 * h * k1x, v + 0.5 * h * k1v);
    const double k3x = v + 0.5 * h * k2v, k3v = -force(x + 0.5 * h * k2x, v + 0.5 * h * k2v);
    const double k4x = v + h * k3v, k4v = -force(x + h * k3x, v + h * k3v);
    const double xn = x + h / 6.0 * (k1x + 2.0 * k2x + 2.0 * k3x + k4x);
    const double vn = v + h / 6.0 * (k1v + 2.0 * k2v + 2.0 * k3v + k4v);
    const double fn = force(xn, vn);
    if (vn < 0.0 && (fn <= 0.0 || xn <= 0.0)) {
      // parted within this step: v where F_n (or x) crossed zero, linearly
      const double g0 = xn <= 0.0 && fn > 0.0 ? x : f, g1 = xn <= 0.0 && fn > 0.0 ? xn : fn;
      const double w = g0 > g1 ? g0 / (g0 - g1) : 1.0;
      return -(v + w * (vn - v));
    }
    x = xn;
    v = vn;
    f = fn;
  }
  return 0.0;  // not reached for beta <= kMaxDampingForRestitution
}

// beta giving the restitution e in [kMinRestitution, 1] (e(beta) falls monotonically)
inline double damping_of_restitution(double e)
{
  if (e >= 1.0) return 0.0;
  double low = 0.0, high = 1.0;
  while (restitution_of_damping(high) > e && high < kMaxDampingForRestitution) high *= 2.0;
  for (int k = 0; k < 60 && high - low > 1e-12 * high; ++k) {
    const double mid = 0.5 * (low + high);
    (restitution_of_damping(mid) > e ? low : high) = mid;
  }
  return 0.5 * (low + high);
}

}  // namespace geocontact_forces
}  // namespace LAMMPS_NS

#endif
