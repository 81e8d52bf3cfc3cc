"""The staircase of the weak grain's FE loading curve (issue 15, part 1).

On sigma_c = 1 MPa (``reference-weak``) loaded 0 -> 6000 N the contact grows to a/R ~ 0.15-0.3
and, with a node-to-flat contact, the contact radius can only move one surface node at a time:
between two engagements the flattened contact sits near its limit load (a plateau in F), then
the next node touches (a riser). Under force control the recorded points lie on the risers; a run
with other load steps samples other risers, so two step counts disagree at the same approach.

Measures (``staircase_measures``), on the loading curve above ``--floor`` x Fy:

- ``force_gap_max`` / ``force_gap_rms``: |F_a / F_b - 1| of two runs at the same approach
  (each curve interpolated linearly in ln F - ln delta at the approaches of the other, both
  directions), the issue's "24 vs 48 steps per segment agree within 1 % in force";
- ``slope_jump_max`` and ``slope_total_variation`` of the local log-slope
  s_k = d ln F / d ln delta between consecutive steps: a smooth power-law-like curve has a slowly
  drifting s (total variation ~ the change of the exponent, < 1 over the range), a staircase
  alternates between plateaus (s ~ 0) and risers (s >> 2).

    PYTHONPATH=src nice -n 5 .venv/bin/python scripts/measure_staircase.py --mesh coarse \
        --steps 24 48 --out out/staircase

Each run is a resumable FE result directory under ``--out`` (``run_history(resume=True)``);
the table of measures is printed and written to ``<out>/staircase.json``.
"""

from __future__ import annotations

import argparse
import itertools
import json
import time
from pathlib import Path

import numpy as np

from geocontact.io import write_json_atomic
from geocontact.material import load_material

FORCE = 6000.0


def loading_branch(curve: dict[str, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """(approach, force) of the loading steps with F > 0 (monotonic part of the curve)."""
    force, approach = np.asarray(curve["force_N"]), np.asarray(curve["approach_m"])
    keep = [0]
    for k in range(1, len(force)):
        if force[k] > force[keep[-1]]:
            keep.append(k)
    keep = np.array(keep)
    keep = keep[force[keep] > 0.0]
    return approach[keep], force[keep]


def log_slopes(approach: np.ndarray, force: np.ndarray) -> np.ndarray:
    """Local log-slope d ln F / d ln delta between consecutive points."""
    return np.diff(np.log(force)) / np.diff(np.log(approach))


def _interp_loglog(x_new, x, y):
    return np.exp(np.interp(np.log(x_new), np.log(x), np.log(y)))


def force_gap(a: tuple[np.ndarray, np.ndarray], b: tuple[np.ndarray, np.ndarray],
              floor_force: float) -> tuple[float, float]:
    """(max, rms) of |F_a/F_b - 1| at the same approach, both ways, where both curves exist and
    F > ``floor_force``."""
    gaps = []
    for (xa, fa), (xb, fb) in ((a, b), (b, a)):
        lo, hi = max(xa[0], xb[0]), min(xa[-1], xb[-1])
        sel = (xa >= lo) & (xa <= hi) & (fa > floor_force)
        if np.any(sel):
            gaps.append(fa[sel] / _interp_loglog(xa[sel], xb, fb) - 1.0)
    if not gaps:
        return float("nan"), float("nan")
    g = np.concatenate(gaps)
    return float(np.max(np.abs(g))), float(np.sqrt(np.mean(g**2)))


def slope_measures(approach: np.ndarray, force: np.ndarray,
                   floor_force: float) -> dict[str, float]:
    sel = force > floor_force
    x, f = approach[sel], force[sel]
    if len(x) < 3:
        return {"slope_jump_max": float("nan"), "slope_total_variation": float("nan"),
                "slope_min": float("nan"), "slope_max": float("nan"), "points": int(len(x))}
    s = log_slopes(x, f)
    jumps = np.abs(np.diff(s))
    return {"slope_jump_max": float(np.max(jumps)), "slope_total_variation": float(np.sum(jumps)),
            "slope_min": float(np.min(s)), "slope_max": float(np.max(s)), "points": int(len(x))}


def staircase_measures(curves: dict[str, dict], yield_force: float, floor: float) -> dict:
    """Per run: the log-slope measures; per pair of runs: the force gap."""
    floor_force = floor * yield_force
    branches = {name: loading_branch(c) for name, c in curves.items()}
    out = {"floor_force_N": floor_force, "runs": {}, "pairs": {}}
    for name, (x, f) in branches.items():
        out["runs"][name] = slope_measures(x, f, floor_force)
    for p, q in itertools.combinations(branches, 2):
        gmax, grms = force_gap(branches[p], branches[q], floor_force)
        out["pairs"][f"{p} vs {q}"] = {"force_gap_max": gmax, "force_gap_rms": grms}
    return out


def main() -> None:
    from geocontact.fem.run import run_history

    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--material", default="reference-weak")
    ap.add_argument("--mesh", default="coarse")
    ap.add_argument("--mesh-rule", default="yield", help="fem mesh rule (run_history)")
    ap.add_argument("--step-rule", default="segment", help="fem step rule (run_history)")
    ap.add_argument("--steps", type=int, nargs="+", default=[24, 48])
    ap.add_argument("--force", type=float, default=FORCE)
    ap.add_argument("--floor", type=float, default=10.0, help="lowest force, x Fy")
    ap.add_argument("--out", required=True)
    args = ap.parse_args()

    material = load_material(args.material)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    curves, runs = {}, {}
    fy = None
    for n in args.steps:
        name = f"{args.mesh}-{args.mesh_rule}-{args.step_rule}-{n}"
        started = time.perf_counter()
        result = run_history(material, [0.0, args.force], args.mesh, out / name,
                             steps_per_segment=n, resume=True, write_fields=False,
                             mesh_rule=args.mesh_rule, step_rule=args.step_rule)
        curves[f"{n} steps"] = result.curve
        fy = fy or result.summary["first_yield_force_N"]
        runs[f"{n} steps"] = {"elements": result.summary["mesh"]["elements"],
                              "wall_time_s": result.summary["wall_time_s"],
                              "this_call_s": time.perf_counter() - started,
                              "steps": result.summary["steps"],
                              "contact_resolution": result.summary["contact_resolution"]}
    measures = staircase_measures(curves, fy, args.floor)
    measures.update({"material": args.material, "mesh": args.mesh, "mesh_rule": args.mesh_rule,
                     "step_rule": args.step_rule,
                     "force_N": args.force, "first_yield_force_N": fy, "cost": runs})
    write_json_atomic(out / f"staircase-{args.mesh}-{args.mesh_rule}-{args.step_rule}.json",
                      measures)
    print(json.dumps({k: measures[k] for k in ("runs", "pairs")}, indent=1))
    for name, r in runs.items():
        print(f"{name}: {r['elements']} elements, {r['wall_time_s']:.0f} s")


if __name__ == "__main__":
    main()
