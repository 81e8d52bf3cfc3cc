"""Rolling (`rolling sds`) and twisting (`twisting marshall`) resistance of pair_style
geocontact and fix wall/geocontact against LAMMPS's own pair granular / fix wall/gran with the
same sub-models, run in the same process, and against the closed form of the spring alone.

The grains are held in place (fix setforce 0 0 0 on atoms at rest) and only spin, at an
approach below yield, where the geocontact law is Hertz exactly and both codes have the same
normal force: LAMMPS's hertz/material with the same E and nu for two grains; for a wall, E_wall
= 2 E, because LAMMPS's wall is a body of the grain's material and ours is rigid (sphere-flat
modulus E / (1 - nu^2)). Spun like meshing gears (w_j = -w_i r_i / r_j, no sliding), a pair
feels the rolling spring only: I theta'' = -2 k R*^2 theta for equal grains (R* = r / 2), a
grain on a wall I theta'' = -k r^2 theta (the wall's R* = r, as LAMMPS), theta the spin angle.
Spun about the normal, the twisting spring k_tw = k_t a^2 / 2 (k_t = 8 G* a, a = sqrt(R* d)).
"""

from __future__ import annotations

import math
import re
from pathlib import Path

import lammps_scenarios as scenarios
import numpy as np
import pytest

from geocontact.analyses.lammps_plugin import open_lammps
from geocontact.law import load_params

ROOT = Path(__file__).resolve().parents[1]
PARAMS_FILE = ROOT / "examples" / "params-illustrative.json"
PARAMS = load_params(PARAMS_FILE)
R = PARAMS.material.radius
E = PARAMS.material.youngs_modulus
NU = PARAMS.material.poissons_ratio
DENSITY = 2650.0
MASS = DENSITY * 4.0 / 3.0 * math.pi * R**3
INERTIA = 0.4 * MASS * R * R
K_ROLL = 1.0e3
SPIN = 1.0e-3  # rad/s
STEPS = 700
DATA = Path(__file__).with_name("data")


def spinning(style: str, spins, model: str, *, radius2=R, dt, approach, friction=0.0,
             tangential=None, wall=False):
    """One grain on a floor (wall) or two grains on the x axis (atom 1 at the origin), held in
    place and spun; `style` "ours" or "lammps", `model` the rolling/twisting keywords.
    `tangential`: LAMMPS's tangential model (stiffness of ours); otherwise none (friction 0)."""
    lmp = open_lammps()
    atoms = ([f"create_atoms 1 single 0 0 {R - approach!r}"] if wall else
             ["create_atoms 1 single 0 0 0",
              f"create_atoms 1 single {R + radius2 - approach!r} 0 0",
              f"set atom 2 diameter {2 * radius2!r}"])
    for line in ("units si", "atom_style sphere", "atom_modify map array", "boundary f f f",
                 "comm_modify vel yes", "region box block -1 1 -1 1 -1 1", "create_box 1 box",
                 *atoms, f"set atom 1 diameter {2 * R!r}", f"set type 1 density {DENSITY}",
                 "neighbor 0.001 bin", f"timestep {dt!r}", "fix nve all nve/sphere"):
        lmp.command(line)
    lammps_tangential = ("tangential linear_nohistory 0 0" if tangential is None else
                         f"tangential linear_history {tangential!r} 0 {friction!r}")
    if wall:
        if style == "ours":
            lmp.command(f"fix wall all wall/geocontact {PARAMS_FILE} friction {friction!r} "
                        f"{model} zplane 0.0 NULL")
        else:
            lmp.command(f"fix wall all wall/gran granular hertz/material {2 * E!r} 0 {NU!r} "
                        f"{lammps_tangential} {model} zplane 0.0 NULL")
    elif style == "ours":
        lmp.command("pair_style geocontact")
        lmp.command(f"pair_coeff * * {PARAMS_FILE} friction {friction!r} {model}")
    else:
        lmp.command("pair_style granular")
        lmp.command(f"pair_coeff * * hertz/material {E!r} 0 {NU!r} {lammps_tangential} {model}")
    lmp.command("fix hold all setforce 0 0 0")  # after the walls: the grains stay put
    for tag, w in enumerate(spins, start=1):
        lmp.command(f"set atom {tag} omega {w[0]!r} {w[1]!r} {w[2]!r}")
    lmp.command("run 0")
    rows = []
    for _ in range(STEPS):
        lmp.command("run 1 pre no post no")
        n = len(spins)
        rows.append(np.concatenate([np.array(lmp.numpy.extract_atom("omega")[:n]).ravel(),
                                    np.array(lmp.numpy.extract_atom("torque")[:n]).ravel()]))
    lmp.close()
    return np.array(rows)  # (step, [omega of each atom, torque of each atom])


def relative_gap(ours, theirs):
    return np.abs(ours - theirs).max() / np.abs(theirs).max()


def hertz_force(approach, reff):
    e_star = E / (2.0 * (1.0 - NU * NU))
    return 4.0 / 3.0 * e_star * math.sqrt(reff) * approach**1.5


PAIR_APPROACH = 0.5 * PARAMS.yield_approach
WALL_APPROACH = 0.25 * PARAMS.yield_approach  # at d = 2 w: half the pair's yield approach


@pytest.mark.parametrize("coulomb", [False, True], ids=["spring", "coulomb"])
def test_pair_rolling_is_lammps_rolling_sds_and_the_rolling_spring(coulomb):
    reff = R / 2
    omega = math.sqrt(2 * K_ROLL * reff**2 / INERTIA)
    dt = 0.01 / omega
    fn = hertz_force(PAIR_APPROACH, reff)
    assert fn == pytest.approx(PARAMS.hertz_coefficient * PAIR_APPROACH**1.5, rel=1e-12)
    # the Coulomb limit at 0.3 of the spring's peak force: rolls, then slides
    mu = 0.3 * K_ROLL * 2 * reff * SPIN / omega / fn if coulomb else 10.0
    model = f"rolling sds {K_ROLL!r} 0 {mu!r}"
    spins = [(0, 0, SPIN), (0, 0, -SPIN)]
    ours = spinning("ours", spins, model, dt=dt, approach=PAIR_APPROACH)
    theirs = spinning("lammps", spins, model, dt=dt, approach=PAIR_APPROACH)
    assert relative_gap(ours, theirs) <= 1e-12  # measured: 0 (spring), 1.4e-15 (Coulomb)
    torque_1, torque_2 = ours[:, 8], ours[:, 11]
    assert np.array_equal(torque_2, -torque_1)  # a couple: equal and opposite
    if coulomb:
        assert np.abs(torque_1).max() == pytest.approx(reff * mu * fn, rel=1e-9)
        sliding = np.abs(torque_1) > (1 - 1e-9) * reff * mu * fn
        assert sliding.sum() > 100
        # sliding: the torque is constant, the spin falls at the rate R* mu F_n / I
        rate = np.diff(ours[:, 2])[sliding[1:] & sliding[:-1]] / dt
        assert np.abs(rate).max() == pytest.approx(reff * mu * fn / INERTIA, rel=1e-6)
    else:
        t = dt * np.arange(1, STEPS + 1)
        # the harmonic rolling spring; Verlet's phase error (omega dt)^2 / 24 per radian
        assert np.abs(ours[:, 2] - SPIN * np.cos(omega * t)).max() <= 1e-4 * SPIN
        assert np.abs(torque_1).max() == pytest.approx(2 * K_ROLL * reff**2 * SPIN / omega,
                                                       rel=1e-3)


def test_pair_rolling_of_unequal_grains_is_lammps_rolling_sds():
    r2 = 0.6 * R
    reff = R * r2 / (R + r2)
    dt = 0.01 / math.sqrt(2 * K_ROLL * reff**2 / INERTIA)
    model = f"rolling sds {K_ROLL!r} 20.0 10.0"  # with rolling damping gamma_roll
    spins = [(0, 0.4 * SPIN, SPIN), (0.2 * SPIN, 0, -SPIN)]
    ours = spinning("ours", spins, model, radius2=r2, dt=dt, approach=PAIR_APPROACH)
    theirs = spinning("lammps", spins, model, radius2=r2, dt=dt, approach=PAIR_APPROACH)
    assert relative_gap(ours, theirs) <= 1e-12  # measured: 0
    assert np.abs(ours[:, 6:9]).max() > 0.0


@pytest.mark.parametrize("slip", [False, True], ids=["spring", "slip"])
def test_pair_twisting_is_lammps_twisting_marshall_and_the_twisting_spring(slip):
    reff = R / 2
    a = math.sqrt(reff * PAIR_APPROACH)
    g_star = PARAMS.material.shear_modulus / (2 * (2 - NU))
    kt = 8 * g_star * a
    k_twist = 0.5 * kt * a * a
    omega = math.sqrt(2 * k_twist / INERTIA)
    dt = 0.01 / omega
    friction = 0.5
    limit = 2.0 / 3.0 * friction * a * hertz_force(PAIR_APPROACH, reff)
    spin = 3 * limit / k_twist * omega if slip else SPIN  # peak spring torque 3x the limit
    spins = [(spin, 0, 0), (-spin, 0, 0)]  # along the normal: no rolling, no sliding
    # LAMMPS's marshall takes k_t from the tangential model: linear_history with our k_t
    # (constant while the grains are held)
    kw = dict(dt=dt, approach=PAIR_APPROACH, friction=friction, tangential=kt)
    ours = spinning("ours", spins, "twisting marshall", **kw)
    theirs = spinning("lammps", spins, "twisting marshall", **kw)
    # measured 1.8e-11 (spring), 5e-12 (slip): LAMMPS's a and F_n are Hertz's, ours the law's
    assert relative_gap(ours, theirs) <= 1e-9
    if slip:
        assert np.abs(ours[:, 6]).max() == pytest.approx(limit, rel=1e-9)
    else:
        t = dt * np.arange(1, STEPS + 1)
        assert np.abs(ours[:, 0] - SPIN * np.cos(omega * t)).max() <= 1e-4 * SPIN
        assert np.abs(ours[:, 6]).max() < limit


@pytest.mark.parametrize("case", ["rolling", "rolling-coulomb", "twisting"])
def test_wall_rolling_and_twisting_are_fix_wall_gran_and_the_closed_form(case):
    fn = 4.0 / 3.0 * E / (1 - NU * NU) * math.sqrt(R) * WALL_APPROACH**1.5  # sphere on flat
    if case == "twisting":
        a = math.sqrt(R * WALL_APPROACH)  # the pair's contact radius at d = 2 w
        kt = 8 * PARAMS.material.shear_modulus / (2 - NU) * a  # sphere-flat Mindlin
        omega = math.sqrt(0.5 * kt * a * a / INERTIA)
        model, spins, kw = "twisting marshall", [(0, 0, SPIN)], dict(friction=0.5, tangential=kt)
    else:
        omega = math.sqrt(K_ROLL * R * R / INERTIA)
        mu = 0.3 * K_ROLL * R * SPIN / omega / fn if case == "rolling-coulomb" else 10.0
        model, spins, kw = f"rolling sds {K_ROLL!r} 0 {mu!r}", [(SPIN, 0, 0)], {}
    dt = 0.01 / omega
    ours = spinning("ours", spins, model, dt=dt, approach=WALL_APPROACH, wall=True, **kw)
    theirs = spinning("lammps", spins, model, dt=dt, approach=WALL_APPROACH, wall=True, **kw)
    assert relative_gap(ours, theirs) <= 1e-9  # measured: 0, 1.4e-16, 1.8e-11
    axis = 2 if case == "twisting" else 0
    if case == "rolling-coulomb":
        assert np.abs(ours[:, 3]).max() == pytest.approx(R * mu * fn, rel=1e-9)
    else:
        t = dt * np.arange(1, STEPS + 1)
        assert np.abs(ours[:, axis] - SPIN * np.cos(omega * t)).max() <= 1e-4 * SPIN


# --- restarts: the rolling displacement and twist angle come back ------------------------------

RESISTANCE = f"rolling sds {K_ROLL!r} 5.0 0.05 twisting marshall"


def spinning_grains(wall: bool):
    """Two unequal grains on the x axis (or one on a floor) held, spun about all three axes,
    with friction, rolling and twisting resistance (all histories build up)."""
    lmp = open_lammps()
    atoms = ([f"create_atoms 1 single 0 0 {R - WALL_APPROACH!r}"] if wall else
             ["create_atoms 1 single 0 0 0",
              f"create_atoms 1 single {1.7 * R - PAIR_APPROACH!r} 0 0",
              f"set atom 2 diameter {1.4 * R!r}"])
    for line in ("units si", "atom_style sphere", "atom_modify map array", "boundary f f f",
                 "comm_modify vel yes", "region box block -1 1 -1 1 -1 1", "create_box 1 box",
                 *atoms, f"set atom 1 diameter {2 * R!r}", f"set type 1 density {DENSITY}",
                 "set atom 1 omega 3e-2 2e-2 1e-2", "timestep 2e-4"):
        lmp.command(line)
    if not wall:
        lmp.command("set atom 2 omega -1e-2 -3e-2 2e-2")
        lmp.command("pair_style geocontact")
        lmp.command(f"pair_coeff * * {PARAMS_FILE} friction 0.5 {RESISTANCE}")
    restart_settings(lmp, wall)
    return lmp


def restart_settings(lmp, wall: bool):
    """What read_restart does not restore: fixes, ghost velocities, neighbor settings."""
    lines = ["comm_modify vel yes", "neighbor 0.001 bin", "fix nve all nve/sphere"]
    if wall:
        lines.append(f"fix wall all wall/geocontact {PARAMS_FILE} friction 0.5 {RESISTANCE} "
                     "zplane 0.0 NULL")
    for line in (*lines, "fix hold all setforce 0 0 0"):
        lmp.command(line)


def spin_steps(lmp, steps: int) -> np.ndarray:
    rows = []
    for k in range(steps):
        lmp.command(f"run 1 pre {'yes' if k == 0 else 'no'} post no")
        ids = lmp.numpy.extract_atom("id")
        order = np.argsort(ids)
        rows.append(np.concatenate([np.array(lmp.numpy.extract_atom("omega"))[order].ravel(),
                                    np.array(lmp.numpy.extract_atom("torque"))[order].ravel()]))
    return np.array(rows)


@pytest.mark.parametrize("wall", [False, True], ids=["pair", "wall"])
def test_restart_with_rolling_and_twist_history_continues_as_the_uninterrupted_run(
        tmp_path, wall):
    # the run split in one process (a full setup at step 150, as a resumed run has): with
    # velocity-dependent forces the setup's forces are not the last step's (LAMMPS alike)
    lmp = spinning_grains(wall)
    uninterrupted = np.vstack([spin_steps(lmp, 150), spin_steps(lmp, 250)])
    lmp.close()
    lmp = spinning_grains(wall)
    before = spin_steps(lmp, 150)
    restart = tmp_path / "spinning.restart"
    lmp.command(f"write_restart {restart}")
    lmp.close()
    lmp = open_lammps()
    lmp.command(f"read_restart {restart}")
    restart_settings(lmp, wall)
    after = spin_steps(lmp, 250)
    lmp.close()
    resumed = np.vstack([before, after])
    n = 1 if wall else 2
    torques = uninterrupted[:, 3 * n:]
    assert np.abs(torques).max() > 0
    assert np.abs(resumed - uninterrupted).max() <= 1e-12 * np.abs(uninterrupted).max()
    # the file carried stretched rolling and twisting springs (their torques act at once)
    assert np.abs(before[-1, 3 * n:]).max() > 0.1 * np.abs(torques).max()


@pytest.mark.parametrize("name", ["pair-v1.restart", "pair-v2.restart", "pair-v3.restart",
                                  "pair-v4.restart", "pair-v5.restart", "pair-v6.restart"])
def test_pair_restart_files_of_older_layouts_are_still_read(name):
    """Files written by older plugins (tests/data/make_layout_restarts.py): version 1, before
    rolling, version 2, before the cumulative dissipation tally, version 3, before the contact
    radius in the record, version 4, before the energy ledger, version 5, before the
    travelled distances, and version 6, before the due flag: the pair's contacts carry on as
    the same run with this plugin (zero rolling and twist history; the energy scale set and the
    contact radius taken from the law state at the next step; the ledger from zero; travel 0,
    far below the dent's diameter here; not due). The
    normal history is the run's to round-off. The tangential force these plugins stored was
    not rescaled as the contact radius fell (issue 34), so the file's differs from this
    plugin's run: it is rescaled at the first step (and never above the Coulomb limit), and
    from the second step on, with the grain sliding again, it is the run's."""
    import test_lammps_plugin as pair_tests

    path = pair_tests.approach_path(pair_tests.PARAMS.yield_approach)[:50]
    lmp = pair_tests.slipping_pair()
    uninterrupted = pair_tests.drive_slipping_pair(lmp, path)
    lmp.close()
    lmp = open_lammps()
    lmp.command(f"read_restart {DATA / name}")
    for line in ("comm_modify vel yes", "neighbor 0.01 bin",
                 "neigh_modify every 1 delay 0 check yes",
                 "compute pl all pair/local p1 p2 p3 p4 p5 p6"):
        lmp.command(line)
    after = pair_tests.drive_slipping_pair(lmp, path[33:])
    lmp.close()
    scale = np.abs(uninterrupted).max()
    assert abs(uninterrupted[32, 1]) > 0  # a tangential force carried by the file
    normal = [0, 2, 3, 5, 6, 7]  # force x; p1, p2, p4, p5, p6 (p3: the tangential force)
    assert np.abs(after[:, normal] - uninterrupted[33:, normal]).max() <= 1e-12 * scale
    assert np.abs(after[1:] - uninterrupted[34:]).max() <= 1e-12 * scale
    assert after[0, 4] <= 0.5 * after[0, 3] * (1 + 1e-12)  # the slipping pair's friction 0.5


@pytest.mark.parametrize("name", ["wall-v1.restart", "wall-v2.restart", "wall-v3.restart",
                                  "wall-v4.restart"])
def test_wall_restart_files_of_older_layouts_are_still_read(name):
    """The wall's files written by the plugin before rolling (version 1), before the contact
    radius (version 2), before the energy ledger (version 3) and before memory with a place
    (version 4; tests/data/make_layout_restarts.py) carry on as the same contact with this
    plugin."""
    import test_lammps_wall as wall_tests

    radius = 0.1
    w = 10 * wall_tests.BASE.for_radius(radius).yield_approach
    lmp = open_lammps()
    lmp.command(f"read_restart {DATA / name}")
    lmp.command(f"fix wall all wall/geocontact {wall_tests.CALIBRATED_FILE} friction 0 "
                "damping 0 zplane 0.0 0.5")
    lmp.command(f"set atom 1 z {radius - 0.5 * w!r}")
    lmp.command("run 1")
    seen = radius - lmp.numpy.extract_atom("x")[0][2]
    reference = wall_tests.Contact(wall_tests.BASE.for_radius(radius))
    reference.update(2 * w)
    assert lmp.numpy.extract_atom("f")[0][2] == pytest.approx(reference.update(2 * seen)[0],
                                                              rel=1e-9)
    lmp.close()


# --- bad input: one-line LAMMPS errors naming the argument --------------------------------------

@pytest.mark.parametrize("keywords, message", [
    ("rolling", "rolling takes the model sds"),
    ("rolling pjkr 1 0 0.1", "rolling takes the model sds .* got 'pjkr'"),
    # the wall's style follows: its name is read as mu_roll
    ("rolling sds 1e3 0", "rolling sds (needs k_roll gamma_roll mu_roll; mu_roll is missing|"
                          "mu_roll must be a number, got 'zplane')"),
    ("rolling sds stiff 0 0.1", "rolling sds k_roll must be a number, got 'stiff'"),
    ("rolling sds 0 0 0.1", "rolling sds k_roll must be > 0, got 0"),
    ("rolling sds 1e3 -1 0.1", "rolling sds gamma_roll must be >= 0, got -1"),
    ("rolling sds 1e3 0 -0.1", "rolling sds mu_roll must be >= 0, got -0.1"),
    ("twisting sds 1 1 1", "twisting takes the model marshall .* got 'sds'"),
])
@pytest.mark.parametrize("where", ["pair", "wall"])
def test_bad_rolling_or_twisting_arguments_are_one_line_lammps_errors(keywords, message, where):
    lmp = open_lammps()
    for line in ("units si", "atom_style sphere", "region box block -1 1 -1 1 -1 1",
                 "create_box 1 box", "create_atoms 1 single 0 0 0.5", "comm_modify vel yes"):
        lmp.command(line)
    command = (f"pair_coeff * * {PARAMS_FILE} {keywords}" if where == "pair" else
               f"fix wall all wall/geocontact {PARAMS_FILE} {keywords} zplane 0.0 NULL")
    if where == "pair":
        lmp.command("pair_style geocontact")
    with pytest.raises(Exception, match=message) as error:
        lmp.command(command)
    assert re.search(message, str(error.value).splitlines()[0])  # the ERROR line itself
    lmp.close()


# --- MPI: 1 and 2 ranks, restart across rank counts ---------------------------------------------

def test_rolling_layer_gives_the_same_spins_on_1_and_2_ranks_and_after_a_restart(tmp_path):
    """The `rolling` scenario (lammps_scenarios.py): 16 spinning grains on a floor, pair and
    wall contacts with rolling and twisting resistance, split over 2 ranks (contacts across the
    rank boundary, each rank holding its grain's copy of the rolling history); a restart written
    on 2 ranks, continued on 1."""
    restart = tmp_path / "rolling.restart"
    serial = scenarios.run_scenario(1, "rolling")
    parallel = scenarios.run_scenario(2, "rolling", "--restart-out", str(restart))
    resumed = scenarios.run_scenario(1, "rolling", "--resume", str(restart))
    assert (serial["ranks"], parallel["ranks"], resumed["ranks"]) == (1, 2, 1)

    def table(run, key):
        return np.array([c[key] for c in run["chunks"]])

    torque = table(serial, "torque")
    omega = table(serial, "omega")
    assert np.abs(torque).max() > 0
    # the spins changed: the resistance acted (rolling and twisting springs, friction)
    assert np.abs(omega[-1] - omega[0]).max() > 0.1 * np.abs(omega[0]).max()
    after = scenarios.ROLLING_RESTART_AFTER
    for key in ("omega", "torque"):
        a, b, c = table(serial, key), table(parallel, key), table(resumed, key)
        scale = np.abs(a).max()
        # the same arithmetic up to the order of force sums: measured difference 0
        assert np.abs(b - a).max() <= 1e-12 * scale
        assert np.abs(c - a[after:]).max() <= 1e-12 * scale
