"""fix wall/geocontact/region (plugin built by `make plugin`): the walls of a LAMMPS region are the
walls of fix wall/geocontact, with the same per-contact step. A region plane gives the zplane's
force history; a curved wall is the flat wall's contact of a grain of the effective radius
R_eff = r rho / (r + rho) (docs/dem.md "Region walls"), checked against Hertz's closed forms
for a sphere in and on a sphere and in a cylinder (elliptical contact, Johnson 1985 §4.2); a
moving region loads a grain as a moving plane does; a rotating drum drags a grain along its wall
velocity with the Mindlin stiffness; restarts continue; bad input is a one-line error."""

from __future__ import annotations

import math
import re
import struct
from pathlib import Path

import lammps_scenarios as scenarios
import numpy as np
import pytest

from geocontact.analyses.lammps_plugin import open_lammps
from geocontact.law import Contact, load_params

ROOT = Path(__file__).resolve().parents[1]
PARAMS = ROOT / "examples" / "params-reference.json"
BASE = load_params(PARAMS)
DENSITY = 2650.0
SLOT = 7  # per-atom columns of a region record: wall id, w, Fn, |Ft|, w_max, w_res, branch
TIMESTEP = 1e-5


def grains(radii, positions, *lines: str, friction=0.0, damping=0.0, fix="wall",
           keywords: str = ""):
    """Grains of the given radii at the given positions (no integrator: positions stay as set),
    then `lines` (regions, variables, fixes; `{P}` stands for the law file and `{K}` for
    `friction F damping D keywords`)."""
    lmp = open_lammps()
    contact_keywords = f"friction {friction} damping {damping} {keywords}".strip()
    for line in ("units si", "atom_style sphere", "atom_modify map array", "boundary f f f",
                 "comm_modify vel yes", "region box block -1 1 -1 1 -1 1", "create_box 1 box",
                 *[f"create_atoms 1 single {x!r} {y!r} {z!r}" for x, y, z in positions],
                 *[f"set atom {k + 1} diameter {2 * r!r}" for k, r in enumerate(radii)],
                 f"set type 1 density {DENSITY}", "neighbor 0.01 bin", f"timestep {TIMESTEP}",
                 *[line.format(P=PARAMS, K=contact_keywords) for line in lines]):
        lmp.command(line)
    return lmp


def per_atom(lmp, fix="wall") -> np.ndarray:
    from lammps import LMP_STYLE_ATOM, LMP_TYPE_ARRAY

    return np.array(lmp.numpy.extract_fix(fix, LMP_STYLE_ATOM, LMP_TYPE_ARRAY), dtype=float)


def global_vector(lmp, fix="wall") -> np.ndarray:
    from lammps import LMP_STYLE_GLOBAL, LMP_TYPE_VECTOR

    return np.array([lmp.extract_fix(fix, LMP_STYLE_GLOBAL, LMP_TYPE_VECTOR, k)
                     for k in range(8)])


def step(lmp, first: bool):
    lmp.command(f"run 1 pre {'yes' if first else 'no'} post no")


def test_plugin_registers_the_region_wall_fix():
    lmp = open_lammps()
    assert lmp.has_style("fix", "wall/geocontact/region")
    lmp.close()


# --- a region plane is the plane wall ---------------------------------------------------------

def plane_path(wy: float, radius: float) -> list[float]:
    """Interference (in wy): load past yield, unload, separate within the skin, reload deeper,
    leave beyond the skin (0.01; the record is forgotten), come back."""
    legs = [(30, 20), (10, 10), (40, 20), (-2, 15), (60, 20), (5, 10)]
    out, start = [], -0.5
    for end, steps in legs:
        out += [start + (end - start) * (k + 1) / steps for k in range(steps)]
        start = end
    path = [a * wy for a in out]
    return [*path, -0.02, -0.02, 20 * wy, 25 * wy]


def plane_history(wall_lines: list[str], radius: float) -> np.ndarray:
    """A sliding, spinning grain pushed into the floor z = 0 along plane_path: per step the
    force and torque on it, its wall output (the six columns) and the fix's global vector."""
    wy = 0.5 * BASE.for_radius(radius).yield_approach
    lmp = grains([radius], [(0.0, 0.0, radius + 0.5 * wy)], *wall_lines, friction=0.4,
                 damping=0.2, keywords="rolling sds 1e3 0.5 0.1 twisting marshall")
    lmp.command("set atom 1 vx 2e-3")
    lmp.command("set atom 1 vz -1e-3")
    lmp.command("set atom 1 omega 0.01 0.02 0.03")
    rows = []
    for k, w in enumerate(plane_path(wy, radius)):
        lmp.command(f"set atom 1 z {radius - w!r}")
        step(lmp, k % 9 == 0)  # a full setup now and then: the record lives on the atom
        row = per_atom(lmp)[0]
        wall = row[1:SLOT] if row.size == SLOT else row
        rows.append([*lmp.numpy.extract_atom("f")[0], *lmp.numpy.extract_atom("torque")[0],
                     *wall, *global_vector(lmp)])
    lmp.close()
    return np.array(rows)


def test_a_region_plane_gives_the_force_history_of_the_zplane_wall():
    """Load, unload, separation within and beyond the skin, re-contact; friction, damping,
    rolling and twisting: force, torque, per-atom output and global vector equal to round-off."""
    radius = 0.05
    plane = plane_history(["fix wall all wall/geocontact {P} {K} zplane 0.0 NULL"], radius)
    region = plane_history(["region floor plane 0 0 0 0 0 1 side in",
                            "fix wall all wall/geocontact/region {P} {K} floor"], radius)
    assert np.abs(plane[:, 2]).max() > 20 * BASE.for_radius(radius).yield_force  # plastic
    assert np.abs(plane[:, 0]).max() > 0 and np.abs(plane[:, 3:6]).max() > 0  # sliding, torque
    assert not plane[-3, 6:12].any() and plane[-3, 12 + 5] == 0  # beyond the skin: forgotten
    scale = np.abs(plane).max(axis=0) + 1e-300
    assert np.all(np.abs(region - plane) <= 1e-12 * scale)


def test_a_grain_in_the_corner_of_a_block_has_one_record_per_face():
    """A block region's floor and side are two walls of one atom: the force and the energies of
    the zplane and xplane fixes together."""
    radius = 0.05
    law = BASE.for_radius(radius)
    wx, wz = 15 * law.yield_approach, 30 * law.yield_approach
    at = [(-0.5 + radius - wx, 0.0, radius - wz)]

    def run(lines, fixes):
        lmp = grains([radius], at, *lines, friction=0.3)
        lmp.command("set atom 1 vy 1e-3")
        for k in range(5):
            step(lmp, k == 0)
        out = [*lmp.numpy.extract_atom("f")[0], *lmp.numpy.extract_atom("torque")[0]]
        vector = sum(global_vector(lmp, fix) for fix in fixes)
        rows = per_atom(lmp)
        lmp.close()
        return np.array(out), vector, rows

    planes = run(["fix wall all wall/geocontact {P} {K} zplane 0.0 NULL",
                  "fix side all wall/geocontact {P} {K} xplane -0.5 NULL"], ["wall", "side"])
    block = run(["region cell block -0.5 0.5 -0.5 0.5 0.0 0.9 side in",
                 "fix wall all wall/geocontact/region {P} {K} cell"], ["wall"])
    assert block[0] == pytest.approx(planes[0], rel=1e-12, abs=1e-12 * np.abs(planes[0]).max())
    # force on the walls, dissipated and stored energies, contacts (the sums of the two fixes)
    assert block[1][:6] == pytest.approx(planes[1][:6], rel=1e-12, abs=1e-15)
    assert block[1][5] == 2  # two contacts
    slots = block[2][0].reshape(-1, SLOT)
    assert sorted(slots[:, 0][slots[:, 0] >= 0]) == [0, 4]  # the block's xlo and zlo faces


# --- curved walls: the effective radius ---------------------------------------------------

def hertz_wall_force(effective_radius: float, w: float) -> float:
    """Hertz, a sphere of radius R_eff on a rigid flat: 4/3 E/(1 - nu^2) sqrt(R_eff) w^1.5."""
    e, nu = BASE.material.youngs_modulus, BASE.material.poissons_ratio
    return 4.0 / 3.0 * e / (1 - nu**2) * math.sqrt(effective_radius) * w**1.5


def hertz_elliptical_radius(radius_1: float, radius_2: float) -> float:
    """The equivalent radius of Hertz's elliptical contact of principal relative radii R1, R2
    (Johnson 1985, §4.2, eqs 4.36-4.39 in K(e), E(e)): the R_e with P = 4/3 E* sqrt(R_e) d^1.5."""
    from scipy.optimize import brentq
    from scipy.special import ellipe, ellipk

    a_curv, b_curv = 0.5 / max(radius_1, radius_2), 0.5 / min(radius_1, radius_2)  # A <= B

    def ratio(m):  # B / A of the ellipse of eccentricity e^2 = m, a along the A direction
        k, e = ellipk(m), ellipe(m)
        return (e / (1 - m) - k) / (k - e)

    if b_curv == a_curv:
        return radius_1  # circular
    m = brentq(lambda q: ratio(q) - b_curv / a_curv, 1e-12, 1 - 1e-12)
    k, e = ellipk(m), ellipe(m)
    # delta = p0 b K / E*, A = p0 b (K - E) / (E* a^2 e^2): a^2 = delta (K - E) / (K e^2 A);
    # P = 2/3 pi a b p0 = 2/3 pi E* delta a / K = 4/3 E* sqrt(R_e) delta^1.5
    a_over_sqrt_delta = math.sqrt((k - e) / (k * m * a_curv))
    return (0.5 * math.pi * a_over_sqrt_delta / k) ** 2


CURVED = {
    # region, grain centre at interference w, effective radius for a grain of radius r:
    # r rho / (r + rho) with LAMMPS's signed radius rho (sphere: its radius; cylinder: 2 R,
    # the sphere of the same mean curvature)
    "sphere-inside": ("region wall sphere 0 0 0 0.6 side in",
                      lambda r, w: (0.6 - r + w, 0.0, 0.0), lambda r: r * 0.6 / (0.6 - r),
                      lambda x: 0.6 - np.linalg.norm(x)),
    "sphere-outside": ("region wall sphere 0 0 0 0.3 side out",
                       lambda r, w: (0.3 + r - w, 0.0, 0.0), lambda r: r * 0.3 / (0.3 + r),
                       lambda x: np.linalg.norm(x) - 0.3),
    "cylinder-inside": ("region wall cylinder z 0 0 0.3 -1 1 side in",
                        lambda r, w: (0.3 - r + w, 0.0, 0.0), lambda r: r * 0.6 / (0.6 - r),
                        lambda x: 0.3 - math.hypot(x[0], x[1])),
}


@pytest.mark.parametrize("shape", list(CURVED))
def test_a_curved_wall_is_the_flat_walls_contact_of_the_effective_radius(shape):
    """Along load, unload and reload past yield the force is the wall law of a grain of radius
    R_eff (the pair law of R_eff at d = 2 w), to 1e-9; below yield, Hertz's closed form."""
    region, centre, effective, gap = CURVED[shape]
    radius = 0.1
    r_eff = effective(radius)
    law = BASE.for_radius(r_eff)
    reference = Contact(law)
    lmp = grains([radius], [centre(radius, -1e-4)], region,
                 "fix wall all wall/geocontact/region {P} {K} wall")
    depths = [0.3, 0.8, 5.0, 20.0, 40.0, 25.0, 10.0, 30.0, 45.0]  # in the pair's delta_y / 2
    for k, depth in enumerate(depths):
        w = 0.5 * depth * law.yield_approach
        x, y, z = centre(radius, w)
        lmp.command(f"set atom 1 x {x!r} y {y!r} z {z!r}")
        step(lmp, k == 0)
        seen = radius - gap(np.array(lmp.numpy.extract_atom("x")[0]))  # as LAMMPS sees it
        f = np.array(lmp.numpy.extract_atom("f")[0])
        expected = reference.update(2 * seen)[0]
        sign = -1.0 if shape.endswith("inside") else 1.0  # pushed to the centre, or away
        assert f[0] == pytest.approx(sign * expected, rel=1e-9)
        assert f[1] == 0.0 and f[2] == 0.0
        if depth < 1.0:  # elastic: Hertz of R_eff, the closed form
            assert abs(f[0]) == pytest.approx(hertz_wall_force(r_eff, seen), rel=1e-9)
    lmp.close()


def test_the_cylinders_mean_curvature_radius_against_elliptical_hertz():
    """A sphere of radius r in a cylinder of radius R_c touches with principal relative radii
    r R_c / (R_c - r) and r: an elliptical Hertz contact. The region's mean-curvature radius
    (2 R_c) gives R_eff = 2 r R_c / (2 R_c - r); its force is below the exact elliptical Hertz
    force at the same interference by 0.09 % at R_c = 10 r, 0.41 % at 5 r, 1.35 % at 3 r,
    3.9 % at 2 r and 9.2 % at 1.5 r (measured; docs/dem.md "Region walls")."""
    for ratio, bound in ((10.0, 0.001), (5.0, 0.0045), (3.0, 0.014), (2.0, 0.04),
                         (1.5, 0.093)):
        r, r_c = 0.1, 0.1 * ratio
        exact = hertz_elliptical_radius(r * r_c / (r_c - r), r)
        mean_curvature = r * 2 * r_c / (2 * r_c - r)
        force_error = math.sqrt(mean_curvature / exact) - 1
        assert -bound < force_error < 0
    # nearly circular, the closed form tends to Hertz's own radius
    assert hertz_elliptical_radius(0.1, 0.1 * (1 + 1e-3)) == pytest.approx(0.1, rel=1e-3)


# --- moving and rotating regions -------------------------------------------------------------

SPEED = 0.02


def roof_history(lines: list[str], damping: float) -> np.ndarray:
    """A grain of radius 0.05 held on the floor (no integrator), the roof moving down onto it by
    the variable `down` (-v t): per step the force on the grain (z) and the fix's force (z)."""
    radius = 0.05
    lmp = grains([radius], [(0.0, 0.0, radius)], f"variable down equal -{SPEED!r}*step*dt",
                 *lines, damping=damping)
    rows = []
    for k in range(120):
        step(lmp, k == 0)
        rows.append([lmp.numpy.extract_atom("f")[0][2], global_vector(lmp)[2]])
    lmp.close()
    return np.array(rows)


def test_a_moving_region_loads_a_grain_as_a_moving_plane_does():
    """`region ... move NULL NULL v_down` against `zplane ... position v_down`: the same force
    at every step, damping (which sees the wall's velocity at the contact) included."""
    top = 0.1 + 0.2 * BASE.for_radius(0.05).yield_approach
    plane = ["fix wall all wall/geocontact {P} {K} zplane NULL " + f"{top!r} position v_down"]
    region = [f"region roof plane 0 0 {top!r} 0 0 -1 side in move NULL NULL v_down",
              "fix wall all wall/geocontact/region {P} {K} roof"]
    by_plane, by_region = roof_history(plane, 0.3), roof_history(region, 0.3)
    undamped = roof_history(region, 0.0)
    peak = np.abs(by_plane[:, 0]).max()
    assert peak > 10 * BASE.for_radius(0.05).yield_force
    assert np.abs(by_region[:, 0] - undamped[:, 0]).max() > 1e-3 * peak  # damping acts
    assert np.abs(by_region - by_plane).max() <= 1e-9 * peak


def test_a_rotating_drum_drags_a_grain_along_its_wall_velocity():
    """A grain pressed into the wall of a cylinder rotating about z at Omega: the wall's velocity
    at the contact (R_c, 0, 0) is Omega R_c along y, the tangential force on the grain follows
    it, first at the sphere-flat Mindlin stiffness 8 G a / (2 - nu) of the effective radius
    (a = sqrt(R_eff w)) times Omega R_c dt, then sliding at mu F_n; the torque is that of the
    force at the contact point."""
    radius, r_c, omega, friction = 0.05, 0.3, 0.01, 0.4
    r_eff = radius * 2 * r_c / (2 * r_c - radius)
    law = BASE.for_radius(r_eff)
    w = 0.4 * law.yield_approach  # d = 2 w below yield: Hertz and Mindlin
    lmp = grains([radius], [(r_c - radius + w, 0.0, 0.0)],
                 f"variable theta equal {omega!r}*step*dt",
                 f"region drum cylinder z 0 0 {r_c!r} -1 1 side in "
                 "rotate v_theta 0 0 0 0 0 1",
                 "fix wall all wall/geocontact/region {P} {K} drum", friction=friction)
    w = radius - (r_c - lmp.numpy.extract_atom("x")[0][0])  # as LAMMPS sees it
    f_n = hertz_wall_force(r_eff, w)
    e_nu = law.material.poissons_ratio
    k_t = 8.0 * law.material.shear_modulus / (2.0 - e_nu) * math.sqrt(r_eff * w)
    lmp.command("run 0")
    forces = []
    for _ in range(100):
        step(lmp, False)
        forces.append(np.array(lmp.numpy.extract_atom("f")[0]))
    forces = np.array(forces)
    assert forces[:, 0] == pytest.approx(-f_n, rel=1e-9)
    assert np.all(forces[:, 1] > 0) and np.all(forces[:, 2] == 0)  # along the wall velocity
    assert forces[0, 1] == pytest.approx(k_t * omega * r_c * TIMESTEP, rel=1e-6)
    assert forces[-1, 1] == pytest.approx(friction * f_n, rel=1e-9)
    # the force at the contact point (r - w along +x from the centre): torque (0, 0, (r - w) F_y)
    torque = lmp.numpy.extract_atom("torque")[0]
    assert torque[2] == pytest.approx((radius - w) * forces[-1, 1], rel=1e-9)
    lmp.close()


# --- restart ----------------------------------------------------------------------------------

DRUM = ["variable theta equal 0.5*step*dt",
        "region drum cylinder z 0 0 0.3 -0.2 0.2 side in rotate v_theta 0 0 0 0 0 1",
        "fix wall all wall/geocontact/region {P} {K} drum"]


def drum_grains():
    """Two grains pressed into the rotating drum: one on its side wall, one in the corner of the
    side and the bottom cap (two records), on unloading branches of plastic contacts."""
    radius = 0.05
    dy = BASE.for_radius(radius).yield_approach
    lmp = grains([radius, radius], [(0.25 + 20 * dy, 0.0, 0.0),
                                     (0.0, -0.25 - 25 * dy, -0.15 - 30 * dy)], *DRUM,
                 friction=0.4, damping=0.1)
    return lmp, dy


def drum_run(lmp, first: int, last: int, dy: float) -> np.ndarray:
    rows = []
    for k in range(first, last):
        depth = dy * 10 * math.sin(math.pi * k / 40) ** 2  # load and unload
        lmp.command(f"set atom 1 x {0.25 + 20 * dy - depth!r}")
        lmp.command(f"set atom 2 z {-0.15 - 30 * dy + depth!r}")
        step(lmp, k == first)
        ids = lmp.numpy.extract_atom("id")
        order = np.argsort(ids)
        f = np.array(lmp.numpy.extract_atom("f"))[order]
        t = np.array(lmp.numpy.extract_atom("torque"))[order]
        rows.append([*f.ravel(), *t.ravel(), *per_atom(lmp)[order].ravel(),
                     *global_vector(lmp)])
    return np.array(rows)


def test_restart_of_a_rotating_drum_continues_as_the_uninterrupted_run(tmp_path):
    """Written mid-history (two grains, three region contacts, tangential springs loaded, the
    drum turning), read into a new LAMMPS with the variable, region and fix defined again: the
    run goes on as if never stopped, the region's velocity included."""
    total, stop = 60, 35
    lmp, dy = drum_grains()
    uninterrupted = drum_run(lmp, 0, total, dy)
    lmp.close()
    lmp, dy = drum_grains()
    before = drum_run(lmp, 0, stop, dy)
    assert before[-1, -3] == 3  # three contacts
    lmp = scenarios.reopen_from_restart(lmp, tmp_path / "drum.restart",
                                        *[line.format(P=PARAMS, K="friction 0.4 damping 0.1")
                                          for line in DRUM])
    after = drum_run(lmp, stop, total, dy)
    lmp.close()
    resumed = np.vstack([before, after])
    scale = np.abs(uninterrupted).max(axis=0) + 1e-300
    assert np.all(np.abs(resumed - uninterrupted) <= 1e-12 * scale)


# --- bad input ----------------------------------------------------------------------------------

@pytest.mark.parametrize(("arguments", "message"), [
    ("nowhere", "region 'nowhere' does not exist"),
    ("frction 0.3 drum", "unknown keyword 'frction'"),
    ("drum wiggle z 0.1 1", "unknown keyword 'wiggle' after the region ID drum"),
    ("friction 0.3", "no region ID given"),
    ("friction -1 drum", "friction must be >= 0"),
    ("rolling sds -1 0 0 drum", "rolling sds k_roll must be > 0"),
])
def test_bad_region_wall_arguments_are_one_line_lammps_errors(arguments, message):
    lmp = grains([0.05], [(0.0, 0.0, 0.0)], "region drum cylinder z 0 0 0.3 -0.2 0.2 side in")
    with pytest.raises(Exception) as error:
        lmp.command(f"fix wall all wall/geocontact/region {PARAMS} {arguments}")
    # one line (LAMMPS adds the input line it stopped at on the next)
    assert re.search(message, str(error.value).splitlines()[0])
    lmp.close()


def test_a_region_deleted_before_the_run_is_a_lammps_error():
    lmp = grains([0.05], [(0.0, 0.0, 0.0)], "region drum cylinder z 0 0 0.3 -0.2 0.2 side in",
                 "fix wall all wall/geocontact/region {P} {K} drum")
    lmp.command("region drum delete")
    with pytest.raises(Exception, match="region 'drum' does not exist"):
        lmp.command("run 0")
    lmp.close()


def test_a_planar_contact_forgotten_beyond_the_skin_leaves_the_other_walls_record():
    """fix wall/geocontact (the per-contact code the region fix shares): a grain squeezed between
    the floor and the roof of one fix, then shrunk onto the floor, beyond the roof's skin: the
    roof's record is forgotten (its dissipation kept in the tally), the floor's record and
    output stay, and the floor contact unloads from the dent it had (below the virgin force)."""
    radius, small = 0.05, 0.03
    w = 20 * BASE.for_radius(radius).yield_approach
    lmp = grains([radius], [(0.0, 0.0, radius - w)],
                 "fix wall all wall/geocontact {P} {K} zplane 0.0 " + f"{2 * radius - 2 * w!r}")
    lmp.command("run 0")
    step(lmp, False)
    both = per_atom(lmp)[0]
    dissipated_both = global_vector(lmp)[3]
    assert both[1] > 0 and both[6 + 1] > 0  # on the floor and the roof
    w_small = 0.7 * w * small / radius  # inside the floor's dent, in the small grain's law
    lmp.command(f"set atom 1 diameter {2 * small!r}")
    lmp.command(f"set atom 1 z {small - w_small!r}")  # the roof 0.04 away: beyond the skin
    step(lmp, False)
    after = per_atom(lmp)[0]
    assert not after[6:].any()  # the roof forgotten
    assert after[1] > 0 and after[3] > 0  # the floor's contact and its dent kept
    # the roof's dissipation kept, the floor's as it was: both in the energy unit of the grain's
    # present size (energies scale with s^3, law.hpp Similarity)
    assert global_vector(lmp)[3] == pytest.approx(dissipated_both * (small / radius) ** 3,
                                                  rel=1e-12)
    # the floor's law state, in the calibrated grain's units (d = 2 w / s), unloaded at the new s
    s_before, s_after = radius / BASE.material.radius, small / BASE.material.radius
    floor = Contact(BASE)
    floor.update(2 * w / s_before)
    seen = small - lmp.numpy.extract_atom("x")[0][2]
    expected = s_after**2 * floor.update(2 * seen / s_after)[0]
    assert lmp.numpy.extract_atom("f")[0][2] == pytest.approx(expected, rel=1e-9)
    assert expected < 0.6 * Contact(BASE.for_radius(small)).update(2 * seen)[0]  # the dent
    lmp.close()


# --- units ----------------------------------------------------------------------------------------

def cavity_contact(style: str) -> np.ndarray:
    """A grain of radius 1 cm pressed 20 um into the wall of a spherical cavity of radius 5 cm,
    sliding and spinning, with damping: after one step its force (N), torque (N m) and the wall's
    dissipated and stored energies (J), in SI whatever the unit style."""
    from test_lammps_units import UNITS

    length, mass, time, force, energy = UNITS[style]
    radius, cavity, w = 0.01 / length, 0.05 / length, 20e-6 / length
    lmp = open_lammps()
    for line in (f"units {style}", "atom_style sphere", "atom_modify map array",
                 "boundary f f f", "comm_modify vel yes",
                 f"region box block -{0.1 / length!r} {0.1 / length!r} -{0.1 / length!r} "
                 f"{0.1 / length!r} -{0.1 / length!r} {0.1 / length!r}", "create_box 1 box",
                 f"create_atoms 1 single {cavity - radius + w!r} 0 0 units box",
                 f"set atom 1 diameter {2 * radius!r}",
                 f"set atom 1 density {DENSITY * length**3 / mass!r}",
                 f"set atom 1 vy {0.01 * time / length!r}",
                 f"set atom 1 omega 0 0 {3.0 * time!r}",
                 f"region cavity sphere 0 0 0 {cavity!r} side in units box",
                 f"fix wall all wall/geocontact/region {PARAMS} friction 0.4 damping 0.3 cavity",
                 f"timestep {1e-6 / time!r}", "run 1"):
        lmp.command(line)
    vector = global_vector(lmp)
    out = np.array([*np.array(lmp.numpy.extract_atom("f")[0]) * force,
                    *np.array(lmp.numpy.extract_atom("torque")[0]) * energy,
                    vector[3] * energy, vector[4] * energy])
    lmp.close()
    return out


@pytest.mark.parametrize("style", ["cgs", "micro", "metal"])
def test_a_region_wall_gives_the_same_contact_in_si_whatever_the_unit_style(style):
    reference, got = cavity_contact("si"), cavity_contact(style)
    assert reference[0] < 0 and reference[1] != 0 and reference[6] > 0  # pushed in, sliding
    assert np.abs(got - reference).max() <= 1e-6 * np.abs(reference).max()
    # the law of the effective radius r R / (R - r) at d = 2 w, in newtons
    r_eff = 0.01 * 0.05 / (0.05 - 0.01)
    assert -reference[0] == pytest.approx(Contact(BASE.for_radius(r_eff)).update(40e-6)[0],
                                          rel=1e-6)


def test_lj_units_are_refused_by_the_region_wall():
    lmp = open_lammps()
    for line in ("units lj", "atom_style sphere", "region box block -1 1 -1 1 -1 1",
                 "create_box 1 box", "region cavity sphere 0 0 0 0.5 side in"):
        lmp.command(line)
    with pytest.raises(Exception, match="units lj have no physical size"):
        lmp.command(f"fix wall all wall/geocontact/region {PARAMS} cavity")
    lmp.close()


# --- MPI: 1 and 2 ranks, migration, restart across rank counts -----------------------------

def test_region_wall_contacts_cross_ranks_and_restart_on_another_rank_count(tmp_path):
    """The `region_wall` scenario (lammps_scenarios.py): plastic contacts with the side and the
    bottom cap of a turning drum, carried around the drum across the rank boundary and back,
    give on 2 ranks the forces and torques of 1 rank; a restart written on 2 ranks mid-history,
    continued on 1, gives the uninterrupted run."""
    restart = tmp_path / "drum.restart"
    serial = scenarios.run_scenario(1, "region_wall")
    parallel = scenarios.run_scenario(2, "region_wall", "--restart-out", str(restart))
    resumed = scenarios.run_scenario(1, "region_wall", "--resume", str(restart))
    assert (serial["ranks"], parallel["ranks"]) == (1, 2)
    x = np.array([s["x"] for s in serial["steps"]])
    assert np.all(x.min(axis=0) < -0.2) and np.all(x.max(axis=0) > 0.1)  # crossed x = 0
    after = scenarios.WALL_RESTART_AFTER
    for key in ("forces", "torques", "wall"):
        one = np.array([s[key] for s in serial["steps"]])
        two = np.array([s[key] for s in parallel["steps"]])
        back = np.array([s[key] for s in resumed["steps"]])
        scale = np.abs(one).max()
        assert scale > 0
        assert np.abs(two - one).max() <= 1e-12 * scale, key
        assert np.abs(back - one[after:]).max() <= 1e-12 * scale, key
    contacts = np.array([s["wall"][5] for s in serial["steps"]])
    assert contacts.max() == 4  # the side, the cap, and the corner grain's two


# the per-atom layout tag as the fix writes it (fix_wall_geocontact_region.h): "GCRA" in the high,
# the region layout version in the low 32 bits of a 64-bit word, once per atom
REGION_ATOM_TAG = struct.pack("<q", (int.from_bytes(b"GCRA", "little") << 32) | 1)


@pytest.mark.parametrize(("edit", "message"), [
    (None, None),
    (REGION_ATOM_TAG[:4].replace(b"\x01", b"\x02") + REGION_ATOM_TAG[4:],
     "region contacts have region layout version 2; this fix reads region layout version 1"),
    (struct.pack("<d", 1.0), "region contacts have no wall/geocontact/region layout tag"),
], ids=["intact", "other-version", "foreign"])
def test_a_restart_of_another_region_layout_is_refused(tmp_path, edit, message):
    radius = 0.05
    w = 20 * BASE.for_radius(radius).yield_approach
    cavity = ["region cavity sphere 0 0 0 0.6 side in",
              "fix wall all wall/geocontact/region {P} {K} cavity"]
    lmp = grains([radius], [(0.6 - radius + w, 0.0, 0.0)], *cavity)
    lmp.command("run 1")
    restart = tmp_path / "cavity.restart"
    lmp.command(f"write_restart {restart}")
    lmp.close()
    if edit is not None:
        data = restart.read_bytes()
        assert data.count(REGION_ATOM_TAG) == 1
        restart.write_bytes(data.replace(REGION_ATOM_TAG, edit))
    lmp = open_lammps()
    lmp.command(f"read_restart {restart}")
    for line in cavity:
        lmp.command(line.format(P=PARAMS, K="friction 0.0 damping 0.0"))
    if message is None:  # the dent came back: unloading to half the interference
        lmp.command(f"set atom 1 x {0.6 - radius + 0.5 * w!r}")
        lmp.command("run 1")
        law = BASE.for_radius(radius * 0.6 / (0.6 - radius))  # R_eff of the cavity
        reference = Contact(law)
        reference.update(2 * w)
        seen = radius - (0.6 - lmp.numpy.extract_atom("x")[0][0])
        unloading = reference.update(2 * seen)[0]
        assert unloading < 0.5 * Contact(law).update(2 * seen)[0]
        assert -lmp.numpy.extract_atom("f")[0][0] == pytest.approx(unloading, rel=1e-9)
    else:
        with pytest.raises(Exception, match=message):
            lmp.command("run 0")
    lmp.close()


def test_a_grain_in_a_turning_drum_is_dragged_as_by_fix_wall_gran_region():
    """LAMMPS's own fix wall/gran/region on the same rotating cylinder region, side by side: a
    held grain pressed (elastically) into the drum's wall, the drum turning. LAMMPS's contact of
    `granular hertz/material 2E 0 nu` (its wall a body of the grain's material: 2E makes it the
    rigid wall's E/(1 - nu^2)) uses its own effective radius r rho / (r + rho) of the region's
    curvature, and `tangential linear_history k_t` the Mindlin stiffness of our static contact:
    the forces on the grain agree at every step, sticking and sliding (to 1e-9; measured
    2.7e-11 of the peak)."""
    radius, r_c, omega, friction = 0.05, 0.3, 0.01, 0.4
    r_eff = radius * 2 * r_c / (2 * r_c - radius)
    law = BASE.for_radius(r_eff)
    w = 0.4 * law.yield_approach
    e, nu = BASE.material.youngs_modulus, BASE.material.poissons_ratio
    k_t = 8.0 * BASE.material.shear_modulus / (2.0 - nu) * math.sqrt(r_eff * w)
    drum = [f"variable theta equal {omega!r}*step*dt",
            f"region drum cylinder z 0 0 {r_c!r} -1 1 side in rotate v_theta 0 0 0 0 0 1"]
    ours = drum + ["fix wall all wall/geocontact/region {P} {K} drum"]
    theirs = drum + [f"fix wall all wall/gran/region granular hertz/material {2 * e!r} 0 "
                     f"{nu!r} tangential linear_history {k_t!r} 0 {friction!r} region drum"]
    rows = []
    for lines in (ours, theirs):
        lmp = grains([radius], [(r_c - radius + w, 0.0, 0.0)], *lines, friction=friction)
        lmp.command("run 0")
        forces = []
        for _ in range(60):
            step(lmp, False)
            forces.append(np.array(lmp.numpy.extract_atom("f")[0]))
        rows.append(np.array(forces))
        lmp.close()
    ours_f, theirs_f = rows
    assert theirs_f[-1, 1] == pytest.approx(friction * -theirs_f[-1, 0], rel=1e-9)  # sliding
    assert theirs_f[0, 1] < 0.5 * theirs_f[-1, 1]  # sticking first
    assert np.abs(ours_f - theirs_f).max() <= 1e-9 * np.abs(theirs_f).max()
