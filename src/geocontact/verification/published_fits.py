"""Published FE fits of an elastic-perfectly plastic (von Mises) sphere pressed by a rigid flat.

Used to verify the FE engine in its von Mises limit (docs/model.md §5, beta = 0; see
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
- Etsion, I., Kligerman, Y. & Kadin, Y. (2005) Unloading of an elastic-plastic loaded spherical
  contact. Int. J. Solids Struct. 42, 3716-3729 (EKK). FE of the same sphere / rigid flat,
  elastic-perfectly plastic, E/S_y = 200-1000, nu = 0.3, 1 <= omega_max/omega_c <= 110, in the
  Kogut-Etsion normalisation (omega_c, P_c above); with w = omega_max / omega_c::

      omega_res / omega_max = [1 - w^-0.28] [1 - w^-0.69],
      P / P_max = ((omega - omega_res) / (omega_max - omega_res))^n,   n = 1.5 w^-0.0331.

- Jackson, R. L., Chusoipin, I. & Green, I. (2005) A finite element study of the residual stress
  and deformation in hemispherical contacts. J. Tribol. 127, 484-493 (JCG), the second published
  residual fit, in the JG normalisation: omega_res / omega_max = 1.02 [1 - ((w + 5.9)/6.9)^-0.54].

The loading work and the loop work ("what unloading does not give back", docs/model.md §6) of a
load-unload cycle follow from KE's loading fit and EKK's unloading fit by integration
(:func:`kogut_etsion_loading_work`, :func:`etsion_loop_work_ratio`); EKK give no energy fit of
their own.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..grain.material import Material


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


def kogut_etsion_loading_work(w) -> np.ndarray:
    """Work of the KE loading force from 0 to w = omega/omega_c, in units of P_c omega_c
    (Hertz below 1, the two KE branches above; closed-form integral of kogut_etsion_load)."""
    w = np.asarray(w, dtype=float)
    hertz = np.minimum(w, 1.0) ** 2.5 / 2.5
    first = 1.03 * (np.clip(w, 1.0, 6.0) ** 2.425 - 1.0) / 2.425
    second = 1.40 * (np.maximum(w, 6.0) ** 2.263 - 6.0**2.263) / 2.263
    return hertz + first + second


# --- Etsion, Kligerman & Kadin (2005), Jackson, Chusoipin & Green (2005) -----------------------
def etsion_residual_ratio(w) -> np.ndarray:
    """omega_res / omega_max after unloading from w = omega_max/omega_c (EKK; 0 up to w = 1)."""
    w = np.maximum(np.asarray(w, dtype=float), 1.0)
    return (1.0 - w**-0.28) * (1.0 - w**-0.69)


def etsion_unloading_exponent(w) -> np.ndarray:
    """n of P/P_max = t^n after unloading from w = omega_max/omega_c (EKK; 3/2 up to w = 1)."""
    return 1.5 * np.maximum(np.asarray(w, dtype=float), 1.0) ** -0.0331


def etsion_unloading_load(w_max: float, interference_ratio) -> np.ndarray:
    """P/P_max on unloading from w_max, against omega/omega_max (EKK); 0 below omega_res."""
    rho = float(etsion_residual_ratio(w_max))
    t = (np.asarray(interference_ratio, dtype=float) - rho) / (1.0 - rho)
    return np.clip(t, 0.0, None) ** float(etsion_unloading_exponent(w_max))


def etsion_loop_work_ratio(w_max) -> np.ndarray:
    """W_p / W_total of a load-unload cycle to w_max: KE loading, EKK unloading.

    W_total = P_c omega_c kogut_etsion_loading_work(w_max); the unloading gives back
    P_max (omega_max - omega_res) / (n + 1) with P_max the KE load at w_max.
    """
    w = np.maximum(np.asarray(w_max, dtype=float), 1.0)
    returned = (kogut_etsion_load(w) * w * (1.0 - etsion_residual_ratio(w))
                / (etsion_unloading_exponent(w) + 1.0))
    return 1.0 - returned / kogut_etsion_loading_work(w)


def jackson_residual_ratio(w) -> np.ndarray:
    """omega_res / omega_max after unloading from w = omega_max/omega_c (JCG; 0 up to w = 1)."""
    w = np.maximum(np.asarray(w, dtype=float), 1.0)
    return 1.02 * (1.0 - ((w + 5.9) / 6.9) ** -0.54)


def fe_load_at(interference: np.ndarray, force: np.ndarray, at: np.ndarray) -> np.ndarray:
    """An FE loading curve F(omega) (monotonic) read at ``at``: linear in log-log between steps."""
    keep = (interference > 0) & (force > 0)
    x, y = np.log(interference[keep]), np.log(force[keep])
    order = np.argsort(x)
    return np.exp(np.interp(np.log(at), x[order], y[order], left=np.nan, right=np.nan))


__all__ = [
    "Critical", "etsion_loop_work_ratio", "etsion_residual_ratio", "etsion_unloading_exponent",
    "etsion_unloading_load", "fe_load_at", "jackson_green_c", "jackson_green_contact_radius",
    "jackson_green_critical", "jackson_green_load", "jackson_residual_ratio",
    "kogut_etsion_critical", "kogut_etsion_load", "kogut_etsion_loading_work",
    "sphere_on_flat_modulus",
]
