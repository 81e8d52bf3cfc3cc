"""The FE's unloading stiffness against Sneddon's S = 2 E* a: the factor the lab fit divides by.

E from the unloading stiffness (``identify.unloading_modulus``) rests on S = dF/d delta = 2 E* a
at the top of each unloading (Sneddon 1965; Pharr, Oliver & Brotzen 1992), which holds for an
elastic half-space. A sphere is not one: the ratio S / (2 E* a) the FE gives grows with the
contact's size, and Oliver & Pharr's own "beta" (S = 2 beta E* a) is their name for it. This
module measures that ratio in this project's committed FE runs (``datasets/fe-runs``), with the
lab route's own estimator (the slope at the peak of the unloading law fitted to the unloading,
``fit.unloading_law``; a the run's contact radius smoothed along its virgin loading, as the
master curve's is), and fits beta(a / R) = b0 + b1 (a / R) + b2 (a / R)^2 over every virgin peak
of every run (closed cycles only, as the lab route takes them).
``scripts/unloading_stiffness_factor.py`` writes the fit and its rows to
``geocontact/data/unloading-stiffness-factor.json``; ``factor`` reads it.
"""

from __future__ import annotations

import csv
import json
import math
from functools import lru_cache
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import InputError

FACTOR_FILE = "unloading-stiffness-factor.json"
DEGREE = 2          # beta(a/R): a quadratic in a/R (Sneddon's 1 at a/R -> 0 is not imposed)
NEW_PEAK = 1.01     # a cycle counts when its peak approach passes every earlier one by this
CLOSED = 0.1        # and when it unloads below this share of its peak force, as a lab cycle
                    # must (``curve``): a partial unloading's power law is another estimator


def _columns(folder: Path) -> dict[str, np.ndarray]:
    with (folder / "curve.csv").open() as handle:
        rows = list(csv.DictReader(handle))
    return {k: np.array([float(r[k]) for r in rows]) for k in
            ("force_N", "approach_m", "contact_radius_m")}


def run_factors(folder: Path) -> list[dict[str, Any]]:
    """S / (2 E* a) at each virgin peak of one FE run folder (``curve.csv``, ``summary.json``):
    S the slope at the peak of the unloading law fitted to the cycle's unloading, a the run's
    contact radius at the peak approach, smoothed in log-log along its virgin loading."""
    from .fit import Peak, unloading_law
    from .identify import RADIUS_SMOOTHING, _log_spline

    summary = json.loads((folder / "summary.json").read_text())
    material = summary["inputs"]["material"]
    c = _columns(folder)
    f, d, a = c["force_N"], c["approach_m"], c["contact_radius_m"]
    virgin = (d > np.maximum.accumulate(np.concatenate([[0.0], d[:-1]]))) & (a > 0) & (f > 0)
    if virgin.sum() < 6:
        return []
    _, _, spline = _log_spline(d[virgin], a[virgin], RADIUS_SMOOTHING)
    e_star = material["youngs_modulus"] / (2.0 * (1.0 - material["poissons_ratio"] ** 2))
    rows, deepest = [], 0.0
    for cycle in summary["cycles"]:
        lo, hi = cycle["steps"]
        k = lo + int(np.argmax(f[lo:hi + 1]))
        rises = np.flatnonzero(np.diff(f[k:hi + 1]) > 0)
        end = k + int(rises[0]) if rises.size else hi  # the unloading: up to a reversal
        if k >= end or f[k] <= 0 or d[k] < NEW_PEAK * deepest or f[end] > CLOSED * f[k]:
            continue
        deepest = d[k]
        unloading = slice(k, end + 1)
        try:
            dres, n, _ = unloading_law(d[unloading], f[unloading], Peak(d[k], f[k]))
        except InputError:  # an unloading too short for the law (a partial unload)
            continue
        radius = float(np.exp(spline(math.log(d[k]))))
        rows.append({"run": folder.name, "mesh": summary["inputs"].get("mesh"),
                     "kinematics": summary.get("kinematics", "small"),
                     "contact_radius_over_radius": radius / material["radius"],
                     "factor": n * f[k] / (d[k] - dres) / (2.0 * e_star * radius)})
    return rows


def measure(campaigns, runs=None) -> dict[str, Any]:
    """beta(a/R) fitted over every run of the FE campaign folders ``campaigns`` (each run once:
    a run committed to two campaigns is the same FE job), or over the run folders named in
    ``runs`` only (what a committed fit was made of: runs committed since do not change it)."""
    rows, seen = [], set()
    for campaign in campaigns:
        for summary in sorted(Path(campaign).glob("*/summary.json")):
            if summary.parent.name in seen or (runs is not None
                                               and summary.parent.name not in runs):
                continue
            seen.add(summary.parent.name)
            rows += [{**r, "campaign": Path(campaign).name} for r in run_factors(summary.parent)]
    if len(rows) < 3 * (DEGREE + 1):
        raise InputError(f"unloading stiffness factor: {len(rows)} FE unloadings found; need "
                         f">= {3 * (DEGREE + 1)}")
    x = np.array([r["contact_radius_over_radius"] for r in rows])
    y = np.array([r["factor"] for r in rows])
    coefficients = np.polynomial.polynomial.polyfit(x, y, DEGREE)
    residual = y - np.polynomial.polynomial.polyval(x, coefficients)
    return {"definition": "beta = S / (2 E* a) of this project's FE unloadings: S the slope at "
                          "the peak of the unloading law F = Fmax ((d - dres)/(dmax - dres))^n "
                          "fitted to each virgin peak's unloading, a the run's contact radius "
                          "smoothed along its virgin loading; beta(a/R) = sum_k b_k (a/R)^k, "
                          "least squares over every unloading",
            "coefficients": [float(v) for v in coefficients],
            "rms_residual": float(np.sqrt(np.mean(residual**2))),
            "contact_radius_over_radius_range": [float(x.min()), float(x.max())],
            "unloadings": len(rows), "runs": len({r["run"] for r in rows}),
            "campaigns": [Path(c).name for c in campaigns], "rows": rows}


@lru_cache(maxsize=1)
def _model() -> dict[str, Any]:
    text = (resources.files("geocontact") / "data" / FACTOR_FILE).read_text()
    return json.loads(text)


def factor(contact_radius_over_radius) -> np.ndarray:
    """beta(a/R) of the committed fit (``measure``), a/R clipped to the range the FE runs
    cover (beyond it the fit would extrapolate)."""
    model = _model()
    low, high = model["contact_radius_over_radius_range"]
    x = np.clip(np.asarray(contact_radius_over_radius, float), low, high)
    return np.polynomial.polynomial.polyval(x, model["coefficients"])


def scatter() -> float:
    """The RMS scatter of the FE unloadings about beta(a/R): the factor's own uncertainty."""
    return float(_model()["rms_residual"])
