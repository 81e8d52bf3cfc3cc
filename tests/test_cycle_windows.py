"""The one segmentation of a force history into load/unload cycles
(``force_history.cycle_windows``), used by the FE run, the law's force-controlled driver and
the cyclic analyses."""

from pathlib import Path

import numpy as np
import pytest

from geocontact.analyses.force_driven import drive_by_force
from geocontact.grain.force_history import cycle_peak, cycle_windows, preset_history
from geocontact.law import load_params

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def test_each_return_to_zero_force_closes_a_cycle():
    forces = preset_history("repeated", 3000.0)  # 10 cycles 0 -> F -> 0
    marks = list(range(0, 10 * len(forces), 10))
    windows = cycle_windows(forces, marks)
    assert len(windows) == 10
    assert windows[0] == (0, 20) and windows[-1] == (marks[-3], marks[-1])
    # consecutive: each cycle starts where the previous one ended
    assert all(a[1] == b[0] for a, b in zip(windows[:-1], windows[1:], strict=True))


def test_partial_reversal_stays_in_its_cycle_and_open_end_is_optional():
    forces = [0.0, 100.0, 50.0, 200.0, 0.0, 300.0, 10.0, 300.0]
    marks = [0, 5, 8, 12, 20, 25, 30, 35]
    assert cycle_windows(forces, marks) == [(0, 20), (20, 35)]
    assert cycle_windows(forces, marks, close_open_end=False) == [(0, 20)]


def test_a_zero_to_zero_segment_is_not_a_cycle():
    forces = [0.0, 50.0, 0.0, 0.0, 80.0, 0.0]
    assert cycle_windows(forces, [0, 4, 8, 8, 12, 16]) == [(0, 8), (8, 16)]
    with pytest.raises(ValueError, match="marks"):
        cycle_windows(forces, [0, 4, 8])


def test_cycle_peak_is_the_largest_force_and_its_approach():
    force = np.array([0.0, 2.0, 5.0, 1.0, 0.0, 7.0, 0.0])
    approach = np.arange(7.0)
    assert cycle_peak(force, approach, (0, 4)) == (5.0, 2.0)
    assert cycle_peak(force, approach, (4, 6)) == (7.0, 5.0)


def test_the_law_under_force_control_has_one_cycle_per_return_to_zero():
    params = load_params(EXAMPLES / "params-illustrative.json")
    forces = [0.0, 20.0, 0.0, 0.0, 30.0, 15.0, 30.0, 0.0, 10.0]
    run = drive_by_force(params, forces, points=10)
    assert len(run.cycles) == 2  # the open last cycle is not reported by the driver
    assert run.cycles[0]["max_force_N"] == pytest.approx(20.0, rel=1e-9)
    assert run.cycles[1]["max_force_N"] == pytest.approx(30.0, rel=1e-9)
    assert run.cycles[1]["residual_approach_m"] >= run.cycles[0]["residual_approach_m"] > 0.0
