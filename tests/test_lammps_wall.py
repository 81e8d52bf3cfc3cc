"""fix wall/geocontact (plugin built by `make plugin`): a grain on a rigid wall is the FE half
model of the pair (docs/model.md §10), F_wall(w) = F_pair,r(d = 2 w) with the pair law of two
spheres of
the grain's radius r (LawParams.for_radius(r)), with the same history rules, the pair style's
tangential force and damping, moving walls, the force on the wall, restarts and bad input."""

from __future__ import annotations

import math
import struct
from pathlib import Path

import lammps_scenarios as scenarios
import numpy as np
import pytest

from geocontact.analyses.lammps_plugin import open_lammps
from geocontact.law import Contact, load_params

ROOT = Path(__file__).resolve().parents[1]
CALIBRATED_FILE = ROOT / "examples" / "params-reference.json"
ILLUSTRATIVE_FILE = ROOT / "examples" / "params-illustrative.json"
BASE = load_params(CALIBRATED_FILE)
DENSITY = 2650.0
WALL_COLUMNS = 6  # per wall: w, Fn, |Ft|, w_max, w_res, branch


def grains(radii, positions, wall: str, *, friction=0.0, damping=0.0, extra=(),
           params_file=CALIBRATED_FILE, boundary="f f f"):
    """Grains of the given radii at the given positions (no integrator: positions stay as set)
    and one wall fix `wall` (its style and motion arguments) with ID `wall`."""
    lmp = open_lammps()
    for line in ("units si", "atom_style sphere", "atom_modify map array",
                 f"boundary {boundary}", "comm_modify vel yes",
                 "region box block -1 1 -1 1 -1 1", "create_box 1 box",
                 *[f"create_atoms 1 single {x!r} {y!r} {z!r}" for x, y, z in positions],
                 *[f"set atom {k + 1} diameter {2 * r!r}" for k, r in enumerate(radii)],
                 f"set type 1 density {DENSITY}", "neighbor 0.01 bin", "timestep 1e-5",
                 *extra,
                 f"fix wall all wall/geocontact {params_file} friction {friction} "
                 f"damping {damping} {wall}"):
        lmp.command(line)
    return lmp


def wall_array(lmp) -> np.ndarray:
    from lammps import LMP_STYLE_ATOM, LMP_TYPE_ARRAY

    return np.array(lmp.numpy.extract_fix("wall", LMP_STYLE_ATOM, LMP_TYPE_ARRAY), dtype=float)


def wall_vector(lmp) -> np.ndarray:
    from lammps import LMP_STYLE_GLOBAL, LMP_TYPE_VECTOR

    return np.array([lmp.extract_fix("wall", LMP_STYLE_GLOBAL, LMP_TYPE_VECTOR, k)
                     for k in range(6)])


def interference_path(wy: float) -> list[float]:
    """Wall interference: load past yield, partial unload and reload, separation, re-contact,
    deep reload, separation (in the pair's yield approaches at d = 2 w: wy = delta_y / 2)."""
    legs = [(30, 25), (12, 15), (40, 25), (-2, 30), (38, 25), (60, 20), (-1, 25)]
    out, start = [], -0.5
    for end, steps in legs:
        out += [start + (end - start) * (k + 1) / steps for k in range(steps)]
        start = end
    return [a * wy for a in out]


def test_plugin_registers_the_wall_fix():
    lmp = open_lammps()
    assert lmp.has_style("fix", "wall/geocontact")
    lmp.close()


@pytest.mark.parametrize(("radius", "side"), [(0.1, "lo"), (0.03, "lo"), (0.25, "hi")],
                         ids=["calibrated-radius", "smaller", "larger-on-hi-wall"])
def test_grain_on_a_wall_is_the_pair_law_at_twice_the_interference(radius, side):
    """F_wall(w) = F_pair,r(2 w) along load, unload, reload, separation and re-contact, to 1e-9
    of the peak; per-atom output in the grain's units (w, w_max, w_res = half the pair's)."""
    law = BASE.for_radius(radius)
    wy = 0.5 * law.yield_approach
    top = 0.5
    wall = "zplane 0.0 NULL" if side == "lo" else f"zplane NULL {top}"

    def centre(w):  # the grain's centre at interference w with the wall
        return radius - w if side == "lo" else top - radius + w

    lmp = grains([radius], [(0.0, 0.0, centre(-0.5 * wy))], wall)
    lmp.command("run 0")
    reference = Contact(law)
    lammps_force, python_force = [], []
    for step, w in enumerate(interference_path(wy)):
        lmp.command(f"set atom 1 z {centre(w)!r}")
        # every 9th step a full setup (neighbor lists rebuilt): the history lives on the atom
        lmp.command("run 1 pre yes post no" if step % 9 == 0 else "run 1 pre no post no")
        fz = lmp.numpy.extract_atom("f")[0][2]
        lammps_force.append(fz if side == "lo" else -fz)
        seen = radius - (lmp.numpy.extract_atom("x")[0][2] if side == "lo"
                         else top - lmp.numpy.extract_atom("x")[0][2])
        python_force.append(reference.update(2 * seen)[0])
        if python_force[-1] > 0:
            row = wall_array(lmp)[0]
            st = reference.state
            assert row[0] == pytest.approx(seen, rel=1e-12)
            assert row[1] == pytest.approx(python_force[-1], rel=1e-9)
            assert row[3] == pytest.approx(0.5 * (st.max_approach + st.ratchet_shift), rel=1e-9)
            assert row[4] == pytest.approx(0.5 * (st.residual_approach + st.ratchet_shift),
                                           rel=1e-9)
            assert row[5] == st.branch
    lammps_force, python_force = np.array(lammps_force), np.array(python_force)
    peak = python_force.max()
    assert peak > 30 * law.yield_force
    assert np.any(python_force[65:110] == 0.0)  # separated, then re-contact
    assert np.max(np.abs(lammps_force - python_force)) <= 1e-9 * peak
    lmp.close()


def test_wall_force_vector_is_the_sum_of_the_contact_forces_and_energies_are_half_the_pairs():
    """Grains of three sizes pressed past yield into the floor and the side walls of a box of
    x planes, sliding: the global vector is minus the sum of the wall forces on the grains; the
    dissipated and stored energies are half those of the pair at d = 2 w (the work of F_pair(2w)
    over w)."""
    radii = [0.05, 0.1, 0.2]
    depth = [8.0, 20.0, 40.0]  # in the pair's yield approaches at d = 2 w
    law = [BASE.for_radius(r) for r in radii]
    w = [0.5 * d * lw.yield_approach for d, lw in zip(depth, law, strict=True)]
    # grain 0 on the lo x wall (x = -0.5), grain 2 on the hi x wall (0.5), grain 1 free
    positions = [(-0.5 + radii[0] - w[0], 0.0, 0.0), (0.0, 0.3, 0.0),
                 (0.5 - radii[2] + w[2], -0.3, 0.0)]
    lmp = grains(radii, positions, "xplane -0.5 0.5", friction=0.4)
    for k in (1, 2, 3):
        lmp.command(f"set atom {k} vy 1e-3")
        lmp.command(f"set atom {k} vz 2e-3")
    lmp.command("run 3")
    f = np.array(lmp.numpy.extract_atom("f"))
    vector = wall_vector(lmp)
    assert np.abs(f[:, 1:]).max() > 0  # tangential forces
    assert vector[:3] == pytest.approx(-f.sum(axis=0), rel=1e-12, abs=1e-12 * np.abs(f).max())
    assert vector[5] == 2  # contacts
    dissipated = stored = 0.0
    for k in (0, 2):
        c = Contact(law[k])
        c.update(2 * w[k])
        dissipated += 0.5 * c.dissipated_energy
        stored += 0.5 * c.elastic_energy
    assert vector[3] == pytest.approx(dissipated, rel=1e-9)
    assert vector[4] == pytest.approx(stored, rel=1e-9)
    rows = wall_array(lmp)
    assert rows.shape == (3, 2 * WALL_COLUMNS)
    assert rows[0, 1] > 0 and rows[0, WALL_COLUMNS + 1] == 0  # grain 0: lo wall only
    assert rows[2, 1] == 0 and rows[2, WALL_COLUMNS + 1] > 0  # grain 2: hi wall only
    assert not rows[1].any()
    lmp.close()


def test_an_elastic_wall_contact_is_hertz_sphere_on_flat_with_its_mindlin_stiffness():
    """Below yield the wall force is Hertz for a sphere on a rigid flat, 4/3 E/(1 - nu^2)
    sqrt(r) w^1.5; sliding, the tangential force grows with the sphere-flat Mindlin stiffness
    8 G a/(2 - nu), a = sqrt(r w) (twice the pair's at d = 2 w), and saturates at mu F_n."""
    radius, friction, speed, dt = 0.04, 0.3, 1e-4, 1e-5
    law = BASE.for_radius(radius)
    w = 0.4 * law.yield_approach  # d = 2 w = 0.8 delta_y: elastic
    lmp = grains([radius], [(0.0, 0.0, radius - w)], "zplane 0.0 NULL", friction=friction,
                 extra=[f"timestep {dt!r}"])
    lmp.command("run 1")
    w = radius - lmp.numpy.extract_atom("x")[0][2]  # as LAMMPS sees it
    e, nu = law.material.youngs_modulus, law.material.poissons_ratio
    f_n = 4.0 / 3.0 * e / (1 - nu**2) * math.sqrt(radius) * w**1.5
    assert lmp.numpy.extract_atom("f")[0][2] == pytest.approx(f_n, rel=1e-12)
    k_t = 8.0 * law.material.shear_modulus / (2.0 - nu) * math.sqrt(radius * w)
    lmp.command(f"set atom 1 vy {speed!r}")
    forces = []
    for step in range(1, 300):
        lmp.command(f"run 1 pre {'yes' if step == 1 else 'no'} post no")
        forces.append(-lmp.numpy.extract_atom("f")[0][1])
    assert forces[0] / (speed * dt) == pytest.approx(k_t, rel=1e-6)
    assert forces[-1] == pytest.approx(friction * f_n, rel=1e-9)
    # the torque of the tangential force at the contact point, on the wall's surface
    # (0, 0, -(r - w)), about the centre: (0, 0, -(r - w)) x (0, -F_t, 0) = (-(r - w) F_t, 0, 0)
    assert lmp.numpy.extract_atom("torque")[0][0] == pytest.approx(-(radius - w) * forces[-1],
                                                                   rel=1e-12)
    lmp.close()


def test_a_grain_inside_a_zcylinder_is_pushed_towards_the_axis_by_the_wall_law():
    radius, cylinder = 0.05, 0.6
    law = BASE.for_radius(radius)
    angle = math.radians(30.0)
    reference = Contact(law)
    lmp = grains([radius], [(0.3, 0.0, 0.0)], f"zcylinder {cylinder!r}")
    lmp.command("run 0")
    for depth in (5.0, 20.0, 12.0):
        w = 0.5 * depth * law.yield_approach
        rho = cylinder - radius + w
        lmp.command(f"set atom 1 x {rho * math.cos(angle)!r} y {rho * math.sin(angle)!r}")
        lmp.command("run 1 pre no post no")
        f = np.array(lmp.numpy.extract_atom("f")[0])
        expected = reference.update(2 * w)[0]
        assert f[:2] == pytest.approx(-expected * np.array([math.cos(angle), math.sin(angle)]),
                                      rel=1e-9)
        assert f[2] == 0.0
    lmp.close()


def test_a_contact_left_beyond_the_skin_is_forgotten_but_its_dissipation_is_kept():
    radius = 0.1
    law = BASE.for_radius(radius)
    w = 10 * law.yield_approach
    lmp = grains([radius], [(0.0, 0.0, radius - w)], "zplane 0.0 NULL")
    lmp.command("run 1")
    dissipated = wall_vector(lmp)[3]
    lmp.command(f"set atom 1 z {radius + 0.005!r}")  # apart, within the skin (0.01)
    lmp.command("run 1")
    assert wall_array(lmp)[0, 3] > 0 and wall_vector(lmp)[3] == dissipated  # remembered
    lmp.command(f"set atom 1 z {radius + 0.02!r}")  # beyond the skin
    lmp.command("run 1")
    assert not wall_array(lmp)[0].any() and wall_vector(lmp)[3] == dissipated
    reference = Contact(law)
    reference.update(2 * w)
    assert dissipated == pytest.approx(0.5 * reference.dissipated_energy, rel=1e-9)
    # back on the wall at half the depth: a virgin contact (the dent was forgotten)
    lmp.command(f"set atom 1 z {radius - 0.5 * w!r}")
    lmp.command("run 1")
    assert lmp.numpy.extract_atom("f")[0][2] == pytest.approx(Contact(law).update(w)[0],
                                                              rel=1e-12)
    lmp.close()


# --- moving walls ----------------------------------------------------------------------------

SPEED = 0.02  # m/s, the top wall down onto a grain held on the floor
STEPS = 120
TIMESTEP = 1e-5


def compressed_grain(motion: str, damping: float) -> np.ndarray:
    """A grain of radius 0.05 sitting on the fixed floor (fix `floor`), held in place (no
    integrator), the top wall (fix `wall`) moving down onto it: per step the force on the
    grain (z) and the floor's force (z)."""
    radius = 0.05
    top = 2 * radius + 0.2 * BASE.for_radius(radius).yield_approach  # a small gap first
    lmp = grains([radius], [(0.0, 0.0, radius)], f"zplane NULL {top!r} {motion}",
                 damping=damping,
                 extra=[f"timestep {TIMESTEP!r}", f"variable down equal -{SPEED!r}*step*dt",
                        f"fix floor all wall/geocontact {CALIBRATED_FILE} zplane 0.0 NULL"])
    rows = []
    lmp.command("run 0")
    for _ in range(STEPS):
        lmp.command("run 1 pre no post no")
        from lammps import LMP_STYLE_GLOBAL, LMP_TYPE_VECTOR

        rows.append([lmp.numpy.extract_atom("f")[0][2],
                     lmp.extract_fix("floor", LMP_STYLE_GLOBAL, LMP_TYPE_VECTOR, 2)])
    lmp.close()
    return np.array(rows)


def test_a_wall_moving_at_constant_velocity_compresses_a_grain_on_a_fixed_wall():
    radius = 0.05
    law = BASE.for_radius(radius)
    rows = compressed_grain(f"velocity {-SPEED!r}", damping=0.0)
    top = 2 * radius + 0.2 * law.yield_approach
    reference = Contact(law)
    expected = []
    for step in range(1, STEPS + 1):
        w = radius - (top - SPEED * step * TIMESTEP - radius)  # interference with the top wall
        expected.append(-reference.update(2 * w)[0])
    expected = np.array(expected)
    assert np.all(np.diff(expected) < 0) and -expected.min() > 10 * law.yield_force  # plastic
    assert np.abs(rows[:, 0] - expected).max() <= 1e-9 * np.abs(expected).max()
    assert np.all(rows[:, 1] == 0.0)  # the floor is just touched: no force


def test_a_wall_driven_by_a_position_variable_moves_as_one_with_that_velocity():
    """`position v_down` with v_down = -v t gives the forces of `velocity -v`, damping (which
    sees the wall's velocity, from the variable's steps) included."""
    by_velocity = compressed_grain(f"velocity {-SPEED!r}", damping=0.3)
    by_variable = compressed_grain("position v_down", damping=0.3)
    undamped = compressed_grain(f"velocity {-SPEED!r}", damping=0.0)
    peak = np.abs(by_velocity[:, 0]).max()
    assert np.abs(by_velocity[:, 0] - undamped[:, 0]).max() > 1e-3 * peak  # damping acts
    assert np.abs(by_variable - by_velocity).max() <= 1e-9 * peak


def test_a_grain_between_platens_measures_the_pair_law_at_the_platen_displacement():
    """docs/model.md §10, laboratory tests: a free grain (integrated, damped) squeezed slowly
    between a
    fixed floor and a roof moving down is two sphere-flat contacts in series at the same force,
    so the platen displacement is the pair's approach: F = F_pair,r(displacement), to the
    viscous force of the slow compression (< 1 % of the force, past yield)."""
    radius, speed, dt, beta = 0.1, 2e-4, 1e-5, 0.5
    law = BASE.for_radius(radius)
    from lammps import LMP_STYLE_GLOBAL, LMP_TYPE_VECTOR

    lmp = grains([radius], [(0.0, 0.0, radius)],
                 f"zplane NULL {2 * radius!r} velocity {-speed!r}", damping=beta,
                 extra=[f"timestep {dt!r}", "fix integrate all nve/sphere",
                        f"fix floor all wall/geocontact {CALIBRATED_FILE} damping {beta} "
                        "zplane 0.0 NULL"])
    chunk = int(2 * law.yield_approach / speed / dt)  # 2 delta_y of platen travel
    lmp.command("run 0")
    for k in range(1, 21):
        lmp.command(f"run {chunk} pre no post no")
        displacement = speed * dt * chunk * k
        roof = lmp.extract_fix("wall", LMP_STYLE_GLOBAL, LMP_TYPE_VECTOR, 2)
        floor = -lmp.extract_fix("floor", LMP_STYLE_GLOBAL, LMP_TYPE_VECTOR, 2)
        expected = Contact(law).update(displacement)[0]
        if k > 10:  # past 20 delta_y: plastic, the start-up transient gone
            assert expected > 20 * law.yield_force
            assert roof == pytest.approx(floor, rel=1e-6)  # in balance
            assert roof == pytest.approx(expected, rel=1e-2)
    lmp.close()


def test_a_wiggling_wall_loads_and_unloads_along_the_law():
    radius = 0.1
    law = BASE.for_radius(radius)
    amplitude, period = 30 * law.yield_approach, 100 * TIMESTEP
    lmp = grains([radius], [(0.0, 0.0, 2 * radius)], f"zplane {radius!r} NULL wiggle z "
                 f"{amplitude!r} {period!r}", extra=[f"timestep {TIMESTEP!r}"])
    reference = Contact(law)
    lmp.command("run 0")
    forces, expected = [], []
    for step in range(1, 160):
        lmp.command("run 1 pre no post no")
        wall = radius + amplitude * (1 - math.cos(2 * math.pi * step * TIMESTEP / period))
        forces.append(lmp.numpy.extract_atom("f")[0][2])
        expected.append(reference.update(2 * (wall - radius))[0])
    lmp.close()
    expected = np.array(expected)
    assert expected.max() > 20 * law.yield_force and expected[-1] > 0  # a second loading
    assert np.abs(np.array(forces) - expected).max() <= 1e-9 * expected.max()


# --- restart ----------------------------------------------------------------------------------

def restart_run(lmp, steps: int) -> np.ndarray:
    """Steps of the wiggling wall with a grain sliding on it: force and torque on the grain and
    the wall's output."""
    rows = []
    for k in range(steps):
        lmp.command(f"run 1 pre {'yes' if k == 0 else 'no'} post no")
        rows.append([*lmp.numpy.extract_atom("f")[0], *lmp.numpy.extract_atom("torque")[0],
                     *wall_array(lmp)[0], *wall_vector(lmp)])
    return np.array(rows)


WIGGLE_FIX = "zplane {lo!r} NULL wiggle z {amplitude!r} {period!r}"


def wiggling_grain():
    radius = 0.1
    law = BASE.for_radius(radius)
    wall = WIGGLE_FIX.format(lo=radius, amplitude=25 * law.yield_approach, period=100 * TIMESTEP)
    lmp = grains([radius], [(0.0, 0.0, 2 * radius)], wall, friction=0.5, damping=0.1,
                 extra=[f"timestep {TIMESTEP!r}"])
    lmp.command("set atom 1 vx 0.01")
    return lmp, wall


def test_restart_written_mid_history_continues_as_the_uninterrupted_run(tmp_path):
    """Written while the grain is on an unloading branch of its second load, with a tangential
    force and the wall in mid-wiggle, read into a new LAMMPS (the fix defined again with the
    same ID): the run goes on as if never stopped (the wall's clock comes from the file)."""
    total, stop = 200, 160
    lmp, wall = wiggling_grain()
    uninterrupted = restart_run(lmp, total)
    lmp.close()

    lmp, wall = wiggling_grain()
    before = restart_run(lmp, stop)
    assert before[-1, 6 + 5] == 2 and abs(before[-1, 0]) > 0  # unloading, sliding
    lmp = scenarios.reopen_from_restart(lmp, tmp_path / "wall.restart")
    lmp.command(f"fix wall all wall/geocontact {CALIBRATED_FILE} friction 0.5 damping 0.1 "
                f"{wall}")
    after = restart_run(lmp, total - stop)
    lmp.close()
    resumed = np.vstack([before, after])
    scale = np.abs(uninterrupted).max(axis=0) + 1e-300
    assert np.all(np.abs(resumed - uninterrupted) <= 1e-12 * scale)


def pair_on_floor_run(lmp, first: int, last: int, radius: float, dy: float) -> np.ndarray:
    """Two grains pressed together (pair law) and into the floor (wall law) along a path,
    sliding: forces on both grains per step."""
    rows = []
    for k in range(first, last):
        depth = dy * (20 * math.sin(math.pi * k / 20) ** 2 + 0.5 * k / 10)
        lmp.command(f"set atom 1 z {radius - depth!r} x {-radius + 0.5 * depth!r}")
        lmp.command(f"set atom 2 z {radius - 0.5 * depth!r} x {radius - 0.5 * depth!r}")
        lmp.command(f"run 1 pre {'yes' if k == first else 'no'} post no")
        ids = lmp.numpy.extract_atom("id")
        f = np.array(lmp.numpy.extract_atom("f"))[np.argsort(ids)]
        rows.append(f.ravel())
    return np.array(rows)


def test_restart_with_pair_and_wall_histories_together(tmp_path):
    """pair_style geocontact's contact history and the wall's records in one restart file
    (two per-atom restart sections): both come back, the run continues uninterrupted."""
    radius = 0.1
    dy = BASE.for_radius(radius).yield_approach
    setup = ["pair_style geocontact", f"pair_coeff * * {CALIBRATED_FILE} friction 0.4"]

    def fresh():
        lmp = grains([radius, radius], [(-radius, 0.0, radius), (radius, 0.0, radius)],
                     "zplane 0.0 NULL", friction=0.4, extra=setup)
        lmp.command("set atom 2 vy 1e-3")
        return lmp

    lmp = fresh()
    uninterrupted = pair_on_floor_run(lmp, 0, 50, radius, dy)
    lmp.close()
    lmp = fresh()
    before = pair_on_floor_run(lmp, 0, 30, radius, dy)
    restart = tmp_path / "both.restart"
    lmp.command(f"write_restart {restart}")
    lmp.close()
    lmp = open_lammps()
    lmp.command(f"read_restart {restart}")
    lmp.command("comm_modify vel yes")
    lmp.command(f"fix wall all wall/geocontact {CALIBRATED_FILE} friction 0.4 damping 0.0 "
                "zplane 0.0 NULL")
    after = pair_on_floor_run(lmp, 30, 50, radius, dy)
    lmp.close()
    resumed = np.vstack([before, after])
    assert np.abs(uninterrupted[:, 0::3]).max() > 0  # the pair pushes along x
    assert np.abs(resumed - uninterrupted).max() <= 1e-12 * np.abs(uninterrupted).max()


# the per-atom layout tag as the fix writes it (fix_wall_geocontact.h): "GCWA" in the high, the
# layout version in the low 32 bits of a 64-bit word, once per atom
ATOM_TAG = struct.pack("<q", (int.from_bytes(b"GCWA", "little") << 32) | 5)


@pytest.mark.parametrize(("edit", "fix", "message"), [
    (None, "zplane 0.0 0.5", None),
    (ATOM_TAG[:4].replace(b"\x05", b"\x06") + ATOM_TAG[4:], "zplane 0.0 0.5",
     "wall contacts have wall layout version 6; this fix reads wall layout versions 1 to 5 "
     "only"),
    (struct.pack("<d", 1.0), "zplane 0.0 0.5", "wall contacts have no wall/geocontact layout tag"),
    (None, "zplane 0.0 NULL", "wall contacts are for 2 wall\\(s\\), this fix wall has 1"),
], ids=["intact", "other-version", "foreign", "other-wall-count"])
def test_a_restart_of_another_layout_or_wall_count_is_refused(tmp_path, edit, fix, message):
    radius = 0.1
    w = 10 * BASE.for_radius(radius).yield_approach
    lmp = grains([radius], [(0.0, 0.0, radius - w)], "zplane 0.0 0.5")
    lmp.command("run 1")
    restart = tmp_path / "wall.restart"
    lmp.command(f"write_restart {restart}")
    lmp.close()
    if edit is not None:
        data = restart.read_bytes()
        assert data.count(ATOM_TAG) == 1
        restart.write_bytes(data.replace(ATOM_TAG, edit))
    lmp = open_lammps()
    lmp.command(f"read_restart {restart}")
    lmp.command(f"fix wall all wall/geocontact {CALIBRATED_FILE} friction 0 damping 0 {fix}")
    if message is None:  # the dent came back: unloading to half the interference
        lmp.command(f"set atom 1 z {radius - 0.5 * w!r}")
        lmp.command("run 1")
        seen = radius - lmp.numpy.extract_atom("x")[0][2]
        reference = Contact(BASE.for_radius(radius))
        reference.update(2 * w)
        unloading = reference.update(2 * seen)[0]
        assert unloading < 0.5 * Contact(BASE.for_radius(radius)).update(2 * seen)[0]
        assert lmp.numpy.extract_atom("f")[0][2] == pytest.approx(unloading, rel=1e-9)
    else:
        with pytest.raises(Exception, match=message):
            lmp.command("run 0")
    lmp.close()


# --- MPI: 1 and 2 ranks, migration, restart across rank counts -----------------------------

run_scenario = scenarios.run_scenario




def test_wall_contacts_cross_ranks_and_restart_on_another_rank_count(tmp_path):
    """The `wall` scenario (lammps_scenarios.py): plastic wall contacts carried across the rank
    boundary give the forces of 1 rank on 2; a restart written on 2 ranks mid-history,
    continued on 1, gives the uninterrupted run; each grain follows the pair law at d = 2 w."""
    import lammps_scenarios as scenarios

    restart = tmp_path / "wall.restart"
    serial = run_scenario(1, "wall")
    parallel = run_scenario(2, "wall", "--restart-out", str(restart))
    resumed = run_scenario(1, "wall", "--resume", str(restart))
    assert (serial["ranks"], parallel["ranks"]) == (1, 2)
    f1 = np.array([s["forces"] for s in serial["steps"]])
    f2 = np.array([s["forces"] for s in parallel["steps"]])
    fr = np.array([s["forces"] for s in resumed["steps"]])
    x = np.array([s["x"] for s in serial["steps"]])
    assert np.all(x[:, :2].min(axis=0) < -0.2) and np.all(x[:, :2].max(axis=0) > 0.2)  # crossed
    peak = np.abs(f1).max()
    assert np.abs(f2 - f1).max() <= 1e-12 * peak
    assert np.abs(fr - f1[scenarios.WALL_RESTART_AFTER:]).max() <= 1e-12 * peak
    w1 = np.array([s["wall"] for s in serial["steps"]])
    wr = np.array([s["wall"] for s in resumed["steps"]])
    assert np.abs(wr - w1[scenarios.WALL_RESTART_AFTER:]).max() <= 1e-12 * np.abs(w1).max()
    # the normal force of each grain: the pair law of its radius at d = 2 w (damping aside: no
    # normal velocity, positions prescribed)
    for k, (radius, side, _, _) in enumerate(scenarios.WALL_GRAINS):
        contact = Contact(BASE.for_radius(radius))
        z = [scenarios.wall_positions(step)[k][2] for step in range(len(f1))]
        w = [radius - (0.5 - side * zk) for zk in z]  # interference with its wall
        expected = np.array([-side * contact.update(2 * wk)[0] for wk in w])
        assert expected.max() - expected.min() > 20 * BASE.for_radius(radius).yield_force
        assert np.abs(f1[:, k, 2] - expected).max() <= 1e-9 * np.abs(expected).max()


# --- bad input ----------------------------------------------------------------------------------

@pytest.mark.parametrize(("wall", "message"), [
    ("zplane 0.5 0.1", "zplane lo \\(0.5\\) must not be above hi \\(0.1\\)"),
    ("zplane NULL NULL", "zplane NULL NULL has no wall"),
    ("zplane 0 NULL stiffness 3", "unknown keyword 'stiffness'"),
    ("stiffness 3 zplane 0 NULL", "unknown keyword 'stiffness'"),
    ("zcylinder -1", "zcylinder radius must be > 0"),
    ("zcylinder 0.5 wiggle x 0.1 1.0", "a zcylinder wiggles along z only"),
    ("zplane 0 NULL velocity 1 wiggle z 0.1 1", "'wiggle' after another wall motion"),
    ("zplane 0 NULL position down", "position needs an equal-style variable v_name"),
    ("zplane", "zplane needs lo and hi"),
    ("friction -1 zplane 0 NULL", "friction must be >= 0"),
])
def test_bad_wall_arguments_are_one_line_lammps_errors(wall, message):
    lmp = open_lammps()
    for line in ("units si", "atom_style sphere", "boundary f f f",
                 "region box block -1 1 -1 1 -1 1", "create_box 1 box",
                 "create_atoms 1 single 0 0 0"):
        lmp.command(line)
    with pytest.raises(Exception, match=message):
        lmp.command(f"fix wall all wall/geocontact {CALIBRATED_FILE} {wall}")
    lmp.close()


def test_a_missing_parameter_file_is_a_lammps_error():
    lmp = open_lammps()
    for line in ("units si", "atom_style sphere", "region box block -1 1 -1 1 -1 1",
                 "create_box 1 box"):
        lmp.command(line)
    with pytest.raises(Exception, match="parameter file not found or unreadable: /nonexist"):
        lmp.command("fix wall all wall/geocontact /nonexistent/P.json zplane 0 NULL")
    lmp.close()


def test_a_wall_in_a_periodic_dimension_is_a_lammps_error():
    lmp = open_lammps()
    for line in ("units si", "atom_style sphere", "boundary p p p",
                 "region box block -1 1 -1 1 -1 1", "create_box 1 box"):
        lmp.command(line)
    with pytest.raises(Exception, match="zplane wall in a periodic dimension"):
        lmp.command(f"fix wall all wall/geocontact {CALIBRATED_FILE} zplane 0 NULL")
    lmp.close()


def test_wrong_atom_style_is_a_lammps_error():
    lmp = open_lammps()
    for line in ("units si", "atom_style atomic", "region box block -1 1 -1 1 -1 1",
                 "create_box 1 box"):
        lmp.command(line)
    with pytest.raises(Exception, match="requires atom style sphere"):
        lmp.command(f"fix wall all wall/geocontact {CALIBRATED_FILE} zplane 0 NULL")
    lmp.close()


@pytest.mark.parametrize(("setting", "message"), [
    ("set atom 1 diameter 0.0", "atom 1 has radius 0 m; every grain needs a radius > 0"),
    ("variable down atom x", "variable 'down' of position is not equal-style"),
    ("", "variable 'down' of position does not exist"),
])
def test_bad_atoms_or_variables_stop_the_run(setting, message):
    lmp = grains([0.1], [(0.0, 0.0, 0.1)], "zplane 0 NULL position v_down",
                 extra=["variable down equal 0.0"] if "diameter" in setting else [])
    if setting:
        lmp.command(setting)
    with pytest.raises(Exception, match=message):
        lmp.command("run 0")
    lmp.close()
