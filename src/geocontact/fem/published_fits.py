"""Published FE fits of an elastic-perfectly plastic (von Mises) sphere pressed by a rigid flat.

Used to verify the FE engine in its von Mises limit (SPEC section 5, beta = 0; see
docs/verification.md). Both fits describe ONE deformable sphere of radius R against a rigid,
frictionless flat, i.e. exactly the half model of :mod:`geocontact.fem` with the interference
omega = the ball-wall interference (= half the ball-ball approach). Their elastic modulus is that
of a sphere on a rigid flat, E' = E / (1 - nu^2) (not the E* of two spheres).

- Kogut, L. & Etsion, I. (2002) Elastic-plastic contact analysis of a sphere and a rigid flat.
  J. Appl. Mech. 69, 657-662. Critical interference omega_c = (pi K H / (2 E'))^2 R with
  K = 0.454 + 0.41 nu and H = 2.8 S_y; P_c the Hertz load at omega_c;
  P/P_c = 1.03 (omega/omega_c)^1.425 for 1 <= omega/omega_c <= 6 and
  1.40 (omega/omega_c)^1.263 for 6 <= omega/omega_c <= 110 (Hertz below 1).
- Jackson, R. L. & Green, I. (2005) A finite element study of elasto-plastic hemispherical
  contact against a rigid flat. J. Tribol. 127, 343-354. omega_c = (pi C S_y / (2 E'))^2 R with
  C = 1.295 exp(0.736 nu); P_c = (4/3) (R / E')^2 (C pi S_y / 2)^3 (the Hertz load at omega_c);
  with w = omega / omega_c::

      P/P_c = exp(-(1/4) w^(5/12)) w^(3/2)
              + (4 H_G / (C S_y)) [1 - exp(-(1/25) w^(5/9))] w,
      H_G / S_y = 2.84 [1 - exp(-0.82 (a/R)^-0.7)],
      a = sqrt(R omega) (w / 1.9)^(B/2) for w >= 1.9 (Hertz a = sqrt(R omega) below),
      B = 0.14 exp(23 S_y / E').
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..material import Material


@dataclass(frozen=True)
class Critical:
    """Critical (first-yield) interference and load of one fit, for one sphere on a rigid flat."""

    interference: float  # m
    force: float  # N


def sphere_on_flat_modulus(material: Material) -> float:
    """E' = E / (1 - nu^2): a sphere of this material against a rigid flat."""
    return material.youngs_modulus / (1.0 - material.poissons_ratio**2)


def _hertz_sphere_on_flat(material: Material, interference: float) -> float:
    e = sphere_on_flat_modulus(material)
    return 4.0 / 3.0 * e * math.sqrt(material.radius) * interference**1.5


def _critical(material: Material, p0_over_sy: float) -> Critical:
    """omega_c = (pi p0 / (2 E'))^2 R with p0 the Hertz peak pressure at first yield."""
    e = sphere_on_flat_modulus(material)
    omega = (math.pi * p0_over_sy * material.compressive_yield_stress / (2.0 * e)) ** 2 \
        * material.radius
    return Critical(omega, _hertz_sphere_on_flat(material, omega))


# --- Kogut & Etsion (2002) ---------------------------------------------------------------------
def kogut_etsion_critical(material: Material) -> Critical:
    k = 0.454 + 0.41 * material.poissons_ratio
    return _critical(material, k * 2.8)


def kogut_etsion_load(w) -> np.ndarray:
    """P/P_c against w = omega/omega_c (KE normalisation); valid for w <= 110."""
    w = np.asarray(w, dtype=float)
    return np.where(w < 1.0, w**1.5, np.where(w <= 6.0, 1.03 * w**1.425, 1.40 * w**1.263))


# --- Jackson & Green (2005) --------------------------------------------------------------------
def jackson_green_c(poissons_ratio: float) -> float:
    return 1.295 * math.exp(0.736 * poissons_ratio)


def jackson_green_critical(material: Material) -> Critical:
    return _critical(material, jackson_green_c(material.poissons_ratio))


def jackson_green_contact_radius(material: Material, w) -> np.ndarray:
    """Contact radius a (m) at w = omega/omega_c (JG eq. for the contact area)."""
    w = np.asarray(w, dtype=float)
    omega = w * jackson_green_critical(material).interference
    b = 0.14 * math.exp(23.0 * material.compressive_yield_stress
                        / sphere_on_flat_modulus(material))
    hertz = np.sqrt(material.radius * omega)
    return np.where(w >= 1.9, hertz * (np.maximum(w, 1.9) / 1.9) ** (b / 2.0), hertz)


def jackson_green_load(material: Material, w) -> np.ndarray:
    """P/P_c against w = omega/omega_c (JG normalisation)."""
    w = np.asarray(w, dtype=float)
    c = jackson_green_c(material.poissons_ratio)
    a_over_r = jackson_green_contact_radius(material, w) / material.radius
    with np.errstate(divide="ignore"):
        hardness = 2.84 * (1.0 - np.exp(-0.82 * np.power(np.maximum(a_over_r, 1e-300), -0.7)))
    return (np.exp(-0.25 * w ** (5.0 / 12.0)) * w**1.5
            + 4.0 * hardness / c * (1.0 - np.exp(-w ** (5.0 / 9.0) / 25.0)) * w)


def fe_load_at(interference: np.ndarray, force: np.ndarray, at: np.ndarray) -> np.ndarray:
    """An FE loading curve F(omega) (monotonic) read at ``at``: linear in log-log between steps."""
    keep = (interference > 0) & (force > 0)
    x, y = np.log(interference[keep]), np.log(force[keep])
    order = np.argsort(x)
    return np.exp(np.interp(np.log(at), x[order], y[order], left=np.nan, right=np.nan))


__all__ = [
    "Critical", "fe_load_at", "jackson_green_c", "jackson_green_contact_radius",
    "jackson_green_critical", "jackson_green_load", "kogut_etsion_critical", "kogut_etsion_load",
    "sphere_on_flat_modulus",
]
