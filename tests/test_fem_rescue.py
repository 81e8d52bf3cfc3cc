"""Rescue mode of the FE engine: a load step that fails with every cutback is solved again with
Newton updates halved until no element is inside out (``ContactSolver.line_search``).

Off, the engine's arithmetic is what it always was (a finished run is reproduced bit for bit);
on, an update that would invert an element is halved instead of giving NaN.
"""

from __future__ import annotations

import dataclasses
import warnings

import numpy as np
import pytest
from conftest import YIELD_FIXED

from geocontact.errors import ConvergenceError
from geocontact.fem import run as fem_run
from geocontact.fem.finite_strain import FiniteStrainSolver
from geocontact.fem.mesh import build_mesh
from geocontact.fem.solver import LINE_SEARCH_HALVINGS, ContactSolver
from geocontact.grain.material import preset


@pytest.fixture(scope="module")
def material():
    return preset("reference")


@pytest.fixture(scope="module")
def solver(material):
    mesh = build_mesh(material.radius, 0.02 * material.radius, 0.05 * material.radius, "coarse")
    return FiniteStrainSolver(material, mesh)


def _squash(solver, factor):
    """u_z = -factor (R - z): the column squashed to 1 - factor of its height (inside out for
    factor > 1)."""
    x, z = solver.mesh.doflocs
    u = np.zeros(solver.ndofs)
    dofs_z = np.concatenate([solver.basis.nodal_dofs[1], solver.basis.facet_dofs[1]])
    u[dofs_z] = factor * (solver.material.radius - z)
    return u


def test_admissible_tells_an_inverted_element(solver, material):
    assert solver.admissible(np.zeros(solver.ndofs))
    assert solver.admissible(_squash(solver, 0.9))
    assert not solver.admissible(_squash(solver, 1.5))
    u = _squash(solver, 0.0)
    u[0] = np.nan
    assert not solver.admissible(u)
    small = ContactSolver(material, solver.mesh)
    assert small.admissible(_squash(solver, 1.5))  # small strain evaluates anything


@pytest.mark.parametrize("linear_solver", ["fast", "reference"])
def test_an_inside_out_iterate_gives_up_before_the_linear_solve(material, linear_solver):
    """An iterate with an element turned inside out has a NaN residual: the Newton iteration
    gives up at once (the caller cuts the step back), without a factorisation of a NaN matrix
    (whose BLAS calls printed "illegal value" into campaign logs) and without a warning."""
    mesh = build_mesh(material.radius, 0.02 * material.radius, 0.05 * material.radius, "coarse")
    fresh = FiniteStrainSolver(material, mesh, linear_solver=linear_solver)
    old = fresh.initial_state()
    u = _squash(fresh, 1.5)
    before = fresh.factorisations
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(ConvergenceError, match="residual nan"):
            fresh._iterate(old, 1.0, u, 0.0, old.active.copy(), elastic=False, label="",
                           final=True)
    assert fresh.factorisations == before


def test_searched_update_halves_an_inverting_step(solver):
    free = np.arange(solver.ndofs)
    free = free[~np.isin(free, solver.top_dofs)]
    step = np.append(_squash(solver, 1.5)[free], 0.0)
    u0 = np.zeros(solver.ndofs)
    before = solver.line_search_halvings
    u, w = solver._searched_update(u0, 0.0, step, free, np.array([], dtype=int), np.array([]))
    assert solver.admissible(u)
    assert solver.line_search_halvings - before == 1  # 1.5 -> 0.75
    np.testing.assert_array_equal(u[free], 0.5 * step[:-1])
    # a step inadmissible at every scale is given up
    hopeless = step.copy()
    hopeless[0] = np.nan
    assert solver._searched_update(u0, 0.0, hopeless, free, np.array([], dtype=int),
                                   np.array([])) == (None, None)
    assert solver.line_search_halvings - before == 2 + LINE_SEARCH_HALVINGS


def test_line_search_changes_nothing_when_no_update_is_halved(solver, material):
    """The same finite-strain steps with and without rescue mode: bit for bit the same states
    (the update of a full step is the engine's usual one)."""
    states = {}
    halvings = solver.line_search_halvings
    for line_search in (False, True):
        solver.line_search = line_search
        try:
            state = solver.initial_state()
            for force in (5.0, 15.0, 27.6):
                state = solver.solve_step(state, force)
        finally:
            solver.line_search = False
        states[line_search] = state
    assert solver.line_search_halvings == halvings
    for name, value in states[False].arrays().items():
        np.testing.assert_array_equal(value, states[True].arrays()[name], err_msg=name)


@dataclasses.dataclass
class _Scripted:
    """A stand-in solver: fails every solve, or every solve outside rescue mode."""

    fail_always: bool
    line_search: bool = False
    line_search_halvings: int = 0
    rescued_steps: list = dataclasses.field(default_factory=list)
    calls: int = 0
    rescue_calls: int = 0

    def solve_step(self, current, goal):
        self.calls += 1
        if self.line_search:
            self.rescue_calls += 1
            self.line_search_halvings += 2
        if self.fail_always or not self.line_search:
            raise ConvergenceError(f"Newton did not converge at F = {goal:g} N")
        return dataclasses.replace(current, force=goal, iterations=3)


@dataclasses.dataclass
class _Point:
    force: float
    iterations: int = 0


def test_a_failed_step_is_rescued_and_recorded():
    solver = _Scripted(fail_always=False)
    state = fem_run._advance(solver, _Point(1.0), 2.0, 7, goals=[1.5, 2.0])
    rescued = solver.rescued_steps
    assert state.force == 2.0 and state.iterations == 6  # two rescue solves of 3 iterations
    assert solver.calls == fem_run.MAX_CUTBACKS + 1 + 2  # the failed attempt, then the rescue
    assert not solver.line_search  # rescue mode ends with the step
    assert rescued == [{"step": 7, "force_N": 2.0, "line_search_halvings": 4,
                        "failure": rescued[0]["failure"]}]
    assert "after 8 cutbacks" in rescued[0]["failure"]


def test_a_step_that_fails_in_rescue_mode_too_is_an_error():
    solver = _Scripted(fail_always=True)
    with pytest.raises(ConvergenceError, match="step 3: .* 8 cutbacks in rescue mode"):
        fem_run._advance(solver, _Point(0.0), 1.0, 3)
    assert not solver.line_search
    assert solver.rescue_calls == fem_run.MAX_CUTBACKS + 1


def test_run_records_a_rescued_step_and_keeps_it_through_a_resume(material, tmp_path,
                                                                  monkeypatch):
    """A step that fails outside rescue mode is solved in it; the run says so in summary.json
    (and keeps saying so when resumed from a checkpoint written after it). Rescue mode with no
    halving is the engine's usual arithmetic, so the curve is the unrescued run's, bit for bit."""
    forces = [0.0, 27.6, 0.0]
    plain = fem_run.run_history(material, forces, mesh="coarse", steps_per_segment=4,
                                write_fields=False, **YIELD_FIXED)
    assert "rescued_steps" not in plain.summary
    real = ContactSolver.solve_step

    def fragile(self, old, force, **kwargs):
        if not self.line_search and 10.0 < force < 16.0:
            raise ConvergenceError(f"Newton did not converge at F = {force:g} N (test)")
        return real(self, old, force, **kwargs)

    monkeypatch.setattr(ContactSolver, "solve_step", fragile)
    out = tmp_path / "run"
    real_advance = fem_run._advance

    def stop_at_nine(solver, state, target, step, *args):
        if step == 9:
            raise KeyboardInterrupt
        return real_advance(solver, state, target, step, *args)

    with monkeypatch.context() as m:
        m.setattr(fem_run, "_advance", stop_at_nine)
        with pytest.raises(KeyboardInterrupt):
            fem_run.run_history(material, forces, mesh="coarse", steps_per_segment=4,
                                write_fields=False, out=out, **YIELD_FIXED)
    rescued = fem_run.run_history(material, forces, mesh="coarse", steps_per_segment=4,
                                  write_fields=False, out=out, resume=True,
                                  **YIELD_FIXED)
    [record] = rescued.summary["rescued_steps"]
    assert record["step"] < 9  # before the interruption: the checkpoint carried it
    assert 10.0 < record["force_N"] < 16.0 and record["line_search_halvings"] == 0
    assert "after 8 cutbacks" in record["failure"]
    for name, values in plain.curve.items():
        np.testing.assert_array_equal(values, rescued.curve[name], err_msg=name)
