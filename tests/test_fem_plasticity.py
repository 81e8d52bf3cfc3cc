"""Drucker-Prager return mapping (docs/model.md §3): yield surface, uniaxial strengths, tangent."""

import math

import numpy as np
import pytest

from geocontact.fem.plasticity import (
    APEX,
    CONE,
    ELASTIC,
    DruckerPrager,
    invariants,
    return_mapping,
    yield_function,
)
from geocontact.grain.material import Material


def _material(beta=30.0, m=0.0, nu=0.25):
    return Material(10e9, nu, 10e6, beta, m, 0.1)


def _strain_driven(model, strain_path, eqps=0.0):
    """Drive one point through a strain path; returns stresses and eqps at every step."""
    d = model.elastic_matrix()
    stress = np.zeros(4)
    out = []
    for k in range(1, len(strain_path)):
        trial = stress + d @ (strain_path[k] - strain_path[k - 1])
        res = return_mapping(model, trial[:, None], np.array([eqps]))
        stress, eqps = res.stress[:, 0], float(res.eqps[0])
        out.append((stress.copy(), eqps))
    return out


def _uniaxial_path(model, direction, peak_strain, n=200):
    """Uniaxial stress in z (s_rr = s_tt = 0) by iterating on the lateral strain."""
    stress = np.zeros(4)
    strain = np.zeros(4)
    eqps = 0.0
    history = []
    for ez in np.linspace(0, direction * peak_strain, n)[1:]:
        lateral = strain[0]
        for _ in range(50):
            trial_strain = np.array([lateral, ez, lateral, 0.0])
            trial = stress + model.elastic_matrix() @ (trial_strain - strain)
            res = return_mapping(model, trial[:, None], np.array([eqps]))
            t = res.tangent[:, :, 0]
            s_new = res.stress[:, 0]
            # Newton on s_rr = 0 (= s_tt by symmetry) for the lateral strain.
            slope = t[0, 0] + t[0, 2]
            if abs(s_new[0]) < 1e-6 * model.yield_stress:
                break
            lateral -= s_new[0] / slope
        strain = trial_strain
        stress, eqps = s_new, float(res.eqps[0])
        history.append((strain.copy(), stress.copy(), eqps))
    return history


@pytest.mark.parametrize("beta", [0.0, 30.0, 55.0])
def test_returned_stress_lies_on_yield_surface(beta):
    model = DruckerPrager.from_material(_material(beta, m=0.2))
    rng = np.random.default_rng(1)
    trial = rng.normal(scale=60e6, size=(4, 500))
    eqps_old = rng.uniform(0, 1e-3, size=500)
    res = return_mapping(model, trial, eqps_old)
    f = yield_function(model, res.stress, res.eqps)
    plastic = res.status != ELASTIC
    assert plastic.sum() > 100
    assert np.all(np.abs(f[plastic]) < 1e-8 * model.yield_stress)
    assert np.all(f[~plastic] <= 1e-8 * model.yield_stress)
    np.testing.assert_allclose(res.stress[:, ~plastic], trial[:, ~plastic])
    if beta > 0:
        assert np.any(res.status == APEX)
        p, q = invariants(res.stress[:, res.status == APEX])
        assert np.all(q < 1e-6 * model.yield_stress)
        assert np.all(p < 0)  # the apex lies in hydrostatic tension


@pytest.mark.parametrize("beta", [0.0, 30.0])
def test_uniaxial_compression_and_tension_strengths(beta):
    mat = _material(beta)
    model = DruckerPrager.from_material(mat)
    comp = _uniaxial_path(model, -1.0, 4e-3)
    tens = _uniaxial_path(model, +1.0, 4e-3)
    assert -comp[-1][1][1] == pytest.approx(mat.compressive_yield_stress, rel=1e-6)
    assert tens[-1][1][1] == pytest.approx(mat.tensile_yield_stress, rel=1e-6)
    # eps_p is the axial plastic strain in uniaxial compression (docs/model.md §3).
    strain, stress, eqps = comp[-1]
    axial_plastic = strain[1] - stress[1] / mat.youngs_modulus
    assert eqps == pytest.approx(-axial_plastic, rel=1e-6)


def test_uniaxial_hardening_follows_tangent_modulus():
    mat = _material(30.0, m=0.1)
    model = DruckerPrager.from_material(mat)
    comp = _uniaxial_path(model, -1.0, 5e-3)
    strain, stress, _ = comp[-1]
    yield_strain = mat.compressive_yield_stress / mat.youngs_modulus
    expected = mat.compressive_yield_stress + mat.hardening_ratio * mat.youngs_modulus * (
        -strain[1] - yield_strain
    )
    assert -stress[1] == pytest.approx(expected, rel=1e-6)


@pytest.mark.parametrize("beta,m", [(0.0, 0.0), (30.0, 0.0), (30.0, 0.3), (60.0, 0.1)])
def test_consistent_tangent_matches_finite_differences(beta, m):
    model = DruckerPrager.from_material(_material(beta, m))
    d = model.elastic_matrix()
    rng = np.random.default_rng(7)
    stress_old = rng.normal(scale=3e6, size=4)
    eqps_old = np.array([1e-4])
    checked = {CONE: 0, APEX: 0}
    for k in range(40):
        # Every other increment is biased to hydrostatic tension to reach the apex.
        dstrain = rng.normal(scale=2e-3, size=4) + (k % 2) * 3e-3 * np.array([1, 1, 1, 0])
        base = return_mapping(model, (stress_old + d @ dstrain)[:, None], eqps_old)
        status = int(base.status[0])
        if status == ELASTIC:
            continue
        h = 1e-8
        fd = np.empty((4, 4))
        for j in range(4):
            e = np.zeros(4)
            e[j] = h
            plus = return_mapping(model, (stress_old + d @ (dstrain + e))[:, None], eqps_old,
                                  tangent=False)
            minus = return_mapping(model, (stress_old + d @ (dstrain - e))[:, None], eqps_old,
                                   tangent=False)
            fd[:, j] = (plus.stress[:, 0] - minus.stress[:, 0]) / (2 * h)
        np.testing.assert_allclose(base.tangent[:, :, 0], fd, atol=1e-5 * np.abs(d).max())
        checked[status] += 1
    assert checked[CONE] > 0
    if beta > 0:
        assert checked[APEX] > 0


def test_beta_zero_is_von_mises_radial_return():
    mat = _material(0.0, m=0.2, nu=0.3)
    model = DruckerPrager.from_material(mat)
    rng = np.random.default_rng(3)
    trial = rng.normal(scale=40e6, size=(4, 200))
    eqps_old = np.full(200, 2e-4)
    res = return_mapping(model, trial, eqps_old)
    # Radial return: deviator scaled to the current Mises radius, mean stress untouched.
    mean = trial[:3].mean(axis=0)
    dev = trial.copy()
    dev[:3] -= mean
    _, q_tr = invariants(trial)
    g, h = mat.shear_modulus, mat.hardening_modulus
    sigma_y = mat.compressive_yield_stress + h * eqps_old
    dgamma = np.maximum(q_tr - sigma_y, 0) / (3 * g + h)
    expected = dev * (1 - 3 * g * dgamma / q_tr)
    expected[:3] += mean
    np.testing.assert_allclose(res.stress, expected, rtol=1e-10, atol=1e-3)
    np.testing.assert_allclose(res.eqps, eqps_old + dgamma, rtol=1e-12)
    assert not np.any(res.status == APEX)


def test_apex_return_in_hydrostatic_tension():
    mat = _material(30.0, m=0.0)
    model = DruckerPrager.from_material(mat)
    # Hydrostatic tension well beyond the apex p = -c sigma_c / tan(beta).
    trial = np.array([[20e6], [20e6], [20e6], [0.0]])
    res = return_mapping(model, trial, np.zeros(1))
    assert res.status[0] == APEX
    p, q = invariants(res.stress)
    apex_pressure = -model.cohesion_factor * mat.compressive_yield_stress / mat.tan_beta
    assert p[0] == pytest.approx(apex_pressure, rel=1e-12)
    assert q[0] == pytest.approx(0.0, abs=1e-6)
    # Volumetric plastic strain and eps_p follow the cone's ratio c / tan(beta).
    dvol = (p[0] - (-20e6)) / mat.bulk_modulus
    assert res.eqps[0] == pytest.approx(model.cohesion_factor / mat.tan_beta * dvol, rel=1e-10)
    assert math.isfinite(float(res.tangent.sum()))
