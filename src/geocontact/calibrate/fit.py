"""Fit the law's parameters (SPEC section 7, docs/law.md forms) to load-unload-reload cycles.

Input: the virgin loading curve and, for each peak level, the unloading and reloading curves with
the peak, the residual approach and the plastic work of the cycle (from FE runs, or experiments).
Every fit is a least-squares problem in the form's natural coordinates; each reports its RMS
error so a calibration file carries how well it describes the data it came from.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import curve_fit

from ..errors import InputError
from ..law.params import HERTZ_EXPONENT, LawParams
from ..material import Material


@dataclass
class LevelData:
    """One load-unload-reload cycle to a peak (ball-ball approach, pair energies)."""

    max_approach: float
    max_force: float
    residual_approach: float
    plastic_work: float
    total_work: float
    unloading_approach: np.ndarray
    unloading_force: np.ndarray
    reloading_approach: np.ndarray
    reloading_force: np.ndarray


def _power_exponent(approach, force, base, peak_approach, peak_force, keep=(0.02, 0.98)):
    """Exponent n of F/Fmax = ((d - base)/(dmax - base))^n, by least squares in log space over
    the part of the curve between keep[0] and keep[1] of the peak force (the ends are where
    contact detection and the peak's rounding live)."""
    t = (np.asarray(approach) - base) / (peak_approach - base)
    f = np.asarray(force) / peak_force
    use = (f > keep[0]) & (f < keep[1]) & (t > 0) & (t < 1)
    if use.sum() < 3:
        raise InputError("calibration: a curve has fewer than 3 points between 2 % and 98 % "
                         "of its peak force; refine the FE output")
    lt, lf = np.log(t[use]), np.log(f[use])
    n = float(np.dot(lt, lf) / np.dot(lt, lt))
    rms = float(np.sqrt(np.mean((t[use] ** n - f[use]) ** 2)))
    return n, rms


def fit_loading(approach, force, yield_approach, hertz_coefficient):
    """n1, delta_p/delta_y, n2 of the three-regime virgin curve (continuous at dy and dp).

    For each candidate delta_p on a log grid, n1 and n2 are linear least-squares problems in
    log space (anchored at the yield point and at delta_p); the best delta_p wins."""
    d = np.asarray(approach, dtype=float)
    f = np.asarray(force, dtype=float)
    dy = yield_approach
    fy = hertz_coefficient * dy**HERTZ_EXPONENT
    use = (d > 1.05 * dy) & (f > 0)
    if use.sum() < 5:
        raise InputError("calibration: the loading curve needs >= 5 points beyond yield")
    x, y = np.log(d[use] / dy), np.log(f[use] / fy)
    best = None
    for ratio in np.geomspace(1.5, max(2.0, 0.95 * np.exp(x.max())), 120):
        lp = np.log(ratio)
        a, b = x <= lp, x > lp
        n1 = float(np.dot(x[a], y[a]) / np.dot(x[a], x[a])) if a.sum() >= 2 else 1.5
        yp = n1 * lp
        n2 = (float(np.dot(x[b] - lp, y[b] - yp) / np.dot(x[b] - lp, x[b] - lp))
              if b.sum() >= 2 else n1)
        model = np.where(a, n1 * x, yp + n2 * (x - lp))
        err = float(np.sqrt(np.mean((np.exp(model) - np.exp(y)) ** 2 / np.exp(2 * y))))
        if best is None or err < best[0]:
            best = (err, n1, ratio, n2)
    err, n1, ratio, n2 = best
    return {"elastic_plastic_exponent": n1, "fully_plastic_approach_ratio": float(ratio),
            "fully_plastic_exponent": n2, "rms_relative_error": err}


def _power_of_depth(depth, exponents):
    """p of n = 1.5 x^p through x = 1 (log-space least squares)."""
    lx = np.log(depth)
    ly = np.log(np.asarray(exponents) / HERTZ_EXPONENT)
    p = float(np.dot(lx, ly) / np.dot(lx, lx))
    rms = float(np.sqrt(np.mean((HERTZ_EXPONENT * depth**p - exponents) ** 2)))
    return p, rms


def _saturating(depth, values, what):
    """limit, power of values = limit (1 - x^-power)."""

    def form(x, limit, power):
        return limit * (1.0 - x ** (-power))

    try:
        (limit, power), _ = curve_fit(form, depth, values, p0=(0.8, 0.3),
                                      bounds=([0.0, 1e-3], [0.999, 10.0]))
    except RuntimeError:
        raise InputError(f"calibration: the {what} fit did not converge") from None
    rms = float(np.sqrt(np.mean((form(depth, limit, power) - values) ** 2)))
    return float(limit), float(power), rms


def fit_law(material: Material, yield_approach: float, loading_approach, loading_force,
            levels: list[LevelData], provenance: dict | None = None) -> LawParams:
    """Every parameter of the law from FE (or test) cycles; returns validated LawParams."""
    if len(levels) < 3:
        raise InputError(f"calibration: needs >= 3 load levels, got {len(levels)}")
    kh = 4.0 / 3.0 * material.effective_modulus * np.sqrt(material.effective_radius)
    loading = fit_loading(loading_approach, loading_force, yield_approach, kh)
    depth = np.array([lv.max_approach / yield_approach for lv in levels])
    if np.any(depth <= 1.0):
        raise InputError("calibration: every level must go past yield (delta_max > delta_y)")
    n_u, n_r, err_u, err_r = [], [], [], []
    for lv in levels:
        n, e = _power_exponent(lv.unloading_approach, lv.unloading_force, lv.residual_approach,
                               lv.max_approach, lv.max_force)
        n_u.append(n)
        err_u.append(e)
        n, e = _power_exponent(lv.reloading_approach, lv.reloading_force, lv.residual_approach,
                               lv.max_approach, lv.max_force)
        n_r.append(n)
        err_r.append(e)
    p_u, rms_nu = _power_of_depth(depth, np.array(n_u))
    p_r, rms_nr = _power_of_depth(depth, np.array(n_r))
    residual = np.array([lv.residual_approach / lv.max_approach for lv in levels])
    rho, s, rms_res = _saturating(depth, residual, "residual approach")
    work = np.array([lv.plastic_work / lv.total_work for lv in levels])
    w_lim, w_pow, rms_w = _saturating(depth, work, "plastic work")
    fit_errors = {
        "loading_rms_relative": loading.pop("rms_relative_error"),
        "unloading_curve_rms_of_peak": float(np.sqrt(np.mean(np.square(err_u)))),
        "reloading_curve_rms_of_peak": float(np.sqrt(np.mean(np.square(err_r)))),
        "unloading_exponent_rms": rms_nu,
        "reloading_exponent_rms": rms_nr,
        "residual_ratio_rms": rms_res,
        "plastic_work_ratio_rms": rms_w,
        "per_level": [{"depth": float(x), "unloading_exponent": a, "reloading_exponent": b,
                       "residual_ratio": float(r), "plastic_work_ratio": float(w)}
                      for x, a, b, r, w in zip(depth, n_u, n_r, residual, work, strict=True)],
    }
    return LawParams(
        material=material,
        yield_approach=yield_approach,
        unloading_power=p_u,
        reloading_power=p_r,
        residual_limit=rho,
        residual_power=s,
        plastic_work_limit=w_lim,
        plastic_work_power=w_pow,
        fit_errors=fit_errors,
        provenance=dict(provenance or {}),
        label="calibrated",
        **loading,
    )
