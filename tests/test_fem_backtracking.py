"""Backtracking of Newton's updates (FE setting ``newton="backtracking"``,
``ContactSolver.backtracking``, docs/fem.md "Backtracking"): from the third iteration of a plastic
solve, an update that does not lower the largest residual is halved, at most
``BACKTRACK_HALVINGS`` times, each trial being the next iterate's own evaluation.

Checked on a linear problem, where the residual along an update is known exactly, and on plastic
finite-strain solves, where a solve whose full updates all lower the residual must come out bit
for bit as without it, with no evaluation added.
"""

from __future__ import annotations

import numpy as np
import pytest

from geocontact.fem.finite_strain import FiniteStrainSolver
from geocontact.fem.solver import BACKTRACK_HALVINGS, ContactSolver


@pytest.fixture(scope="module")
def material(reference_coarse):
    return reference_coarse[0]


@pytest.fixture(scope="module")
def mesh(reference_coarse):
    return reference_coarse[1]


def _largest_residual(solver, old, u, free, force):
    f_int = solver._response(old, u, elastic=False)[4]
    return max(np.max(np.abs(f_int[free])), abs(-np.sum(f_int[solver.top_dofs]) - force))


@pytest.mark.parametrize("overshoot, halvings, kept_scale", [
    (3.0, 1, 0.5),  # the full update doubles the error; half of it leaves half the error
    (9.0, BACKTRACK_HALVINGS, 0.5 ** BACKTRACK_HALVINGS),  # no trial lowers it: the last is kept
])
def test_an_update_that_does_not_lower_the_residual_is_halved(material, mesh, overshoot,
                                                              halvings, kept_scale):
    """A linear elastic grain at equilibrium under 5 N, its free dofs moved off by d: the exact
    Newton update is -d. Given -3 d, the full update leaves an error of -2 d (twice the residual)
    and the half update -0.5 d (half of it): one halving. Given -9 d, the trials leave -8 d,
    -3.5 d and -1.25 d, none below: the last is kept after BACKTRACK_HALVINGS halvings. The
    evaluation returned is the one at the iterate returned."""
    force = 5.0
    solver = ContactSolver(material, mesh, plastic=False)
    old = solver.initial_state()
    solved = solver.solve_step(old, force)
    cdofs, z0 = solver.candidate_dofs, solver.candidate_z0
    fixed = np.concatenate([solver.axis_dofs, solver.top_dofs, cdofs[solved.active]])
    free = np.setdiff1d(np.arange(solver.ndofs), fixed)
    d = np.zeros(solver.ndofs)
    d[free] = 1e-3 * np.max(np.abs(solved.displacement)) * np.random.default_rng(7).standard_normal(
        len(free))
    u0 = solved.displacement + d
    w0 = solved.top_displacement
    before = _largest_residual(solver, old, u0, free, force)
    step = np.append(-overshoot * d[free], 0.0)
    counted = solver.backtracked_updates
    u, w, evaluated = solver._backtracked_update(old, force, u0, w0, step, free,
                                                 cdofs[solved.active], -z0[solved.active], before)
    assert solver.backtracked_updates - counted == halvings
    np.testing.assert_array_equal(u[free], u0[free] + kept_scale * step[:-1])
    np.testing.assert_array_equal(u[fixed], u0[fixed])
    assert w == w0
    after = _largest_residual(solver, old, u, free, force)
    np.testing.assert_allclose(after, abs(1.0 - kept_scale * overshoot) * before, rtol=1e-6)
    np.testing.assert_array_equal(evaluated[4], solver._response(old, u, elastic=False)[4])


def _count_calls(solver, name: str) -> list:
    """The solver's method ``name`` wrapped to note each call in the list returned."""
    calls, plain = [], getattr(solver, name)

    def counted(*args, **kwargs):
        calls.append(1)
        return plain(*args, **kwargs)

    setattr(solver, name, counted)
    return calls


def test_a_solve_whose_full_updates_lower_the_residual_is_unchanged(material, mesh):
    """Plastic finite-strain steps of the reference grain (to 27.6 N, about 10 Fy) with full and
    with backtracked updates: no update is halved, the states are the same bit for bit and the
    iterates are evaluated as often (each trial is the next iteration's evaluation)."""
    states, evaluations = {}, {}
    for backtracking in (False, True):
        solver = FiniteStrainSolver(material, mesh, backtracking=backtracking)
        calls = _count_calls(solver, "_response")
        searched = _count_calls(solver, "_backtracked_update")
        state = solver.initial_state()
        for force in (5.0, 15.0, 27.6):
            state = solver.solve_step(state, force)
        assert solver.backtracked_updates == 0
        assert bool(searched) == backtracking  # updates from the third iteration were searched
        assert state.eqps.max() > 0.0  # the steps are plastic
        states[backtracking], evaluations[backtracking] = state, len(calls)
    assert evaluations[True] == evaluations[False]
    for name, value in states[False].arrays().items():
        np.testing.assert_array_equal(value, states[True].arrays()[name], err_msg=name)
