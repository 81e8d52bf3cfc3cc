"""The material space of the universal law and the campaign's deterministic point list.

By similarity (docs/model.md §10) the normalised response F/Fy(x = delta/delta_y) of two identical
Drucker-Prager spheres depends on the friction angle beta, Poisson's ratio nu and the hardening
ratio m alone while the contact is small against the sphere; E/sigma_c enters only through the
finite size of the sphere. The campaign therefore spans four coordinates (``AXES``); the radius
and E are fixed (they scale out exactly: radius by docs/model.md §10, E at fixed E/sigma_c because
the
continuum problem is linear in the stress scale).

The point list is deterministic: the centre of the box, 8 of its corners (a half fraction),
8 points of a scrambled Sobol sequence (scipy.stats.qmc, fixed seed), the other 8 corners,
then the Sobol sequence on. Extending the campaign continues the same list, so a
dataset built over several sessions is one design.

    points = design_points(40)      # list of DesignPoint, the first 40 of the sequence
    material = points[3].material()  # the campaign's Material for that point
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from ..grain.hertz import incipient_yield
from ..grain.material import Material

# (name, low, high): the coordinates of the space, in the order
# of every array of this package.
AXES = (
    ("friction_angle_deg", 0.0, 55.0),
    ("poissons_ratio", 0.15, 0.35),
    ("hardening_ratio", 0.0, 0.3),
    ("log10_modulus_over_strength", 2.0, 4.0),
)
AXIS_NAMES = tuple(a[0] for a in AXES)
# The campaign's fixed scale (any other E and radius follow by similarity).
CAMPAIGN_MODULUS = 10e9  # Pa, the reference grain's
CAMPAIGN_RADIUS = 0.1  # m
SOBOL_SEED = 20261202
# Peaks of the calibration-grade set of one point, as multiples of the analytic Fy: LEVELS
# geometric from 2 Fy (the lowest level of `geocontact calibrate`) to the top
# TOP_AT_LOWEST x 10^(s - 2), s = log10(E/sigma_c). At fixed F/Fy the contact radius over R goes
# as 10^-s x sqrt(F/Fy) (a_y / R ~ sigma_c / E), so the top keeps a <= R/2 (the FE mesh's limit,
# README) at E/sigma_c = 100 for every beta, nu, m of the box (`largest_contact_over_radius`
# checks it on the fem.run estimate) and gives the weak grains, whose DEM forces are many
# thousand Fy, the depth range they need: 1400 Fy at E/sigma_c = 1000 (the shipped reference
# calibration goes to 2200 Fy), 14000 Fy at 10^4. One smooth function of s, so every level's
# data varies smoothly over the space.
LEVELS = 7
LOWEST_FORCE_OVER_YIELD = 2.0
TOP_AT_LOWEST = 140.0


def top_force_over_yield(log10_modulus_over_strength: float) -> float:
    return TOP_AT_LOWEST * 10.0 ** (float(log10_modulus_over_strength) - AXES[3][1])


def force_levels(log10_modulus_over_strength: float) -> np.ndarray:
    """The peaks of a point's FE runs, in units of the analytic first-yield force."""
    return np.geomspace(LOWEST_FORCE_OVER_YIELD,
                        top_force_over_yield(log10_modulus_over_strength), LEVELS)


@dataclass(frozen=True)
class DesignPoint:
    """One point of material space: its index in the sequence and its four coordinates."""

    index: int
    friction_angle_deg: float
    poissons_ratio: float
    hardening_ratio: float
    log10_modulus_over_strength: float

    @property
    def coordinates(self) -> tuple[float, float, float, float]:
        return tuple(float(getattr(self, name)) for name in AXIS_NAMES)  # type: ignore

    def material(self) -> Material:
        """The campaign's material at this point (E and R fixed, sigma_c = E / 10^s)."""
        return material_at(self.coordinates)


def material_at(coordinates, modulus: float = CAMPAIGN_MODULUS,
                radius: float = CAMPAIGN_RADIUS) -> Material:
    beta, nu, m, s = (float(v) for v in coordinates)
    return Material(youngs_modulus=modulus, poissons_ratio=nu,
                    compressive_yield_stress=modulus / 10.0**s, friction_angle_deg=beta,
                    hardening_ratio=m, radius=radius)


def coordinates_of(material: Material) -> np.ndarray:
    """The four coordinates of a material (any E and radius)."""
    return np.array([material.friction_angle_deg, material.poissons_ratio,
                     material.hardening_ratio,
                     math.log10(material.youngs_modulus / material.compressive_yield_stress)])


def unit(coordinates) -> np.ndarray:
    """Coordinates scaled to the unit box (each axis by its range)."""
    c = np.asarray(coordinates, dtype=float)
    low = np.array([a[1] for a in AXES])
    high = np.array([a[2] for a in AXES])
    return (c - low) / (high - low)


def from_unit(u) -> np.ndarray:
    low = np.array([a[1] for a in AXES])
    high = np.array([a[2] for a in AXES])
    return low + np.asarray(u, dtype=float) * (high - low)


def outside_range(material: Material) -> list[str]:
    """One message per coordinate of ``material`` outside the campaign's box (empty: inside)."""
    names = {"friction_angle_deg": "friction_angle_deg", "poissons_ratio": "poissons_ratio",
             "hardening_ratio": "hardening_ratio",
             "log10_modulus_over_strength": "youngs_modulus / compressive_yield_stress"}
    out = []
    for (name, low, high), value in zip(AXES, coordinates_of(material), strict=True):
        tol = 1e-9 * max(1.0, abs(high - low))
        if value < low - tol or value > high + tol:
            if name == "log10_modulus_over_strength":
                out.append(f"{names[name]}: {10**value:.4g} is outside the universal law's "
                           f"range [{10**low:g}, {10**high:g}]")
            else:
                out.append(f"{names[name]}: {value:g} is outside the universal law's range "
                           f"[{low:g}, {high:g}]")
    return out


def unit_sequence(count: int, dimensions: int = len(AXES)) -> np.ndarray:
    """The first ``count`` points of the campaign's sequence in the unit box (shared by every
    design version: ``record`` uses it on its own box)."""
    from scipy.stats import qmc

    # the 16 corners, the half fraction x4 = x1 x2 x3 (in +-1) first: its 8 corners span
    # every axis already, so a campaign stopped after 9 points still has a full-rank design
    corners = [np.array(c) for c in itertools.product((-1.0, 1.0), repeat=dimensions)]
    corners.sort(key=lambda c: c[3] != c[0] * c[1] * c[2])  # stable: product order within
    corners = [(c + 1.0) / 2.0 for c in corners]
    sobol = list(qmc.Sobol(d=dimensions, scramble=True, seed=SOBOL_SEED).random_base2(12))
    # centre, half-fraction corners, 8 interior Sobol points (the curvature a random material
    # inside the box needs), the other 8 corners (the interactions), then Sobol on
    sequence = [np.full(dimensions, 0.5), *corners[:8], *sobol[:8], *corners[8:], *sobol[8:]]
    return np.array(sequence[:count])


def design_points(count: int) -> list[DesignPoint]:
    """The first ``count`` points of the campaign's sequence (centre, corners, Sobol)."""
    if isinstance(count, bool) or not isinstance(count, int) or not 1 <= count <= 4096:
        raise InputError(f"points: need an integer in [1, 4096], got {count!r}")
    coords = from_unit(unit_sequence(count))
    return [DesignPoint(i, *(float(v) for v in c)) for i, c in enumerate(coords)]


def largest_contact_over_radius() -> float:
    """The largest contact radius over R that a top level reaches (``fem.run`` estimate, the
    one the mesh is sized with) over the corners of the box; must stay <= 1/2."""
    from ..fem.run import largest_contact_radius_estimate

    worst = 0.0
    for c in itertools.product(*[(a[1], a[2]) for a in AXES]):
        material = material_at(c)
        force = top_force_over_yield(c[3]) * incipient_yield(material).force
        worst = max(worst, largest_contact_radius_estimate(material, force) / material.radius)
    return worst
