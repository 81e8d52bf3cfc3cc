"""fix wall/geocontact `shear dim V|v_name` (plugin built by `make plugin`): a wall sliding in
its own plane drags the grains on it through the tangential force (and rolling), as LAMMPS's
fix wall/gran `shear` does, here with the velocity also from an equal-style variable (a base
driven by a record).

Below yield the geocontact wall is Hertz sphere-on-flat, which LAMMPS's hertz/material wall is
with E_wall = 2 E (its wall is a body of the grain's material, ours rigid); LAMMPS's tangential
model is linear_history with our sphere-flat Mindlin stiffness 8 G a / (2 - nu), a = sqrt(r w),
constant while the grain is held at its interference (tests/test_lammps_rolling.py does the
same for rolling). LAMMPS's wall torque has the arm r, ours r - w (the contact on the wall's
surface), which a spinning grain feels at O(w / r)."""

from __future__ import annotations

import math
from pathlib import Path

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
G = PARAMS.material.shear_modulus
DENSITY = 2650.0
W = 0.25 * PARAMS.yield_approach  # wall interference: d = 2 w is half the pair's yield approach
FRICTION = 0.4
K_ROLL = 1.0e3
STEPS = 400


def sphere_flat():
    """Hertz normal force and Mindlin tangential stiffness of the grain on a rigid flat."""
    fn = 4.0 / 3.0 * E / (1 - NU * NU) * math.sqrt(R) * W**1.5
    kt = 8.0 * G / (2.0 - NU) * math.sqrt(R * W)
    return fn, kt


MASS = DENSITY * 4.0 / 3.0 * math.pi * R**3


def time_step() -> float:
    """A fiftieth of the period of the grain spinning on the tangential spring."""
    kt = sphere_flat()[1]
    return 2 * math.pi / math.sqrt(kt * R * R / (0.4 * MASS * R * R)) / 50


def speed(dt: float) -> float:
    """The wall speed at which a held grain starts sliding after 150 steps."""
    fn, kt = sphere_flat()
    return FRICTION * fn / (kt * dt * 150)


def sheared(style: str, motion: str, *, rolling: str = "", spin: bool = False, extra=()):
    """One grain at interference W on a floor that moves by `motion`. Held (no integrator):
    rows of the wall's force on it; `spin`: its centre held (fix setforce) but free to spin,
    rows of torque and spin."""
    fn, kt = sphere_flat()
    lmp = open_lammps()
    for line in ("units si", "atom_style sphere", "atom_modify map array", "boundary f f f",
                 "comm_modify vel yes", "region box block -1 1 -1 1 -1 1", "create_box 1 box",
                 f"create_atoms 1 single 0 0 {R - W!r}", f"set atom 1 diameter {2 * R!r}",
                 f"set type 1 density {DENSITY}", "neighbor 0.001 bin",
                 f"timestep {time_step()!r}", *(["fix nve all nve/sphere"] if spin else []),
                 *extra):
        lmp.command(line)
    if style == "ours":
        lmp.command(f"fix wall all wall/geocontact {PARAMS_FILE} friction {FRICTION!r} "
                    f"{rolling} zplane 0.0 NULL {motion}")
    else:
        lmp.command(f"fix wall all wall/gran granular hertz/material {2 * E!r} 0 {NU!r} "
                    f"tangential linear_history {kt!r} 0 {FRICTION!r} {rolling} "
                    f"zplane 0.0 NULL {motion}")
    if spin:
        lmp.command("fix hold all setforce 0 0 0")  # after the wall: the centre stays put
    lmp.command("run 0")
    rows = []
    for _ in range(STEPS):
        lmp.command("run 1 pre no post no")
        rows.append(np.concatenate([lmp.numpy.extract_atom("torque")[0],
                                    lmp.numpy.extract_atom("omega")[0]]) if spin else
                    np.array(lmp.numpy.extract_atom("f")[0], dtype=float))
    lmp.close()
    return np.array(rows)


def test_a_held_grain_on_a_shearing_wall_is_dragged_as_by_fix_wall_gran_shear():
    fn, kt = sphere_flat()
    dt, v = time_step(), speed(time_step())
    ours = sheared("ours", f"shear x {v!r}")
    theirs = sheared("lammps", f"shear x {v!r}")
    assert np.abs(ours - theirs).max() <= 1e-9 * np.abs(theirs).max()
    # the wall slides +x under the grain: the spring drags it +x by k_t V dt a step, until it
    # slides at mu F_n; the normal force stays Hertz's
    assert ours[0, 0] == pytest.approx(kt * v * dt, rel=1e-9)
    assert np.diff(ours[:140, 0]) == pytest.approx(kt * v * dt, rel=1e-9)
    assert ours[-1, 0] == pytest.approx(FRICTION * fn, rel=1e-9)
    assert ours[:, 0].max() <= FRICTION * fn * (1 + 1e-9)
    assert np.all(ours[:, 1] == 0)
    assert ours[:, 2] == pytest.approx(fn, rel=1e-9)  # W as LAMMPS places the grain


@pytest.mark.parametrize("rolling", ["", f"rolling sds {K_ROLL!r} 0 0.3"],
                         ids=["friction", "friction+rolling"])
def test_a_grain_free_to_spin_on_a_shearing_wall_is_fix_wall_gran_shear(rolling):
    v = speed(time_step())
    ours = sheared("ours", f"shear x {v!r}", rolling=rolling, spin=True)
    theirs = sheared("lammps", f"shear x {v!r}", rolling=rolling, spin=True)
    # LAMMPS's wall acts at the arm r; ours at the contact point on the wall's surface, r - w
    # (in the torque and in the contact point's velocity alike), so the spring's rotational
    # stiffness, k_t arm^2, is 2 w / r lower and the spin's oscillation drifts in phase by
    # 2 pi (w / r) per period (time_step: 50 steps a period)
    drift = 2 * math.pi * (STEPS / 50) * 2 * W / R
    for k in (slice(0, 3), slice(3, 6)):  # torque, spin
        assert np.abs(ours[:, k] - theirs[:, k]).max() <= drift * np.abs(theirs[:, k]).max()
    # the drag at the bottom (+x) spins the grain about -y
    assert ours[-1, 4] < 0 and np.all(ours[:, 3] == 0)


def test_a_shear_velocity_variable_is_the_constant_and_the_wiggle_it_equals():
    fn, kt = sphere_flat()
    dt, v = time_step(), speed(time_step())
    constant = sheared("ours", f"shear x {v!r}")
    variable = sheared("ours", "shear x v_vb", extra=[f"variable vb equal {v!r}"])
    assert np.array_equal(constant, variable)
    # a variable that is the velocity of a tangential wiggle: the wiggle's forces, through
    # sliding and sticking again (two periods)
    amplitude = 3 * FRICTION * fn / kt
    period = STEPS * dt / 2
    omega = 2 * math.pi / period
    wiggle = sheared("ours", f"wiggle y {amplitude!r} {period!r}")
    driven = sheared("ours", "shear y v_vb", extra=[
        f"variable vb equal {amplitude * omega!r}*sin({omega!r}*step*dt)"])
    assert np.abs(wiggle - driven).max() <= 1e-9 * np.abs(wiggle).max()
    assert np.abs(wiggle[:, 1]).max() == pytest.approx(FRICTION * fn, rel=1e-9)


def box_with_a_grain(*commands):
    """A grain of radius 0.1 resting on z = 0 in a 2 m box, then `commands`."""
    lmp = open_lammps()
    for line in ("units si", "atom_style sphere", "boundary f f f",
                 "region box block -1 1 -1 1 -1 1", "create_box 1 box",
                 "create_atoms 1 single 0 0 0.1", "set atom 1 diameter 0.2", *commands):
        lmp.command(line)
    return lmp


@pytest.mark.parametrize(("wall", "message"), [
    ("zplane 0 NULL shear z 1", "shear dim must lie in the zplane wall \\(not its normal z\\)"),
    ("xplane 0 NULL shear x 1", "shear dim must lie in the xplane wall"),
    ("zcylinder 0.5 shear x 1", "a zcylinder shears along z only"),
    ("zplane 0 NULL shear q 1", "shear dim must be x, y or z, got 'q'"),
    ("zplane 0 NULL shear x", "shear needs dim and a velocity"),
    ("zplane 0 NULL shear x v_", "shear velocity 'v_' names no variable"),
    ("zplane 0 NULL shear x 1 wiggle z 0.1 1", "'wiggle' after another wall motion"),
    ("zplane 0 NULL velocity 1 shear x 1", "'shear' after another wall motion"),
])
def test_bad_shear_arguments_are_one_line_lammps_errors(wall, message):
    lmp = box_with_a_grain()
    with pytest.raises(Exception, match=message):
        lmp.command(f"fix wall all wall/geocontact {PARAMS_FILE} {wall}")
    lmp.close()


@pytest.mark.parametrize(("setting", "message"), [
    ("variable vb atom x", "variable 'vb' of shear is not equal-style"),
    ("", "variable 'vb' of shear does not exist"),
])
def test_a_bad_shear_variable_stops_the_run(setting, message):
    lmp = box_with_a_grain(
        f"fix wall all wall/geocontact {PARAMS_FILE} zplane 0 NULL shear x v_vb")
    if setting:
        lmp.command(setting)
    with pytest.raises(Exception, match=message):
        lmp.command("run 0")
    lmp.close()
