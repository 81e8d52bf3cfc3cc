"""One load step of the weak grain's flattening, split into sub-steps (issue 15, part 1).

The weak grain (sigma_c = 1 MPa) 0 -> 3000 N on the coarse mesh, 12 steps per segment; from the
converged state at ~1060 N the next load step (to ~1340 N) is solved

1. from three starting points of Newton (the solution scaled by 0.98 and 1.02 from the old
   state, and from the old contact set): is the incremental solution unique?
2. in 1, 2, 4 and 8 equal sub-steps: how much does the end state depend on the load path?

    PYTHONPATH=src nice -n 5 .venv/bin/python scripts/probe_step_path.py   # ~1 min

Prints the approach, contact radius, contact nodes and the dissipation of each (docs/fem.md,
"The staircase of a growing contact").
"""

from __future__ import annotations

import argparse

import numpy as np

from geocontact.errors import ConvergenceError
from geocontact.fem.run import run_history
from geocontact.grain.material import preset


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--mesh-rule", default="yield", help="fem mesh rule (run_history)")
    ap.add_argument("--parts", type=int, nargs="+", default=[1, 2, 4, 8])
    args = ap.parse_args()
    material = preset("reference-weak")
    result = run_history(material, [0.0, 3000.0], mesh="coarse", steps_per_segment=12,
                         write_fields=False, keep_states=True, mesh_rule=args.mesh_rule,
                         step_control="fixed")  # the fixed steps it probes
    solver, states, force = result.solver, result.states, result.curve["force_N"]
    k = int(np.searchsorted(force, 1000.0))
    old, target = states[k], float(force[k + 1])
    print(f"load step {old.force:.1f} -> {target:.1f} N")
    one = solver.solve_step(old, target)

    for label, scale, active in (("0.98 x the solution", 0.98, one.active),
                                 ("1.02 x the solution", 1.02, one.active),
                                 ("0.9 x, old contact set", 0.9, old.active)):
        u = old.displacement + scale * (one.displacement - old.displacement)
        w = old.top_displacement + scale * (one.top_displacement - old.top_displacement)
        try:
            other = solver._iterate(old, target, u, w, active.copy(), elastic=False,
                                    label="", final=True)[3]
        except ConvergenceError as exc:
            print(f"start {label}: no convergence ({str(exc)[:60]}...)")
            continue
        print(f"start {label}: approach {other.top_displacement / one.top_displacement - 1:+.1e}"
              f", eqps {np.max(np.abs(other.eqps - one.eqps)):.1e} from the first solution")

    for parts in args.parts:
        state = old
        for j in range(1, parts + 1):
            state = solver.solve_step(state, old.force + j * (target - old.force) / parts)
        change = state.top_displacement / one.top_displacement - 1
        radius = solver.contact_radius(state) * 1e3
        print(f"{parts} sub-step(s): approach {change:+.3f}, contact radius {radius:.3f} mm, "
              f"{int(state.active.sum())} contact nodes, dissipation of the step "
              f"{2 * (state.plastic_dissipation - old.plastic_dissipation):.4f} J (pair)")


if __name__ == "__main__":
    main()
