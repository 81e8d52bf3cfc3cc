"""Loading-history classes (rainflow), shakedown states and the paper's peak-time rule."""

from __future__ import annotations

import numpy as np
import pytest

from geocontact.analyses.seismic import classify
from geocontact.calibrate.cyclic_fit import (
    ELASTIC,
    ELASTIC_SHAKEDOWN,
    PLASTIC_SHAKEDOWN,
    RATCHETTING,
)
from geocontact.errors import InputError

pytest.importorskip("rainflow")

SAMPLES_PER_RAMP = 40


def force_history(peaks, base=0.0):
    """Piecewise-linear 0 -> peak -> 0 cycles (docs/model.md §8 histories), sampled finely."""
    points = [base]
    for p in peaks:
        points += [p, base]
    ramps = [np.linspace(a, b, SAMPLES_PER_RAMP, endpoint=False)
             for a, b in zip(points[:-1], points[1:], strict=True)]
    return np.concatenate([*ramps, [points[-1]]])


# docs/model.md §8 (paper): the three idealised histories.
MONO_DECREASING = [3000, 2500, 2000, 1500, 1000, 500, 100]
REPEATED = [3000] * 10
MONO_INCREASING = list(np.linspace(100, 3000, 7))


@pytest.mark.parametrize(
    "peaks, expected",
    [
        (MONO_DECREASING, classify.DECREASING),
        (REPEATED, classify.REPEATED),
        (MONO_INCREASING, classify.INCREASING),
        ([6000], classify.SINGLE),
    ],
    ids=["mono-decreasing", "repeated", "mono-increasing", "single"],
)
@pytest.mark.parametrize("noise", [0.0, 15.0], ids=["clean", "noisy"])
def test_paper_histories_are_classified(peaks, expected, noise):
    force = force_history(peaks)
    force = force + np.random.default_rng(1).normal(0.0, noise, force.size)
    result = classify.history_class(force)
    assert result.history_class == expected
    assert result.top_force == pytest.approx(max(peaks), abs=4 * noise + 1e-9)


def test_decreasing_history_under_a_static_preload_is_still_decreasing():
    # a contact in a column: static force plus cycles of decaying amplitude after an early peak
    force = 800.0 + force_history([1200, 900, 700, 600, 400, 300, 200, 150])
    assert classify.history_class(force).history_class == classify.DECREASING


def test_late_peak_after_small_cycles_is_not_decreasing():
    # many small cycles, then the top late: not an (extended) decreasing history
    force = force_history([300, 320, 310, 330, 3000, 500])
    result = classify.history_class(force)
    assert result.history_class != classify.DECREASING
    assert result.peaks_before_top_fraction > 0.5


def test_constant_force_has_no_loading_class():
    assert classify.history_class(np.full(100, 5.0)).history_class == classify.NO_LOADING


def test_rainflow_cycle_tops_point_at_the_upper_reversal():
    force = force_history([3000, 1000])
    cycles = classify.rainflow_cycles(force)
    assert sum(c.count for c in cycles) == pytest.approx(2.0)  # a full and two half cycles
    tops = {c.peak_index for c in cycles}
    assert tops == {SAMPLES_PER_RAMP, 3 * SAMPLES_PER_RAMP}
    assert max(c.peak for c in cycles) == pytest.approx(3000.0)


@pytest.mark.parametrize(
    "fraction, expected",
    [(0.07, classify.DECREASING), (0.19, classify.DECREASING),
     (0.25, classify.REPEATED_OR_INCREASING)],
    ids=["el-centro-7%", "kobe-19%", "wenchuan-25%"],
)
def test_peak_time_rule_reproduces_the_papers_three_records(fraction, expected):
    assert classify.peak_time_rule(fraction) == expected


def test_peak_time_rule_rejects_fractions_outside_the_record():
    with pytest.raises(InputError, match="peak_time_fraction"):
        classify.peak_time_rule(1.5)


def test_agreement_between_rule_and_history_class():
    assert classify.agrees_with_paper_rule(classify.DECREASING, classify.DECREASING)
    assert not classify.agrees_with_paper_rule(classify.REPEATED, classify.DECREASING)
    assert classify.agrees_with_paper_rule(classify.INCREASING, classify.REPEATED_OR_INCREASING)


def _law_like_series(force, residual_per_cycle, dissipation_per_cycle):
    """Residual approach / dissipation that grow at each top by the given per-cycle amounts."""
    tops = np.flatnonzero((force[1:-1] > force[:-2]) & (force[1:-1] >= force[2:])) + 1
    residual = np.zeros_like(force)
    dissipated = np.zeros_like(force)
    for k, i in enumerate(tops):
        residual[i:] += residual_per_cycle(k)
        dissipated[i:] += dissipation_per_cycle(k)
    return residual, dissipated


@pytest.mark.parametrize(
    "residual, dissipation, expected",
    [
        (lambda k: 1e-6 if k == 0 else 0.0, lambda k: 1.0 if k == 0 else 0.0,
         ELASTIC_SHAKEDOWN),
        (lambda k: 1e-6 if k == 0 else 0.0, lambda k: 1.0 if k == 0 else 0.1,
         PLASTIC_SHAKEDOWN),
        (lambda k: 1e-6 / (k + 1) ** 0.2, lambda k: 1.0 / (k + 1) ** 0.2, RATCHETTING),
        (lambda k: 0.0, lambda k: 0.0, ELASTIC),
    ],
    ids=["elastic-shakedown", "plastic-shakedown", "ratchetting", "elastic"],
)
def test_shakedown_state_from_residual_approach_and_dissipation(residual, dissipation, expected):
    force = force_history(REPEATED)
    r, d = _law_like_series(force, residual, dissipation)
    state = classify.shakedown_state(force, r, d, approach_scale=1e-5, energy_scale=1.0)
    assert state.state == expected
    if expected == ELASTIC_SHAKEDOWN:
        assert state.shakedown_cycle == 1
    if expected == RATCHETTING:
        assert state.shakedown_cycle is None


def test_shakedown_cycle_counts_the_cycles_until_the_residual_approach_settles():
    force = force_history(REPEATED)
    r, d = _law_like_series(force, lambda k: 1e-6 * 0.1**k, lambda k: 0.5**k)
    state = classify.shakedown_state(force, r, d, approach_scale=1e-5, energy_scale=1.0)
    assert state.state == ELASTIC_SHAKEDOWN
    # increments 1, 0.1, 0.01, ... of 1.111: within 5 % of the end from the second cycle
    assert state.shakedown_cycle == 2
