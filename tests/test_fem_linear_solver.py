"""The FE solver's fast linear-algebra path against the reference path (issue 12)."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp
from conftest import YIELD_FIXED

from geocontact.fem import linear_algebra
from geocontact.fem.run import history_mesh
from geocontact.fem.solver import ContactSolver
from geocontact.fem.solver_comparison import ACCURACY, compare_linear_solvers
from geocontact.grain.material import load_material

HISTORY = [0.0, 3000.0, 0.0]


@pytest.fixture(scope="module")
def material():
    return load_material("reference")


@pytest.fixture(scope="module")
def contact_solver(material):
    return ContactSolver(material, history_mesh(material, 3000.0, "coarse"), force_scale=3000.0)


def test_bordered_system_is_the_condensed_global_stiffness(contact_solver):
    """A = T^T K T, T mapping [u_free, w] to all dofs (u_top = -w), built from the global CSR."""
    s = contact_solver
    active = np.zeros(len(s.candidate_dofs), dtype=bool)
    active[:4] = True
    rng = np.random.default_rng(1)
    # a symmetric positive tangent at every point: the elastic one scaled point by point
    scale = 0.2 + rng.random(s.dvolume.shape)
    tangent = s.elastic_matrix[:, :, None, None] * scale[None, None]
    reduced = s._reduced(active)
    a = s._bordered_system(s.element_matrices(tangent), reduced).toarray()
    K = s.stiffness(tangent)
    T = sp.lil_matrix((s.ndofs, reduced.n + 1))
    T[reduced.free, np.arange(reduced.n)] = 1.0
    T[s.top_dofs, reduced.n] = -1.0
    expected = (T.T @ K @ T).toarray()
    assert np.max(np.abs(a - expected)) <= 1e-12 * np.max(np.abs(expected))
    assert np.allclose(a, a.T, rtol=0, atol=1e-12 * np.max(np.abs(a)))


@pytest.mark.parametrize("cholmod", [True, False], ids=["fast", "fast-superlu"])
def test_fast_path_matches_reference_path(material, monkeypatch, cholmod):
    """Same schedule, same Newton iterations, curves and energies within 0.2 % (here to
    round-off), with fewer factorisations; also with SuperLU when CHOLMOD is absent."""
    if cholmod:
        pytest.importorskip("sksparse.cholmod")
    else:
        monkeypatch.setattr(linear_algebra, "_cholmod", lambda: None)
    report = compare_linear_solvers(material, HISTORY, mesh="coarse", steps_per_segment=3,
                                    **YIELD_FIXED)
    diff = report["max_relative_difference"]
    assert report["within_accuracy"], diff
    assert max(diff.values()) < 1e-6 < ACCURACY  # the same equations, solved to round-off
    fast, reference = report["paths"]["fast"], report["paths"]["reference"]
    assert fast["newton_iterations"] == reference["newton_iterations"]
    assert fast["factorisations"] < reference["factorisations"]


def test_unknown_linear_solver_is_one_line_error(material, contact_solver):
    with pytest.raises(ValueError, match="linear_solver must be one of fast, reference"):
        ContactSolver(material, contact_solver.mesh, linear_solver="umfpack")
