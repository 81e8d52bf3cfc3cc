"""Memory with a place (pair_style geocontact memory place|pair; docs/dem.md "Memory with a
place"): the law's state is a dent in the grains' material at the spot where they touch, and is
forgotten once the contact point has travelled more than the dent's diameter 2 a_max on either
grain.

Two grains of the parameter file's radius, moved kinematically (no integrator: positions,
velocities and spins set at each step). Atom 1 stays at the origin; atom 2 is pressed past
yield, unloaded part-way, then carried round atom 1 at that constant approach on the circle of
radius r = 2 R - delta, at angle theta. Without spin the contact point moves by b theta on each
grain (b = R - delta/2, its arm); with atom 2 spinning at w = r theta' / b it rolls without
slip and the point moves by b theta on both as well (contact_forces.h travel_rates derives
both). The references are independent of the plugin: the Python law (geocontact.law.Contact)
started fresh at the same approach (forgotten), and the force the same run had before the move
(kept).
"""

from __future__ import annotations

import math
from pathlib import Path

import lammps_scenarios as scenarios
import numpy as np
import pytest

from geocontact.analyses.lammps_plugin import open_lammps
from geocontact.law import Contact, load_params

ROOT = Path(__file__).resolve().parents[1]
PARAMS_FILE = ROOT / "examples" / "params-illustrative.json"
PARAMS = load_params(PARAMS_FILE)
R = PARAMS.material.radius
DY = PARAMS.yield_approach
DENSITY = 2650.0
DT = 1e-4
PEAK = 30 * DY  # the envelope: plastic
HELD = 20 * DY  # the approach the grains are moved at, on the unloading branch
ARM = R - 0.5 * HELD
DISTANCE = 2 * R - HELD
MOVE_STEPS = 200
# pair/local columns
APPROACH, NORMAL, TANGENTIAL, MAX_APPROACH, BRANCH, RADIUS = range(6)


def pair_settings(lmp, memory: str | None, friction: float):
    style = "pair_style geocontact" + (f" memory {memory}" if memory else "")
    for line in (style, f"pair_coeff * * {PARAMS_FILE} friction {friction}", *probe_lines()):
        lmp.command(line)


def probe_lines():
    return ("comm_modify vel yes", "neighbor 0.01 bin", "neigh_modify every 1 delay 0 check yes",
            "compute pl all pair/local p1 p2 p3 p4 p6 p10", "compute law all pair geocontact",
            "thermo 1")


def grains(memory: str | None = "place", friction: float = 0.0):
    lmp = open_lammps()
    for line in ("units si", "atom_style sphere", "atom_modify map array", "boundary f f f",
                 "region box block -1 1 -1 1 -1 1", "create_box 1 box",
                 "create_atoms 1 single 0 0 0", f"create_atoms 1 single {2 * R} 0 0",
                 f"set type 1 diameter {2 * R}", f"set type 1 density {DENSITY}",
                 f"timestep {DT}"):
        lmp.command(line)
    pair_settings(lmp, memory, friction)
    return lmp


def pair_row(lmp) -> np.ndarray:
    from lammps import LMP_STYLE_LOCAL, LMP_TYPE_ARRAY

    rows = lmp.numpy.extract_compute("pl", LMP_STYLE_LOCAL, LMP_TYPE_ARRAY)
    return np.atleast_2d(np.array(rows, dtype=float))[0]


def law_tally(lmp) -> tuple[float, float, float]:
    """compute pair geocontact's law dissipation [1], stored normal energy [2] and the memory
    resets' change of stored energy [18]."""
    from lammps import LMP_STYLE_GLOBAL, LMP_TYPE_VECTOR

    vector = lmp.extract_compute("law", LMP_STYLE_GLOBAL, LMP_TYPE_VECTOR)
    return vector[0], vector[1], vector[17]


def place_atom2(lmp, approach, theta=0.0, rate=0.0, spin=0.0, first=False) -> np.ndarray:
    """Atom 2 at `approach` and angle `theta`, moving round atom 1 at `rate` (rad/s) and
    spinning at `spin` about z; one step. Returns the pair's row."""
    r, rate, spin = 2 * R - float(approach), float(rate), float(spin)
    c, s = math.cos(theta), math.sin(theta)
    lmp.command(f"set atom 2 x {r * c!r} y {r * s!r} vx {-r * rate * s!r} vy {r * rate * c!r} "
                f"omega 0 0 {spin!r}")
    lmp.command(f"run 1 pre {'yes' if first else 'no'} post no")
    return pair_row(lmp)


def press(lmp) -> tuple[float, float]:
    """Load to PEAK, unload to HELD; returns the dent's radius a_max and the unloading force."""
    top = None
    for k, d in enumerate(np.linspace(-0.5 * DY, PEAK, 31)):
        top = place_atom2(lmp, d, first=k == 0)
    for d in np.linspace(PEAK, HELD, 11)[1:]:
        held = place_atom2(lmp, d)
    assert top[BRANCH] == 1 and held[BRANCH] == 2  # virgin at the top, then unloading
    return top[RADIUS], held[NORMAL]


def move(lmp, travel: float, *, rolling: bool, theta0: float = 0.0) -> tuple[np.ndarray, float]:
    """Carry atom 2 round atom 1 at HELD until the contact point has moved `travel` on each
    grain (b theta). Returns the last row and the end angle."""
    theta_end = theta0 + travel / ARM
    rate = (theta_end - theta0) / (MOVE_STEPS * DT)
    spin = DISTANCE * rate / ARM if rolling else 0.0
    row = None
    for k in range(1, MOVE_STEPS + 1):
        row = place_atom2(lmp, HELD, theta0 + rate * k * DT, rate, spin)
    return row, theta_end


def virgin_force(approach: float) -> float:
    return Contact(PARAMS, beyond_range="ignore").update(approach)[0]


def test_a_slide_past_the_dent_diameter_meets_fresh_material():
    """Slid by 1.5 x 2 a_max at constant approach, the contact carries the virgin law's force
    at that approach, not the unloading branch's; the law's tally (dissipation + stored) is the
    same just before and just after the dent is forgotten (no normal work at constant
    approach), so nothing tallied is lost, and [18] reports the change of stored energy."""
    lmp = grains()
    a_max, unloading = press(lmp)
    fresh = virgin_force(HELD)
    assert abs(fresh - unloading) > 0.2 * unloading  # the two are told apart
    tallies = []
    row = None
    theta_end = 3.0 * a_max / ARM
    rate = theta_end / (MOVE_STEPS * DT)
    for k in range(1, MOVE_STEPS + 1):
        row = place_atom2(lmp, HELD, rate * k * DT, rate)
        tallies.append((row[MAX_APPROACH], law_tally(lmp)))
    lmp.close()
    assert row[NORMAL] == pytest.approx(fresh, rel=1e-9)
    assert row[MAX_APPROACH] == pytest.approx(HELD, rel=1e-9)  # the envelope: this approach
    reset = next(k for k, (envelope, _) in enumerate(tallies) if envelope < PEAK * (1 - 1e-9))
    # travel b rate dt per step passes 2 a_max at the step the rule says
    assert reset + 1 == math.floor(2.0 * a_max / (ARM * rate * DT)) + 1
    (law_before, stored_before, reset_before), (law, stored, reset_energy) = (
        tallies[reset - 1][1], tallies[reset][1])
    assert law + stored == pytest.approx(law_before + stored_before, rel=1e-9)
    assert reset_before == 0 and stored != pytest.approx(stored_before, rel=1e-3)
    assert reset_energy == pytest.approx(stored_before - stored, rel=1e-9)


def test_a_slide_shorter_than_the_dent_keeps_it():
    lmp = grains()
    a_max, unloading = press(lmp)
    row, _ = move(lmp, 0.7 * 2 * a_max, rolling=False)
    lmp.close()
    assert row[MAX_APPROACH] == pytest.approx(PEAK, rel=1e-9)
    assert row[NORMAL] == pytest.approx(unloading, rel=1e-9)


def test_rolling_without_slip_past_the_dent_diameter_forgets_it():
    """Rolling (no slip: with friction the tangential spring stays unloaded) by 1.5 x 2 a_max
    on both grains meets fresh material on both; by 0.7 x 2 a_max the dent stays."""
    for factor, forgotten in ((0.7, False), (1.5, True)):
        lmp = grains(friction=0.5)
        a_max, unloading = press(lmp)
        row, _ = move(lmp, factor * 2 * a_max, rolling=True)
        lmp.close()
        assert row[TANGENTIAL] < 1e-6 * row[NORMAL]  # rolling, not sliding
        expected = virgin_force(HELD) if forgotten else unloading
        assert row[NORMAL] == pytest.approx(expected, rel=1e-9)


@pytest.mark.parametrize("memory", ["pair", None])
def test_memory_pair_keeps_the_dent_however_far_the_contact_moves(memory):
    """`memory pair`, the default, keeps the behaviour before memory had a place."""
    lmp = grains(memory=memory)
    a_max, unloading = press(lmp)
    row, _ = move(lmp, 3 * 2 * a_max, rolling=False)
    lmp.close()
    assert row[MAX_APPROACH] == pytest.approx(PEAK, rel=1e-9)
    assert row[NORMAL] == pytest.approx(unloading, rel=1e-9)


def test_restart_carries_the_travelled_distances(tmp_path):
    """0.6 x 2 a_max before the restart and 0.6 x 2 a_max after forget the dent, as the
    uninterrupted run does: neither leg alone would."""
    rows = {}
    for split in (False, True):
        lmp = grains()
        a_max, unloading = press(lmp)
        _, theta = move(lmp, 0.6 * 2 * a_max, rolling=False)
        if split:
            lmp = scenarios.reopen_from_restart(lmp, tmp_path / "moved.restart",
                                                *probe_lines()[1:])
        rows[split], _ = move(lmp, 0.6 * 2 * a_max, rolling=False, theta0=theta)
        lmp.close()
    assert rows[True][MAX_APPROACH] == pytest.approx(HELD, rel=1e-9)
    assert rows[True][NORMAL] == pytest.approx(virgin_force(HELD),
                                                                           rel=1e-9)
    assert np.abs(rows[True] - rows[False]).max() <= 1e-12 * np.abs(rows[False]).max()


@pytest.mark.parametrize("argument, message", [
    ("memory", "keyword 'memory' needs a value"),
    ("memory spot", "memory must be place or pair, got 'spot'"),
    ("skin 2", "unexpected argument 'skin'"),
])
def test_bad_memory_arguments_are_one_line_lammps_errors(argument, message):
    lmp = open_lammps()
    for line in ("units si", "atom_style sphere", "region box block -1 1 -1 1 -1 1",
                 "create_box 1 box"):
        lmp.command(line)
    with pytest.raises(Exception, match=message):
        lmp.command(f"pair_style geocontact {argument}")
    lmp.close()
