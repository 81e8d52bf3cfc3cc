"""The compiled finite-strain engine with and without the reuse of the factorisation
(``CompiledFiniteStrainSolver.reuse_factor``, issue 36) through the same load schedule, in
lockstep (one load step of each in turn, so a change of the shared machine's load falls on both
alike): CPU time, factorisations, Newton iterations, cut-backs, Krylov solves, and how far the
reused run's states are from the direct one's.

    .venv/bin/python scripts/compare_factor_reuse.py [--material reference-weak] [--mesh coarse]
        [--force 3000] [--steps 24]
"""

from __future__ import annotations

import argparse
import os
import time

os.environ.setdefault("OMP_NUM_THREADS", "1")  # one core, as the benchmarks
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

from geocontact.errors import ConvergenceError  # noqa: E402
from geocontact.fem.compiled import compiled_solver  # noqa: E402
from geocontact.fem.run import _advance, history_mesh, load_schedule  # noqa: E402
from geocontact.grain.hertz import incipient_yield  # noqa: E402
from geocontact.grain.material import preset  # noqa: E402


def counted(solver, failures: dict, name: str):
    """``solver.solve_step`` counting the solves that did not converge (the step cut back)."""
    solve = solver.solve_step

    def solve_step(old, force, *, label=""):
        try:
            return solve(old, force, label=label)
        except ConvergenceError:
            failures[name] += 1
            raise
    return solve_step


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--material", default="reference-weak")
    parser.add_argument("--mesh", default="coarse")
    parser.add_argument("--force", type=float, default=3000.0)
    parser.add_argument("--steps", type=int, default=24, help="load steps per segment")
    args = parser.parse_args()
    material = preset(args.material)
    mesh = history_mesh(material, args.force, args.mesh, rule="contact")
    solvers, states, cpu, failures, iterations = {}, {}, {}, {}, {}
    for name, reuse in (("direct", False), ("reuse", True)):
        solver = compiled_solver(material, mesh, factoriser="cholmod", force_scale=args.force)
        solver.reuse_factor = reuse
        solver.solve_step = counted(solver, failures, name)
        solvers[name], states[name] = solver, solver.initial_state()
        cpu[name], failures[name], iterations[name] = 0.0, 0, 0
    targets, _ = load_schedule([0.0, args.force, 0.0], args.steps,
                               float(incipient_yield(material).force))
    print(f"{args.material}, {args.mesh} mesh: {solvers['direct'].ndofs} unknowns, "
          f"{len(targets) - 1} load steps")
    largest = 0.0
    for step, target in enumerate(targets[1:], start=1):
        for name, solver in solvers.items():
            start = time.process_time()
            states[name] = _advance(solver, states[name], target, step)
            cpu[name] += time.process_time() - start
            iterations[name] += states[name].iterations
        a, b = states["direct"], states["reuse"]
        if a.top_displacement != 0.0:
            largest = max(largest, abs(b.top_displacement / a.top_displacement - 1.0))
    for name, solver in solvers.items():
        print(f"  {name:6s} CPU {cpu[name]:6.1f} s, {solver.factorisations} factorisations, "
              f"{iterations[name]} Newton iterations in the converged solves, "
              f"{failures[name]} solves cut back, {solver.krylov_solves} Krylov solves "
              f"({solver.krylov_iterations} CG iterations, {solver.krylov_refactorisations} "
              "refactorised)")
    a, b = states["direct"], states["reuse"]
    print(f"  reuse / direct CPU {cpu['reuse'] / cpu['direct']:.3f}; approach at most "
          f"{largest:.1e} apart (relative), final eqps "
          f"{np.max(np.abs(b.eqps - a.eqps)) / np.max(a.eqps):.1e} of its largest, plastic "
          f"work {b.plastic_dissipation / a.plastic_dissipation - 1.0:+.1e}; load average "
          f"{os.getloadavg()[0]:.1f}")


if __name__ == "__main__":
    main()
