"""Linear Drucker-Prager plasticity with linear isotropic hardening (docs/model.md §3).

Yield function (ABAQUS linear form, K = 1, hardening defined in uniaxial compression)::

    F = q - p tan(beta) - (1 - tan(beta)/3) * sigma_c(eps_p),   sigma_c = sigma_c0 + H eps_p

with p = -tr(sigma)/3 (positive in compression) and q = sqrt(3 J2). The flow is associated
(G = q - p tan(beta)), and the equivalent plastic strain is the axial plastic strain of a
uniaxial compression test: d(eps_p) = (1 - tan(beta)/3) d(lambda).

The stress update is the implicit (backward Euler) return mapping of de Souza Neto, Peric &
Owen, *Computational Methods for Plasticity* (2008), section 8.3.3 (Boxes 8.9-8.10), rewritten
for this yield function: a closed-form return to the smooth cone and, when that would overshoot
the apex (q < 0), a closed-form return to the apex. Both come with their consistent tangent.

Arrays follow the axisymmetric 4-component convention of the FE code:
stress ``[s_rr, s_zz, s_tt, s_rz]`` and strain ``[e_rr, e_zz, e_tt, gamma_rz]`` (engineering
shear), component axis first, any trailing shape (e.g. ``(4, elements, points)``). Internally
the tensors are written in Mandel form (shear times sqrt 2) so that double contractions are
plain dot products.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..grain.material import Material

ELASTIC, CONE, APEX = 0, 1, 2

_SQRT2 = math.sqrt(2.0)
_SQRT6 = math.sqrt(6.0)
# Mandel <-> engineering conversions of the shear component.
_STRESS_TO_MANDEL = np.array([1.0, 1.0, 1.0, _SQRT2])
_STRAIN_TO_MANDEL = np.array([1.0, 1.0, 1.0, 1.0 / _SQRT2])
_IDENTITY = np.array([1.0, 1.0, 1.0, 0.0])
_DEVIATORIC = np.eye(4) - np.outer(_IDENTITY, _IDENTITY) / 3.0  # Mandel I_dev


def _col(v: np.ndarray, ndim: int) -> np.ndarray:
    """Broadcast a 4-vector against an array with the component axis first."""
    return v.reshape((4,) + (1,) * (ndim - 1))


@dataclass(frozen=True)
class DruckerPrager:
    """Material constants of the return mapping (SI units)."""

    shear_modulus: float
    bulk_modulus: float
    tan_beta: float
    yield_stress: float  # sigma_c0, uniaxial compression
    hardening_modulus: float  # H = m E / (1 - m)

    @classmethod
    def from_material(cls, material: Material) -> DruckerPrager:
        return cls(
            shear_modulus=material.shear_modulus,
            bulk_modulus=material.bulk_modulus,
            tan_beta=material.tan_beta,
            yield_stress=material.compressive_yield_stress,
            hardening_modulus=material.hardening_modulus,
        )

    @property
    def cohesion_factor(self) -> float:
        """c = 1 - tan(beta)/3: cohesion d = c * sigma_c, and d(eps_p) = c d(lambda)."""
        return 1.0 - self.tan_beta / 3.0

    def compressive_yield_stress(self, eqps: np.ndarray) -> np.ndarray:
        return self.yield_stress + self.hardening_modulus * eqps

    def elastic_matrix(self) -> np.ndarray:
        """4x4 isotropic elasticity, stress from engineering strain."""
        return _from_mandel(self._elastic_mandel())

    def _elastic_mandel(self) -> np.ndarray:
        return 2.0 * self.shear_modulus * _DEVIATORIC + self.bulk_modulus * np.outer(
            _IDENTITY, _IDENTITY
        )


def _from_mandel(tangent: np.ndarray) -> np.ndarray:
    """Mandel 4x4(...) tangent -> engineering (stress from engineering strain)."""
    scale = np.outer(_STRAIN_TO_MANDEL, _STRAIN_TO_MANDEL)
    return tangent * scale.reshape((4, 4) + (1,) * (tangent.ndim - 2))


def invariants(stress: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Pressure p = -tr(sigma)/3 (compression positive) and q = sqrt(3 J2)."""
    s_rr, s_zz, s_tt, s_rz = stress
    mean = (s_rr + s_zz + s_tt) / 3.0
    j2 = 0.5 * ((s_rr - mean) ** 2 + (s_zz - mean) ** 2 + (s_tt - mean) ** 2) + s_rz**2
    return -mean, np.sqrt(3.0 * j2)


def yield_ratio(model: DruckerPrager, stress: np.ndarray, eqps: np.ndarray) -> np.ndarray:
    """Drucker-Prager measure (q - p tan(beta)) / (c sigma_c(eps_p)); yield when it reaches 1."""
    p, q = invariants(stress)
    return (q - p * model.tan_beta) / (
        model.cohesion_factor * model.compressive_yield_stress(eqps)
    )


def yield_function(model: DruckerPrager, stress: np.ndarray, eqps: np.ndarray) -> np.ndarray:
    p, q = invariants(stress)
    return q - p * model.tan_beta - model.cohesion_factor * model.compressive_yield_stress(eqps)


def elastic_energy_density(model: DruckerPrager, stress: np.ndarray) -> np.ndarray:
    """psi = sigma : C^-1 : sigma / 2 = q^2 / (6 G) + p^2 / (2 K)."""
    p, q = invariants(stress)
    return q**2 / (6.0 * model.shear_modulus) + p**2 / (2.0 * model.bulk_modulus)


def elastic_strain(model: DruckerPrager, stress: np.ndarray) -> np.ndarray:
    """C^-1 : sigma in engineering components."""
    mean = (stress[0] + stress[1] + stress[2]) / 3.0
    dev = stress - _col(_IDENTITY, stress.ndim) * mean
    strain = dev / (2.0 * model.shear_modulus) + _col(_IDENTITY, stress.ndim) * (
        mean / (3.0 * model.bulk_modulus)
    )
    strain[3] *= 2.0  # engineering shear
    return strain


@dataclass
class ReturnMapping:
    """Result of :func:`return_mapping` at every point (arrays with the trailing shape)."""

    stress: np.ndarray  # (4, ...)
    eqps: np.ndarray  # (...)
    plastic_multiplier: np.ndarray  # (...) d(lambda) of the step (volumetric increment at apex)
    status: np.ndarray  # (...) ELASTIC, CONE or APEX
    tangent: np.ndarray | None  # (4, 4, ...) consistent tangent, engineering strain


def return_mapping(
    model: DruckerPrager,
    stress_trial: np.ndarray,
    eqps_old: np.ndarray,
    *,
    tangent: bool = True,
) -> ReturnMapping:
    """Backward-Euler return of the elastic trial stress to the Drucker-Prager cone or apex.

    Cone (de Souza Neto et al. 2008, Box 8.9 with our F): with c = 1 - tan(beta)/3,
    A = 3G + K tan(beta)^2 + c^2 H, the multiplier is closed form, d(lambda) = F_trial / A, and
    q = q_trial - 3G d(lambda), p = p_trial + K tan(beta) d(lambda).
    Apex (q would be < 0): sigma = -p I with -tan(beta) p = c sigma_c(eps_p) (tension) and
    d(eps_p) = (c / tan(beta)) d(eps_v^p), the cone's ratio of the two plastic strains.
    """
    ndim = stress_trial.ndim
    shape = stress_trial.shape[1:]
    G, K, tb, H = model.shear_modulus, model.bulk_modulus, model.tan_beta, model.hardening_modulus
    c = model.cohesion_factor
    eqps_old = np.broadcast_to(np.asarray(eqps_old, dtype=float), shape)

    s_m = stress_trial * _col(_STRESS_TO_MANDEL, ndim)
    mean_tr = (s_m[0] + s_m[1] + s_m[2]) / 3.0  # tension positive
    p_tr = -mean_tr
    dev_tr = s_m - _col(_IDENTITY, ndim) * mean_tr
    norm_tr = np.sqrt(np.sum(dev_tr**2, axis=0))
    q_tr = math.sqrt(1.5) * norm_tr
    f_tr = q_tr - p_tr * tb - c * model.compressive_yield_stress(eqps_old)

    scale = c * model.compressive_yield_stress(eqps_old)
    plastic = f_tr > 1e-12 * scale
    a_cone = 3.0 * G + K * tb**2 + c**2 * H
    dlam = np.where(plastic, f_tr / a_cone, 0.0)
    apex = plastic & (q_tr - 3.0 * G * dlam < 0.0) & (tb > 0.0)  # no apex for von Mises
    cone = plastic & ~apex

    status = np.full(shape, ELASTIC, dtype=np.int8)
    status[cone] = CONE
    status[apex] = APEX

    # --- cone -----------------------------------------------------------------------------
    with np.errstate(divide="ignore", invalid="ignore"):
        shrink = np.where(cone, 1.0 - 3.0 * G * dlam / np.where(norm_tr > 0, q_tr, 1.0), 1.0)
    p_new = np.where(cone, p_tr + K * tb * dlam, p_tr)
    eqps = eqps_old + c * np.where(cone, dlam, 0.0)

    # --- apex (only reachable for tan(beta) > 0) ------------------------------------------
    if np.any(apex):
        a_apex = K * tb + c**2 * H / tb
        # -tan(beta) (p_trial + K dvol) = c sigma_c(eps_p_old + (c / tan(beta)) dvol)
        dvol = (-tb * p_tr - c * model.compressive_yield_stress(eqps_old)) / a_apex
        dvol = np.where(apex, dvol, 0.0)
        p_new = np.where(apex, p_tr + K * dvol, p_new)
        shrink = np.where(apex, 0.0, shrink)
        eqps = eqps + (c / tb) * dvol
        dlam = np.where(apex, dvol, dlam)

    stress_m = dev_tr * shrink - _col(_IDENTITY, ndim) * p_new
    stress = stress_m / _col(_STRESS_TO_MANDEL, ndim)

    result = ReturnMapping(stress=stress, eqps=eqps, plastic_multiplier=dlam, status=status,
                           tangent=None)
    if not tangent:
        return result

    # --- consistent tangent (Mandel) ------------------------------------------------------
    eye_outer = np.outer(_IDENTITY, _IDENTITY)
    d_el = model._elastic_mandel()
    tan = np.broadcast_to(d_el.reshape((4, 4) + (1,) * (ndim - 1)), (4, 4) + shape).copy()
    if np.any(cone):
        idx = np.nonzero(cone)
        n_hat = dev_tr[(slice(None),) + idx] / norm_tr[idx]  # (4, k)
        ratio = 3.0 * G * dlam[idx] / q_tr[idx]
        # d(sigma) = 2G (1 - ratio) I_dev + 2G ratio n(x)n + K I(x)I - b(x)b / A,
        # b = sqrt(6) G n + K tan(beta) I  (symmetric: associated flow).
        b = _SQRT6 * G * n_hat + K * tb * _IDENTITY[:, None]
        t_c = (
            2.0 * G * (1.0 - ratio)[None, None] * _DEVIATORIC[:, :, None]
            + 2.0 * G * ratio[None, None] * np.einsum("ik,jk->ijk", n_hat, n_hat)
            + K * eye_outer[:, :, None]
            - np.einsum("ik,jk->ijk", b, b) / a_cone
        )
        tan[(slice(None), slice(None)) + idx] = t_c
    if np.any(apex):
        idx = np.nonzero(apex)
        a_apex = K * tb + c**2 * H / tb
        k_apex = K * (1.0 - K * tb / a_apex)
        tan[(slice(None), slice(None)) + idx] = (k_apex * eye_outer)[:, :, None]
    result.tangent = _from_mandel(tan)
    return result
