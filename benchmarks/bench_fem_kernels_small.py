"""Time of one evaluation and one Newton iteration of the small-strain FE (issue 36): the numpy
path of today (``ContactSolver``) against the compiled kernels (``CompiledSmallStrainSolver``,
``kernels="compiled"``) on the reference grain, sized for 0 -> 6000 N (the yield mesh rule), at a
plastic state of its loading.

The evaluation is what the engine computes at an iterate before the linear algebra: strains,
the return mapping with its consistent tangent, the internal force and the element matrices
(numpy: ``_response`` then ``element_matrices``; compiled: one ``_response``). The iteration
adds the assembly of the bordered system of the contact set, its CHOLMOD factorisation and the
solve (``_fast_step``), as ``ContactSolver._iterate`` does once per Newton iteration. Both paths
are timed alternately in the same process on one core (bench_fem_kernels.interleaved: median
CPU time of rounds that take every path in turn; the machine is shared, so CPU time, not wall
time), and their Newton steps compared."""

from __future__ import annotations

import os

os.environ.setdefault("OMP_NUM_THREADS", "1")  # before BLAS loads: one core
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402
from bench_fem_kernels import interleaved  # noqa: E402
from common import record  # noqa: E402

from geocontact.fem.compiled import CompiledSmallStrainSolver  # noqa: E402
from geocontact.fem.run import _advance, history_mesh, load_schedule  # noqa: E402
from geocontact.fem.solver import ContactSolver  # noqa: E402
from geocontact.grain.hertz import incipient_yield  # noqa: E402
from geocontact.grain.material import preset  # noqa: E402

MATERIAL = "reference"
PEAK_N = 6000.0


def problem(load_steps: int, mesh: str):
    """The mesh, a converged plastic state after ``load_steps`` steps of the 0 -> 6000 N
    schedule and the one before it (solved on the numpy path)."""
    material = preset(MATERIAL)
    fe_mesh = history_mesh(material, PEAK_N, mesh, rule="yield")
    solver = ContactSolver(material, fe_mesh, force_scale=PEAK_N)
    targets, _ = load_schedule([0.0, PEAK_N], 24, float(incipient_yield(material).force))
    previous = state = solver.initial_state()
    for step, target in enumerate(targets[1:load_steps + 1], start=1):
        previous, state = state, _advance(solver, state, target, step)
    return material, fe_mesh, previous, state


def newton_iteration(solver, old, state):
    """The evaluation and the whole Newton iteration at an iterate 2 % past the converged
    increment old -> state (its residual far above round-off), and the Newton step."""
    u = old.displacement + 1.02 * (state.displacement - old.displacement)
    active = state.active
    free = solver._reduced(active).free
    prescribed = np.zeros(solver.ndofs)

    def evaluate():
        response = solver._response(old, u, elastic=False)
        return response[4], solver.element_matrices(response[5])

    def iteration():
        response = solver._response(old, u, elastic=False)
        f_int = response[4]
        r_top = -np.sum(f_int[solver.top_dofs]) - state.force
        return solver._fast_step(response[5], active, prescribed, f_int[free], r_top, False)

    return {"evaluation": evaluate, "iteration": iteration}, iteration()


def main(mesh: str = "default", load_steps: int = 12, repeats: int = 9) -> dict:
    material, fe_mesh, old, state = problem(load_steps, mesh)
    paths = {"numpy": ContactSolver(material, fe_mesh, force_scale=PEAK_N),
             "compiled": CompiledSmallStrainSolver(material, fe_mesh, force_scale=PEAK_N)}
    n, elements = paths["numpy"].ndofs, paths["numpy"].dvolume.shape[0]
    print(f"{MATERIAL}, {mesh} mesh (0 -> {PEAK_N:g} N): {elements} elements, {n} unknowns; "
          f"state after {load_steps} load steps ({state.force:.4g} N, "
          f"{np.count_nonzero(state.eqps)} plastic points)")
    work, steps = {}, {}
    for path, solver in paths.items():
        parts, steps[path] = newton_iteration(solver, old, state)
        work.update({(path, part): run for part, run in parts.items()})
    measured = interleaved(work, repeats)
    rows = {path: {"evaluation_cpu_ms": measured[(path, "evaluation")][0],
                   "iteration_cpu_ms": measured[(path, "iteration")][0],
                   "least_evaluation_cpu_ms": measured[(path, "evaluation")][1],
                   "least_iteration_cpu_ms": measured[(path, "iteration")][1]}
            for path in paths}
    difference = float(np.linalg.norm(steps["compiled"] - steps["numpy"])
                       / np.linalg.norm(steps["numpy"]))
    for path, row in rows.items():
        print(f"  {path:9s} evaluation {row['evaluation_cpu_ms']:7.2f} ms, iteration "
              f"{row['iteration_cpu_ms']:7.2f} ms CPU (least {row['least_evaluation_cpu_ms']:.2f}"
              f" / {row['least_iteration_cpu_ms']:.2f})")
    print(f"  Newton steps within {difference:.1e} of each other")
    fast, today = rows["compiled"], rows["numpy"]
    common = {"unknowns": n, "elements": elements, "load_steps": load_steps,
              "force_N": state.force, "repeats": repeats, "numpy_path": today,
              "compiled": fast, "step_difference": difference,
              "load_average": os.getloadavg()[0]}
    record(f"fem_evaluation_small_{mesh}", fast["evaluation_cpu_ms"], "ms",
           "numpy path, same run", today["evaluation_cpu_ms"],
           ratio=fast["evaluation_cpu_ms"] / today["evaluation_cpu_ms"], **common,
           note=(f"{n} unknowns, median CPU of one evaluation (strains, return mapping, "
                 "internal force, element matrices): compiled vs numpy"))
    return record(f"fem_newton_iteration_small_{mesh}", fast["iteration_cpu_ms"], "ms",
                  "numpy path, same run", today["iteration_cpu_ms"],
                  ratio=fast["iteration_cpu_ms"] / today["iteration_cpu_ms"], **common,
                  note=(f"{n} unknowns, median CPU per Newton iteration (evaluation, assembly, "
                        "CHOLMOD, solve): compiled kernels vs numpy path"))


if __name__ == "__main__":
    main()
