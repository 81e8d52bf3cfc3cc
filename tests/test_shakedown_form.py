"""The shakedown form of the cyclic extension (docs/law.md, "Repeated cycles: the shakedown form").

Closed cycle N (from zero force to the envelope and back, N >= 2) ratchets by
``c N^-p d_res,1`` in every cycle (no cut at the tolerance) and dissipates ``c_w N^-p_w`` times
cycle 1's dissipation, the envelope's plastic work: the main reloading exponent k_N is chosen
so, and tends to n_u as the ratio decays (the loop closes, elastic shakedown as in the FE).
Expected values here come from the fitted power laws and the envelope's plastic work in closed
form (``LawParams.envelope_plastic_work``), not from earlier runs of the law.
"""

import dataclasses
import json
import math
from pathlib import Path

import numpy as np
import pytest
from conftest import YIELD_APPROACH, make_params
from hypothesis import given, settings
from hypothesis import strategies as st

from geocontact.analyses.force_driven import drive_by_force
from geocontact.errors import InputError
from geocontact.law import Contact, ContactArrays, CyclicLaw, LawParams, force_history

ROOT = Path(__file__).resolve().parents[1]
DY = YIELD_APPROACH
SHAKEDOWN = make_params(cyclic=CyclicLaw(
    enabled=True, form="shakedown", residual_ratio_coefficient=0.05, residual_ratio_power=2.5,
    plastic_work_ratio_coefficient=0.2, plastic_work_ratio_power=2.0, tolerance=0.01))


def cycles_to(params: LawParams, depth: float, cycles: int, jitter: float = 0.0, seed: int = 0):
    """Force-driven cycles 0 -> F -> 0 to the virgin force at ``depth`` dy, peaks jittered."""
    rng = np.random.default_rng(seed)
    fmax = float(params.virgin_force(depth * DY))
    forces = [0.0]
    for _ in range(cycles):
        forces += [fmax * (1.0 + jitter * float(rng.uniform(-1.0, 1.0))), 0.0]
    return drive_by_force(params, forces, points=30).cycles


@pytest.mark.parametrize("jitter", [0.0, 1e-9], ids=["exact", "jittered"])
@pytest.mark.parametrize("depth", [5.0, 40.0])
def test_increments_and_loops_follow_the_fitted_power_laws(depth, jitter):
    rows = cycles_to(SHAKEDOWN, depth, 12, jitter)
    cyclic = SHAKEDOWN.cyclic
    residual = np.array([r["residual_approach_m"] for r in rows])
    work = np.array([r["plastic_work_J"] for r in rows])
    dmax = rows[0]["max_approach_m"]
    # cycle 1: the envelope's residual approach and plastic work, in closed form
    assert residual[0] == pytest.approx(float(SHAKEDOWN.residual_ratio(dmax / DY)) * dmax,
                                        rel=1e-9)
    assert work[0] == pytest.approx(float(SHAKEDOWN.envelope_plastic_work(dmax)), rel=1e-6)
    n = np.arange(2, 13)
    np.testing.assert_allclose(np.diff(residual) / residual[0],
                               [cyclic.residual_ratio(k) for k in n], rtol=1e-6)
    np.testing.assert_allclose(work[1:] / work[0], [cyclic.plastic_work_ratio(k) for k in n],
                               rtol=1e-5)
    # every increment is below the tolerance after a few cycles: the truncated form would stop
    assert cyclic.residual_ratio(12) < cyclic.tolerance


def test_truncated_form_is_unchanged_and_differs():
    """Files without cyclic.form read as the original form: increments cut at the tolerance,
    every closed cycle the same n_r loop."""
    truncated = dataclasses.replace(SHAKEDOWN, cyclic=dataclasses.replace(SHAKEDOWN.cyclic,
                                                                          form="truncated"))
    rows = cycles_to(truncated, 40.0, 8)
    residual = [r["residual_approach_m"] for r in rows]
    increments = np.diff(residual)
    cut = [k for k in range(2, 9) if truncated.cyclic.residual_ratio(k) == 0.0]
    # zero but for the force-driven bisection's round-off
    assert cut and np.all(np.abs(increments[cut[0] - 2:]) < 1e-11 * residual[0])
    loops = [r["plastic_work_J"] for r in rows[cut[0] - 1:]]
    np.testing.assert_allclose(loops, loops[0], rtol=1e-9)  # never closes
    assert loops[0] > 0.0


def test_reloading_exponent_tends_to_the_unloading_exponent():
    contact = Contact(SHAKEDOWN)
    dmax = 40 * DY
    contact.update(dmax)
    exponents = []
    for _ in range(30):
        contact.update(-DY)  # apart, then reload from zero force
        contact.update(contact.state.residual_approach + contact.state.ratchet_shift + 1e-3 * DY)
        exponents.append(contact.state.branch_value)
        contact.update(contact.state.ratchet_shift + contact.state.max_approach
                       + contact.state.pending_ratchet)
    n_u = contact.state.unloading_exponent
    assert np.all(np.diff(exponents) > 0.0) and np.all(np.array(exponents) <= n_u)
    assert (n_u - exponents[-1]) < 0.02 * (n_u - exponents[0])


def small_amplitude(cycles: int):
    """``cycles`` of 100 % -> 80 % -> 100 % of the peak around a static load, then unloaded."""
    fmax = float(SHAKEDOWN.virgin_force(40 * DY))
    run = drive_by_force(SHAKEDOWN, [0.0, fmax] + [0.8 * fmax, fmax] * cycles + [0.0], points=3)
    return run.cycles[-1]["residual_approach_m"], run.cycles[-1]["plastic_work_J"]


def test_long_small_amplitude_history_converges():
    """1000 small cycles around a static load (a seismic column's contact): each adds depth 0.2
    to the count and ratchets by 0.2 r(N) d_res,1, so the residual approach and dissipation
    converge to the fitted law's sum instead of growing linearly."""
    residual_500, work_500 = small_amplitude(500)
    residual_1000, work_1000 = small_amplitude(1000)
    residual_1, work_1 = small_amplitude(0)
    cyclic = SHAKEDOWN.cyclic
    series = sum(0.2 * cyclic.residual_ratio(1.0 + 0.2 * k) for k in range(1, 1001))
    assert residual_1000 == pytest.approx(residual_1 * (1.0 + series), rel=1e-6)
    assert residual_1000 - residual_500 < 0.01 * (residual_500 - residual_1)
    assert work_1000 - work_500 < 0.01 * (work_500 - work_1)


def test_many_full_cycles_bounded_by_the_fitted_sum():
    # 400 full cycles (1000 take 30 s here; the LAMMPS test and docs/cycles.md run more)
    rows = cycles_to(SHAKEDOWN, 40.0, 400, jitter=1e-9)
    residual = rows[-1]["residual_approach_m"]
    series = sum(SHAKEDOWN.cyclic.residual_ratio(n) for n in range(2, 401))
    assert residual == pytest.approx(rows[0]["residual_approach_m"] * (1.0 + series), rel=1e-6)
    infinite = SHAKEDOWN.cyclic.residual_ratio_coefficient * (
        math.fsum(n ** -SHAKEDOWN.cyclic.residual_ratio_power for n in range(2, 10**5)))
    assert residual < rows[0]["residual_approach_m"] * (1.0 + infinite)
    loops = [r["plastic_work_J"] for r in rows]
    assert loops[-1] < 1e-5 * loops[0]


@settings(max_examples=150, deadline=None)
@given(st.lists(st.floats(min_value=-3.0, max_value=150.0, allow_nan=False), min_size=1,
                max_size=25))
def test_no_energy_created_and_continuous_on_any_path(xs):
    """Dissipation never decreases step by step on random paths (reversals anywhere, separation
    and re-contact, new envelopes), and the force has no jumps at the reversals."""
    path = [0.0, *[x * DY for x in xs], -DY]
    dense = [path[0]]
    for a, b in zip(path[:-1], path[1:], strict=True):
        dense += list(np.linspace(a, b, 101)[1:])
    contact = Contact(SHAKEDOWN)
    scale = SHAKEDOWN.yield_force * DY
    dissipated, force = 0.0, 0.0
    for d in dense:
        f, _ = contact.update(d)
        now = contact.dissipated_energy
        assert now >= dissipated - 1e-9 * scale - 1e-12 * abs(contact.state.work)
        dissipated = now
        force = f
    assert force == 0.0 and contact.state.work >= -1e-9 * scale


def test_compiled_kernel_agrees_on_random_walks():
    rng = np.random.default_rng(11)
    n, steps = 32, 300
    paths = np.cumsum(rng.normal(0.0, 3.0, size=(steps, n)) * DY, axis=0)
    paths[-5:] = -DY
    arrays = ContactArrays(SHAKEDOWN, n)
    forces = np.array([arrays.step(paths[s])[0].copy() for s in range(steps)])
    for i in range(n):
        fs, _ = force_history(SHAKEDOWN, paths[:, i])
        np.testing.assert_allclose(forces[:, i], fs, rtol=1e-12, atol=1e-12 * max(max(fs), 1e-300))


@pytest.mark.parametrize("form, message", [
    ("bogus", 'cyclic.form: must be one of truncated, shakedown, got "bogus"'),
    (3, "cyclic.form: must be a string, got a number"),
])
def test_bad_form_is_a_one_line_error(form, message):
    doc = json.loads((ROOT / "examples" / "params-reference.json").read_text())
    doc["cyclic"]["form"] = form
    with pytest.raises(InputError) as error:
        LawParams.from_dict(doc)
    assert str(error.value) == message
