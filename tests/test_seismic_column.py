"""The sphere column on a moving base: statics, energy conservation, dissipation = plastic work."""

from __future__ import annotations

import math

import numpy as np
import pytest
from make_illustrative_params import illustrative_params

from geocontact import preset
from geocontact.analyses.seismic.column import (
    Column,
    ColumnModel,
    hertz_contacts,
    law_contacts,
    virgin_approach,
)
from geocontact.errors import InputError

PARAMS = illustrative_params(preset("reference"))
MATERIAL = PARAMS.material
KH = PARAMS.hertz_coefficient
DENSITY = 2650.0


def shake(amplitude=3.0, frequency=4.0):
    return lambda t: amplitude * np.sin(2 * np.pi * frequency * t)


@pytest.mark.parametrize("surcharge", [0.0, 2000.0])
def test_static_column_matches_analytic_hertz_forces_and_approaches(surcharge):
    model = ColumnModel(6, MATERIAL.radius, DENSITY, surcharge=surcharge)
    column = Column(model, hertz_contacts(MATERIAL))
    weight = 4 / 3 * math.pi * MATERIAL.radius**3 * DENSITY * model.gravity
    expected_force = (np.arange(6) + 1) * weight + surcharge
    np.testing.assert_allclose(column.static_force, expected_force, rtol=1e-12)
    # inverse Hertz: delta = (F / Kh)^(2/3)
    np.testing.assert_allclose(column.static_approach, (expected_force / KH) ** (2 / 3),
                               rtol=1e-10)
    np.testing.assert_allclose(column.force, expected_force, rtol=1e-10)
    # the top sphere sits the sum of all approaches below the unstressed column
    assert column.static_top == pytest.approx(-column.static_approach.sum(), rel=1e-12)
    # exact equilibrium: nothing moves without base motion
    column.run(0.2)
    np.testing.assert_allclose(column.force, expected_force, rtol=1e-7)
    assert abs(column.settlement()) < 1e-9 * column.static_approach.sum()


def test_static_column_with_the_law_sits_on_its_virgin_curve():
    model = ColumnModel(4, MATERIAL.radius, DENSITY, surcharge=500.0)
    column = Column(model, law_contacts(PARAMS))
    np.testing.assert_allclose(PARAMS.virgin_force(column.static_approach), column.static_force,
                               rtol=1e-10)
    # deep in the plastic range already under its own weight (Fy is a few newtons here)
    assert np.all(column.contacts.max_approach > PARAMS.fully_plastic_approach)
    assert np.all(column.contacts.residual_approach > 0)


def test_virgin_approach_of_zero_force_is_zero():
    np.testing.assert_array_equal(virgin_approach(law_contacts(PARAMS), np.zeros(3)), 0.0)


def _max_energy_error(excitation, safety):
    model = ColumnModel(5, MATERIAL.radius, DENSITY, surcharge=300.0)
    kick = np.array([0.0, 0.02, -0.03, 0.0, 0.01]) if excitation == "kick" else None
    column = Column(model, hertz_contacts(MATERIAL), safety=safety, initial_velocity=kick)
    column.run(0.6, shake() if excitation == "base" else None)
    h = column.history.arrays()
    return column, np.max(np.abs(h["energy_error"])) / np.max(h["kinetic_energy"])


@pytest.mark.parametrize("excitation", ["kick", "base"])
def test_elastic_undamped_column_conserves_total_energy(excitation):
    column, error = _max_energy_error(excitation, 0.2)
    _, error_fine = _max_energy_error(excitation, 0.1)
    # velocity Verlet: a bounded energy error, second order in dt
    assert error < 0.03
    assert error_fine < error / 3.0
    # for Hertz the contact work is stored elastic energy: 2/5 Kh delta^(5/2) per contact
    # (the trapezoid of F d(approach) is second-order accurate too)
    stored = 0.4 * KH * np.sum(column.approach**2.5 - column.static_approach**2.5)
    kinetic_max = np.max(column.history.kinetic_energy)
    assert abs(column.contact_work - stored) < 1e-3 * kinetic_max
    assert np.all(column.contacts.dissipated_energy == 0.0)
    assert column.stability_ratio < 1.0


@pytest.mark.parametrize("factory, dissipates", [(hertz_contacts(MATERIAL), False),
                                                 (law_contacts(PARAMS), True)],
                         ids=["hertz", "law"])
def test_impact_energy_lost_equals_the_laws_plastic_work(factory, dissipates):
    # no gravity: the top sphere hits the column at rest, the pulse runs down, bounces off the
    # base grain, and the spheres fly apart; all contacts end apart, storing nothing.
    model = ColumnModel(4, MATERIAL.radius, DENSITY, gravity=0.0)
    v0 = np.array([-0.2, 0.0, 0.0, 0.0])
    column = Column(model, factory, time_step=2e-6, initial_velocity=v0)
    kinetic_before = 0.5 * column.mass * float(v0 @ v0)
    column.run(0.03)
    assert np.all(column.force == 0.0), "contacts must end apart"
    kinetic_after = 0.5 * column.mass * float(column.v @ column.v)
    dissipated = float(column.contacts.dissipated_energy.sum())
    assert kinetic_before - kinetic_after == pytest.approx(dissipated, rel=1e-4,
                                                           abs=1e-6 * kinetic_before)
    if dissipates:
        assert dissipated > 0.1 * kinetic_before
        np.testing.assert_allclose(column.contacts.work, column.contacts.dissipated_energy,
                                   rtol=1e-9)
    else:
        assert kinetic_after == pytest.approx(kinetic_before, rel=1e-5)


def test_shaken_hysteretic_column_energy_balance_and_dissipation():
    model = ColumnModel(5, MATERIAL.radius, DENSITY, surcharge=200.0)
    column = Column(model, law_contacts(PARAMS))
    work_start = column.contacts.work.copy()
    dissipated_start = column.contacts.dissipated_energy.copy()
    stored_start = column.contacts.elastic_energy.copy()
    column.run(1.5, shake(amplitude=3.0, frequency=3.0))
    # the integrator's trapezoid of F d(approach) is the law's exact work
    law_work = float(np.sum(column.contacts.work - work_start))
    assert column.contact_work == pytest.approx(law_work, rel=1e-3)
    # energy put in by the base and released by the column = stored + dissipated by the law
    dissipated = float(np.sum(column.contacts.dissipated_energy - dissipated_start))
    stored = float(np.sum(column.contacts.elastic_energy - stored_start))
    assert dissipated > 0
    assert column.contact_work == pytest.approx(stored + dissipated, rel=1e-3)
    assert abs(column.energy_error()) < 1e-3 * dissipated
    # the first upward force excursion beyond the static load loads the envelope further
    assert np.all(column.contacts.residual_approach > column.history.residual_approach[0])
    assert column.settlement() > 0


def test_damping_is_accounted_and_only_removes_energy():
    model = ColumnModel(3, MATERIAL.radius, DENSITY, damping_ratio=0.05)
    column = Column(model, hertz_contacts(MATERIAL), initial_velocity=[0.0, 0.05, 0.0])
    kinetic_before = column.history.kinetic_energy[0]
    column.run(0.5)
    # viscous damping in the contacts takes out nearly all of the kick's energy ...
    assert 0.9 * kinetic_before < column.damping_loss < 1.01 * kinetic_before
    # ... and the book (mechanical + contact work + damping loss) still balances
    assert np.max(np.abs(column.history.energy_error)) < 0.03 * kinetic_before
    assert abs(column.energy_error()) < 1e-6 * kinetic_before


def test_bad_column_inputs_are_rejected():
    with pytest.raises(InputError, match="spheres"):
        ColumnModel(0, 0.1, DENSITY)
    with pytest.raises(InputError, match="density"):
        ColumnModel(3, 0.1, -1.0)
    with pytest.raises(InputError, match="damping_ratio"):
        ColumnModel(3, 0.1, DENSITY, damping_ratio=float("nan"))
    with pytest.raises(InputError, match="time_step_safety"):
        Column(ColumnModel(2, 0.1, DENSITY), hertz_contacts(MATERIAL), safety=2.0)
