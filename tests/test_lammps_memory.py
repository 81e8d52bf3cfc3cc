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

The reset is energy-safe: a contact whose point has travelled past its dent is *due*, and
forgets the dent at the first step where the fresh state stores no more normal elastic energy
than the dent at the same approach (at the latest when the grains part, where both store none).
A dent unloaded part-way stores far less than fresh material pressed to the same approach (the
dent's residual approach is most of it), so a contact slid while held on its unloading branch
keeps its dent, due, until the grains part; the reference for when is the Python law's elastic
energies of the two states along the same path.
"""

from __future__ import annotations

import math
import sys
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

    rows = np.atleast_2d(np.array(
        lmp.numpy.extract_compute("pl", LMP_STYLE_LOCAL, LMP_TYPE_ARRAY), dtype=float))
    if rows.size == 0:  # the grains apart beyond the cutoff: no forces, the state not shown
        return np.array([np.nan, 0.0, 0.0, np.nan, np.nan, np.nan])
    return rows[0]


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


def dent_contact(path) -> Contact:
    """The Python law along press()'s path (to PEAK, back to HELD), then along `path`."""
    c = Contact(PARAMS, beyond_range="ignore")
    for d in [*np.linspace(-0.5 * DY, PEAK, 31), *np.linspace(PEAK, HELD, 11)[1:], *path]:
        c.update(d)
    return c


def fresh_contact(path) -> Contact:
    c = Contact(PARAMS, beyond_range="ignore")
    for d in path:
        c.update(d)
    return c


def expected_reset(path) -> int:
    """The step of `path` (after the slide at HELD) at which the due contact forgets its dent:
    the first whose previous approach has the fresh state store no more than the dent (the rule
    reads the approach of the contact's last step, before its law update)."""
    before = [HELD, *path]
    for k in range(len(path)):
        d = before[k]
        dent = dent_contact(path[:k])
        fresh = fresh_contact([d]) if d > 0 else Contact(PARAMS, beyond_range="ignore")
        if fresh.elastic_energy <= dent.elastic_energy:
            return k
    raise AssertionError("the path never lets the dent go")


def unload_and_reload(lmp, theta: float, rate: float) -> list:
    """After a slide at HELD ending at angle `theta`: unload to the grains apart, then reload
    to HELD, at rest. Returns (approach, row, law tally) per step."""
    path = [*np.linspace(HELD, -0.5 * DY, 42)[1:], *np.linspace(-0.5 * DY, HELD, 42)[1:]]
    rows = []
    for k, d in enumerate(path):
        row = place_atom2(lmp, d, theta, rate if k == 0 else 0.0)
        rows.append((d, row, law_tally(lmp)))
    return rows


def test_past_the_dent_it_is_forgotten_only_where_that_stores_no_more_energy():
    """Slid by 1.5 x 2 a_max while held at HELD on its unloading branch, the contact keeps its
    dent (forgetting it there would store 16 x the dent's energy: the old rule's created
    energy); it forgets it at the step the Python law's energies say (here: once the grains
    part), and the reload follows the virgin curve. Along the whole path the law's tally never
    falls, the stored normal energy never jumps up, [18] is what the reset released (>= 0), and
    the tally + stored is the reference's work (the law's work, the dent's up to the reset,
    then the fresh state's, plus what the reset carried over): the ledger closes."""
    lmp = grains()
    a_max, unloading = press(lmp)
    assert virgin_force(HELD) > 1.2 * unloading
    slid, theta = move(lmp, 1.5 * 2 * a_max, rolling=False)
    assert slid[MAX_APPROACH] == pytest.approx(PEAK, rel=1e-9)  # due, not forgotten
    assert slid[NORMAL] == pytest.approx(unloading, rel=1e-9)
    rows = unload_and_reload(lmp, theta, 0.0)
    lmp.close()
    path = [d for d, _, _ in rows]
    reset = expected_reset(path)
    assert 0 < reset < len(path) // 2  # due for a while, forgotten before the reload
    envelopes = [row[MAX_APPROACH] for _, row, _ in rows]
    assert all(e == pytest.approx(PEAK, rel=1e-9) for e in envelopes[:reset] if e == e)
    assert not envelopes[reset] >= PEAK * (1 - 1e-9)  # forgotten (or apart: not shown)
    assert rows[-1][1][MAX_APPROACH] == pytest.approx(HELD, rel=1e-9)
    # after the reset: the fresh law along the rest of the path (from the reset's approach)
    start = [HELD, *path][reset]
    fresh = fresh_contact([start] if start > 0 else [])
    for d, row, _ in rows[reset:]:
        fresh.update(d)
        assert row[NORMAL] == pytest.approx(fresh.state.force, rel=1e-9, abs=1e-12 * unloading)
    assert rows[-1][1][NORMAL] == pytest.approx(virgin_force(HELD), rel=1e-9)
    law = np.array([t[0] for _, _, t in rows])
    stored = np.array([t[1] for _, _, t in rows])
    released = np.array([t[2] for _, _, t in rows])
    assert np.all(np.diff(law) >= -1e-12 * law.max())  # dissipation never decreases
    unloading_part = stored[: len(path) // 2]
    assert np.all(np.diff(unloading_part) <= 1e-12 * stored.max())  # no jump up on the way
    dent = dent_contact(path[:reset])
    before = [HELD, *path][reset]
    fresh_at = fresh_contact([before] if before > 0 else [])
    assert released[reset - 1] == 0
    assert released[-1] == pytest.approx(dent.elastic_energy - fresh_at.elastic_energy,
                                         abs=1e-12 * law.max())
    assert released[-1] >= 0
    # the ledger: tally + stored = the law's work, the dent's to the reset, the fresh state's
    # after, and the dent's work less the fresh state's at the reset carried over
    carried = dent.state.work - fresh_at.state.work
    assert law[-1] + stored[-1] == pytest.approx(fresh.state.work + carried, rel=1e-9)
    assert law[reset - 1] + stored[reset - 1] == pytest.approx(dent.state.work, rel=1e-9)


def test_past_the_dent_held_contact_keeps_it_while_due_and_a_short_slide_never_forgets():
    """Slid by only 0.7 x 2 a_max, the same unload and reload follow the dent's law (the Python
    law continued along the path): the dent is kept."""
    lmp = grains()
    a_max, _ = press(lmp)
    _, theta = move(lmp, 0.7 * 2 * a_max, rolling=False)
    rows = unload_and_reload(lmp, theta, 0.0)
    lmp.close()
    dent = dent_contact([])
    for d, row, _ in rows:
        dent.update(d)
        assert row[NORMAL] == pytest.approx(dent.state.force, rel=1e-9, abs=1e-9)
        assert not row[MAX_APPROACH] < PEAK * (1 - 1e-9)  # kept (nan: apart, not shown)


def test_a_slide_shorter_than_the_dent_keeps_it():
    lmp = grains()
    a_max, unloading = press(lmp)
    row, _ = move(lmp, 0.7 * 2 * a_max, rolling=False)
    lmp.close()
    assert row[MAX_APPROACH] == pytest.approx(PEAK, rel=1e-9)
    assert row[NORMAL] == pytest.approx(unloading, rel=1e-9)


def test_rolling_without_slip_past_the_dent_diameter_forgets_it():
    """Rolling (no slip: with friction the tangential spring stays unloaded) by 1.5 x 2 a_max
    on both grains meets fresh material on both: once the grains part, the reload follows the
    virgin curve; by 0.7 x 2 a_max the dent stays (the reload is the dent's)."""
    for factor, forgotten in ((0.7, False), (1.5, True)):
        lmp = grains(friction=0.5)
        a_max, unloading = press(lmp)
        row, theta = move(lmp, factor * 2 * a_max, rolling=True)
        assert row[TANGENTIAL] < 1e-6 * row[NORMAL]  # rolling, not sliding
        assert row[NORMAL] == pytest.approx(unloading, rel=1e-9)  # held: kept (or due)
        rows = unload_and_reload(lmp, theta, 0.0)
        lmp.close()
        expected = virgin_force(HELD) if forgotten else dent_contact(
            [d for d, _, _ in rows]).state.force
        assert rows[-1][1][NORMAL] == pytest.approx(expected, rel=1e-9)


@pytest.mark.parametrize("memory", ["pair", None])
def test_memory_pair_keeps_the_dent_however_far_the_contact_moves(memory):
    """`memory pair`, the default, keeps the behaviour before memory had a place."""
    lmp = grains(memory=memory)
    a_max, unloading = press(lmp)
    row, _ = move(lmp, 3 * 2 * a_max, rolling=False)
    lmp.close()
    assert row[MAX_APPROACH] == pytest.approx(PEAK, rel=1e-9)
    assert row[NORMAL] == pytest.approx(unloading, rel=1e-9)


@pytest.mark.parametrize("legs", [(0.6, 0.6), (1.2, 0.0)], ids=["travel", "due"])
def test_restart_carries_the_travelled_distances_and_the_due_flag(tmp_path, legs):
    """0.6 x 2 a_max before the restart and 0.6 x 2 a_max after (the distances carried), or
    1.2 x 2 a_max before it (the contact due when written), then unloaded and reloaded: the
    dent is forgotten as in the uninterrupted run, to the bit, and the reload is virgin."""
    rows = {}
    for split in (False, True):
        lmp = grains()
        a_max, unloading = press(lmp)
        _, theta = move(lmp, legs[0] * 2 * a_max, rolling=False)
        if split:
            lmp = scenarios.reopen_from_restart(lmp, tmp_path / "moved.restart",
                                                *probe_lines()[1:])
        if legs[1]:
            _, theta = move(lmp, legs[1] * 2 * a_max, rolling=False, theta0=theta)
        rows[split] = np.array([row for _, row, _ in unload_and_reload(lmp, theta, 0.0)])
        lmp.close()
    assert rows[True][-1][NORMAL] == pytest.approx(virgin_force(HELD), rel=1e-9)
    assert np.allclose(rows[True], rows[False], rtol=1e-12, atol=0, equal_nan=True)


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


# --- walls: fix wall/geocontact and fix wall/geocontact/region, memory place|pair ------------
#
# One grain of the file's radius R on a rigid floor at z = 0 (a zplane, or a region plane), or
# inside a region drum (a z cylinder of radius DRUM), moved kinematically. Its law is the pair
# law at d = 2 w (the FE half model, s = 1 on the flat floor): pressed to w = PEAK / 2,
# unloaded to HELD / 2, then carried along the wall. The wall is rigid: only the grain's side
# has a dent, and the contact point moves over the grain at b |dn/dt - w x n|, b = R - w. On a
# plane that is rolling (the spin), not sliding; inside the drum, carried round without spin,
# the normal turns and the point moves by b theta. Then unloaded until the grain leaves the
# wall and reloaded to HELD / 2: a forgotten dent reloads on the virgin curve (the Python law
# started fresh; w_max at the reload's top), a kept one on the dent's (the Python law carried
# on; w_max at PEAK / 2).
DRUM = 0.9
WALL_REGIONS = ("region floor plane 0 0 0 0 0 1 side in",
                f"region drum cylinder z 0 0 {DRUM} -1 1 side in")
WALL_VECTOR = {"law": 3, "stored": 4, "reset": 20}


def wall_fix(kind: str, memory: str | None, friction: float = 0.5) -> str:
    memory_kw = f" memory {memory}" if memory else ""
    contact = f"{PARAMS_FILE} friction {friction}{memory_kw}"
    return {"plane": f"fix wall all wall/geocontact {contact} zplane 0 NULL",
            "region": f"fix wall all wall/geocontact/region {contact} floor",
            "drum": f"fix wall all wall/geocontact/region {contact} drum"}[kind]


def wall_grain(kind: str, memory: str | None, friction: float = 0.5):
    lmp = open_lammps()
    fix = wall_fix(kind, memory, friction)
    for line in ("units si", "atom_style sphere", "atom_modify map array", "boundary f f f",
                 "comm_modify vel yes", "region box block -1 1 -1 1 -1 1", "create_box 1 box",
                 "create_atoms 1 single 0 0 0.5", f"set type 1 diameter {2 * R}",
                 f"set type 1 density {DENSITY}", "neighbor 0.01 bin", f"timestep {DT}",
                 *WALL_REGIONS, fix, "thermo 1",
                 "thermo_style custom step f_wall[4] f_wall[5]"):
        lmp.command(line)
    return lmp


def wall_row(lmp, kind: str) -> tuple[np.ndarray, np.ndarray]:
    """The grain's per-atom record [w, Fn, |Ft|, w_max, w_res, branch] and the wall's global
    vector."""
    from lammps import LMP_STYLE_ATOM, LMP_STYLE_GLOBAL, LMP_TYPE_ARRAY, LMP_TYPE_VECTOR

    row = np.array(lmp.numpy.extract_fix("wall", LMP_STYLE_ATOM, LMP_TYPE_ARRAY),
                   dtype=float)[0]
    if kind != "plane":
        row = row[1:7]  # the region's first slot, past its wall id
    vector = np.array([lmp.extract_fix("wall", LMP_STYLE_GLOBAL, LMP_TYPE_VECTOR, k)
                       for k in range(21)])
    return row, vector


def place_grain(lmp, kind: str, w: float, along: float = 0.0, speed: float = 0.0,
                spin: float = 0.0, first: bool = False):
    """The grain at interference w, `along` the wall (a plane: x; the drum: the angle), moving
    along it at `speed` (m/s; the drum: rad/s) and spinning at `spin` about y; one step."""
    w, along, speed, spin = float(w), float(along), float(speed), float(spin)
    if kind == "drum":
        rho = DRUM - R + w
        c, s = math.cos(along), math.sin(along)
        position = f"x {rho * c!r} y {rho * s!r} z 0 vx {-rho * speed * s!r} " \
                   f"vy {rho * speed * c!r} vz 0"
    else:
        position = f"x {along!r} y 0 z {R - w!r} vx {speed!r} vy 0 vz 0"
    lmp.command(f"set atom 1 {position} omega 0 {spin!r} 0")
    lmp.command(f"run 1 pre {'yes' if first else 'no'} post no")
    return wall_row(lmp, kind)


def wall_dent_radius() -> float:
    """a_max of the floor contact pressed to w = PEAK / 2: the pair's at d = PEAK (s = 1;
    law.hpp wall_similarity: the contact radius is the pair's), from the pair's own output."""
    lmp = grains()
    a_max, _ = press(lmp)
    lmp.close()
    return a_max


def wall_history(kind: str, memory: str | None, travel: float, *, rolling: bool,
                 restart: Path | None = None):
    """Press, unload to HELD / 2, carry the grain `travel` along the wall (the contact point's
    distance over the grain when rolling on a plane or carried round the drum; a slide without
    spin on a plane moves the grain, not the point), unload off the wall and reload to
    HELD / 2. Returns (w, row, vector) per step after the carry. `restart`: written half-way
    through the carry and read back."""
    lmp = wall_grain(kind, memory)
    for k, d in enumerate(np.linspace(-0.5 * DY, PEAK, 31)):
        place_grain(lmp, kind, 0.5 * d, first=k == 0)
    for d in np.linspace(PEAK, HELD, 11)[1:]:
        place_grain(lmp, kind, 0.5 * d)
    w = 0.5 * HELD
    arm = R - w
    if kind == "drum":
        end = travel / arm
    else:
        end = travel
    speed = end / (MOVE_STEPS * DT)
    spin = speed / arm if rolling else 0.0
    for k in range(1, MOVE_STEPS + 1):
        place_grain(lmp, kind, w, speed * k * DT, speed, spin)
        if restart is not None and k == MOVE_STEPS // 2:
            lmp = scenarios.reopen_from_restart(lmp, restart, "neighbor 0.01 bin",
                                                *WALL_REGIONS, wall_fix(kind, memory),
                                                "thermo 1")
    path = [*np.linspace(HELD, -0.5 * DY, 42)[1:], *np.linspace(-0.5 * DY, HELD, 42)[1:]]
    rows = [(0.5 * d, *place_grain(lmp, kind, 0.5 * d, end)) for d in path]
    lmp.close()
    return rows


@pytest.mark.parametrize("kind", ["plane", "region"])
def test_a_grain_rolled_along_a_flat_wall_past_its_dent_forgets_it(kind):
    """Rolled by 1.6 x 2 a_max along the floor (zplane or region plane), the grain's dent is
    forgotten once it leaves the wall, and the reload follows the virgin curve (the Python law
    started fresh, F_wall(w) = F_pair(2 w)); the law's tally never falls, [21] >= 0 and the
    ledger closes (tally + stored = half the pair's work along the path, the fresh state's
    plus the dent's carried over)."""
    a_max = wall_dent_radius()
    rows = wall_history(kind, "place", 1.6 * 2 * a_max, rolling=True)
    fresh = Contact(PARAMS, beyond_range="ignore")
    apart = [k for k, (w, _, _) in enumerate(rows) if w <= 0]
    assert apart  # the grain left the wall
    start = apart[-1]  # forgotten by then: the reload from here is the fresh law's
    for w, row, _ in rows[start:]:
        fresh.update(2 * w)
        assert row[1] == pytest.approx(fresh.state.force, rel=1e-9, abs=1e-9)
    assert rows[-1][1][3] == pytest.approx(0.5 * HELD, rel=1e-9)  # w_max: the reload's top
    law = np.array([v[WALL_VECTOR["law"]] for _, _, v in rows])
    stored = np.array([v[WALL_VECTOR["stored"]] for _, _, v in rows])
    reset = np.array([v[WALL_VECTOR["reset"]] for _, _, v in rows])
    assert np.all(np.diff(law) >= -1e-12 * law.max())
    assert np.all(reset >= 0)
    dent = dent_contact([2 * w for w, _, _ in rows[:start]])
    carried = dent.state.work - 0.0  # forgotten apart: the fresh state has done no work
    assert law[-1] + stored[-1] == pytest.approx(0.5 * (fresh.state.work + carried), rel=1e-9)


@pytest.mark.parametrize(("kind", "memory", "travel", "rolling"), [
    ("plane", "place", 0.6, True),
    ("region", "place", 0.6, True),
    ("plane", "place", 3.0, False),
    ("plane", "pair", 3.0, True),
    ("plane", None, 3.0, True),
], ids=["roll-short", "region-roll-short", "slide-no-spin", "memory-pair", "default"])
def test_a_grain_keeps_its_wall_dent_when_its_contact_point_has_not_left_it(kind, memory, travel,
                                                                            rolling):
    """Rolled by only 0.6 x 2 a_max, slid 3 x 2 a_max without spin (the grain's point on the
    rigid wall stays where the dent is), or under memory pair (the default): the reload
    follows the dent's law (the Python law carried on along the same path)."""
    a_max = wall_dent_radius()
    rows = wall_history(kind, memory, travel * 2 * a_max, rolling=rolling)
    dent = dent_contact([])
    for w, row, _ in rows:
        dent.update(2 * w)
        assert row[1] == pytest.approx(dent.state.force, rel=1e-9, abs=1e-9)
    assert rows[-1][1][3] == pytest.approx(0.5 * PEAK, rel=1e-9)


@pytest.mark.parametrize(("factor", "forgotten"), [(0.6, False), (1.6, True)])
def test_a_grain_carried_round_a_drum_forgets_its_dent_past_it(factor, forgotten):
    """Carried round the inside of a region drum without spin, the grain's contact normal turns
    and the point moves over the grain by b theta: past 2 a_max (the flat floor's, within a few
    per cent of the drum's: its R_eff = r rho / (r + rho) = 1.06 R, rho = -2 DRUM as LAMMPS
    reports a cylinder's curvature) the dent is forgotten once the grain leaves
    the wall (w_max after the reload: its top), short of it kept (w_max: the press's)."""
    a_max = wall_dent_radius()
    rows = wall_history("drum", "place", factor * 2 * a_max, rolling=False)
    w_max = rows[-1][1][3]
    if forgotten:
        assert w_max == pytest.approx(0.5 * HELD, rel=1e-9)
    else:
        assert w_max > 0.5 * HELD * 1.2
    law = np.array([v[WALL_VECTOR["law"]] for _, _, v in rows])
    assert np.all(np.diff(law) >= -1e-12 * law.max())


@pytest.mark.parametrize("kind", ["plane", "drum"])
def test_a_wall_restart_carries_the_travel_and_the_last_normal(tmp_path, kind):
    """Rolled (plane) or carried round (drum) by 1.6 x 2 a_max with a restart half-way: the
    same steps as the uninterrupted run, to round-off, and the dent forgotten, which the second
    half alone (0.8 x 2 a_max) would not do: the travelled distance is in the wall's records
    (with the due flag and the last normal, from which the drum's turn is taken)."""
    a_max = wall_dent_radius()
    runs = [wall_history(kind, "place", 1.6 * 2 * a_max, rolling=kind == "plane",
                         restart=restart) for restart in (None, tmp_path / "wall.restart")]
    (whole, split) = (np.array([row for _, row, _ in run]) for run in runs)
    assert split[-1][3] == pytest.approx(0.5 * HELD, rel=1e-9)  # forgotten
    assert np.allclose(split, whole, rtol=1e-12, atol=1e-12 * np.abs(whole).max())


def test_bad_wall_memory_arguments_are_one_line_lammps_errors():
    lmp = wall_grain("plane", None)
    with pytest.raises(Exception, match="memory must be place or pair, got 'spot'"):
        lmp.command(f"fix w2 all wall/geocontact {PARAMS_FILE} memory spot zplane 0 NULL")
    lmp.close()


# --- MPI: a due contact carried across the rank boundary ----------------------------------


def test_a_due_contact_carried_across_ranks_keeps_its_travel_and_its_ledger():
    """The `due_migration` scenario (lammps_scenarios.py): a pair slid round by 1.5 x 2 a_max
    and a grain rolled on the floor by 1.6 x 2 a_max, both due (dents kept while held), carried
    across the rank boundary x = 0, unloaded until they part (the dents forgotten there), reloaded
    on fresh material and carried back with the forgotten work in their records. On 2 ranks:
    the steps of 1 rank to round-off; the reload is the virgin law's (so the travel and the due
    flag crossed the boundary: without them the dent would be kept, as a 0.7 slide keeps it); the
    pair's ledger (compute pair geocontact [1] + [2]) and the wall's ([4] + [5]) close against
    the Python law, and [18] / [21] are what the resets released (>= 0)."""
    if not Path(sys.executable).with_name("mpiexec").exists():
        pytest.skip("no mpiexec beside the venv's python (make plugin installs the mpich wheel)")
    serial = scenarios.run_scenario(1, "due_migration")
    parallel = scenarios.run_scenario(2, "due_migration")
    assert (serial["ranks"], parallel["ranks"]) == (1, 2)
    steps = parallel["steps"]
    x = [s["x"] for s in steps]
    assert min(x) < -0.3 and max(x) > 0.2  # crossed x = 0 there and back
    for key in ("pair", "law", "wall_row", "wall"):
        one = np.array([s[key] for s in serial["steps"]])
        two = np.array([s[key] for s in steps])
        assert np.allclose(two, one, rtol=1e-12, atol=1e-12 * np.abs(one).max()), key
    crossing = [s for s in steps if s["vx"] > 0]
    assert crossing and all(s["d"] == pytest.approx(HELD) for s in crossing)
    for s in crossing:  # due and held: the dents kept on the way across
        assert s["pair"][2] == pytest.approx(PEAK, rel=1e-9)
        assert s["wall_row"][2] == pytest.approx(0.5 * PEAK, rel=1e-9)
    last = steps[-1]
    assert last["d"] == pytest.approx(HELD) and last["x"] == pytest.approx(steps[0]["x"])
    assert last["pair"][1] == pytest.approx(virgin_force(HELD), rel=1e-9)  # fresh material
    assert last["pair"][2] == pytest.approx(HELD, rel=1e-9)
    assert last["wall_row"][2] == pytest.approx(0.5 * HELD, rel=1e-9)
    # the ledgers, against the Python law along the approaches after the moves
    moved = next(k for k, s in enumerate(steps) if s["rate"] > 0)
    after = [s["d"] for s in steps[moved:] if s["rate"] == 0]
    reset = expected_reset(after)
    dent = dent_contact(after[:reset])
    start = [HELD, *after][reset]
    fresh = fresh_contact([start] if start > 0 else [])
    for d in after[reset:]:
        fresh.update(d)
    carried = dent.state.work - fresh_contact([start] if start > 0 else []).state.work
    law, stored, released = last["law"]
    assert law + stored == pytest.approx(fresh.state.work + carried, rel=1e-9)
    assert released >= 0
    wall_law, wall_stored, wall_released = last["wall"]  # the wall's law at w = d / 2
    assert wall_law + wall_stored == pytest.approx(0.5 * (fresh.state.work + carried), rel=1e-9)
    assert wall_released >= 0
