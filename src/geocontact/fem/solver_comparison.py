"""The two linear-algebra paths of the FE solver run side by side (issue 12).

:func:`compare_linear_solvers` runs one force history with ``linear_solver="reference"`` (the
earlier path: global CSR, slicing, SuperLU at every Newton iteration) and with the default
``"fast"`` path in the same process, and reports the wall time of each, the factorisations, and
the largest relative differences of the results the law is fitted to: the force-approach curve
(approach at every step, relative to the largest approach), the residual approach and the plastic
work of every cycle. The accuracy goal of issue 12 is 0.2 % (``ACCURACY``).
"""

from __future__ import annotations

import time

import numpy as np

from ..grain.material import Material
from .run import run_history
from .solver import LINEAR_SOLVERS

ACCURACY = 2e-3  # issue 12: same curves within 0.2 %


def _relative(new: float | None, old: float | None, scale: float) -> float:
    if new is None or old is None:
        return 0.0 if new is None and old is None else float("inf")
    return abs(new - old) / scale


def compare_linear_solvers(material: Material, forces, mesh: str = "coarse",
                           **run_options) -> dict:
    """Run ``forces`` on both paths (reference first) and compare; ``run_options`` go to
    :func:`geocontact.fem.run.run_history` (``write_fields`` is off)."""
    runs = {}
    for name in ("reference", "fast"):
        started, cpu = time.perf_counter(), time.process_time()
        result = run_history(material, forces, mesh=mesh, write_fields=False,
                             linear_solver=name, **run_options)
        runs[name] = {"result": result, "wall_time_s": time.perf_counter() - started,
                      "cpu_time_s": time.process_time() - cpu, "summary": result.summary,
                      "factorisations": result.solver.factorisations,
                      "newton_iterations": result.summary["newton_iterations"],
                      "steps": result.summary["steps"]}
    old, new = runs["reference"]["result"], runs["fast"]["result"]
    a_old = np.asarray(old.curve["approach_m"], float)
    a_new = np.asarray(new.curve["approach_m"], float)
    f_old = np.asarray(old.curve["force_N"], float)
    f_new = np.asarray(new.curve["force_N"], float)
    # the schedule places steps at the predicted first-yield force (an elastic solve): the two
    # paths agree on it to round-off
    if a_old.shape != a_new.shape or not np.allclose(f_old, f_new, rtol=1e-9, atol=0.0):
        raise AssertionError("the two paths ran different load schedules "
                             f"({len(a_old)} and {len(a_new)} steps)")
    scale = float(np.max(np.abs(a_old)))
    differences = {"approach": float(np.max(np.abs(a_new - a_old)) / scale)}
    residual, work = 0.0, 0.0
    for c_old, c_new in zip(old.summary["cycles"], new.summary["cycles"], strict=True):
        residual = max(residual, _relative(c_new["residual_approach_m"],
                                           c_old["residual_approach_m"], c_old["max_approach_m"]))
        work = max(work, _relative(c_new["plastic_work_J"], c_old["plastic_work_J"],
                                   abs(c_old["plastic_work_J"] or 1e-300)))
    differences["residual_approach"] = residual  # relative to the cycle's largest approach
    differences["plastic_work"] = work
    return {
        "mesh": mesh, "elements": old.summary["mesh"]["elements"], "forces_N": list(forces),
        "paths": {name: {k: v for k, v in run.items() if k != "result"}
                  for name, run in runs.items()},
        "speedup": runs["reference"]["wall_time_s"] / runs["fast"]["wall_time_s"],
        "max_relative_difference": differences,
        "within_accuracy": max(differences.values()) <= ACCURACY,
        "linear_solvers": list(LINEAR_SOLVERS),
        "factoriser": fast_factoriser(),
    }


def fast_factoriser() -> str:
    """Which factorisation the fast path uses on this machine."""
    try:
        import sksparse.cholmod  # noqa: F401
    except ImportError:
        return "SuperLU (scikit-sparse not installed)"
    from importlib.metadata import version
    return f"CHOLMOD (scikit-sparse {version('scikit-sparse')})"
