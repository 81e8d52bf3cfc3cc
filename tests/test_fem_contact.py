"""FE contact model on the coarse mesh (docs/model.md §5 verification).

References: the analytic layer ``geocontact.grain.hertz`` (Hertz, ball-ball, docs/model.md §4, and
the
Drucker-Prager incipient yield), itself checked against Johnson's closed forms.
"""

import math

import numpy as np
import pytest
from conftest import assert_energy_balance

from geocontact.fem.mesh import build_mesh
from geocontact.fem.run import run_history
from geocontact.fem.solver import ContactSolver
from geocontact.grain import hertz
from geocontact.grain.material import Material, preset

REFERENCE = Material(10e9, 0.25, 10e6, 30.0, 0.0, 0.1)


def _hertz_force(material, approach):
    return hertz.hertz_force(material, approach)


def _hertz_approach(material, force):
    return hertz.hertz_approach(material, force)


def _hertz_contact_radius(material, approach):
    return hertz.contact_radius(material, approach)


def _von_mises_yield_force(material):
    """Analytic incipient yield (p0 = 1.613 sigma_c for nu = 0.3, Johnson 1985; tested in
    test_hertz.py against the closed forms)."""
    return hertz.incipient_yield(material).force


def _elastic_solver(material, volumetric_order=1, bbar=True):
    mesh = build_mesh(material.radius, 2e-4, 5e-3, "coarse")
    return ContactSolver(material, mesh, plastic=False, force_scale=3000.0, bbar=bbar,
                         volumetric_order=volumetric_order)


def test_elastic_force_approach_and_contact_radius_match_hertz():
    solver = _elastic_solver(REFERENCE)
    state = solver.initial_state()
    for force in (5.0, 50.0, 500.0, 3000.0):
        state = solver.solve_step(state, force)
        approach = 2.0 * state.top_displacement  # ball-ball
        assert state.force == force
        assert solver.reaction_force(state) == pytest.approx(force, rel=1e-6)
        assert _hertz_force(REFERENCE, approach) == pytest.approx(force, rel=0.02)
        assert solver.contact_radius(state) == pytest.approx(
            _hertz_contact_radius(REFERENCE, _hertz_approach(REFERENCE, force)), rel=0.02)
        r, pressure = solver.contact_pressure(state)
        a = solver.contact_radius(state)
        p0 = 2.0 * REFERENCE.effective_modulus * a / (math.pi * REFERENCE.effective_radius)
        assert np.max(pressure) == pytest.approx(p0, rel=0.05)
        assert np.all(pressure[r > 1.05 * a] == 0.0)


def test_near_incompressible_elastic_contact_does_not_lock():
    """nu -> 1/2 (the isochoric limit of beta = 0 plastic flow) must not stiffen the contact.

    The Hertz approach error of the same mesh at nu = 0.25 is the reference (finite body,
    discretization); locking shows as an extra stiffening at nu = 0.4999.
    """
    def approach_error(nu, bbar, order):
        material = REFERENCE.with_(poissons_ratio=nu)
        solver = _elastic_solver(material, volumetric_order=order, bbar=bbar)
        state = solver.solve_step(solver.initial_state(), 3000.0)
        return 2.0 * state.top_displacement / _hertz_approach(material, 3000.0) - 1.0

    extra = {name: approach_error(0.4999, *opts) - approach_error(0.25, *opts)
             for name, opts in {"bbar-p1": (True, 1), "full": (False, 0)}.items()}
    assert abs(extra["bbar-p1"]) < 0.002
    assert extra["full"] < -0.005  # the fully integrated P2 element locks visibly


def test_von_mises_incipient_yield_within_5_percent():
    material = preset("von-mises")
    fy = _von_mises_yield_force(material)
    result = run_history(material, [0.0, 3.0 * fy], mesh="coarse", write_fields=False)
    s = result.summary
    assert s["first_yield_force_N"] == pytest.approx(fy, rel=0.05)
    approach_y = 2.0 * _hertz_approach(material, fy) / 2.0
    assert s["first_yield_approach_m"] == pytest.approx(approach_y, rel=0.05)
    # below the surface, near the axis (Hertz: z = 0.48 a)
    a_y = _hertz_contact_radius(material, approach_y)
    assert 0.3 * a_y < s["first_yield_location_m"]["z"] < 0.7 * a_y


@pytest.fixture(scope="module")
def reference_cycle():
    """0 -> 100 Fy -> 0 on the reference Drucker-Prager material (beta = 30 deg)."""
    material = REFERENCE
    probe = run_history(material, [0.0, 1.0], mesh="coarse", write_fields=False,
                        steps_per_segment=1)
    fy = probe.summary["first_yield_force_predicted_N"]
    return fy, run_history(material, [0.0, 100.0 * fy, 0.0], mesh="coarse",
                           write_fields=False)


def test_energy_balance_at_every_step(reference_cycle):
    assert_energy_balance(reference_cycle[1].curve)


def test_loading_past_yield_leaves_residual_approach(reference_cycle):
    fy, result = reference_cycle
    s = result.summary
    assert s["first_yield_force_N"] == pytest.approx(fy, rel=0.1)
    (cycle,) = s["cycles"]
    assert cycle["max_force_N"] == pytest.approx(100.0 * fy)
    assert cycle["residual_approach_m"] > 0.1 * cycle["max_approach_m"]
    assert cycle["plastic_work_J"] > 0.0
    # the loop area (work of the force over the cycle) is what unloading does not give back:
    # the plastic dissipation plus the elastic energy locked in by residual stresses
    assert cycle["loop_work_J"] == pytest.approx(
        cycle["plastic_work_J"] + cycle["residual_elastic_energy_J"], rel=0.01)
    assert result.curve["force_N"][-1] == 0.0
    assert result.curve["contact_radius_m"][-1] == pytest.approx(0.0, abs=1e-12)


def test_elastic_unloading_before_yield_leaves_no_residual(reference_cycle):
    fy, _ = reference_cycle
    result = run_history(REFERENCE, [0.0, 0.5 * fy, 0.0], mesh="coarse", write_fields=False,
                         steps_per_segment=4)
    (cycle,) = result.summary["cycles"]
    assert result.summary["first_yield_force_N"] is None
    assert abs(cycle["residual_approach_m"]) < 1e-6 * cycle["max_approach_m"]
    assert abs(cycle["plastic_work_J"]) < 1e-12 * result.curve["work_J"].max()
    assert np.all(result.curve["plastic_points"] == 0)
