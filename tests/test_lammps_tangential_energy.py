"""The contact creates no energy (issue 34): a grain driven kinematically against another grain or
a wall on a closed path, the work the driver puts in is never negative.

A passive contact stores at most the work done on it: from an untouched start, the driver's work
W(t) = E_stored(t) + D(t) >= 0 at every instant, and over a cycle that brings the contact back to
the same state it is the dissipation, >= 0. The springs whose stiffness follows the contact radius
a (the tangential k_t = 8 G* a, the twist k_t a^2 / 2) break this if their stored force is kept
while a falls: the path of the issue (plastic normal load, a tangential offset in stick, a partial
normal unload, the offset back, the reload) then returns more tangential work than it took,
about (k_t(a1) - k_t(a2)) u^2 / 2 per cycle. The driver here sets the grain's position and
velocity every step (no integrator; velocity = displacement / dt, so the incremental springs
follow the displacement exactly) and the work is the trapezoid rule of the contact forces and
torques over each step's displacement and rotation.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from geocontact.analyses.lammps_plugin import open_lammps
from geocontact.law import load_params

ROOT = Path(__file__).resolve().parents[1]
PARAMS_FILE = ROOT / "examples" / "params-reference.json"
PARAMS = load_params(PARAMS_FILE)
RADIUS = 0.01        # m: grains of radius 1 cm (similarity scale 0.1)
SCALE = RADIUS / PARAMS.material.radius
YIELD = SCALE * PARAMS.yield_approach  # the pair's yield approach at this radius
FRICTION = 0.5
TIMESTEP = 1e-6      # s: only sets the velocities the driver gives
STEPS_PER_LEG = 40
ROLLING = "rolling sds 2e4 0 0.2 twisting marshall"  # k_roll N/m, gamma_roll, mu_roll


class Driver:
    """Grain 2 (or the only grain, against a zplane wall at z = 0) moved through positions and
    spin angles, one step each; accumulates the driver's work (total and tangential)."""

    def __init__(self, wall: bool, rolling: bool, damping: float = 0.0):
        self.wall = wall
        self.lmp = lmp = open_lammps()
        resistance = ROLLING if rolling else ""
        lines = [
            "units si", "atom_style sphere", "atom_modify map array sort 0 0",
            "boundary f f f", "comm_modify vel yes",
            "region box block -0.05 0.05 -0.05 0.05 -0.05 0.05", "create_box 1 box",
        ]
        if wall:
            lines += [f"create_atoms 1 single 0 0 {RADIUS!r} units box",
                      "pair_style zero 0.03", "pair_coeff * *",
                      f"fix wall all wall/geocontact {PARAMS_FILE} friction {FRICTION} "
                      f"damping {damping} {resistance} zplane 0.0 NULL"]
        else:
            lines += ["create_atoms 1 single 0 0 0 units box",
                      f"create_atoms 1 single {2 * RADIUS!r} 0 0 units box",
                      "pair_style geocontact",
                      f"pair_coeff * * {PARAMS_FILE} friction {FRICTION} damping {damping} "
                      f"{resistance}"]
        lines += [f"set type 1 diameter {2 * RADIUS!r}", "set type 1 density 2650",
                  "neighbor 0.001 bin", "neigh_modify every 1 delay 0 check yes",
                  f"timestep {TIMESTEP!r}"]
        for line in lines:
            lmp.command(line)
        self.index = 0 if wall else 1
        self.place = np.array(lmp.numpy.extract_atom("x")[self.index])
        self.angle = np.zeros(3)
        self.force = np.zeros(3)
        self.torque = np.zeros(3)
        self.work = 0.0
        self.tangential_work = 0.0  # of the tangential forces over the displacements
        self.shear_work = 0.0       # the same and the work of every torque
        self.started = False

    def normal_axis(self) -> int:
        return 2 if self.wall else 0

    def position(self, approach: float, offset: tuple[float, float]) -> np.ndarray:
        """Centre of the driven grain at this approach (pair: of the two grains; wall: the
        interference) and tangential offset."""
        if self.wall:
            return np.array([offset[0], offset[1], RADIUS - approach])
        return np.array([2 * RADIUS - approach, offset[0], offset[1]])

    def step(self, approach: float, offset=(0.0, 0.0), angle=(0.0, 0.0, 0.0)) -> None:
        lmp = self.lmp
        target, angle = self.position(approach, offset), np.asarray(angle, dtype=float)
        dx, dtheta = target - self.place, angle - self.angle
        lmp.numpy.extract_atom("x")[self.index][:] = target
        lmp.numpy.extract_atom("v")[self.index][:] = dx / TIMESTEP
        lmp.numpy.extract_atom("omega")[self.index][:] = dtheta / TIMESTEP
        lmp.command(f"run 1 pre {'no' if self.started else 'yes'} post no")
        self.started = True
        force = np.array(lmp.numpy.extract_atom("f")[self.index])
        torque = np.array(lmp.numpy.extract_atom("torque")[self.index])
        # the driver holds the grain against the contact: its force is -f, its torque -torque
        self.work -= 0.5 * (self.force + force) @ dx + 0.5 * (self.torque + torque) @ dtheta
        n_old, n = self.normal(self.place), self.normal(target)
        ft_old = self.force - (self.force @ n_old) * n_old
        ft_new = force - (force @ n) * n
        self.tangential_work -= 0.5 * (ft_old + ft_new) @ dx
        self.shear_work -= 0.5 * (ft_old + ft_new) @ dx + 0.5 * (self.torque + torque) @ dtheta
        self.place, self.angle, self.force, self.torque = target, angle, force, torque

    def normal(self, centre: np.ndarray) -> np.ndarray:
        if self.wall:
            return np.array([0.0, 0.0, 1.0])
        return centre / np.linalg.norm(centre)  # grain 1 stays at the origin

    def leg(self, start, end, steps: int = STEPS_PER_LEG) -> None:
        """Straight leg in (approach, offset y, offset z, angle x, angle y, angle z)."""
        start, end = np.asarray(start, dtype=float), np.asarray(end, dtype=float)
        for k in range(1, steps + 1):
            p = start + (end - start) * k / steps
            self.step(p[0], (p[1], p[2]), p[3:6])

    def close(self) -> None:
        self.lmp.close()


def stick_offset(driver: Driver, approach: float, fraction: float) -> float:
    """The tangential offset whose Mindlin force k_t u is `fraction` of the Coulomb limit at
    this loaded state (k_t = 8 G* a from the contact radius of the law's unloading stiffness,
    read back as the force and its tangent: a = F n_u / (2 E* (d - d_res)) is not exposed for
    the wall, so the stiffness is probed by a step of 1e-4 of the yield approach)."""
    lmp = driver.lmp
    base = np.array(lmp.numpy.extract_atom("f")[driver.index])
    axis = driver.normal_axis()
    fn = abs(base[axis])
    probe = 1e-4 * YIELD
    driver.step(approach, (probe, 0.0))
    kt = abs(driver.force[1 if not driver.wall else 0]) / probe
    driver.step(approach, (0.0, 0.0))
    return fraction * FRICTION * fn / kt


def issue_path(driver: Driver, cycles: int = 5) -> list[tuple[float, float]]:
    """The closed path of the issue: plastic load to 20 yield approaches, then per cycle a
    tangential offset u in stick, a normal unload part-way, the offset back, the reload.
    Returns (work, tangential work) of each cycle."""
    loaded, unloaded = 20 * YIELD, 17 * YIELD
    driver.leg((0.0,) * 6, (loaded, 0, 0, 0, 0, 0))
    u = stick_offset(driver, loaded, 0.3)
    per_cycle = []
    for _ in range(cycles):
        w0, t0 = driver.work, driver.tangential_work
        driver.leg((loaded, 0, 0, 0, 0, 0), (loaded, u, 0, 0, 0, 0))
        driver.leg((loaded, u, 0, 0, 0, 0), (unloaded, u, 0, 0, 0, 0))
        driver.leg((unloaded, u, 0, 0, 0, 0), (unloaded, 0, 0, 0, 0, 0))
        driver.leg((unloaded, 0, 0, 0, 0, 0), (loaded, 0, 0, 0, 0, 0))
        per_cycle.append((driver.work - w0, driver.tangential_work - t0))
    return per_cycle, u


def tolerance(driver: Driver, u: float) -> float:
    """Round-off of the work sums: 1e-9 of the energy scale of the tangential spring."""
    return 1e-9 * abs(driver.force[driver.normal_axis()]) * u


@pytest.mark.parametrize("wall", [False, True], ids=["pair", "wall"])
def test_the_issue_path_returns_no_more_work_than_it_took(wall):
    driver = Driver(wall=wall, rolling=False)
    per_cycle, u = issue_path(driver)
    tol = tolerance(driver, u)
    driver.close()
    # the tangential spring carried a real load (k_t u = 0.3 mu F_n)
    assert u > 1e-3 * YIELD
    for work, tangential in per_cycle:
        assert tangential >= -tol, per_cycle
        assert work >= -tol, per_cycle


def random_excursions(driver: Driver, rng, count: int, legs: int, spin: bool):
    """A plastic load to 20 yield approaches (the envelope), then `count` random closed
    excursions from there. Each leg moves one coordinate to a random value: the approach
    (12-20 yield approaches, unloading and reloading below the envelope, where the contact
    radius changes most), a tangential offset (up to 0.4 of the stick limit at the envelope:
    mostly stick, where a kept spring force would return energy) or, with `spin`, a rotation
    angle (the same contact displacement on the arm); one
    coordinate at a time, so the trapezoid rule of the work is exact to second order in the
    step for each leg. Each excursion starts with no shear spring (between excursions the
    grains separate, which empties them, and are loaded back to the envelope point) and ends at
    its start, so the work of its shear forces and torques is what they dissipated plus what
    their springs still hold: never negative. Returns the shear work of each excursion, the
    least cumulative work from the untouched start, and the stick offset."""
    loaded = np.array([20 * YIELD, 0, 0, 0, 0, 0])
    driver.leg(np.zeros(6), loaded)
    u = stick_offset(driver, loaded[0], 1.0)
    span = np.array([0, 0.4 * u, 0.4 * u, *(3 * [0.8 * u / RADIUS])])
    coordinates = 6 if spin else 3
    works, least = [], driver.work
    for _ in range(count):
        start, here = driver.shear_work, loaded
        for _ in range(legs):
            there = here.copy()
            k = int(rng.integers(0, coordinates))
            there[k] = rng.uniform(12, 20) * YIELD if k == 0 else rng.uniform(-span[k], span[k])
            driver.leg(here, there, steps=int(rng.integers(10, 40)))
            least = min(least, driver.work)
            here = there
        for k in range(1, coordinates):  # back, one coordinate at a time
            there = here.copy()
            there[k] = 0.0
            driver.leg(here, there)
            here = there
        driver.leg(here, loaded)
        works.append(driver.shear_work - start)
        least = min(least, driver.work)
        driver.leg(loaded, np.zeros(6))  # apart: the shear springs empty
        driver.leg(np.zeros(6), loaded)
    return works, min(least, driver.work), u


@pytest.mark.parametrize("rolling", [False, True], ids=["plain", "rolling"])
@pytest.mark.parametrize("wall", [False, True], ids=["pair", "wall"])
def test_random_closed_paths_never_return_more_work_than_they_took(wall, rolling):
    rng = np.random.default_rng(34 + 2 * wall + rolling)
    driver = Driver(wall=wall, rolling=rolling)
    works, least, u = random_excursions(driver, rng, count=8, legs=10, spin=rolling)
    tol = tolerance(driver, u)
    driver.close()
    assert least >= -tol  # from the untouched start W(t) >= E_stored(t) >= 0
    assert min(works) >= -tol, works
    assert max(works) > 1e3 * tol  # the shear springs were loaded


def _sliding_on_a_wall(beta: float, dashpot_share: float, steps: int = 302):
    """A grain held below yield on a wall that slides at V for 300 steps, then stops; V is such
    that the dashpot's force g V is ``dashpot_share`` of the Coulomb limit, g = 2 beta sqrt(m k_t)
    with the sphere-flat Mindlin stiffness k_t = 8 G a / (2 - nu), a = sqrt(r w). Returns the
    forces per step, the wall's global vector per step, mu F_n, k_t and V."""
    m = PARAMS.material
    w = 0.2 * YIELD  # d = 2 w: elastic
    mass = 2650 * 4 / 3 * np.pi * RADIUS**3
    kt = 8 * m.shear_modulus / (2 - m.poissons_ratio) * np.sqrt(RADIUS * w)
    g = 2 * beta * np.sqrt(mass * kt)
    fn = 4 / 3 * m.youngs_modulus / (1 - m.poissons_ratio**2) * np.sqrt(RADIUS) * w**1.5
    speed = float(dashpot_share * FRICTION * fn / g)
    lmp = open_lammps()
    for line in ("units si", "atom_style sphere", "atom_modify map array", "boundary f f f",
                 "comm_modify vel yes", "region box block -0.05 0.05 -0.05 0.05 -0.05 0.05",
                 "create_box 1 box", f"create_atoms 1 single 0 0 {RADIUS - w!r} units box",
                 f"set type 1 diameter {2 * RADIUS!r}", "set type 1 density 2650",
                 "timestep 1e-5", f"variable vb equal {speed!r}*(step<=300)",
                 f"fix wall all wall/geocontact {PARAMS_FILE} friction {FRICTION} damping "
                 f"{beta} zplane 0.0 NULL shear x v_vb", "run 0"):
        lmp.command(line)
    forces, tallies = [], []
    for _ in range(steps):
        lmp.command("run 1 pre no post no")
        forces.append(np.array(lmp.numpy.extract_atom("f")[0]))
        tallies.append([lmp.numpy.extract_fix("wall", 0, 1, k) for k in range(20)])
    lmp.close()
    return np.array(forces), np.array(tallies), FRICTION * fn, kt, speed


def test_sliding_spring_holds_the_coulomb_force_and_the_dashpot_gives_up_its_excess():
    """While the wall slides the force on the grain is the Coulomb limit mu F_n; the spring (a
    Coulomb slider in series) has loaded elastically up to mu F_n and holds it, the dashpot's
    share of the capped total being nothing then; so the moment the wall stops the force is
    still mu F_n (the spring's). LAMMPS's reset would leave mu F_n - g V in the spring: here
    g V = 0.3 mu F_n. Every ledger channel of the step is >= 0."""
    forces, tallies, limit, kt, _ = _sliding_on_a_wall(0.4, 0.3)
    assert forces[298, 0] == pytest.approx(limit, rel=1e-9)  # sliding
    assert forces[300, 0] == pytest.approx(limit, rel=1e-9)  # stopped: the spring's mu F_n
    scale = limit**2 / (2 * kt)  # the spring's energy at the limit
    for channel in (8, 9, 10):  # sliding, normal damping, tangential damping
        assert np.all(np.diff(tallies[:, channel]) >= -1e-9 * scale)


def test_a_dashpot_stronger_than_friction_loads_no_spring_along_the_slip():
    """The case LAMMPS's reset gets wrong: the dashpot's force alone (g V = 3 mu F_n) exceeds
    the Coulomb limit. The spring must still oppose the slip and hold at most mu F_n (stored
    energy (mu F_n)^2 / 2 k_t), and the sliding and dashpot dissipations must both grow; with
    the reset to the capped total less g V the spring would hold (g V - mu F_n) = 2 mu F_n along
    the slip, 4x the energy, and the ledger's sliding channel would fall."""
    forces, tallies, limit, kt, speed = _sliding_on_a_wall(0.4, 3.0)
    assert forces[298, 0] == pytest.approx(limit, rel=1e-9)
    assert forces[300, 0] == pytest.approx(limit, rel=1e-9)  # the spring opposes the slip
    stored = tallies[298, 14]  # stored tangential
    assert stored == pytest.approx(limit**2 / (2 * kt), rel=1e-6)
    sliding, tangential_damping = tallies[:, 8], tallies[:, 10]
    assert np.all(np.diff(sliding) >= -1e-9 * stored)
    assert np.all(np.diff(tangential_damping) >= -1e-9 * stored)
    # once the spring holds mu F_n the whole capped force is the spring's: the dashpot no
    # longer works, the slider dissipates mu F_n V dt a step
    assert tangential_damping[298] == pytest.approx(tangential_damping[200], abs=1e-9 * stored)
    assert sliding[298] - sliding[200] == pytest.approx(98 * limit * speed * 1e-5, rel=1e-6)


def test_the_tangential_force_acts_at_the_contact_plane_halfway_into_the_overlap():
    """Two grains at overlap delta, one sliding: the torque of the tangential force about each
    centre has the arm r - delta/2 (the contact plane halves the overlap; LAMMPS's pair granular
    does the same), equal on both grains."""
    driver = Driver(wall=False, rolling=False)
    delta = 10 * YIELD
    driver.leg(np.zeros(6), (delta, 0, 0, 0, 0, 0))
    driver.leg((delta, 0, 0, 0, 0, 0), (delta, 0.01 * YIELD, 0, 0, 0, 0), steps=5)
    lmp = driver.lmp
    x = np.array(lmp.numpy.extract_atom("x"))
    f = np.array(lmp.numpy.extract_atom("f"))
    torque = np.array(lmp.numpy.extract_atom("torque"))
    driver.close()
    n = (x[1] - x[0]) / np.linalg.norm(x[1] - x[0])  # from grain 1 to grain 2
    ft = f[1] - (f[1] @ n) * n  # the tangential force on grain 2
    assert np.linalg.norm(ft) > 1e-4 * abs(f[1] @ n)
    arm = RADIUS - 0.5 * delta
    # grain 2 touches at -arm n from its centre, grain 1 at +arm n and feels -F
    tiny = 1e-12 * arm * np.abs(ft).max()
    assert torque[1] == pytest.approx(np.cross(-arm * n, ft), rel=1e-9, abs=tiny)
    assert torque[0] == pytest.approx(np.cross(arm * n, -ft), rel=1e-9, abs=tiny)
