"""The FE reference cycle (issue 3 speed goal): E = 10 GPa, nu = 0.25, sigma_c = 10 MPa,
beta = 30 deg, m = 0, R = 0.1 m, 0 -> 6000 N -> 0 on the `default` mesh, wall and CPU time.

CalculiX has no Drucker-Prager material, so this run has no code peer: its reference is the
issue's budget of 60 s wall on this 2-core machine (ratio = wall time / 60 s; <= 1 meets it).
The code peer is the von Mises problem of bench_ccx.py.

Issue 12 (FE runs per hour): the same cycle also on the solver's reference linear-algebra path
(``linear_solver="reference"``, the path before issue 12) in the same run, with the largest
relative differences of the force-approach curve, residual approach and plastic work between the
two (goal: >= 2x the runs per hour at <= 0.2 %).
"""

from __future__ import annotations

from common import record

from geocontact.fem.solver_comparison import ACCURACY, compare_linear_solvers
from geocontact.grain.material import preset

BUDGET_S = 60.0


def main(mesh: str = "default") -> dict:
    material = preset("reference")
    # the "yield" mesh and fixed steps (the defaults before issue 36): the series of this
    # benchmark and its budget; the same cycle on today's defaults ("auto": contact-dense, and
    # the adaptive control) is case (a) of docs/fem.md's verification, 631 s of CPU
    report = compare_linear_solvers(material, [0.0, 6000.0, 0.0], mesh=mesh, mesh_rule="yield",
                                    step_control="fixed")
    fast, reference = report["paths"]["fast"], report["paths"]["reference"]
    wall, cpu = fast["wall_time_s"], fast["cpu_time_s"]
    s = fast["summary"]
    cycle = s["cycles"][0]
    document = record(
        f"fem_reference_cycle_{mesh}", wall, "s", "issue-3 budget", BUDGET_S,
        ratio=wall / BUDGET_S, cpu_s=cpu, steps=s["steps"],
        newton_iterations=s["newton_iterations"], mesh=s["mesh"],
        max_approach_m=cycle["max_approach_m"], residual_approach_m=cycle["residual_approach_m"],
        plastic_work_J=cycle["plastic_work_J"], first_yield_force_N=s["first_yield_force_N"],
        fully_plastic_force_N=s["fully_plastic_force_N"],
        note=f"0->6000->0 N, {s['mesh']['elements']} elements, CPU {cpu:.1f} s",
    )
    per_hour = {name: 3600.0 / run["wall_time_s"] for name, run in report["paths"].items()}
    record(
        f"fem_runs_per_hour_{mesh}", per_hour["fast"], "runs/h",
        "reference linear-algebra path (before issue 12), same run", per_hour["reference"],
        ratio=fast["wall_time_s"] / reference["wall_time_s"],
        speedup=report["speedup"], factoriser=report["factoriser"],
        paths={name: {k: v for k, v in run.items() if k != "summary"}
               for name, run in report["paths"].items()},
        max_relative_difference=report["max_relative_difference"], accuracy_goal=ACCURACY,
        within_accuracy=report["within_accuracy"],
        goal="runs per hour >= 2x the reference path at <= 0.2 % difference",
        note=(f"0->6000->0 N, {report['elements']} elements; wall {wall:.1f} s vs "
              f"{reference['wall_time_s']:.1f} s"),
    )
    return document


def main_finite(mesh: str = "default") -> dict:
    """The reference cycle in finite strain (``kinematics="finite"``, issue 15) against the
    same cycle in small strain, run one after the other on the same mesh; with the finite/small
    differences of the results (at a/R = 0.06 they should be a fraction of a per cent)."""
    import time

    from geocontact.fem.run import run_history

    material = preset("reference")
    runs = {}
    for kinematics in ("small", "finite"):
        wall0, cpu0 = time.perf_counter(), time.process_time()
        result = run_history(material, [0.0, 6000.0, 0.0], mesh=mesh, write_fields=False,
                             kinematics=kinematics, mesh_rule="yield", step_control="fixed")
        s = result.summary
        runs[kinematics] = {"wall_time_s": time.perf_counter() - wall0,
                            "cpu_time_s": time.process_time() - cpu0, "steps": s["steps"],
                            "newton_iterations": s["newton_iterations"],
                            "cycle": s["cycles"][0],
                            "first_yield_force_N": s["first_yield_force_N"]}
    small, finite = runs["small"], runs["finite"]
    difference = {q: finite["cycle"][q] / small["cycle"][q] - 1.0
                  for q in ("max_approach_m", "residual_approach_m", "plastic_work_J")}
    return record(
        f"fem_reference_cycle_finite_{mesh}", finite["wall_time_s"], "s",
        "the same cycle in small strain, same run", small["wall_time_s"],
        ratio=finite["wall_time_s"] / small["wall_time_s"],
        cpu_time_ratio=finite["cpu_time_s"] / small["cpu_time_s"], runs=runs,
        finite_over_small_minus_1=difference, mesh=mesh,
        note=(f"0->6000->0 N; CPU {finite['cpu_time_s']:.1f} vs {small['cpu_time_s']:.1f} s, "
              f"Newton {finite['newton_iterations']} vs {small['newton_iterations']}; finite/small"
              f" - 1: max approach {100 * difference['max_approach_m']:+.2f} %, residual "
              f"{100 * difference['residual_approach_m']:+.2f} %"),
    )
