"""The coefficient of restitution of the plugin's viscous damping on an elastic Hertz impact
(docs/dem.md, "Damping as a coefficient of restitution"), for the DEM drivers that give
LAMMPS's granular styles the restitution the plugin's `damping beta` has.

The plugin damps at the fraction beta of critical, F_n = F + 2 beta sqrt(m k) d(delta)/dt with
k = dF/d(delta), F_n >= 0; on Hertz's F = K delta^3/2 the restitution depends on beta alone:
x'' = -x^3/2 - 2 beta sqrt(3/2) x^1/4 x' from x = 0, x' = 1, and e = -x' where F_n returns to
zero. The plugin solves the same problem in C++ (plugins/lammps/src/restitution.h: fixed-step
Runge-Kutta, bisection for `restitution e`); here scipy's adaptive integrator with an event.
"""

from __future__ import annotations

import math

from scipy.integrate import solve_ivp

from ..errors import InputError


def restitution_of_damping(beta: float) -> float:
    """e of an elastic Hertz impact damped at ``beta`` of critical (module docstring)."""
    if not (math.isfinite(beta) and 0.0 <= beta <= 100.0):
        raise InputError(f"damping: must be in [0, 100], got {beta:g}")
    if beta == 0.0:
        return 1.0
    c = 2.0 * beta * math.sqrt(1.5)

    def normal_force(x: float, v: float) -> float:
        xp = max(x, 0.0)
        return xp**1.5 + c * xp**0.25 * v

    def parted(_, y):
        return normal_force(y[0], y[1]) if y[1] < 0.0 else 1.0

    parted.terminal, parted.direction = True, -1
    sol = solve_ivp(lambda _, y: [y[1], -normal_force(y[0], y[1])], (0.0, 1e3), [0.0, 1.0],
                    events=parted, rtol=1e-11, atol=1e-13, max_step=1e-2)
    return -float(sol.y_events[0][0][1])
