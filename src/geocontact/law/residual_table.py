"""The tabulated residual-approach form (docs/law.md, "Tabulated residual approach").

Knots (x_k, rho_k) of the residual ratio rho = delta_res/delta_max against the plastic depth
x = delta_max/delta_y, interpolated in the coordinates

    u = ln(ln x),    g = logit(rho) = ln(rho / (1 - rho)),

by a monotone cubic Hermite spline (PCHIP): interior knot slopes by the Fritsch-Butland
weighted harmonic mean of the neighbouring secants (Fritsch & Butland 1984, what scipy's
``PchipInterpolator`` uses; 0 where the secants change sign or one vanishes), end-knot slopes
the secant of the end segment, and beyond the end knots the straight line in (u, g) with that
slope, so the function is C1 everywhere. In these coordinates rho -> 0 as x -> 1 (u -> -inf)
like a power of ln x and rho -> 1 only as x -> inf: both ends of the physical range are where
the lines go. rho = 0 for x <= 1.

The C++ header (``ResidualTable`` in ``plugins/lammps/include/geocontact/law.hpp``) computes
the same slopes and coefficients once when the parameters are derived, and evaluates them with
the same operations; the golden vectors hold the two together.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property
from typing import NamedTuple

import numpy as np

# g is capped here before rho = 1/(1 + exp(-g)): 1/(1 + e^-36) rounds to 1 - 2^-52 < 1, so
# delta_res < delta_max always (an unloading span of zero would divide by zero); e^-37 would
# round 1 + e^-37 to 1. A knot ratio of 1 - 2e-16 or closer is read as 1 - 2^-52.
LOGIT_CAP = 36.0


def knot_slopes(u: np.ndarray, g: np.ndarray) -> np.ndarray:
    """dg/du at the knots: the Fritsch-Butland weighted harmonic mean of the two secants inside
    (0 where they change sign or one is 0), the end segment's secant at each end."""
    h = np.diff(u)
    secant = np.diff(g) / h
    slopes = np.empty_like(g)
    slopes[0], slopes[-1] = secant[0], secant[-1]
    before, after = secant[:-1], secant[1:]
    w1 = 2.0 * h[1:] + h[:-1]
    w2 = h[1:] + 2.0 * h[:-1]
    flat = (before * after <= 0.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        mean = 1.0 / ((w1 / before + w2 / after) / (w1 + w2))
    slopes[1:-1] = np.where(flat, 0.0, mean)
    return slopes


class _Spline(NamedTuple):
    u: np.ndarray  # ln ln x_k
    g: np.ndarray  # logit rho_k
    slope: np.ndarray  # dg/du at the knots
    quadratic: np.ndarray  # per segment: g = g_k + s (m_k + s (c2_k + s c3_k)), s = u - u_k
    cubic: np.ndarray


@dataclass(frozen=True)
class ResidualTable:
    """The knots of a tabulated residual ratio (empty: the law uses the closed form)."""

    depth: tuple[float, ...] = ()
    ratio: tuple[float, ...] = ()

    def __post_init__(self) -> None:
        # tuples (hashable, frozen); the entries are checked by LawParams, with the messages
        # of the file's schema
        object.__setattr__(self, "depth", tuple(self.depth))
        object.__setattr__(self, "ratio", tuple(self.ratio))

    def __bool__(self) -> bool:
        return bool(self.depth)

    @cached_property
    def spline(self) -> _Spline:
        """The Hermite spline in (u, g), computed once (the C++ ``ResidualTable::derive``)."""
        x = np.asarray(self.depth)
        rho = np.asarray(self.ratio)
        u = np.log(np.log(x))
        g = np.log(rho) - np.log1p(-rho)
        m = knot_slopes(u, g)
        h = np.diff(u)
        secant = np.diff(g) / h
        quadratic = (3.0 * secant - 2.0 * m[:-1] - m[1:]) / h
        cubic = (m[:-1] + m[1:] - 2.0 * secant) / (h * h)
        return _Spline(u, g, m, quadratic, cubic)

    def logit(self, depth):
        """g(u) at u = ln ln x for x > 1 (vectorised; -inf at x = 1)."""
        sp = self.spline
        x = np.maximum(np.asarray(depth, dtype=float), 1.0)
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            u = np.log(np.log(x))
            k = np.clip(np.searchsorted(sp.u, u, side="right") - 1, 0, sp.u.size - 2)
            s = u - sp.u[k]
            inside = sp.g[k] + s * (sp.slope[k] + s * (sp.quadratic[k] + s * sp.cubic[k]))
            below = sp.g[0] + sp.slope[0] * (u - sp.u[0])
            above = sp.g[-1] + sp.slope[-1] * (u - sp.u[-1])
            g = np.where(u <= sp.u[0], below, np.where(u >= sp.u[-1], above, inside))
        return np.where(x > 1.0, g, -np.inf)

    def __call__(self, depth):
        """rho(x) = 1/(1 + exp(-g)), 0 for x <= 1 (vectorised)."""
        x = np.asarray(depth, dtype=float)
        g = np.minimum(self.logit(x), LOGIT_CAP)
        with np.errstate(over="ignore"):
            rho = 1.0 / (1.0 + np.exp(-g))
        return np.where(x > 1.0, rho, 0.0)

    def to_dict(self) -> dict[str, list[float]]:
        return {"depth": list(self.depth), "ratio": list(self.ratio)}
