"""The FE reference cycle (issue 3 speed goal): E = 10 GPa, nu = 0.25, sigma_c = 10 MPa,
beta = 30 deg, m = 0, R = 0.1 m, 0 -> 6000 N -> 0 on the `default` mesh, wall and CPU time.

CalculiX has no Drucker-Prager material, so this run has no code peer: its reference is the
issue's budget of 60 s wall on this 2-core machine (ratio = wall time / 60 s; <= 1 meets it).
The code peer is the von Mises problem of bench_ccx.py.
"""

from __future__ import annotations

import time

from common import record

from geocontact.fem.run import run_history
from geocontact.material import preset

BUDGET_S = 60.0


def main(mesh: str = "default") -> dict:
    material = preset("reference")
    wall0, cpu0 = time.perf_counter(), time.process_time()
    result = run_history(material, [0.0, 6000.0, 0.0], mesh=mesh, write_fields=False)
    wall, cpu = time.perf_counter() - wall0, time.process_time() - cpu0
    s = result.summary
    cycle = s["cycles"][0]
    return record(
        f"fem_reference_cycle_{mesh}", wall, "s", "issue-3 budget", BUDGET_S,
        ratio=wall / BUDGET_S, cpu_s=cpu, steps=s["steps"],
        newton_iterations=s["newton_iterations"], mesh=s["mesh"],
        max_approach_m=cycle["max_approach_m"], residual_approach_m=cycle["residual_approach_m"],
        plastic_work_J=cycle["plastic_work_J"], first_yield_force_N=s["first_yield_force_N"],
        fully_plastic_force_N=s["fully_plastic_force_N"],
        note=f"0->6000->0 N, {s['mesh']['elements']} elements, CPU {cpu:.1f} s",
    )
