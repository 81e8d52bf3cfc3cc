"""The linear solver of the compiled finite-strain path (fem.compiled, issue 36): CHOLMOD's
supernodal LL^T solves the bordered system of a plastic tangent to its round-off; the Newton step
by conjugate gradients preconditioned with an earlier tangent's factorisation (reuse_factor) is
the direct solve's to the inexact-Newton target; and load steps solved with the reuse equal those
solved with a factorisation per iteration within the Newton tolerance, with fewer
factorisations."""

import numpy as np
import pytest
from test_fem_finite_strain import _large_deformation

from geocontact.fem import compiled
from geocontact.fem.compiled import (
    available_factorisers,
    compiled_solver,
    default_factoriser,
    make_factoriser,
    preconditioned_cg,
)
from geocontact.fem.mesh import build_mesh
from geocontact.grain.material import preset

pytestmark = pytest.mark.skipif("cholmod" not in available_factorisers(),
                                reason="scikit-sparse (CHOLMOD) not installed")


@pytest.fixture(scope="module")
def material():
    return preset("reference")


@pytest.fixture(scope="module")
def mesh(material):
    return build_mesh(material.radius, 0.02 * material.radius, 0.05 * material.radius, "coarse")


def _tangents(material, mesh):
    """The solver, two plastic tangents of one contact set at neighbouring iterates (as two
    Newton iterations give them) and the contact set's index maps."""
    solver = compiled_solver(material, mesh)
    assert not solver.reuse_factor  # an option: off by default (direct solves reproduce)
    solver.reuse_factor = True
    old = solver.initial_state()
    u = 0.01 * _large_deformation(solver)
    first = solver._evaluate(old, u, elastic=False)
    assert np.count_nonzero(first[0].status) > 50  # plastic points: D^ep, not D
    second = solver._evaluate(old, 1.01 * u, elastic=False)[2]
    active = np.zeros(len(solver.candidate_dofs), dtype=bool)
    active[:5] = True
    return solver, first[2], second, solver._reduced(active)


def test_default_factoriser_solves_the_bordered_system(material, mesh):
    """kernels="compiled" factorises with CHOLMOD's supernodal LL^T (the tangent is positive
    definite here: no fallback to the LDL^T) to the round-off of the system."""
    assert default_factoriser() == "cholmod"
    solver, local, _, reduced = _tangents(material, mesh)
    matrix = solver._bordered_system(local, reduced)
    factoriser = make_factoriser("cholmod", reduced.indptr, reduced.indices)
    assert factoriser.factor(matrix.data)
    assert factoriser.indefinite is None and factoriser.mode == "supernodal"
    rhs = np.random.default_rng(3).standard_normal(matrix.shape[0])
    x = factoriser.solve(rhs)
    dense = matrix.toarray()
    # backward error: the residual at the round-off of |A| |x|
    assert np.max(np.abs(matrix @ x - rhs)) <= 1e-12 * np.max(abs(matrix) @ np.abs(x))
    reference = np.linalg.solve(dense, rhs)
    assert np.max(np.abs(x - reference)) <= 1e-8 * np.max(np.abs(reference))


def test_indefinite_matrix_falls_back_to_ldlt(material, mesh):
    """A symmetric matrix that is not positive definite (LL^T fails) is factorised by the
    simplicial LDL^T and still solved."""
    solver, local, _, reduced = _tangents(material, mesh)
    matrix = solver._bordered_system(local, reduced)
    shift = 1e-3 * np.abs(matrix.diagonal()).max()  # a few negative eigenvalues
    indefinite = (matrix - shift * _identity(matrix.shape[0])).tocsc()
    indefinite.sort_indices()
    assert np.min(np.linalg.eigvalsh(indefinite.toarray())) < 0.0
    factoriser = make_factoriser("cholmod", reduced.indptr, reduced.indices)
    assert factoriser.factor(indefinite.data)
    assert factoriser.indefinite is not None
    rhs = np.ones(matrix.shape[0])
    reference = np.linalg.solve(indefinite.toarray(), rhs)
    assert np.max(np.abs(factoriser.solve(rhs) - reference)) <= 1e-7 * np.max(np.abs(reference))


def _identity(n):
    import scipy.sparse as sp

    return sp.identity(n, format="csc")


def test_preconditioned_step_is_the_direct_step(material, mesh):
    """The step of the second tangent by CG preconditioned with the first tangent's
    factorisation: its residual within the inexact-Newton target, and so within
    |K^-1| target of the direct solve; with the exact factorisation, one iteration."""
    solver, first, second, reduced = _tangents(material, mesh)
    a = solver._bordered_system(first, reduced)
    b = solver._bordered_system(second, reduced)
    assert abs(b - a).max() > 1e-4 * abs(a).max()  # the tangents differ
    factoriser = make_factoriser("cholmod", reduced.indptr, reduced.indices)
    preconditioner = factoriser.factorise(a.data)
    rhs = np.random.default_rng(4).standard_normal(b.shape[0]) * np.abs(b).max() * 1e-6
    direct = np.linalg.solve(b.toarray(), rhs)
    target = 1e-8 * np.max(np.abs(rhs))
    x, iterations = preconditioned_cg(b, rhs, preconditioner.solve_A, target, 50)
    assert x is not None and 1 < iterations <= 50
    assert np.max(np.abs(b @ x - rhs)) <= target
    bound = np.linalg.norm(np.linalg.inv(b.toarray()), np.inf) * target
    assert np.max(np.abs(x - direct)) <= bound
    assert np.max(np.abs(x - direct)) <= 1e-6 * np.max(np.abs(direct))
    exact = factoriser.factorise(b.data)
    x, iterations = preconditioned_cg(b, rhs, exact.solve_A, 1e-6 * np.max(np.abs(rhs)), 50)
    assert iterations == 1
    # not within the iterations allowed: no step (the caller factorises)
    assert preconditioned_cg(b, rhs, preconditioner.solve_A, 0.0, 2) == (None, 2)


def test_krylov_solve_refactorises_when_it_does_not_converge(material, mesh, monkeypatch):
    """A Newton step that CG does not solve within KRYLOV_ITERATIONS is solved directly with a
    new factorisation, which becomes the preconditioner."""
    solver, first, second, reduced = _tangents(material, mesh)
    plan = solver._plan(reduced)
    solver._factor(first, reduced)(np.ones(reduced.n + 1))  # the first iteration's LDL^T
    assert plan.preconditioner is not None and solver.factorisations == 1
    kept = plan.preconditioner
    monkeypatch.setattr(compiled, "KRYLOV_ITERATIONS", 1)
    solver._newton_tolerance = 1e-30  # unreachable in one iteration
    rhs = np.ones(reduced.n + 1)
    x = solver._factor(second, reduced)(rhs)
    b = solver._bordered_system(second, reduced)
    reference = np.linalg.solve(b.toarray(), rhs)
    assert np.max(np.abs(x - reference)) <= 1e-8 * np.max(np.abs(reference))
    assert solver.krylov_solves == 1 and solver.krylov_refactorisations == 1
    assert solver.factorisations == 2 and plan.preconditioner is not kept


def test_load_steps_with_reused_factorisations_equal_direct_solves():
    """0 -> 3 load steps past first yield -> back to 0 with the weak grain (plastic, finite
    strain), each Newton step by preconditioned CG (reuse_factor) or by a new factorisation:
    the same approaches, contact sets and plastic work within the Newton tolerance, with fewer
    factorisations."""
    material = preset("reference-weak")
    radius = material.radius
    mesh = build_mesh(radius, 0.02 * radius, 0.05 * radius, "coarse")
    solvers = {reuse: compiled_solver(material, mesh, factoriser="cholmod", force_scale=40.0)
               for reuse in (False, True)}
    states = {}
    for reuse, solver in solvers.items():
        solver.reuse_factor = reuse
        states[reuse] = solver.initial_state()
    for force in (10.0, 25.0, 40.0, 15.0):
        for reuse, solver in solvers.items():
            states[reuse] = solver.solve_step(states[reuse], force)
        a, b = states[False], states[True]
        assert abs(b.top_displacement / a.top_displacement - 1.0) < 1e-7
        assert np.array_equal(a.active, b.active)
    assert a.plastic_dissipation > 0.0
    assert abs(b.plastic_dissipation / a.plastic_dissipation - 1.0) < 1e-6
    assert np.max(np.abs(b.eqps - a.eqps)) <= 1e-6 * np.max(a.eqps)
    direct, reused = solvers[False], solvers[True]
    assert direct.krylov_solves == 0 and reused.krylov_solves > 0
    assert reused.factorisations < direct.factorisations


def test_tangent_with_many_changed_returns_is_factorised(material, mesh):
    """The last factorisation is reused only while at most STATUS_CHANGES points changed their
    return since its tangent; beyond, the tangent is factorised (no CG iterations spent)."""
    solver, first, second, reduced = _tangents(material, mesh)
    solver._evaluate(solver.initial_state(), 0.01 * _large_deformation(solver), elastic=False)
    solver._factor(first, reduced)
    plan = solver._plan(reduced)
    status = plan.status.copy()
    assert solver._reusable(plan)
    changed = status.reshape(-1)
    changed[:compiled.STATUS_CHANGES + 1] = 3  # returns no point has
    plan.status = changed.reshape(status.shape)
    assert not solver._reusable(plan)
    solver._factor(second, reduced)(np.ones(reduced.n + 1))
    assert solver.krylov_solves == 0 and solver.factorisations == 2
