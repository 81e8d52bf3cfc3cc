"""The material behind a fitted test (docs/model.md §9: E, nu, sigma_c, beta, m).

What one test separates and what it does not:

* E* and sigma_c at a given beta (and nu, m): the FE master curve. For two identical spheres
  the virgin loading curve in yield units, F / Fy against delta / delta_y, depends on nu, beta,
  m and, through the mesh and a / R, on the trial material; at a given E*, Fy ~ sigma_c^3 / E*^2
  and delta_y ~ sigma_c^2 / E*^2 (p0 at yield = sigma_c / C(nu, beta), Hertz). So one FE run of
  this project's engine (``geocontact.fem``, monotonic loading, coarse by default) at a trial
  material gives the curve's shape (smoothed by a cubic spline in log-log), and (sigma_c, E*)
  are the two-parameter least-squares scale that lays it on the measured virgin loading (a grid
  over both, then least squares; weights: force noise and a 1 % form error, per log-depth
  share); the Hertz part fixes E*, the bend past yield sigma_c. Rounds with the identified
  material as the next trial run until both move less than ``TOLERANCE`` (at most ``ROUNDS`` FE
  runs, cached by their inputs); ``master_sensitivity`` (4 more runs) measures how much the
  result depends on the trial; ``valley`` keeps the misfit's profile along sigma_c;
* beta (and m) against sigma_c: one curve fixes one yield force, and beta moves the shape of
  F / Fy only weakly; beta and m are given (``--friction-angle``) or assumed and then
  reported with sigma_c(beta) from the analytic incipient yield at the fitted yield force;
* with the universal law (``geocontact.universal.for_material``, issue 12; ``identify_universal``):
  sigma_c without FE runs, first from its virgin loading, then from the whole record (the whole
  law driven along every cycle), and the profile of the misfit over beta when no beta is given
  (the correlated pair).
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np
from scipy.interpolate import UnivariateSpline
from scipy.ndimage import median_filter
from scipy.optimize import brentq, least_squares, minimize_scalar

from ..calibrate.fit import _trapezoid_weights
from ..errors import InputError
from ..grain.hertz import incipient_yield
from ..grain.material import Material
from ..law.params import HERTZ_EXPONENT
from .stiffness import factor as stiffness_factor
from .stiffness import scatter as stiffness_factor_scatter

ROUNDS = 4          # FE runs at most
TOLERANCE = 0.01    # relative change of sigma_c and E that ends the rounds
MASTER_SMOOTHING = 0.005  # RMS of the master curve's smoothing spline in log F (0.5 %)
FE_STEPS = 40       # load steps of the FE run: the curve's shape between steps is linear
DEPTH_MARGIN = 3.0  # the FE run loads this far beyond the test's largest force (in Fy units)
WHOLE_RANGE = 1.5  # the whole-record search of the universal mode: this factor about the
                   # virgin-loading estimate of sigma_c

# model error of the virgin form in the weights: a point weighs 1/(sigma^2 + (e F)^2)
FORM_ERROR = 0.01
# a force resolution in the weights of at least this share of the largest force (a record
# without noise, or with its noise estimate below the digits written, still has one)
RESOLUTION_FLOOR = 1e-4
SELECTION_WINDOW = 11  # points of the running median that selects the virgin points (its
                       # noise is 1.25 sigma / sqrt(11) = 0.4 sigma: no truncation bias)


def _weighted_virgin(vd, vf, noise: float):
    """The virgin points above the noise with their weights 1/(sigma^2 + (FORM_ERROR F)^2) x
    log-depth share (every decade of depth counts the same, as in ``fit_loading``).

    sigma is the noise, at least the resolution floor, and a point is kept where the force,
    smoothed along the approach (a running median of SELECTION_WINDOW points), is above 5 sigma
    of that same sigma. Smoothed, because selecting on the noisy force itself keeps, near the
    threshold, the points the noise lifted and drops those it lowered: the shallowest kept
    points then lie above the curve, and the log-depth share gives them the weight of a decade,
    so the onset looked early (the flat test under its load-cell noise: the contact -0.008 dy
    and sigma_c +4 % on average; a truncated sample's least squares is biased, a sample
    selected on the regressor is not). The floor, because a point below 5 x the resolution is
    not resolved either (on an FE-made record they are the chord from the contact to the FE's
    first load step, up to 4 x Hertz at 0.006 dy on the ramp record). docs/fit.md, "The
    contact point and the master curve"."""
    vd, vf = np.asarray(vd, float), np.asarray(vf, float)
    sigma = max(noise, RESOLUTION_FLOOR * float(vf.max()))
    order = np.argsort(vd, kind="stable")
    smoothed = np.empty_like(vf)
    smoothed[order] = median_filter(vf[order], size=SELECTION_WINDOW, mode="nearest")
    use = (smoothed > 5.0 * sigma) & (vd > 0)
    d, f = vd[use], vf[use]
    if d.size < 10:
        raise InputError("curve: fewer than 10 virgin loading points above the noise")
    return d, f, _trapezoid_weights(np.log(d)) / (sigma**2 + (FORM_ERROR * f) ** 2)


def universal_law():
    """``geocontact.universal.for_material`` when this installation has it, else None."""
    try:
        from ..universal import for_material
    except ImportError:
        return None
    return for_material


def master_curve(material: Material, max_force: float, *, mesh: str, cache_dir,
                 progress: bool = False) -> dict[str, Any]:
    """FE monotonic loading of ``material`` to ``max_force``: delta/delta_y and F/Fy (the FE's
    own first yield force Fy and its Hertz approach delta_y)."""
    from ..fem.campaign import FemJob, run_campaign
    from ..fem.identity import run_key

    job = FemJob(material, (0.0, float(max_force)), mesh=mesh, steps_per_segment=FE_STEPS,
                 label="identification")
    result = run_campaign([job], cache_dir, workers=1, progress=progress)[0]
    c = result.curve
    d, f = np.asarray(c["approach_m"], float), np.asarray(c["force_N"], float)
    fe_fy = result.summary.get("first_yield_force_N")
    if not fe_fy:
        raise InputError("identification: the FE run did not yield; the test's forces are "
                         "elastic for this material")
    # in units of the analytic first yield (exactly Fy ~ sigma_c^3, dy ~ sigma_c^2); the FE's
    # own first yield (a load-step bracket) is kept as its ratio to it
    analytic = incipient_yield(material)
    fy, dy = analytic.force, analytic.approach
    keep = (d > 0) & (f > 0)
    # the contact radius in units of Hertz's at the yield approach, sqrt(R* dy): what the
    # unloading stiffness S = 2 E* a needs (``unloading_modulus``)
    a = np.asarray(c["contact_radius_m"], float)[keep] / math.sqrt(
        material.effective_radius * dy)
    return {"x": d[keep] / dy, "g": f[keep] / fy, "a": a, "yield_force_N": float(fy),
            "fe_over_analytic_yield": float(fe_fy / fy),
            "material": material,
            "yield_approach_m": float(dy), "fe_yield_approach_m":
                result.summary.get("first_yield_approach_m"),
            "cache_key": run_key(result, job.identity()), "mesh": mesh,
            "max_force_N": float(max_force)}


def read_master(path) -> dict[str, Any]:
    """A master curve ``master_curve`` made, written as JSON (scripts/make_synthetic_lab_tests.py
    ``write_masters``)."""
    data = json.loads(Path(path).read_text())
    data["material"] = Material(**data["material"])
    for key in ("x", "g", "a"):
        if key in data:
            data[key] = np.asarray(data[key], float)
    return data


def _log_spline(x, y, smoothing: float):
    """(log x sorted and strictly rising, log y at those points, the smoothing spline of log y
    on them): within ``smoothing`` (relative) of the points."""
    lx, ly = np.log(np.asarray(x, float)), np.log(np.asarray(y, float))
    order = np.argsort(lx)
    lx, ly = lx[order], ly[order]
    keep = np.concatenate([[True], np.diff(lx) > 0])
    lx, ly = lx[keep], ly[keep]
    return lx, ly, UnivariateSpline(lx, ly, k=3, s=lx.size * smoothing**2)


def _residual_of(curve: dict, vd, vf, noise: float):
    """residual(log s, log e[, shift]) of the master curve scaled onto the measured virgin
    loading; ``shift`` moves the contact point by shift x dy(trial) of approach."""
    # a smoothing spline in log-log: the FE curve steps as contact nodes engage (docs/fem.md),
    # and those steps, scaled against the record's, make the misfit multi-modal; the spline
    # keeps the curve within MASTER_SMOOTHING (relative) of the FE points
    lx, _, spline = _log_spline(curve["x"], curve["g"], MASTER_SMOOTHING)

    def shape(x):
        return np.where((x >= lx[0]) & (x <= lx[-1]), spline(x), np.nan)
    fy, dy = curve["yield_force_N"], curve["yield_approach_m"]
    d, f, w = _weighted_virgin(vd, vf, noise)
    sw = np.sqrt(w / np.sum(w))

    def residual(theta):
        s, e = math.exp(theta[0]), math.exp(theta[1])
        # a third parameter: the contact shift, in units of the trial's dy (scale_fit_contact)
        # (a point the shift leaves before the contact carries no force: F = 0 there)
        shifted = d - theta[2] * dy if len(theta) > 2 else d
        xx = np.log(np.maximum(shifted, 1e-300) / (s * s / (e * e) * dy))
        below = xx < lx[0]  # below the FE's first point: Hertz, g = x^1.5
        g = np.where(below, np.exp(HERTZ_EXPONENT * xx), np.exp(shape(xx)))
        g = np.where(shifted > 0.0, g, 0.0)
        r = sw * (s**3 / e**2 * fy * g - f)
        return np.where(np.isnan(r), 1e3 * np.abs(f).max() * sw, r)

    return residual


BOUNDS = ([math.log(0.2), math.log(0.5)], [math.log(2.5), math.log(2.0)])


def scale_fit(curve: dict, vd, vf, noise: float) -> tuple[float, float, float, list]:
    """s and e of sigma_c = s sigma_c(trial), E* = e E*(trial) laying the FE master curve on the
    measured virgin loading: F = Fy g(d / dy) with Fy = s^3 / e^2 Fy(trial) and
    dy = s^2 / e^2 dy(trial) (Hertz at p0 = sigma_c / C), weighted least squares in force
    (``_weighted_virgin``). The Hertz part fixes e, the bend past yield s. Returns
    (s, e, misfit, profile of the misfit over s at the best e)."""
    residual = _residual_of(curve, vd, vf, noise)

    def misfit(theta):
        return float(np.sum(residual(theta) ** 2))

    grid = np.linspace(math.log(0.25), math.log(2.0), 36)
    moduli = np.linspace(math.log(0.8), math.log(1.25), 19)
    # a grid over both first: the misfit has a long valley along the sigma_c-E correlation
    # and the interpolated master curve makes it rough, so a local start can stop short
    start = min(((g, h) for g in grid for h in moduli), key=misfit)
    best = least_squares(residual, list(start), x_scale=[0.05, 0.02], bounds=BOUNDS)
    log_s, log_e = (float(v) for v in best.x)
    profile = [{"scale": float(math.exp(g)), "misfit": misfit((g, log_e))} for g in grid]
    return math.exp(log_s), math.exp(log_e), misfit(best.x), profile


CONTACT_SHIFT = 0.1  # the contact shift scale_fit_contact may take, in dy of the fitted scales


def scale_fit_contact(curve: dict, vd, vf, noise: float) -> dict[str, Any]:
    """``scale_fit`` with the contact point as a third parameter: (s, e) and the shift of the
    approach that lay the master curve best on the measured virgin loading.

    Why: sigma_c moves by several per cent per hundredth of dy of contact error (the bend past
    yield is read in units of dy, and the Hertz part's E* with it), and the contact found from
    the record's own models (``labtest.contact``: the power-law envelope and branches, or the
    Hertz onset) carries those models' form error, which the noise lets pull it (docs/fit.md,
    "The contact point and the master curve"). The master curve is the model sigma_c is read
    with, and it has no free shape: where it is the grain's curve, the contact under which it
    fits the whole virgin loading best is the maximum-likelihood one for the same weights.
    The shift is bounded by CONTACT_SHIFT dy (the candidates are within a few hundredths; a
    point it leaves before the contact is predicted at zero force). Returns s, e, the shift
    (m of approach), its Gauss-Newton standard error and the misfit."""
    s, e, _, _ = scale_fit(curve, vd, vf, noise)
    residual = _residual_of(curve, vd, vf, noise)
    dy = curve["yield_approach_m"]
    reach = CONTACT_SHIFT * s * s / (e * e)  # in dy(trial)

    def at(shift):
        """(s, e) re-fitted at a contact shift (from the unshifted scales: they move little)"""
        return least_squares(lambda t: residual((t[0], t[1], shift)), [math.log(s), math.log(e)],
                             x_scale=[0.05, 0.02], bounds=BOUNDS)

    # a profile over the shift, not a joint least squares: the interpolated master curve makes
    # the misfit rough, and a joint step stopped short (-0.012 dy for -0.008 dy on the ramp)
    grid = np.linspace(-reach, reach, 11)
    costs = [at(g).cost for g in grid]
    k = int(np.argmin(costs))
    step = grid[1] - grid[0]
    best = minimize_scalar(lambda g: at(g).cost, bounds=(grid[max(k - 1, 0)],
                                                         grid[min(k + 1, grid.size - 1)]),
                           method="bounded", options={"xatol": 1e-3 * step})
    shift = float(best.x)
    fit = at(shift)
    # the shift's standard error: Gauss-Newton over the three parameters at the optimum
    theta = np.array([*fit.x, shift])
    r0 = residual(theta)
    jac = np.empty((r0.size, 3))
    for j, h in enumerate((1e-6, 1e-6, 1e-6 * reach)):
        step_theta = theta.copy()
        step_theta[j] += h
        jac[:, j] = (residual(step_theta) - r0) / h
    s2 = float(np.sum(r0**2)) / max(r0.size - 3, 1)
    try:
        se = float(math.sqrt(max(np.linalg.pinv(jac.T @ jac)[2, 2] * s2, 0.0))) * dy
    except (np.linalg.LinAlgError, ValueError):
        se = math.nan
    return {"scale": math.exp(fit.x[0]), "modulus_scale": math.exp(fit.x[1]),
            "approach_shift_m": shift * dy, "approach_shift_se_m": se,
            "on_bound": bool(abs(shift) > 0.999 * reach),
            "misfit": float(np.sum(r0**2))}


RADIUS_SMOOTHING = 0.02  # RMS of the contact radius's smoothing spline in log a: the FE's
                         # contact radius steps from node to node (coarse mesh)


def _radius_of(curve: dict):
    """A(x) = a / sqrt(R* dy) of the master curve's FE run at x = delta / dy (analytic yield
    units): a smoothing spline in log-log; Hertz (A = sqrt(x)) below the FE's first point."""
    x, a = np.asarray(curve["x"], float), np.asarray(curve["a"], float)
    use = a > 0
    lx, la, spline = _log_spline(x[use], a[use], RADIUS_SMOOTHING)

    def radius(xx):
        lxx = np.log(np.asarray(xx, float))
        inside = np.exp(spline(np.clip(lxx, lx[0], lx[-1])))
        return np.where(lxx < lx[0], np.exp(0.5 * lxx) * math.exp(la[0] - 0.5 * lx[0]),
                        inside)

    return radius


def unloading_modulus(curve: dict, peaks, s: float) -> dict[str, Any]:
    """The E* scale e (E* = e E*(trial)) the unloading stiffness gives at the sigma_c scale s.

    The unloading of an axisymmetric contact is elastic, and its initial slope is
    S = dF/d delta = 2 E* a, a the contact radius at the peak, whatever the loaded shape
    (Sneddon 1965; Pharr, Oliver & Brotzen 1992) for an elastic half-space; a sphere's is
    S = 2 beta E* a, Oliver & Pharr's (1992, eq. 2) beta, which this project's FE unloadings
    give as beta(a/R) (``stiffness``: 1.02 at small contacts, rising with a/R). In the pair
    approach delta of two identical spheres E* is the pair's, E = 2 (1 - nu^2) E*
    (docs/model.md §2). The record gives S_k at each peak (``fit.levels_of``), the master
    curve's FE run the contact radius a_k = sqrt(R* dy) A(delta_k / dy) with
    dy = s^2 / e^2 dy(trial), so e solves
    log e = median_k log(S_k / (2 beta_k E*(trial) a_k)) (a_k moves with e only through A's
    argument; the median: a cycle whose peak is poorly sampled, the first of a sparse first
    loading, is an outlier). ``peaks``: (delta_max, S) of each cycle. Returns e, its standard
    error (the cycles' robust scatter) and each cycle's value."""
    if "a" not in curve:
        raise InputError("identification: the master curve has no contact radius (an older "
                         "master curve file): rerun the identification")
    radius = _radius_of(curve)
    dy_t = curve["yield_approach_m"]
    trial = curve["material"]
    es_t, r_star = trial.effective_modulus, trial.effective_radius
    dmax = np.array([p[0] for p in peaks], float)
    stiff = np.array([p[1] for p in peaks], float)

    def each(log_e):
        """each cycle's e, S_k / (2 beta E*(trial) a_k), with a_k at the scales (s, e)"""
        e = math.exp(log_e)
        dy = s * s / (e * e) * dy_t
        a = math.sqrt(r_star * dy) * radius(dmax / dy)
        return stiff / (2.0 * es_t * a * stiffness_factor(a / trial.radius))

    def gap(log_e):  # decreasing: a_k grows with e only through A's argument
        return float(np.median(np.log(each(log_e)))) - log_e

    lo, hi = math.log(0.1), math.log(10.0)
    log_e = brentq(gap, lo, hi) if gap(lo) > 0 > gap(hi) else min((lo, hi), key=lambda t: abs(
        gap(t)))
    values = each(log_e)
    e = float(math.exp(log_e))
    # the median's standard error from the cycles' robust scatter (MAD; 1.253: the median's
    # efficiency against the mean for normal scatter)
    spread = 1.4826 * float(np.median(np.abs(values - np.median(values))))
    se = 1.253 * spread / math.sqrt(values.size) if values.size > 2 else None
    dy = s * s / (e * e) * dy_t
    betas = stiffness_factor(math.sqrt(r_star * dy) * radius(dmax / dy) / trial.radius)
    return {"scale": e, "standard_error": se, "per_cycle": [float(v) for v in values],
            "stiffness_factor": [float(v) for v in betas],
            # the FE unloadings' own scatter about beta(a/R): a systematic error of e
            "stiffness_factor_standard_error": e * stiffness_factor_scatter()}


def scale_fit_unloading(curve: dict, vd, vf, noise: float, peaks, *,
                        modulus_factor: float = 1.0) -> tuple[float, float, float, list]:
    """``scale_fit`` with E* from the unloading stiffness (``unloading_modulus``) instead of
    the Hertz part: for a record whose Hertz part is not resolved the virgin loading fixes E*
    and sigma_c only along their correlation (Fy ~ sigma_c^3 / E*^2), so E* comes from the
    unloadings, dense on every record, and the virgin loading fixes sigma_c.
    ``modulus_factor``: E* that many times the unloadings' (how sigma_c moves with E*)."""
    residual = _residual_of(curve, vd, vf, noise)

    def log_e(log_s):
        return math.log(modulus_factor * unloading_modulus(curve, peaks, math.exp(log_s))[
            "scale"])

    def misfit(log_s):
        return float(np.sum(residual((log_s, log_e(log_s))) ** 2))

    grid = np.linspace(math.log(0.25), math.log(2.0), 36)
    values = [misfit(g) for g in grid]
    k = int(np.argmin(values))
    step = grid[1] - grid[0]
    best = minimize_scalar(misfit, bounds=(grid[k] - step, grid[k] + step), method="bounded",
                           options={"xatol": 1e-4})
    log_s = float(best.x)
    profile = [{"scale": float(math.exp(g)), "misfit": v}
               for g, v in zip(grid, values, strict=True)]
    return math.exp(log_s), math.exp(log_e(log_s)), misfit(log_s), profile


VALLEY = 0.10  # the correlated range: misfit within this share of its minimum


def valley(curve: dict, vd, vf, noise: float, best: tuple[float, float]) -> dict[str, Any]:
    """The (sigma_c, E) pairs one record cannot tell apart: for sigma_c on a grid around the
    best, the E that fits best and the misfit (a profile); the range of sigma_c whose profile
    misfit is within VALLEY of the minimum."""
    residual = _residual_of(curve, vd, vf, noise)
    trial = curve["material"]
    rows = []
    for s in np.sort(np.append(best[0] * np.geomspace(0.75, 1.3, 41), best[0])):
        log_s = math.log(s)

        def at(t, log_s=log_s):
            return residual((log_s, t[0]))

        start = min(math.log(best[1]) + np.linspace(-0.2, 0.2, 41),
                    key=lambda h, at=at: float(np.sum(at([h]) ** 2)))
        fit = least_squares(at, [start], bounds=([BOUNDS[0][1]], [BOUNDS[1][1]]))
        rows.append({"compressive_yield_stress_Pa": float(s * trial.compressive_yield_stress),
                     "youngs_modulus_Pa": float(math.exp(fit.x[0]) * trial.youngs_modulus),
                     "misfit": float(2.0 * fit.cost)})
    low = min(r["misfit"] for r in rows)
    inside = [r["compressive_yield_stress_Pa"] for r in rows
              if r["misfit"] <= (1 + VALLEY) * low]
    return {"profile": rows,
            "sigma_c_range_Pa": [min(inside), max(inside)],
            "definition": f"sigma_c whose best-E misfit is within {100 * VALLEY:g} % of the "
                          "minimum (E re-fitted at each sigma_c): what the record does not "
                          "separate along the sigma_c-E correlation"}


def identify_by_fe(material: Material, virgins, noise: float, *, mesh: str = "coarse",
                   cache_dir=None, progress: bool = False) -> dict[str, Any]:
    """sigma_c (at the material's E, nu, beta, m) whose FE virgin loading reproduces the
    measured one (module docstring). ``virgins``: the measured virgin loading (approach, force,
    and the cycles' (delta_max, S) when E* is to come from the unloadings, else None) at each
    candidate contact point (``fit.choose_contact``); each round takes the one the
    master curve fits best. Returns the identified material, the FE yield of the last round,
    the rounds and which candidate the last round took (``virgin_choice``)."""
    from ..fem.campaign import DEFAULT_CACHE

    cache_dir = DEFAULT_CACHE if cache_dir is None else cache_dir
    virgins = [(np.asarray(v[0], float), np.asarray(v[1], float),
                v[2] if len(v) > 2 else None) for v in virgins]
    rounds = []
    trial = material
    for _ in range(ROUNDS):
        top = max(float(v[1].max()) for v in virgins)
        fy_trial = incipient_yield(trial).force
        # deep enough for any scale the fit may take (s down to 0.25: Fy / 64)
        depth_force = DEPTH_MARGIN * top
        curve = master_curve(trial, max(depth_force, 2.0 * fy_trial), mesh=mesh,
                             cache_dir=cache_dir, progress=progress)
        # a candidate without a resolved Hertz part takes E* from its unloadings
        fits = [scale_fit(curve, a, b, noise) if peaks is None else
                scale_fit_unloading(curve, a, b, noise, peaks) for a, b, peaks in virgins]
        choice = min(range(len(fits)), key=lambda k: fits[k][2])
        vd, vf, _ = virgins[choice]
        s, e, misfit, profile = fits[choice]
        sigma = s * trial.compressive_yield_stress
        modulus = e * trial.youngs_modulus  # E* ~ E at a fixed nu
        rounds.append({"trial_sigma_c_Pa": trial.compressive_yield_stress,
                       "trial_youngs_modulus_Pa": trial.youngs_modulus, "scale": s,
                       "modulus_scale": e, "sigma_c_Pa": sigma, "youngs_modulus_Pa": modulus,
                       "misfit": misfit, "virgin_choice": choice,
                       "misfits": [f[2] for f in fits], "fe_cache_key": curve["cache_key"],
                       "fe_max_force_N": curve["max_force_N"], "profile": profile})
        done = abs(s - 1.0) < TOLERANCE and abs(e - 1.0) < TOLERANCE
        trial = trial.with_(compressive_yield_stress=sigma, youngs_modulus=modulus)
        if done:
            break
    last = rounds[-1]
    fy = curve["yield_force_N"] * last["scale"] ** 3 / last["modulus_scale"] ** 2
    sensitivity = master_sensitivity(curve["material"], vd, vf, noise, last, mesh=mesh,
                                     cache_dir=cache_dir, progress=progress)
    correlated = valley(curve, vd, vf, noise, (last["scale"], last["modulus_scale"]))
    return {"method": "FE master curve: scale (sigma_c, E*) of the FE virgin loading (F/Fy "
                      "against delta/delta_y, analytic yield units) on the measured virgin "
                      f"loading, rounds until both move < {100 * TOLERANCE:g} %",
            "master_sensitivity": sensitivity,
            "sigma_c_modulus_valley": correlated,
            "mesh": mesh, "compressive_yield_stress_Pa": trial.compressive_yield_stress,
            "youngs_modulus_Pa": trial.youngs_modulus,
            "yield_force_N": float(fy),
            "rounds": rounds, "converged": done, "virgin_choice": choice,
            "master": curve}




# trial (sigma_c, E) of the extra master curves, x the final trial's
SENSITIVITY = ((0.9, 1.0), (1.1, 1.0), (1.0, 0.97), (1.0, 1.03))


def master_sensitivity(trial: Material, vd, vf, noise: float, last: dict, *, mesh: str,
                       cache_dir, progress: bool = False) -> dict[str, Any]:
    """How much the identified values move when the master curve is computed at sigma_c 10 %
    or E 3 % off the final trial: the FE curve's shape in yield units moves with the trial (mesh
    and load steps are sized by it), so the fixed point of the rounds is only as sharp as this.
    Half the range of the identified values over the three masters is reported as the
    identification's systematic standard error (``standard_errors``), beside the bootstrap's
    (which holds the master fixed)."""
    top = float(np.max(vf))
    sig, mod = [last["sigma_c_Pa"]], [last["youngs_modulus_Pa"]]
    rows = []
    for factor, modulus in SENSITIVITY:
        other = trial.with_(compressive_yield_stress=factor * trial.compressive_yield_stress,
                            youngs_modulus=modulus * trial.youngs_modulus)
        curve = master_curve(other, DEPTH_MARGIN * top, mesh=mesh, cache_dir=cache_dir,
                             progress=progress)
        s, e, misfit, _ = scale_fit(curve, vd, vf, noise)
        sig.append(s * other.compressive_yield_stress)
        mod.append(e * other.youngs_modulus)
        rows.append({"trial_sigma_c_Pa": other.compressive_yield_stress,
                     "sigma_c_Pa": sig[-1], "youngs_modulus_Pa": mod[-1], "misfit": misfit,
                     "fe_cache_key": curve["cache_key"]})
    return {"masters": rows,
            "standard_errors": {"compressive_yield_stress_Pa": 0.5 * float(np.ptp(sig)),
                                "youngs_modulus_Pa": 0.5 * float(np.ptp(mod))},
            "definition": "half the range of sigma_c and E identified with master curves at "
                          "the final trial and at (sigma_c, E) x (0.9, 1), (1.1, 1), (1, 0.97), "
                          "(1, 1.03) of it"}


# --- with the universal law (issue 12) ----------------------------------------------------------
UNIVERSAL_BETAS = (0.0, 15.0, 30.0, 45.0, 55.0)  # the profile over beta when none is given


def _universal_misfit(law, material: Material, vd, vf, noise: float) -> float:
    d, f, w = _weighted_virgin(vd, vf, noise)
    params = law(material)
    return float(np.sum(w * (params.virgin_force(d) - f) ** 2) / np.sum(w))


def _best_sigma(law, material: Material, vd, vf, noise: float) -> tuple[float, float]:
    """sigma_c (at the material's E, nu, beta, m) whose universal-law virgin loading fits the
    measured one best; bounded by the universal law's range of E / sigma_c."""
    return _bounded_sigma(lambda trial: _universal_misfit(law, trial, vd, vf, noise), material,
                          (2.0, 4.0), 1e6 * float(np.max(vf)) ** 2)


def _record_misfit(law, material: Material, approach, force, weights) -> float:
    """RMS over the path length of (universal law - record) along the whole record, as a
    fraction of the record's peak force: the law of ``material`` (its own loading, unloading,
    reloading and residual-approach laws) driven along the record's approach history."""
    from ..law import ContactArrays

    # a trial material's law along the record: the identification's objective, not a use of it
    contacts = ContactArrays(law(material), 1, beyond_range="ignore")
    one = np.empty(1)
    model = np.empty_like(approach)
    for i, a in enumerate(approach):
        one[0] = a
        model[i] = contacts.step_unchecked(one)[0][0]
    rms = math.sqrt(float(np.sum(weights * (model - force) ** 2) / np.sum(weights)))
    return rms / float(np.max(force))


def _bounded_sigma(misfit_of, material: Material, log_ratio_range: tuple[float, float],
                   worst: float) -> tuple[float, float]:
    """Bounded 1-D search of log10(E / sigma_c) in ``log_ratio_range`` (clipped to the
    universal law's range: outside it the misfit is ``worst``); returns (sigma_c, misfit)."""
    from scipy.optimize import minimize_scalar

    e = material.youngs_modulus

    def misfit(log_ratio):
        try:
            return misfit_of(material.with_(compressive_yield_stress=e / 10.0**log_ratio))
        except InputError:  # outside the universal law's range: worse than any fit
            return worst

    low, high = max(2.0, log_ratio_range[0]), min(4.0, log_ratio_range[1])
    fit = minimize_scalar(misfit, bounds=(low, high), method="bounded",
                          options={"xatol": 1e-3})
    return float(e / 10.0**fit.x), float(fit.fun)


def _best_sigma_whole(law, material: Material, approach, force, start_sigma: float,
                      ) -> tuple[float, float]:
    """sigma_c whose universal law reproduces the whole record best (``_record_misfit``),
    searched within a factor WHOLE_RANGE of ``start_sigma`` (the virgin-loading estimate)."""
    from ..calibrate.acceptance import path_weights

    approach, force = np.asarray(approach, float), np.asarray(force, float)
    weights = path_weights(approach)
    centre = math.log10(material.youngs_modulus / start_sigma)
    span = math.log10(WHOLE_RANGE)
    return _bounded_sigma(lambda trial: _record_misfit(law, trial, approach, force, weights),
                          material, (centre - span, centre + span), 1.0)


def beyond_calibrated_depth(params, approach) -> dict[str, Any]:
    """Does the record go deeper than the law it is identified with was calibrated
    (``calibrated_range.max_depth``, in delta / delta_y of that law)? Then sigma_c was found on
    the law's extrapolation (docs/law.md, "The calibrated range"): ``warning`` says so in one
    line, with the count of the record's points beyond and the largest depth reached."""
    depth = np.asarray(approach, float) / params.yield_approach
    top = float(params.calibrated_depth)
    beyond = int(np.sum(depth > top))
    out: dict[str, Any] = {"calibrated_depth": top, "largest_depth": float(depth.max()),
                           "points_beyond": beyond, "warning": None}
    if beyond:
        out["warning"] = (
            f"the record reaches {depth.max():.3g} delta_y, beyond the universal law's "
            f"calibrated depth {top:.3g} delta_y at the identified material ({beyond} points): "
            "sigma_c was found on the law's extrapolation; use --identify fe")
    return out


def identify_universal(material: Material, vd, vf, noise: float, *,
                       beta_given: bool, approach=None, force=None,
                       start_sigma: float | None = None) -> dict[str, Any]:
    """sigma_c from the universal law (``for_material``, no FE run) at the fit's E, nu, beta, m:
    first where its virgin loading fits the measured one best, then, when the whole record
    (``approach``, ``force``: conditioned, every cycle) is given, where the whole law - its
    unloading, reloading and residual approach too - reproduces the record best (the answer;
    the virgin-only value is kept as ``virgin_only``). ``start_sigma`` (with the whole record:
    the bootstrap's refits) skips the virgin search and centres the whole-record search there.
    Without a given beta, the profile of the misfit over beta with its best sigma_c (the
    correlated pair) is added."""
    law = universal_law()
    if law is None:
        raise InputError("identify: the universal law (universal.for_material) is not in "
                         "this installation; use --identify fe")
    vd, vf = np.asarray(vd, float), np.asarray(vf, float)
    whole = approach is not None and force is not None

    def best(trial: Material) -> tuple[float, float, float | None, float | None]:
        if whole and start_sigma is not None:
            return (*_best_sigma_whole(law, trial, approach, force, start_sigma), None, None)
        sigma_v, misfit_v = _best_sigma(law, trial, vd, vf, noise)
        if not whole:
            return sigma_v, misfit_v, sigma_v, misfit_v
        sigma_w, misfit_w = _best_sigma_whole(law, trial, approach, force, sigma_v)
        return sigma_w, misfit_w, sigma_v, misfit_v

    sigma, misfit, sigma_v, misfit_v = best(material)
    out: dict[str, Any] = {
        "method": ("universal law (geocontact.universal.for_material) at the fit's E, nu, beta, m: "
                   + ("sigma_c minimising the RMS over the path length of (law - record) along "
                      "the whole record, as a fraction of its peak force, searched within a "
                      f"factor {WHOLE_RANGE:g} of the virgin-loading estimate" if whole else
                      "sigma_c minimising the weighted misfit of its virgin loading to the "
                      "measured one")),
        "compressive_yield_stress_Pa": sigma, "misfit": misfit,
        "friction_angle_deg": material.friction_angle_deg,
        "virgin_only": {"compressive_yield_stress_Pa": sigma_v, "misfit": misfit_v,
                        "method": "sigma_c minimising the weighted misfit of the universal "
                                  "law's virgin loading to the measured one"},
    }
    if not beta_given:
        profile = []
        for beta in UNIVERSAL_BETAS:
            s, f, _, _ = best(material.with_(friction_angle_deg=beta))
            profile.append({"friction_angle_deg": beta, "compressive_yield_stress_Pa": s,
                            "misfit": f})
        out["beta_profile"] = profile
        out["beta_profile_note"] = ("best sigma_c and misfit at each beta: the pair one curve "
                                    "gives; beta stays assumed in the law file")
    found = law(material.with_(compressive_yield_stress=sigma))
    out["calibrated_range"] = beyond_calibrated_depth(found, approach if whole else vd)
    out["universal"] = found.provenance.get("universal", {})
    out["yield_force_N"] = found.yield_force
    out["material"] = found.material
    return out
