"""Measures of a staircase in an FE loading curve (issue 15; scripts/measure_staircase.py).

A node-to-flat contact grows one surface node at a time; between two engagements the flattened
contact of a weak grain sits near its limit load (F flat in delta), then the next node touches.
Under force control the recorded points lie on the risers, and a run with other load steps
samples other risers. Two measures, on the loading branch above a force floor:

- ``force_gap``: |F_a / F_b - 1| of two runs at the same approach (each curve interpolated
  linearly in ln F - ln delta at the approaches of the other, both ways), max and RMS;
- ``slope_measures``: the local log-slope s_k = d ln F / d ln delta between consecutive steps,
  its largest jump |s_k+1 - s_k| and total variation sum |s_k+1 - s_k|: a smooth
  power-law-like curve has a slowly drifting s (total variation about the change of the
  exponent, < 1 over the range), a staircase alternates between plateaus (s ~ 0) and risers
  (s >> 2).
"""

from __future__ import annotations

import itertools

import numpy as np


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


__all__ = ["force_gap", "loading_branch", "log_slopes", "slope_measures", "staircase_measures"]
