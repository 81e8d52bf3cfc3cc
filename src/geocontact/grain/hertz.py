"""Elastic Hertz contact of two identical spheres and its incipient Drucker-Prager yield.

docs/model.md §2 and 4. Everything is in the ball-ball approach delta (SI units, compression
positive); E* = E / (2 (1 - nu^2)) and R* = R / 2 come from ``grain.material.Material``.

Hertz (Johnson, *Contact Mechanics*, 1985, section 4.2, with E* and R*)::

    F = (4/3) E* sqrt(R*) delta^(3/2),   a = sqrt(R* delta),   p0 = 2 E* a / (pi R*)

The sub-surface stress field is Huber's closed form (Johnson eq. 3.45), written here in a form
that stays finite on the axis, on the surface and at the contact edge (see :func:`stress_field`).
Because the field scales with p0, first yield is at p0_y = sigma_c / C where C is the largest
p0-normalised Drucker-Prager measure over the half-space (:func:`incipient_yield`). For small
friction angles C is on the axis (von Mises, nu = 0.3: p0_y = 1.613 sigma_c at z = 0.48 a); as
beta grows the axis point moves deeper and, above a critical beta (49.06 deg for nu = 0.25), the
maximum jumps to the contact edge r = a, z = 0, where the surface is in pure shear (Johnson
eq. 3.44: sigma_r = -sigma_theta = (1 - 2 nu) p0 / 3, p = 0) and C = (1 - 2 nu)/(sqrt(3)(1 - tan
beta / 3)).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from functools import lru_cache
from typing import NamedTuple

import numpy as np
from scipy import optimize

from ..errors import InputError
from .material import Material

# --- Hertz: force, approach, contact radius, pressure, stiffness ----------------------------


def _output(value: np.ndarray, like) -> float | np.ndarray:
    """A float for scalar input, an array otherwise."""
    return float(value) if np.ndim(like) == 0 else value


def hertz_coefficient(material: Material) -> float:
    """Kh = (4/3) E* sqrt(R*), so that F = Kh delta^(3/2)."""
    return 4.0 / 3.0 * material.effective_modulus * math.sqrt(material.effective_radius)


def hertz_force(material: Material, approach) -> float | np.ndarray:
    """Normal force F = Kh delta^(3/2) for the ball-ball approach delta; 0 without contact."""
    delta = np.clip(np.asarray(approach, dtype=float), 0.0, None)
    return _output(hertz_coefficient(material) * delta**1.5, approach)


def hertz_approach(material: Material, force) -> float | np.ndarray:
    """Inverse of :func:`hertz_force`: delta = (F / Kh)^(2/3); 0 for F <= 0."""
    load = np.clip(np.asarray(force, dtype=float), 0.0, None)
    return _output((load / hertz_coefficient(material)) ** (2.0 / 3.0), force)


def contact_radius(material: Material, approach) -> float | np.ndarray:
    """a = sqrt(R* delta); 0 without contact."""
    delta = np.clip(np.asarray(approach, dtype=float), 0.0, None)
    return _output(np.sqrt(material.effective_radius * delta), approach)


def peak_pressure(material: Material, approach) -> float | np.ndarray:
    """p0 = 2 E* a / (pi R*); the mean pressure is 2 p0 / 3."""
    a = np.asarray(contact_radius(material, approach))
    p0 = 2.0 * material.effective_modulus * a / (math.pi * material.effective_radius)
    return _output(p0, approach)


def hertz_stiffness(material: Material, approach) -> float | np.ndarray:
    """Tangent stiffness dF/d delta = 2 E* a = (3/2) Kh delta^(1/2)."""
    a = np.asarray(contact_radius(material, approach))
    return _output(2.0 * material.effective_modulus * a, approach)


# --- Huber's stress field (Johnson section 3.4) --------------------------------------------


class StressField(NamedTuple):
    """Axisymmetric stresses normalised by p0; compression is negative."""

    sigma_r: np.ndarray
    sigma_theta: np.ndarray
    sigma_z: np.ndarray
    tau_rz: np.ndarray


# Beyond this u/a^2 the term sqrt(u) arctan(1/sqrt(u)) - 1 is summed as its series in 1/u.
_LARGE_U = 100.0
_SERIES_TERMS = 12


def _arctan_deficit(u: np.ndarray) -> np.ndarray:
    """g(u) = sqrt(u) arctan(1/sqrt(u)) - 1, accurate also for u -> infinity.

    Direct evaluation loses the O(1/u) remainder to cancellation far from the contact; there
    g = sum_k>=1 (-1)^k u^-k / (2k + 1). arctan2 makes g(0) = -1 without a division.
    """
    v = np.sqrt(u)
    direct = v * np.arctan2(1.0, v) - 1.0
    x = 1.0 / np.maximum(u, _LARGE_U)
    series = np.zeros_like(x)
    for k in range(_SERIES_TERMS, 0, -1):  # Horner, highest power first
        series = x * ((-1.0) ** k / (2 * k + 1) + series)
    return np.where(u >= _LARGE_U, series, direct)


def stress_field(r_over_a, z_over_a, poissons_ratio: float) -> StressField:
    """Hertz sub-surface stresses sigma_r, sigma_theta, sigma_z, tau_rz divided by p0.

    Huber's closed form (Johnson eq. 3.45) with a = 1, rho = r/a, zeta = z/a and
    u = (1/2) {s + D}, s = rho^2 + zeta^2 - 1, D = sqrt(s^2 + 4 zeta^2)::

        sigma_r     =  (1-2nu)/3 T1 + T2 + w [-(1-nu)/(1+u) + (1+nu) g(u)]
        sigma_theta = -(1-2nu)/3 T1      + w [ (1-nu)/(1+u) + (1+nu) g(u)]
        sigma_z     = -T2
        tau_rz      = -rho sqrt(u) w^2 / ((u + w^2)(1 + u))

    with w = zeta / sqrt(u), T1 = (1 - w^3) / rho^2, T2 = w^3 u / (u^2 + zeta^2) = w^3/(u + w^2)
    and g(u) = sqrt(u) arctan(1/sqrt(u)) - 1; this is eq. 3.45 regrouped, not changed. The
    regrouping removes every 0/0: w^2 = (D - s)/2 = 2 zeta^2/(D + s) is evaluated on the side
    without cancellation (w -> sqrt(1 - rho^2) on the surface inside the contact, 0 outside), and
    (1 - w^2)/rho^2 = 2 w^2 / (D + 1 + zeta^2 - rho^2) near the axis, which is finite as rho -> 0.
    At the contact edge (rho = 1, zeta = 0) u = w = 0 and T2 = tau_rz = 0, their limits.
    """
    rho = np.asarray(r_over_a, dtype=float)
    zeta = np.asarray(z_over_a, dtype=float)
    valid = np.isfinite(rho) & np.isfinite(zeta) & (rho >= 0) & (zeta >= 0)
    if not np.all(valid):
        raise InputError("stress_field: r_over_a and z_over_a must be finite and >= 0")
    nu = float(poissons_ratio)
    rho, zeta = np.broadcast_arrays(rho, zeta)
    rho2, zeta2 = rho * rho, zeta * zeta

    s = rho2 + zeta2 - 1.0
    D = np.hypot(s, 2.0 * zeta)
    outer = s >= 0.0
    # u = (D + s)/2 and w^2 = zeta^2/u = (D - s)/2, each from its cancellation-free form:
    # u = (D + s)/2, w^2 = 2 zeta^2/(D + s) where s >= 0; u = 2 zeta^2/(D - s), w^2 = (D - s)/2
    # where s < 0. D + s = 0 only at the contact edge, where u = w = 0.
    d_plus_s = np.where(outer, D + s, 1.0)
    d_minus_s = np.where(outer, 1.0, D - s)
    at_edge = d_plus_s <= 0.0
    u = np.where(outer, 0.5 * (D + s), 2.0 * zeta2 / d_minus_s)
    w2 = np.where(outer, 2.0 * zeta2 / np.where(at_edge, 1.0, d_plus_s), 0.5 * (D - s))
    w = np.sqrt(w2)

    # (1 - w^2)/rho^2: series-free identity inside the cylinder rho^2 < 1 + zeta^2, direct outside.
    c = 1.0 + zeta2 - rho2
    near_axis = c > 0.0
    one_minus_w2_over_rho2 = np.where(
        near_axis,
        2.0 * w2 / np.where(near_axis, D + c, 1.0),
        (1.0 - w2) / np.where(near_axis, 1.0, rho2),
    )
    T1 = one_minus_w2_over_rho2 * (1.0 + w + w2) / (1.0 + w)  # (1 - w^3)/rho^2

    den = u + w2
    edge = den <= 0.0
    safe_den = np.where(edge, 1.0, den)
    T2 = np.where(edge, 0.0, w2 * w / safe_den)
    tau_rz = np.where(edge, 0.0, -rho * np.sqrt(u) * w2 / (safe_den * (1.0 + u)))

    g = _arctan_deficit(u)
    k = (1.0 - 2.0 * nu) / 3.0
    sigma_r = k * T1 + T2 + w * (-(1.0 - nu) / (1.0 + u) + (1.0 + nu) * g)
    sigma_theta = -k * T1 + w * ((1.0 - nu) / (1.0 + u) + (1.0 + nu) * g)
    sigma_z = -T2
    return StressField(sigma_r, sigma_theta, sigma_z, tau_rz)


# --- Drucker-Prager measure (docs/model.md §3) -----------------------------------------------


def pressure_and_equivalent_stress(field: StressField) -> tuple[np.ndarray, np.ndarray]:
    """p = -tr(sigma)/3 (compression positive) and q = sqrt(3 J2), hoop stress included."""
    p = -(field.sigma_r + field.sigma_theta + field.sigma_z) / 3.0
    s_r, s_theta, s_z = field.sigma_r + p, field.sigma_theta + p, field.sigma_z + p
    J2 = 0.5 * (s_r**2 + s_theta**2 + s_z**2) + field.tau_rz**2
    return p, np.sqrt(3.0 * J2)


def drucker_prager_measure(field: StressField, tan_beta: float) -> np.ndarray:
    """(q - p tan beta) / (1 - tan beta / 3): the stress that yields when it reaches sigma_c."""
    p, q = pressure_and_equivalent_stress(field)
    return (q - p * tan_beta) / (1.0 - tan_beta / 3.0)


# --- incipient yield (docs/model.md §4) ------------------------------------------------------

# Search box of the first-yield point, in units of the contact radius: outside it the field has
# decayed (as 1/rho^2 on the surface, 1/zeta^2 on the axis) far below its maxima.
_SEARCH_EXTENT = 3.0
# A location this close to z = 0 (in units of a) counts as on the surface.
_SURFACE_TOLERANCE = 1e-6


def _search_axis(n: int) -> np.ndarray:
    """[0, 3] with points clustered near 0 and 1 (the surface and the contact edge)."""
    t = np.linspace(0.0, 1.0, n)
    clustered = np.concatenate([t**2, 1.0 - (1.0 - t) ** 2, 1.0 + 2.0 * t**2, [1e-9, 1e-6, 1e-3]])
    return np.unique(np.clip(clustered, 0.0, _SEARCH_EXTENT))


@lru_cache(maxsize=256)
def _first_yield_point(poissons_ratio: float, friction_angle_deg: float):
    """(C, r/a, z/a): the maximum of the p0-normalised DP measure over the half-space."""
    tan_beta = math.tan(math.radians(friction_angle_deg))

    def measure(rho, zeta):
        return drucker_prager_measure(stress_field(rho, zeta, poissons_ratio), tan_beta)

    def negative(x):
        return -float(measure(x[0], x[1]))

    # Exact points and 1-D searches first, so that among equal maxima (to round-off) the
    # reported location is the exact one (r = 0 on the axis, z = 0 on the surface).
    candidates: list[tuple[float, float, float]] = []
    # 1. The contact edge, where the surface stress has a kink, and the two lines on which the
    #    maximum sits in the limits beta -> 0 (the axis) and beta large (the surface).
    candidates.append((float(measure(1.0, 0.0)), 1.0, 0.0))
    brent = {"method": "bounded", "options": {"xatol": 1e-12}}
    for lo, hi in ((0.0, 1.0), (1.0, _SEARCH_EXTENT)):
        res = optimize.minimize_scalar(lambda x: negative((x, 0.0)), bounds=(lo, hi), **brent)
        candidates.append((-float(res.fun), float(res.x), 0.0))
    res = optimize.minimize_scalar(
        lambda x: negative((0.0, x)), bounds=(0.0, _SEARCH_EXTENT), **brent
    )
    candidates.append((-float(res.fun), 0.0, float(res.x)))
    # 2. Global grid, refined near the surface and the contact edge.
    axis = _search_axis(161)
    rho, zeta = np.meshgrid(axis, axis, indexing="ij")
    values = measure(rho, zeta).ravel()
    best_grid = [
        (float(values[i]), float(rho.flat[i]), float(zeta.flat[i]))
        for i in np.argsort(values)[-4:]
    ]
    # 3. Bounded local optimisation from the best few grid points.
    bounds = [(0.0, _SEARCH_EXTENT), (0.0, _SEARCH_EXTENT)]
    for _, r0, z0 in best_grid:
        res = optimize.minimize(
            negative, x0=[r0, z0], method="Nelder-Mead", bounds=bounds,
            options={"xatol": 1e-11, "fatol": 1e-15, "maxiter": 4000},
        )
        candidates.append((-float(res.fun), float(res.x[0]), float(res.x[1])))
    candidates += best_grid
    top = max(value for value, _, _ in candidates)
    return next(c for c in candidates if c[0] >= top - 1e-12 * abs(top))


@dataclass(frozen=True)
class IncipientYield:
    """First yield of the Hertz contact (docs/model.md §4); lengths in m, force in N."""

    force: float
    approach: float
    contact_radius: float
    peak_pressure: float
    r_over_a: float
    z_over_a: float
    at_surface: bool
    dp_factor: float  # C = max (DP measure / p0); p0_y = sigma_c / C

    def to_dict(self) -> dict[str, float | bool]:
        d = asdict(self)
        return {
            "force_N": d["force"],
            "approach_m": d["approach"],
            "contact_radius_m": d["contact_radius"],
            "peak_pressure_Pa": d["peak_pressure"],
            "mean_pressure_Pa": 2.0 * d["peak_pressure"] / 3.0,
            "location_r_over_a": d["r_over_a"],
            "location_z_over_a": d["z_over_a"],
            "location_r_m": d["r_over_a"] * d["contact_radius"],
            "location_z_m": d["z_over_a"] * d["contact_radius"],
            "at_surface": d["at_surface"],
            "dp_factor": d["dp_factor"],
        }


def incipient_yield(material: Material) -> IncipientYield:
    """Force, approach, contact radius and p0 at which the elastic field first reaches yield.

    p0_y = sigma_c / C; a_y = pi R* p0_y / (2 E*); delta_y = a_y^2 / R*; F_y = Kh delta_y^(3/2)
    (the same formula as :func:`hertz_force`, so that the loading curve is continuous at delta_y).
    """
    C, r_over_a, z_over_a = _first_yield_point(material.poissons_ratio,
                                               material.friction_angle_deg)
    p0 = material.compressive_yield_stress / C
    a = math.pi * material.effective_radius * p0 / (2.0 * material.effective_modulus)
    approach = a * a / material.effective_radius
    return IncipientYield(
        force=float(hertz_force(material, approach)),
        approach=approach,
        contact_radius=a,
        peak_pressure=p0,
        r_over_a=r_over_a,
        z_over_a=z_over_a,
        at_surface=z_over_a <= _SURFACE_TOLERANCE,
        dp_factor=C,
    )
