"""Fit the law's parameters (docs/model.md §7, docs/law.md forms) to load-unload-reload cycles.

Input: the virgin loading curve and, for each peak level, the unloading and reloading curves with
the peak, the residual approach and the plastic work of the cycle (from FE runs, or experiments).
Every fit is a least-squares problem in the form's natural coordinates; each reports its RMS
error so a calibration file carries how well it describes the data it came from.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares

from .. import schema
from ..errors import InputError
from ..grain.hertz import hertz_coefficient
from ..grain.material import Material
from ..law.params import (
    HERTZ_EXPONENT,
    MAX_SEGMENTS,
    LawParams,
    LoadingSegments,
    saturating_ratio,
)
from ..law.residual_table import ResidualTable

# Upper bound of a saturating ratio's limit (the JSON allows [0, 1)).
MAX_LIMIT = 1.0 - 1e-9
# Ratios (residual approach / max approach) below about this are near the FE's resolution.
RATIO_FLOOR = 0.05
# The residual-approach forms fit_law can fit (docs/law.md): the closed saturating form, or the
# table through the calibration levels (law/residual_table.py).
SATURATING, TABLE = "saturating", "table"
RESIDUAL_FORMS = (SATURATING, TABLE)


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


# A third loading regime is fitted when it lowers the loading error by this factor, over a
# tail of at least MIN_TAIL_DECADES of depth (a weak sphere's log-slope keeps falling over five
# decades; two power laws then miss the middle by 10 %, docs/calibration.md).
THIRD_REGIME_GAIN = 0.75
MIN_TAIL_DECADES = 0.5


# The segments form of the virgin curve: this many power-law segments per decade of plastic
# depth the data span (at least 3, at most law.params.MAX_SEGMENTS), starts equally spaced in
# log depth from yield. Where the fit misses the loading goal (2 % RMS, docs/calibration.md)
# at one per decade, the density steps up to SEGMENTS_PER_DECADE_MAX: a grain loaded until its
# contact runs away (the reference grain to a/R 0.35, log-slope 0.85 -> 0.41 over its last half
# decade) bends faster there than one power law per decade follows (3.3 %; 1.0 % at two).
SEGMENTS_PER_DECADE = 1
SEGMENTS_PER_DECADE_MAX = 4
LOADING_GOAL = 0.02
REGIMES, SEGMENTS = "regimes", "segments"
LOADING_FORMS = (REGIMES, SEGMENTS)


def fit_loading(approach, force, yield_approach, hertz_coefficient, max_first_slope=None,
                form=REGIMES):
    """n1, delta_p/delta_y, n2 (and, where it pays, delta_q/delta_y, n3) of the virgin curve:
    power laws continuous at dy, dp (and dq).

    ``form="segments"``: instead, ``loading_segments`` (``LoadingSegments``): one power law per
    decade of plastic depth the data span (``SEGMENTS_PER_DECADE``, more where that misses
    LOADING_GOAL; 3 to MAX_SEGMENTS), starts equally spaced in log depth from yield,
    exponents by the same weighted least squares; the curve of a weak grain bends over five
    decades, which three regimes follow to 2-5 % only.

    For each candidate break (pair) on a log grid, the exponents are a linear least-squares
    problem in log space (anchored at the yield point); the best breaks win. Points are
    weighted by their share of log(delta) (trapezoid), so every decade of depth counts the same
    however the FE placed its load steps (they crowd near yield).

    ``max_first_slope``: an upper bound on n1 (``fit_law`` sets one when the free fit would
    create energy just past yield); the other exponents are fitted with n1 at the bound."""
    d = np.asarray(approach, dtype=float)
    f = np.asarray(force, dtype=float)
    dy = yield_approach
    fy = hertz_coefficient * dy**HERTZ_EXPONENT
    use = (d > 1.05 * dy) & (f > 0)
    if use.sum() < 5:
        raise InputError("calibration: the loading curve needs >= 5 points beyond yield")
    order = np.argsort(d[use])
    x, y = np.log(d[use][order] / dy), np.log(f[use][order] / fy)
    w = _trapezoid_weights(x)
    if form not in LOADING_FORMS:
        raise InputError(f"loading form: must be one of {', '.join(LOADING_FORMS)}, got "
                         f"{form!r}")
    if form == SEGMENTS:
        return _fit_segments(x, y, w, max_first_slope)
    top = max(np.log(2.0), np.log(0.95) + x.max())
    grid = np.log(np.geomspace(1.5, np.exp(top), 240))
    two = min((_broken_power_fit(x, y, w, (lp,), max_first_slope) for lp in grid),
              key=lambda r: r[0])
    err, slopes, breaks = two
    tail = MIN_TAIL_DECADES * np.log(10.0)
    coarse = grid[::4]
    pairs = [(a, b) for a in coarse for b in coarse if b - a >= tail and x.max() - b >= tail]
    if pairs:
        three = min((_broken_power_fit(x, y, w, pq, max_first_slope) for pq in pairs),
                    key=lambda r: r[0])
        if three[0] < THIRD_REGIME_GAIN * err:
            err, slopes, breaks = three
    out = {"elastic_plastic_exponent": slopes[0],
           "fully_plastic_approach_ratio": float(np.exp(breaks[0])),
           "fully_plastic_exponent": slopes[1], "rms_relative_error": err}
    if len(breaks) == 2:
        out["deep_plastic_approach_ratio"] = float(np.exp(breaks[1]))
        out["deep_plastic_exponent"] = slopes[2]
    return out


def _fit_segments(x, y, w, max_first_slope=None):
    """``fit_loading``'s segments form on log depth x and log force ratio y (from yield): the
    first density from SEGMENTS_PER_DECADE up whose fit meets LOADING_GOAL, else the best."""
    best = None
    for density in range(SEGMENTS_PER_DECADE, SEGMENTS_PER_DECADE_MAX + 1):
        fit = _fit_segments_at(x, y, w, density, max_first_slope)
        if best is None or fit["rms_relative_error"] < best["rms_relative_error"]:
            best = fit
        if fit["rms_relative_error"] <= LOADING_GOAL:
            return fit
    return best


def _fit_segments_at(x, y, w, density, max_first_slope=None):
    """The segments fit at ``density`` segments per decade of the depth the data span."""
    decades = x.max() / np.log(10.0)
    count = int(min(max(math.ceil(density * decades), 3), MAX_SEGMENTS))
    # fewer segments where the data leave one with fewer than 3 points or an exponent out of
    # (0, 3] (the file's range)
    for k in range(count, 1, -1):
        breaks = tuple(np.linspace(0.0, x.max(), k + 1)[1:-1])
        starts = np.concatenate([[-np.inf], breaks, [np.inf]])
        counts = [np.sum((x > a) & (x <= b))
                  for a, b in zip(starts[:-1], starts[1:], strict=True)]
        enough = min(counts) >= 3
        err, slopes, breaks = _broken_power_fit(x, y, w, breaks, max_first_slope)
        if enough and np.isfinite(err):
            depth = (1.0, *(float(np.exp(b)) for b in breaks))
            # the regime fields mirror the first segments (LawParams sets them so too)
            return {"elastic_plastic_exponent": slopes[0],
                    "fully_plastic_approach_ratio": depth[1],
                    "fully_plastic_exponent": slopes[1],
                    "loading_segments": LoadingSegments(depth, tuple(slopes)),
                    "rms_relative_error": err}
    raise InputError("calibration: no segments fit of the loading curve has exponents in (0, 3]")


def _broken_power_fit(x, y, w, breaks, max_first_slope=None):
    """Continuous piecewise-linear y(x) through the origin with the given breaks: weighted
    least squares for the slopes. Returns (weighted RMS relative force error, slopes, breaks);
    slopes outside (0, 3] (the parameter file's range) make the candidate infinitely bad.
    With ``max_first_slope`` a first slope above it is fixed at it and the rest refitted."""
    basis = np.column_stack([x] + [np.maximum(x - b, 0.0) for b in breaks])
    sw = np.sqrt(w)
    coef, *_ = np.linalg.lstsq(basis * sw[:, None], y * sw, rcond=None)
    if max_first_slope is not None and coef[0] > max_first_slope:
        rest, *_ = np.linalg.lstsq(basis[:, 1:] * sw[:, None],
                                   (y - max_first_slope * x) * sw, rcond=None)
        coef = np.concatenate([[max_first_slope], rest])
    slopes = np.cumsum(coef)
    if np.any(slopes <= 0.0) or np.any(slopes > 3.0) or np.sum(x <= breaks[0]) < 2:
        return np.inf, [float(v) for v in slopes], tuple(breaks)
    model = basis @ coef
    err = float(np.sqrt(np.sum(w * np.expm1(model - y) ** 2) / np.sum(w)))
    return err, [float(v) for v in slopes], tuple(float(b) for b in breaks)


def _trapezoid_weights(x: np.ndarray) -> np.ndarray:
    """Weight of each point of an increasing coordinate: half the gaps on either side."""
    gap = np.diff(x)
    w = np.zeros_like(x)
    w[:-1] += 0.5 * gap
    w[1:] += 0.5 * gap
    return w if np.any(w > 0) else np.ones_like(x)


def _power_of_depth(depth, exponents):
    """p of n = 1.5 x^p through x = 1 (log-space least squares)."""
    lx = np.log(depth)
    ly = np.log(np.asarray(exponents) / HERTZ_EXPONENT)
    p = float(np.dot(lx, ly) / np.dot(lx, lx))
    rms = float(np.sqrt(np.mean((HERTZ_EXPONENT * depth**p - exponents) ** 2)))
    return p, rms


def _saturating(depth, values, what, starts=None, max_log_power=5.0, original=False):
    """limit, power, transition, log_power of values = limit (1 - exp(-power L^b)),
    L = log(1 + (x - 1)/transition) (``law.params.saturating_ratio``).

    Least squares on the relative error of the complement 1 - ratio (the elastic recovery
    dmax - dres, which sets where the unloading curve lies at depth, where the recovery is a few
    % of dmax and an absolute fit of the ratio would misplace it by tens of %) and, with five
    or more levels (log power free), also of the ratio itself (the residual approach a DEM user
    reads; over five decades of depth one form must serve both ends). Started from a grid over
    the transition depth. With fewer than 4 levels the transition is fixed at 1 (the original
    two-parameter form); with fewer than 5 the log power is fixed at 1.

    ``starts``: (limit, power, transition, log_power) tuples to start from instead of the grid
    (a warm start from a known fit nearby, e.g. the universal law's nearest campaign point: the
    same least-squares problem, one local solve instead of 30)."""
    depth = np.asarray(depth, dtype=float)
    values = np.asarray(values, dtype=float)
    if np.any(values >= 1.0) or np.any(values < 0.0):
        raise InputError(f"calibration: {what} ratios must lie in [0, 1)")
    complement = np.log1p(-values)
    ratio = np.log(np.maximum(values, 1e-12))
    free_transition = depth.size >= 4 and not original
    free_log_power = depth.size >= 5 and not original
    # The ratio's own relative error enters only with the log power free (enough levels for
    # the form to follow both ends); a ratio of a few % (a level just past yield) is at the
    # FE's resolution, so its relative error weighs less (weight 1/2 at RATIO_FLOOR).
    weight = values / (values + RATIO_FLOOR) if free_log_power else np.zeros_like(values)

    def model_of(theta):
        limit, power, log_transition, log_power = theta
        return saturating_ratio(depth, limit, power, float(np.exp(log_transition)),
                                float(log_power))

    def residual(theta):
        model = np.clip(model_of(theta), 1e-12, 1.0 - 1e-15)
        return np.concatenate([np.log1p(-model) - complement,
                               weight * (np.log(model) - ratio)])

    best = None
    if starts is None:
        grid = [(None, lt, lp)
                for lt in (np.log(np.geomspace(1.0, 1e3, 10)) if free_transition else [0.0])
                for lp in ((1.0, 1.5, 2.0) if free_log_power else (1.0,))]
    else:
        grid = [((float(lim), float(pw)), np.log(float(tr)) if free_transition else 0.0,
                 float(lp) if free_log_power else 1.0) for lim, pw, tr, lp in starts]
    for given, log_transition, log_power in grid:
        lo = [0.0, 1e-4, log_transition - 1e-9 if not free_transition else -1e-9,
              min(0.2, max_log_power - 1e-9) if free_log_power else 1.0 - 1e-9]
        hi = [MAX_LIMIT, 10.0,
              log_transition + 1e-9 if not free_transition else np.log(1e6),
              max_log_power if free_log_power else 1.0 + 1e-9]
        first = (min(values.max() * 1.2, 0.99), 0.3) if given is None else given
        start = np.clip([*first, log_transition, log_power], lo, hi)
        fit = least_squares(residual, start, bounds=(lo, hi),
                            x_scale=[0.1, 0.1, 1.0, 0.3])
        if best is None or fit.cost < best.cost:
            best = fit
    if best is None or not best.success:
        raise InputError(f"calibration: the {what} fit did not converge")
    limit, power, log_transition, log_power = (float(v) for v in best.x)
    transition = float(np.exp(log_transition)) if free_transition else 1.0
    log_power = log_power if free_log_power else 1.0
    model = saturating_ratio(depth, limit, power, transition, log_power)
    errors = {"rms": float(np.sqrt(np.mean((model - values) ** 2))),
              "max_relative": float(np.max(np.abs(model[values > 0] / values[values > 0]
                                                  - 1.0), initial=0.0)),
              "recovery": float(np.sqrt(np.mean(((1.0 - model) / (1.0 - values) - 1.0) ** 2)))}
    return limit, power, transition, log_power, errors


def residual_table_fit(depth, values) -> tuple[ResidualTable, dict]:
    """The tabulated residual form through the levels (knots at their depths and ratios) and
    its errors: in sample zero by construction (the table passes through every level; what
    rounding leaves is reported under names that say so), and leave-one-out, each interior
    level predicted by the table of the others (max relative error of rho and of 1 - rho, the
    elastic recovery); the end levels' predictions extrapolate and are listed apart."""
    order = np.argsort(depth, kind="stable")
    x = np.asarray(depth, dtype=float)[order]
    rho = np.asarray(values, dtype=float)[order]
    most = schema.field("residual_approach.table.depth")["maxItems"]
    if x.size > most:
        raise InputError(f"calibration: the tabulated residual form holds at most {most} "
                         f"levels, got {x.size}; use the saturating form")
    if np.any(np.diff(x) <= 0.0):
        raise InputError("calibration: the tabulated residual form needs levels of distinct "
                         "depths delta_max/delta_y")
    if np.any(rho <= 0.0) or np.any(rho >= 1.0):
        raise InputError("calibration: the tabulated residual form needs residual ratios in "
                         "(0, 1)")
    falls = np.flatnonzero(np.diff(rho) <= 0.0)
    if falls.size:
        k = int(falls[0])
        raise InputError(
            "calibration: the tabulated residual form needs residual ratios rising strictly "
            f"with depth; the level at delta_max/delta_y = {x[k + 1]:.4g} has "
            f"{rho[k + 1]:.4g} after {rho[k]:.4g} at {x[k]:.4g}; use the saturating form")
    table = ResidualTable(tuple(map(float, x)), tuple(map(float, rho)))
    own = table(x)
    per_level = []
    for i in range(x.size):
        keep = np.arange(x.size) != i
        predicted = float(ResidualTable(tuple(x[keep]), tuple(rho[keep]))(x[i]))
        per_level.append({"depth": float(x[i]), "ratio": float(rho[i]),
                          "predicted_ratio": predicted,
                          "ratio_relative_error": predicted / rho[i] - 1.0,
                          "elastic_recovery_relative_error": (1.0 - predicted) / (1.0 - rho[i])
                          - 1.0,
                          "extrapolated": i in (0, x.size - 1)})
    interior = [lv for lv in per_level if not lv["extrapolated"]]
    errors = {
        "residual_ratio_in_sample_max_relative_zero_by_construction":
            float(np.max(np.abs(own / rho - 1.0))),
        "elastic_recovery_in_sample_max_relative_zero_by_construction":
            float(np.max(np.abs((1.0 - own) / (1.0 - rho) - 1.0))),
        "residual_table_leave_one_out": {
            "levels": "each interior level predicted by the table of the other levels (the "
                      "end levels' predictions extrapolate: listed, not in the maxima)",
            "residual_ratio_max_relative": max(abs(lv["ratio_relative_error"])
                                               for lv in interior),
            "elastic_recovery_max_relative": max(abs(lv["elastic_recovery_relative_error"])
                                                 for lv in interior),
            "per_level": per_level,
        },
    }
    return table, errors


def fit_law(material: Material, yield_approach: float, loading_approach, loading_force,
            levels: list[LevelData], provenance: dict | None = None,
            starts: dict | None = None, residual_form: str = SATURATING,
            loading_form: str = REGIMES) -> LawParams:
    """Every parameter of the law from FE (or test) cycles; returns validated LawParams.

    ``loading_form``: the virgin curve's form, "regimes" (two or three power laws) or
    "segments" (one power law per decade of depth; ``fit_loading``).

    ``starts``: optional warm starts of the saturating fits, {"residual": [(limit, power,
    transition, log_power), ...], "plastic_work": [...]} (see ``_saturating``).
    ``residual_form``: ``"saturating"`` (the closed form, fitted) or ``"table"`` (knots at
    the levels' depths and residual ratios, ``residual_table_fit``: needs ratios rising
    strictly with depth)."""
    if residual_form not in RESIDUAL_FORMS:
        raise InputError(f"residual form: must be one of {', '.join(RESIDUAL_FORMS)}, got "
                         f"{residual_form!r}")
    if len(levels) < 3:
        raise InputError(f"calibration: needs >= 3 load levels, got {len(levels)}")
    kh = hertz_coefficient(material)
    loading = fit_loading(loading_approach, loading_force, yield_approach, kh,
                          form=loading_form)
    loading_inputs = (loading_approach, loading_force, yield_approach, kh)
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
    starts = starts or {}
    if residual_form == TABLE:
        table, table_errors = residual_table_fit(depth, residual)
    else:
        rho, s, x0, b, res_err = _saturating(depth, residual, "residual approach",
                                             starts.get("residual"))
    work = np.array([lv.plastic_work / lv.total_work for lv in levels])
    w_lim, w_pow, w_x0, w_b, work_err = _saturating(depth, work, "plastic work",
                                                    starts.get("plastic_work"))
    fit_errors = {
        "loading_rms_relative": loading.pop("rms_relative_error"),
        "unloading_curve_rms_of_peak": float(np.sqrt(np.mean(np.square(err_u)))),
        "reloading_curve_rms_of_peak": float(np.sqrt(np.mean(np.square(err_r)))),
        "unloading_exponent_rms": rms_nu,
        "reloading_exponent_rms": rms_nr,
        **(table_errors if residual_form == TABLE else {
            "residual_ratio_rms": res_err["rms"],
            "residual_ratio_max_relative": res_err["max_relative"],
            "elastic_recovery_rms_relative": res_err["recovery"]}),
        "plastic_work_ratio_rms": work_err["rms"],
        "per_level": [{"depth": float(x), "unloading_exponent": nu, "reloading_exponent": nr,
                       "residual_ratio": float(r), "plastic_work_ratio": float(w)}
                      for x, nu, nr, r, w in zip(depth, n_u, n_r, residual, work, strict=True)],
    }
    top = levels[int(np.argmax(depth))]
    values = dict(
        material=material,
        yield_approach=yield_approach,
        # beyond the deepest level every form below is extrapolated (docs/law.md)
        calibrated_depth=float(depth.max()),
        calibrated_range_extra={"max_approach_m": top.max_approach,
                                "max_force_N": top.max_force,
                                "source": f"the deepest of the {len(levels)} levels fitted"},
        unloading_power=p_u,
        reloading_power=p_r,
        **({"residual_table": table} if residual_form == TABLE else {
            "residual_limit": rho, "residual_power": s, "residual_transition": x0,
            "residual_log_power": b}),
        plastic_work_limit=w_lim,
        plastic_work_power=w_pow,
        plastic_work_transition=w_x0,
        plastic_work_log_power=w_b,
        fit_errors=fit_errors,
        provenance=dict(provenance or {}),
        label="calibrated",
        **loading,
    )
    try:
        return LawParams(**values)
    except InputError as exc:
        if "creates energy" not in str(exc):
            raise
        refused = str(exc)
    # With a loading exponent near Hertz's (hardening grains, steep friction angles) and a
    # residual form that starts flat at x = 1 (log power b > 1, or a large transition depth),
    # the unloading gives back more than the loading took just past yield: to first order in
    # x - 1 the plastic work grows only if n1 <= 1.5 + 0.6 p_u (n_u = 1.5 x^p_u). First refit
    # the loading with n1 at that bound (the residual form kept), then the residual form with
    # b <= 1, then in the original form (transition 1, b = 1), before giving up; a parameter
    # set the check accepts is never changed. A table (rho ~ (ln x)^m near yield: flat there
    # when its first slope m in (ln ln x, logit rho) exceeds 1) is kept through the first
    # step; it has nothing to restrict (it is the data), so the next steps are the saturating
    # form's, recorded as the table given up.
    bound = HERTZ_EXPONENT + 0.6 * p_u - 0.005
    if loading["elastic_plastic_exponent"] > bound:
        capped = fit_loading(*loading_inputs, max_first_slope=bound, form=loading_form)
        capped_error = capped.pop("rms_relative_error")
        trial = {**values, **capped}
        if "deep_plastic_approach_ratio" not in capped and "loading_segments" not in capped:
            trial.update(deep_plastic_approach_ratio=math.inf, deep_plastic_exponent=1.0)
        try:
            params = LawParams(**trial)
        except InputError:
            pass
        else:
            fit_errors.update({
                "loading_rms_relative": capped_error,
                "loading_first_exponent_bounded": f"n1 <= {bound:.4g}: the free fit created "
                                                  f"energy just past yield ({refused})"})
            return params
    if residual_form == TABLE:
        for key in table_errors:
            fit_errors.pop(key)
        values.pop("residual_table")
    for original in (False, True):
        rho, s, x0, b, res_err = _saturating(depth, residual, "residual approach",
                                             None if original else starts.get("residual"),
                                             max_log_power=1.0, original=original)
        given_up = ("the table through the levels given up for the saturating form, "
                    if residual_form == TABLE else "")
        fit_errors.update({
            "residual_ratio_rms": res_err["rms"],
            "residual_ratio_max_relative": res_err["max_relative"],
            "elastic_recovery_rms_relative": res_err["recovery"],
            "residual_form_restricted": given_up + ("original form (transition 1, log power 1)"
                                                    if original else "log power <= 1")
            + f": the free fit created energy just past yield ({refused})"})
        values.update(residual_limit=rho, residual_power=s, residual_transition=x0,
                      residual_log_power=b, fit_errors=fit_errors)
        try:
            return LawParams(**values)
        except InputError as exc:
            if "creates energy" not in str(exc) or original:
                raise
