"""Similarity (docs/model.md §10, issue 11): the rate-independent continuum problem has no length
scale, so spheres of radius r = s R are the calibrated spheres scaled by s: at the force s^2 F
the approach is s times, the contact radius s times, the energies s^3 times. The FE engine
itself must show it (geometrically scaled mesh, same load schedule in F / Fy), to the solver's
tolerance: it is the proof behind the law's rescaling for grains of any size."""

from dataclasses import replace

import numpy as np
import pytest
from conftest import YIELD_FIXED

from geocontact.fem.run import run_history
from geocontact.grain.material import preset

SCALE = 0.1
FORCES = [0.0, 3000.0, 0.0, 1500.0, 0.0]  # past yield (Fy ~ 12 N), unload, partial reload


@pytest.fixture(scope="module")
def runs():
    big = preset("reference")
    small = replace(big, radius=SCALE * big.radius)
    # the "yield" meshes and fixed steps (the defaults before issue 36): the subject is the
    # scaling, which any one discretisation must show, and these are the cheapest at 3 kN
    common = dict(mesh="coarse", steps_per_segment=5, write_fields=False, **YIELD_FIXED)
    return (run_history(big, FORCES, **common),
            run_history(small, [SCALE**2 * f for f in FORCES], **common), big)


def test_scaled_mesh_is_the_same_mesh_scaled(runs):
    big, small, _ = runs
    assert small.summary["mesh"]["elements"] == big.summary["mesh"]["elements"]
    # gmsh meshes the scaled geometry with the scaled sizes to its own round-off (~1e-9)
    np.testing.assert_allclose(small.solver.mesh.doflocs, SCALE * big.solver.mesh.doflocs,
                               rtol=0, atol=1e-8 * SCALE * big.solver.mesh.doflocs.max())


@pytest.mark.parametrize(("column", "power"), [
    ("force_N", 2), ("approach_m", 1), ("contact_radius_m", 1), ("plastic_dissipation_J", 3),
    ("elastic_energy_J", 3), ("work_J", 3), ("peak_pressure_Pa", 0)])
def test_fe_curves_scale_exactly(runs, column, power):
    big, small, _ = runs
    assert len(small.curve["step"]) == len(big.curve["step"])  # the same load schedule
    expected = SCALE**power * big.curve[column]
    scale = np.max(np.abs(expected))
    # measured: 5e-13 (force) to 3e-10 (contact radius) of the peak, the mesh's round-off
    # carried through Newton (tolerance 1e-8 on the residual); a law that broke similarity (a
    # length scale anywhere) would be off by O(1)
    np.testing.assert_allclose(small.curve[column], expected, rtol=0, atol=1e-8 * scale)


def test_yield_and_cycles_scale(runs):
    big, small, _ = runs
    b, s = big.summary, small.summary
    assert s["first_yield_force_N"] == pytest.approx(SCALE**2 * b["first_yield_force_N"],
                                                     rel=1e-7)
    assert s["first_yield_approach_m"] == pytest.approx(SCALE * b["first_yield_approach_m"],
                                                        rel=1e-7)
    for cb, cs in zip(b["cycles"], s["cycles"], strict=True):
        assert cs["residual_approach_m"] == pytest.approx(SCALE * cb["residual_approach_m"],
                                                          rel=1e-6)
        assert cs["plastic_work_J"] == pytest.approx(SCALE**3 * cb["plastic_work_J"], rel=1e-6)
