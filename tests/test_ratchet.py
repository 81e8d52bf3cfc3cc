"""The cyclic extension counts repeated cycles robustly (docs/model.md §6, docs/law.md "Repeated
cycles").

A reload that reaches the envelope band, within ``tol (d_max - d_res)`` of the envelope point, is
a repeated cycle: it ratchets by ``depth * residual_ratio(N) * d_res,1`` and the count goes on.
Only an excursion beyond d_max that is large against the band restarts the count. Expected
series, exactly: the residual approach after cycle N minus after cycle N - 1 is
``CyclicLaw.residual_ratio(N) * d_res,1`` (``c N^-p``, zero once below ``tolerance``), d_res,1
the residual approach of cycle 1. Peaks exactly repeated and jittered by 1e-9 relative (as a
DEM code produces) give the same increments.
"""

import copy
import dataclasses
from pathlib import Path

import numpy as np
import pytest

from geocontact.analyses.force_driven import drive_by_force
from geocontact.law import Contact, ContactArrays, load_params

ROOT = Path(__file__).resolve().parents[1]
REFERENCE = load_params(ROOT / "examples" / "params-reference.json")
WEAK = load_params(ROOT / "examples" / "params-reference-weak.json")
PEAK_FORCE = 3000.0  # N, the history: 0 -> 3000 -> 0, repeated


def decaying(params, coefficient=0.5, power=1.0, tolerance=1e-3):
    """``params`` with a slowly decaying cyclic law: increments over hundreds of cycles."""
    cyclic = dataclasses.replace(params.cyclic, enabled=True,
                                 residual_ratio_coefficient=coefficient,
                                 residual_ratio_power=power, tolerance=tolerance)
    return dataclasses.replace(params, cyclic=cyclic)


def peaks(cycles: int, jitter: float, seed: int = 0) -> list[float]:
    """Force waypoints 0, F1, 0, F2, 0, ... with F_k = 3000 N (1 + jitter u), u in [-1, 1]."""
    rng = np.random.default_rng(seed)
    forces = [0.0]
    for _ in range(cycles):
        forces += [PEAK_FORCE * (1.0 + jitter * float(rng.uniform(-1.0, 1.0))), 0.0]
    return forces


def increments_by_force(params, cycles: int, jitter: float) -> tuple[np.ndarray, float]:
    """Residual-approach increments of cycles 2..N over cycle 1's residual, force-driven."""
    run = drive_by_force(params, peaks(cycles, jitter), points=40)
    residual = np.array([c["residual_approach_m"] for c in run.cycles])
    return np.diff(residual) / residual[0], residual[0]


def expected(params, cycles: int) -> np.ndarray:
    return np.array([params.cyclic.residual_ratio(n) for n in range(2, cycles + 1)])


@pytest.mark.parametrize("jitter", [0.0, 1e-9], ids=["exact", "jittered"])
def test_repeated_peaks_ratchet_by_the_fitted_series(jitter):
    params = decaying(REFERENCE)
    ratios, _ = increments_by_force(params, 12, jitter)
    series = expected(params, 12)
    assert np.all(np.diff(series) < 0.0)  # a decaying series: 0.25, 0.167, 0.125, ...
    # jittered peaks above the envelope point grow it by ~1e-9 (not the count)
    assert np.abs(ratios - series).max() <= (1e-12 if jitter == 0.0 else 1e-8)


@pytest.mark.parametrize("jitter", [0.0, 1e-9], ids=["exact", "jittered"])
def test_shipped_calibrated_file_ratchets_by_its_decaying_series(jitter):
    """examples/params-reference.json (shakedown form, fitted to the default-mesh FE): every
    cycle ratchets by the fitted ratio c N^-p of cycle 1's residual approach, below the
    tolerance too, exactly repeated or jittered."""
    assert REFERENCE.cyclic.form == "shakedown"
    ratios, _ = increments_by_force(REFERENCE, 6, jitter)
    series = expected(REFERENCE, 6)
    assert np.all(series > 0.0) and series[-1] < REFERENCE.cyclic.tolerance
    assert np.abs(ratios - series).max() <= 1e-8


@pytest.mark.parametrize("jitter", [0.0, 1e-9], ids=["exact", "jittered"])
def test_shipped_weak_file_ratchets_on_with_its_finite_strain_fe(jitter):
    """The 1 MPa file (finite-strain FE): its repeated history ratchets by ~1.2e-3 of cycle 1's
    residual approach per cycle, decaying slowly (docs/cycles.md), fitted from the ratchet's
    onset; the law's increments follow that series, exactly repeated or jittered. With a faster
    ratchet switched on, its envelope (d_res = 0.976 d_max: a band of 2.7e-7 m) ratchets as the
    fitted series says."""
    ratios, _ = increments_by_force(WEAK, 8, jitter)
    series = expected(WEAK, 8)
    assert np.all(np.diff(series) < 0.0) and np.all((series > 1e-3) & (series < 2e-3))
    assert np.abs(ratios - series).max() <= 1e-8
    params = decaying(WEAK)
    ratios, _ = increments_by_force(params, 8, jitter)
    assert np.abs(ratios - expected(params, 8)).max() <= (1e-12 if jitter == 0.0 else 1e-8)


def envelope_cycles(contact: Contact, cycles: int, jitter: float, seed: int = 0,
                    steps: int = 4) -> list[float]:
    """Approach-controlled repeated cycles, as a DEM contact meets them: each reload goes to the
    envelope point after its creep (found on a copy of the contact) times (1 + jitter u), then
    unloads to separation. Returns the approach path; ``contact`` has gone along it."""
    rng = np.random.default_rng(seed)
    path = []

    def leg(end):
        start = path[-1] if path else 0.0
        for k in range(steps):
            path.append(start + (end - start) * (k + 1) / steps)
            contact.update(path[-1])

    for _ in range(cycles):
        probe = copy.deepcopy(contact)
        s = probe.state
        if s.max_approach == 0.0:
            envelope = 40.0 * probe.params.yield_approach
        else:  # step the copy into the band: the creep is under way, pending is what is left
            probe.update(s.ratchet_shift + s.max_approach * (1.0 - 1e-6))
            envelope = s.max_approach + s.ratchet_shift + s.pending_ratchet
        leg(envelope * (1.0 + jitter * float(rng.uniform(-1.0, 1.0))))
        leg(-0.01 * envelope)
    return path


def residual(contact: Contact) -> float:
    return contact.state.residual_approach + contact.state.ratchet_shift


@pytest.mark.parametrize("jitter", [0.0, 1e-9], ids=["exact", "jittered"])
def test_a_thousand_cycles_stay_within_the_fitted_sum(jitter):
    params = decaying(REFERENCE)
    first = Contact(params)
    envelope_cycles(first, 1, 0.0)
    d_res1 = residual(first)
    contact = Contact(params)
    envelope_cycles(contact, 1000, jitter)
    series = sum(params.cyclic.residual_ratio(n) for n in range(2, 1001))
    assert params.cyclic.critical_cycle() == 500  # 0.5 / N below 1e-3 from cycle 500
    # the ratchet: each increment is ratio(N) times the envelope's d_res; peaks above the
    # envelope point (jitter) grow the envelope itself, by less than the positive jitters' sum
    envelope_res = contact.state.residual_approach
    assert envelope_res / d_res1 - 1.0 <= (1e-12 if jitter == 0.0 else 1000 * jitter)
    assert contact.state.ratchet_shift <= series * envelope_res * (1.0 + 1e-12)
    assert contact.state.ratchet_shift == pytest.approx(series * d_res1, rel=1e-12 + 1000 * jitter)
    assert residual(contact) - d_res1 <= series * d_res1 * (1.0 + 1e-12 + 2000 * jitter)
    # the count went on through every cycle, jitter or not
    assert contact.state.cycles == 1000.0


def test_a_thousand_cycles_through_the_compiled_law():
    """The same 1000 cycles, exact and jittered either side, through ContactArrays (the C++
    header): equal to the reference to 1e-12 of the peak force, same residual approach."""
    params = decaying(REFERENCE)
    contacts = [Contact(params) for _ in range(3)]
    paths = [envelope_cycles(contacts[0], 1000, 0.0),
             envelope_cycles(contacts[1], 1000, 1e-9, seed=1),
             envelope_cycles(contacts[2], 1000, 1e-9, seed=2)]
    path = np.array(paths).T
    arrays = ContactArrays(params, 3)
    replay = [Contact(params) for _ in range(3)]
    worst = 0.0
    for row in path:
        forces, _ = arrays.step(row)
        worst = max(worst, max(abs(forces[i] - replay[i].update(row[i])[0]) for i in range(3)))
    peak = max(c.state.max_force for c in contacts)
    assert worst <= 1e-12 * peak
    state = arrays.state
    for i, c in enumerate(contacts):
        assert state.residual_approach[i] + state.ratchet_shift[i] == pytest.approx(
            residual(c), rel=1e-12)
        assert state.cycles[i] == pytest.approx(c.state.cycles, rel=1e-12)


def reload_to_force(contact: Contact, fraction: float, steps: int = 60) -> None:
    """Reload from separation until the force reaches ``fraction`` of F_max (force control)."""
    s = contact.state
    top = s.max_approach + s.ratchet_shift
    start = s.approach
    for d in np.linspace(start, top, steps + 1)[1:]:
        probe = copy.deepcopy(contact)
        if probe.update(d)[0] >= fraction * s.max_force:
            break
        contact.update(d)
    # the exact crossing, by bisection on copies
    low, high = contact.state.approach, d
    for _ in range(100):
        mid = 0.5 * (low + high)
        probe = copy.deepcopy(contact)
        if probe.update(mid)[0] < fraction * s.max_force:
            low = mid
        else:
            high = mid
    contact.update(high)
    if contact.state.branch == 4:  # under force control the whole creep happens here
        contact.update(contact.state.approach + contact.state.pending_ratchet)


def test_partial_reload_counts_its_cycle_but_does_not_ratchet():
    """Existing semantics kept: a reload counts its depth (1 - f at its start) when it starts,
    and ratchets by depth * ratio(N) * d_res,1 only if it reaches the envelope band; a reload to
    0.9 F_max (far below the band, t = 0.92 < 1 - tol) leaves the residual approach alone."""
    params = decaying(REFERENCE, coefficient=0.8, power=1.0, tolerance=0.01)
    contact = Contact(params)
    envelope_cycles(contact, 1, 0.0)
    d_res1 = residual(contact)
    reload_to_force(contact, 0.9)
    assert contact.state.cycles == 2.0 and residual(contact) == d_res1
    contact.update(-1e-6)
    reload_to_force(contact, 1.0)  # cycle 3 by the count: ratchets by ratio(3)
    contact.update(-1e-6)
    assert (residual(contact) - d_res1) / d_res1 == pytest.approx(
        params.cyclic.residual_ratio(3), abs=1e-9)
    # inside the band counts as reaching the envelope: 0.999 F_max (t ~ 0.9992 > 0.99)
    before = residual(contact)
    reload_to_force(contact, 0.999)
    contact.update(-1e-6)
    assert (residual(contact) - before) / d_res1 == pytest.approx(
        params.cyclic.residual_ratio(4), abs=1e-9)


def test_depth_weighted_share_of_half_cycles():
    """Unloading only to half the force and reloading to F_max: each reload adds depth 0.5 to
    the count and ratchets by 0.5 ratio(N) d_res,1 (zero while N < 2)."""
    params = decaying(REFERENCE, coefficient=0.8, power=1.0, tolerance=0.01)
    contact = Contact(params)
    run_up = envelope_cycles(contact, 1, 0.0)[:4]  # load to the envelope point only
    contact = Contact(params)
    for d in run_up:
        contact.update(d)
    d_res1 = contact.state.residual_approach
    shifts = []
    for _ in range(3):
        s = contact.state
        # unload along the unloading curve to half of F_max: f = t^n_u = 0.5
        t = 0.5 ** (1.0 / s.unloading_exponent)
        contact.update(s.ratchet_shift + s.residual_approach
                       + t * (s.max_approach - s.residual_approach))
        assert contact.state.force == pytest.approx(0.5 * s.max_force, rel=1e-9)
        before = contact.state.ratchet_shift
        reload_to_force(contact, 1.0)
        shifts.append((contact.state.ratchet_shift - before) / d_res1)
    ratio = params.cyclic.residual_ratio
    assert shifts == pytest.approx([0.0, 0.5 * ratio(2.0), 0.5 * ratio(2.5)], abs=1e-9)


def test_a_real_excursion_grows_the_envelope_and_restarts_the_count():
    params = decaying(REFERENCE)
    contact = Contact(params)
    envelope_cycles(contact, 5, 0.0)
    assert contact.state.cycles == pytest.approx(5.0)
    s = contact.state
    band = params.cyclic.tolerance * (s.max_approach - s.residual_approach)
    # cycle 6: into the band, through its creep, then beyond the envelope point by 1e-9 and by
    # 0.9 of the band: the same cycle
    contact.update(s.ratchet_shift + s.max_approach * (1.0 - 1e-6))
    assert s.branch == 4
    contact.update(s.approach + s.pending_ratchet)
    envelope = s.ratchet_shift + s.max_approach
    for excess in (1e-9 * envelope, 0.9 * band):
        contact.update(envelope + excess)
        assert contact.state.branch == 1 and contact.state.cycles == 6.0
    # 1.1 bands beyond where it left the envelope: a new envelope, counted from 1
    contact.update(contact.state.approach + 0.2 * band)
    assert contact.state.cycles == 1.0
    new_res1 = contact.state.residual_approach
    contact.update(-1e-6)
    shift = contact.state.ratchet_shift
    envelope_cycles(contact, 1, 0.0)  # cycle 2 of the new envelope
    assert (contact.state.ratchet_shift - shift) / new_res1 == pytest.approx(
        params.cyclic.residual_ratio(2), abs=1e-9)


def test_the_creep_is_continuous_and_dissipates():
    """In the band the reload creeps at its own force: no jump, dissipation F ds >= 0."""
    params = decaying(REFERENCE)
    contact = Contact(params)
    path = envelope_cycles(contact, 1, 0.0)
    contact = Contact(params)
    for d in path:
        contact.update(d)
    top = contact.state.max_approach
    forces, dissipated = [], []
    for d in np.linspace(0.0, top * 1.05, 4000):
        forces.append(contact.update(d)[0])
        dissipated.append(contact.dissipated_energy)
    assert contact.state.ratchet_shift > 0.0
    steps = np.abs(np.diff(forces))
    assert steps.max() <= 2e-3 * max(forces)  # a fine path: no jump anywhere
    assert np.all(np.diff(dissipated) >= -1e-12 * max(forces) * top)
