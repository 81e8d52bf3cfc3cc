"""Measures of a staircase in an FE loading curve (issue 15; scripts/measure_staircase.py).

A node-to-flat contact grows one surface node at a time; between two engagements the flattened
contact of a weak grain sits near its limit load (F flat in delta), then the next node touches.
Under force control the recorded points lie on the risers, and a run with other load steps
samples other risers. Two measures, on the loading branch above a force floor:

- ``force_gap``: |F_a / F_b - 1| of two runs at the same approach (each curve interpolated
  linearly in ln F - ln delta at the approaches of the other, both ways), max and RMS;
- ``approach_gap``: |delta_a / delta_b - 1| at the forces both runs recorded (no interpolation
  over the risers), and ``gap_by_decade``: where along the curve the force gap is;
- ``slope_measures``: the local log-slope s_k = d ln F / d ln delta between consecutive steps,
  its largest jump |s_k+1 - s_k| and total variation sum |s_k+1 - s_k|: a smooth
  power-law-like curve has a slowly drifting s (total variation about the change of the
  exponent, < 1 over the range), a staircase alternates between plateaus (s ~ 0) and risers
  (s >> 2);
- ``bump_correlation``: where the bumps come from. The bump of a run is its ln delta less a
  smooth fit (a cubic in ln F) over the top ``BUMP_DECADES`` decades of its force (where the
  contact is large and the staircase shows, the 1e2-1e4 N of the weak grain); two runs whose
  bumps correlate at the forces both recorded have the same bumps (the spatial discretisation
  they share), two whose bumps do not have bumps of their own (the load steps, or
  discretisations that differ).
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


def force_gap_profile(a: tuple[np.ndarray, np.ndarray], b: tuple[np.ndarray, np.ndarray],
                      floor_force: float) -> tuple[np.ndarray, np.ndarray]:
    """(F, F_a/F_b - 1) at the same approach, both ways (at the points of a, then of b), where
    both curves exist and F > ``floor_force``."""
    forces, gaps = [np.empty(0)], [np.empty(0)]
    for (xa, fa), (xb, fb), sign in ((a, b, 1.0), (b, a, -1.0)):
        lo, hi = max(xa[0], xb[0]), min(xa[-1], xb[-1])
        sel = (xa >= lo) & (xa <= hi) & (fa > floor_force)
        forces.append(fa[sel])
        gaps.append(sign * (fa[sel] / _interp_loglog(xa[sel], xb, fb) - 1.0))
    return np.concatenate(forces), np.concatenate(gaps)


def force_gap(a: tuple[np.ndarray, np.ndarray], b: tuple[np.ndarray, np.ndarray],
              floor_force: float) -> tuple[float, float]:
    """(max, rms) of |F_a/F_b - 1| at the same approach, both ways, where both curves exist and
    F > ``floor_force``."""
    g = force_gap_profile(a, b, floor_force)[1]
    if not g.size:
        return float("nan"), float("nan")
    return float(np.max(np.abs(g))), float(np.sqrt(np.mean(g**2)))


def approach_gap(a: tuple[np.ndarray, np.ndarray], b: tuple[np.ndarray, np.ndarray],
                 floor_force: float) -> dict[str, float]:
    """|delta_a / delta_b - 1| at the forces both runs recorded (above ``floor_force``): no
    interpolation, so a riser of the node staircase sampled differently by the two runs does
    not count, only a different state at the same load. A schedule of 2n steps per segment
    holds those of n (``fem.run.load_schedule``), so 24 and 48 steps share about 40 forces."""
    (xa, fa), (xb, fb) = a, b
    j = np.clip(np.searchsorted(fb, fa), 0, len(fb) - 1)
    common = (np.abs(fb[j] / fa - 1.0) < 1e-9) & (fa > floor_force)
    if not np.any(common):
        return {"approach_gap_max": float("nan"), "approach_gap_rms": float("nan"),
                "common_forces": 0, "approach_gap_max_at_N": float("nan")}
    g = xa[common] / xb[j[common]] - 1.0
    k = int(np.argmax(np.abs(g)))
    return {"approach_gap_max": float(np.abs(g[k])), "approach_gap_rms": float(
        np.sqrt(np.mean(g**2))), "common_forces": int(common.sum()),
        "approach_gap_max_at_N": float(fa[common][k])}


def sampling_gap(a: tuple[np.ndarray, np.ndarray], b: tuple[np.ndarray, np.ndarray],
                 floor_force: float) -> tuple[float, float]:
    """The part of ``force_gap(a, b)`` that is sampling alone: the run with more points against
    itself kept only at the forces the other recorded (and below ``floor_force``). Two runs in
    the same state at every shared force still differ by this much in the force gap, from
    interpolating a curve with kinks (the risers of the node staircase) over fewer points."""
    (fine, coarse) = (a, b) if len(a[1]) >= len(b[1]) else (b, a)
    x, f = fine
    j = np.clip(np.searchsorted(coarse[1], f), 0, len(coarse[1]) - 1)
    keep = (np.abs(coarse[1][j] / f - 1.0) < 1e-9) | (f <= floor_force)
    if keep.sum() < 2 or keep.all():
        return float("nan"), float("nan")
    return force_gap(fine, (x[keep], f[keep]), floor_force)


def gap_by_decade(forces: np.ndarray, gaps: np.ndarray) -> dict[str, float]:
    """Largest |gap| per decade of force ("1e2-1e3": 100 N <= F < 1000 N)."""
    out = {}
    decades = np.floor(np.log10(forces)).astype(int)
    for d in np.unique(decades):
        out[f"1e{d}-1e{d + 1}"] = float(np.max(np.abs(gaps[decades == d])))
    return out


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


BUMP_FIT_DEGREE = 3  # the smooth curve the bumps are measured from: a cubic in ln F ...
BUMP_DECADES = 2.0  # ... over this many decades of force below the largest


def bumps(approach: np.ndarray, force: np.ndarray,
          floor_force: float) -> tuple[np.ndarray, np.ndarray]:
    """(F, ln delta less its least-squares cubic in ln F) at the points above ``floor_force``
    and within ``BUMP_DECADES`` decades of the largest force."""
    sel = (force > floor_force) & (force >= np.max(force) * 10.0 ** -BUMP_DECADES)
    lf, lx = np.log(force[sel]), np.log(approach[sel])
    if len(lf) <= BUMP_FIT_DEGREE + 1:
        return force[sel], np.full(len(lf), np.nan)
    return force[sel], lx - np.polyval(np.polyfit(lf, lx, BUMP_FIT_DEGREE), lf)


def _rms(values: np.ndarray) -> float:
    """Root mean square; NaN for no values."""
    return float(np.sqrt(np.mean(values**2))) if values.size else float("nan")


def bump_correlation(a: tuple[np.ndarray, np.ndarray], b: tuple[np.ndarray, np.ndarray],
                     floor_force: float) -> dict[str, float]:
    """The two runs' bumps (``bumps``, each about its own fit) at the forces both recorded:
    their correlation, the RMS of each and of their difference (in ln delta)."""
    fa, ra = bumps(*a, floor_force)
    fb, rb = bumps(*b, floor_force)
    j = np.clip(np.searchsorted(fb, fa), 0, max(len(fb) - 1, 0))
    common = (np.abs(fb[j] / fa - 1.0) < 1e-9) if len(fb) else np.zeros(len(fa), bool)
    x, y = ra[common], rb[j[common]]
    if len(x) < 3 or not (np.all(np.isfinite(x)) and np.all(np.isfinite(y))):
        nan = float("nan")
        return {"bump_correlation": nan, "bump_rms_a": nan, "bump_rms_b": nan,
                "bump_rms_difference": nan, "bump_forces": int(len(x))}
    return {"bump_correlation": float(np.corrcoef(x, y)[0, 1]),
            "bump_rms_a": _rms(x), "bump_rms_b": _rms(y), "bump_rms_difference": _rms(x - y),
            "bump_forces": int(len(x))}


def staircase_measures(curves: dict[str, dict], yield_force: float, floor: float) -> dict:
    """Per run: the log-slope measures; per pair of runs: the force gap."""
    floor_force = floor * yield_force
    branches = {name: loading_branch(c) for name, c in curves.items()}
    out = {"floor_force_N": floor_force, "runs": {}, "pairs": {}}
    for name, (x, f) in branches.items():
        out["runs"][name] = slope_measures(x, f, floor_force)
        out["runs"][name]["bump_rms"] = _rms(bumps(x, f, floor_force)[1])
    for p, q in itertools.combinations(branches, 2):
        gmax, grms = force_gap(branches[p], branches[q], floor_force)
        pair = {"force_gap_max": gmax, "force_gap_rms": grms,
                "force_gap_max_by_decade": gap_by_decade(
                    *force_gap_profile(branches[p], branches[q], floor_force))}
        pair.update(approach_gap(branches[p], branches[q], floor_force))
        pair["sampling_gap_max"], pair["sampling_gap_rms"] = sampling_gap(
            branches[p], branches[q], floor_force)
        pair.update(bump_correlation(branches[p], branches[q], floor_force))
        out["pairs"][f"{p} vs {q}"] = pair
    return out


__all__ = ["BUMP_DECADES", "BUMP_FIT_DEGREE", "approach_gap", "bump_correlation", "bumps",
           "force_gap", "force_gap_profile", "gap_by_decade", "loading_branch", "log_slopes",
           "sampling_gap", "slope_measures", "staircase_measures"]
