"""The contact point of a test, found from the whole record (docs/fit.md, "Contact point").

The machine zero is never the contact: the press travels at zero force, touches the grain at an
unknown displacement u0, and the load cell reads an unknown offset f0. Both are parameters of
one least-squares fit of every branch of the record, in the machine displacement u (after the
machine compliance):

* virgin loading (every loading point beyond the largest displacement before it, the approach
  included): F = f0 + V(u - u0), with the envelope
  V(d) = K d_+^1.5 (1 + (d / d_t)^p)^(-q / p): Hertz at the onset (Johnson 1985, §4.2: the
  exponent 3/2 is the geometry's, not a fitted one), bending over past yield to the local
  exponent 1.5 - q (q in [0, 1]: between Hertz and below the truncation limit);
* unloading of cycle k from its peak (U_k, P_k): F = f0 + P_k ((u - r_k) / (U_k - r_k))_+^n_k,
  the unloading's power law (Etsion, Kligerman & Kadin 2005) ending at the residual
  r_k = u0 + s_k (U_k - u0), s_k in [0, 0.99]: the residual approach is >= 0;
* reloading of cycle k (the next loading up to U_k): the same ends, its own exponent m_k;
* pre-contact and lift-off points: F = f0 (the ``_+``).

The peak of a cycle that goes beyond every earlier one lies on the envelope: P_k = V(U_k - u0).

Why the fit finds u0 (the identifiability argument of docs/fit.md): each branch's own shape is
the same wherever the contact is (a shift of u moves a power law of (u - r_k) along with it),
so u0 is fixed by what ties the branches to the contact: the envelope's Hertz onset, whose
exponent 3/2 is not shift-invariant (c (u - u0 - e)^1.5 is not a multiple of (u - u0)^1.5);
the peaks of the unloadings, dense and sharp where the loading may be sparse or at the noise,
which all lie on that one envelope and so fix its shape at every depth; and the residual
approach of every unloading, at or after the contact (a one-sided bound, tight for the shallow
cycles whose residual is small). A first loading that barely rises above the noise is thus
helped by the rest of the record instead of being needed alone.

The loss is ``soft_l1`` (scipy.optimize.least_squares, trust region reflective with bounds):
the power laws are not the FE's or the grain's exact curves, and the robust loss keeps their
form error near the turning points from pulling the contact. Its scale is that form error's
size, a share of the peak force, or the noise where that is larger (``loss_scale``): at 3 x the
noise, as it was, the flat test's contact moved by -0.021 dy when only the scale was raised to
its noisy value, and its sigma_c by +11 % (docs/fit.md). The residuals are in units of the
noise (the standard errors).
"""

from __future__ import annotations

import contextlib
import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares
from scipy.signal import savgol_filter

from ..errors import InputError
from ..law.params import HERTZ_EXPONENT

NOISE_SIGMAS = 5.0        # force above NOISE_SIGMAS x sigma is contact, below is noise
MIN_CONTACT_POINTS = 20   # points of the whole record above the noise floor
RESOLUTION_FLOOR = 1e-4   # a force resolution of at least this share of the peak (a record
                          # without noise still has its digits and the model its form error)
ROBUST_SCALE = 3.0        # soft_l1 scale, in units of RESOLUTION_FLOOR x the peak force (at
                          # least the noise): the size of the power laws' form error the loss
                          # bounds, which is the model's and not the noise's (3 x the noise, a
                          # noisier record let it pull the contact: docs/fit.md, "The flat
                          # test's bias")
SEED_SHIFTS = (0.0, -0.5, 0.5)  # starts of u0 about the first guess, share of the first depth
TOLERANCE = 1e-6          # ftol and xtol of the fit: u0 to a millionth of the travel
UNDETERMINED = 0.5        # refuse when the contact's standard error exceeds this share of the
                          # first peak's depth


@dataclass
class Branches:
    """Indices of the record's points by branch, in machine coordinates (no u0 needed)."""

    virgin: np.ndarray            # loading beyond the largest displacement before it
    cycle: list[tuple[int, np.ndarray, np.ndarray]]  # (peak index, unloading, reloading)
    peak_u: np.ndarray            # U_k, the machine displacement at each peak
    on_envelope: np.ndarray       # bool: the peak goes beyond every earlier one


def branches(u, turns: list[int], smooth_window: int) -> Branches:
    """Split the record at its turning points ([peak, valley, peak, ...]) into virgin loading,
    and per peak its unloading and the reloading that follows up to the peak's displacement."""
    u = np.asarray(u, dtype=float)
    window = min(smooth_window, u.size - (1 - u.size % 2))
    s = savgol_filter(u, window, 2)
    bounds = [0, *turns, u.size - 1]
    virgin, cycles, peaks, beyond = [], [], [], []
    largest = -math.inf
    for j in range(len(bounds) - 1):
        a, b = bounds[j], bounds[j + 1]
        idx = np.arange(a, b + 1)
        if j % 2 == 0:  # a loading: virgin beyond the largest displacement so far
            virgin.append(idx[s[idx] > largest])
            if j > 0:  # the reloading of the cycle that ended in this loading's valley
                k, un, _ = cycles[-1]
                cycles[-1] = (k, un, idx[s[idx] <= peaks[-1]])
            if j < len(turns):
                peak = float(s[max(a, b - 2):b + 3].max())
                beyond.append(peak > largest)
                peaks.append(peak)
                largest = max(largest, float(s[idx].max()))
        else:  # an unloading from the peak at bounds[j]
            cycles.append((a, idx, np.array([], dtype=int)))
    return Branches(np.concatenate(virgin), cycles, np.array(peaks), np.array(beyond, bool))


def envelope(d, k, t, q, p):
    """V(d) = K d_+^1.5 (1 + (d/t)^p)^(-q/p) (module docstring)."""
    d = np.maximum(d, 0.0)
    return k * d**HERTZ_EXPONENT * (1.0 + (d / t) ** p) ** (-q / p)


class _Model:
    """The whole-record model in scaled units (u by the travel, F by the peak force)."""

    def __init__(self, u, f, parts: Branches):
        self.u, self.f, self.parts = u, f, parts
        self.free_peaks = np.flatnonzero(~parts.on_envelope)
        self.n_cycles = len(parts.cycle)

    def unpack(self, theta):
        f0, u0, log_k, log_t, q, p = theta[:6]
        per = theta[6:6 + 3 * self.n_cycles].reshape(-1, 3)
        free = theta[6 + 3 * self.n_cycles:]
        return f0, u0, math.exp(log_k), math.exp(log_t), q, p, per, free

    def peaks(self, theta):
        f0, u0, k, t, q, p, _, free = self.unpack(theta)
        forces = envelope(self.parts.peak_u - u0, k, t, q, p)
        forces[self.free_peaks] = free
        return forces

    def predict(self, theta):
        f0, u0, k, t, q, p, per, _ = self.unpack(theta)
        out = np.full(self.u.size, f0)
        v = self.parts.virgin
        out[v] += envelope(self.u[v] - u0, k, t, q, p)
        tops = self.peaks(theta)
        for c, (_, unload, reload) in enumerate(self.parts.cycle):
            top_u, top_f = self.parts.peak_u[c], tops[c]
            s, n, m = per[c]
            r = u0 + s * (top_u - u0)
            for idx, power in ((unload, n), (reload, m)):
                x = np.clip((self.u[idx] - r) / (top_u - r), 0.0, None)
                out[idx] += top_f * x**power
        return out

    def residual(self, theta, scale):
        return (self.predict(theta) - self.f) / scale


def _first_guess(u, f, sigma, parts: Branches, first_peak: int):
    """f0 from the start of the record; u0 and K from F^(2/3) linear in u over the first
    loading's points above 3 sigma (Hertz: F^(2/3) = K^(2/3) (u - u0))."""
    f0 = float(np.median(f[: max(5, f.size // 50)]))
    g = f[: first_peak + 1] - f0
    uu = u[: first_peak + 1]
    rise = g > 3.0 * sigma
    if rise.sum() >= 2 and np.ptp(uu[rise]) > 0:
        slope, icpt = np.polyfit(uu[rise], g[rise] ** (2.0 / 3.0), 1)
        u0 = -icpt / slope if slope > 0 else float(uu[rise][0])
    else:
        u0 = float(uu[int(np.argmax(g > 0.5 * g.max()))])
    top = float(parts.peak_u[0])
    u0 = min(u0, top - 1e-3 * max(np.ptp(u), 1e-300))
    k = max(float(g.max()), 3.0 * sigma) / (top - u0) ** HERTZ_EXPONENT
    return f0, u0, k


def fit_contact(u, f, sigma: float, turns: list[int], smooth_window: int) -> dict:
    """f0, u0 and the onset's Hertz coefficient K (F = K (u - u0)^1.5, in the machine
    displacement) from the whole record (module docstring), with their standard errors."""
    u = np.asarray(u, dtype=float)
    f = np.asarray(f, dtype=float)
    parts = branches(u, turns, smooth_window)
    f0, u0, k = _first_guess(u, f, sigma, parts, turns[0])
    above = int(np.sum(f - f0 > NOISE_SIGMAS * sigma))
    if above < MIN_CONTACT_POINTS:
        raise InputError(f"curve: only {above} points of the whole record rise above the noise "
                         f"floor ({NOISE_SIGMAS:g} x {sigma:.3g} N); need >= "
                         f"{MIN_CONTACT_POINTS} to find the contact point: load further or "
                         "use a more sensitive load cell")
    # scaled units: u by the travel from the guess, F by the peak force
    span = float(u.max() - u0)
    fp = float(f.max() - f0)
    us, fs = (u - u0) / span, (f - f0) / fp
    parts_s = Branches(parts.virgin, parts.cycle, (parts.peak_u - u0) / span, parts.on_envelope)
    model = _Model(us, fs, parts_s)
    scale = max(sigma, RESOLUTION_FLOOR * fp) / fp
    first_depth = float(parts_s.peak_u[0])
    with _one_blas_thread():
        best = _solve(model, k * span**HERTZ_EXPONENT / fp, first_depth, scale)
    return _result(best, model, parts, u0, span, f0, fp, scale, sigma, first_depth)


def _one_blas_thread():
    """The fit's linear algebra is small (an SVD of a few thousand x twenty each step): one
    BLAS thread does it faster than waking a pool, markedly so on a shared machine. Through
    threadpoolctl when it is installed (it is not a dependency)."""
    try:
        from threadpoolctl import threadpool_limits
    except ImportError:
        return contextlib.nullcontext()
    return threadpool_limits(1, user_api="blas")


def _solve(model: _Model, k, first_depth, scale):
    best = None
    for shift in SEED_SHIFTS:  # further starts only when the first ends on a bound or fails
        guess_u0 = shift * first_depth
        theta0, lower, upper = _start(model, k, guess_u0, first_depth)
        fit = least_squares(model.residual, theta0, args=(scale,), bounds=(lower, upper),
                            loss="soft_l1", f_scale=loss_scale(scale),
                            method="trf",
                            x_scale="jac", ftol=TOLERANCE, xtol=TOLERANCE, max_nfev=400)
        if best is None or fit.cost < best.cost:
            best = fit
        if best.success and not best.active_mask[1]:
            break
    return best


def loss_scale(scale: float) -> float:
    """The robust loss's scale in units of ``scale`` (the noise, at least the resolution
    floor, as a share of the peak force): the form error's size, ROBUST_SCALE x
    RESOLUTION_FLOOR of the peak force, and never below the noise (a loss scale below it is
    least absolute values on the noise: no less biased by the form error, since the noise
    smooths the loss's kink to a quadratic of its own width, only less efficient and harder
    to converge; it lost the long-approach record's Hertz onset)."""
    return max(ROBUST_SCALE * RESOLUTION_FLOOR / scale, 1.0)


def _start(model: _Model, k, u0, first_depth):
    """Start and bounds of theta (scaled units): f0, u0, ln K, ln d_t, q, p, per cycle
    (s, n, m), free peaks."""
    t = max(first_depth - u0, 1e-3)
    theta = [0.0, u0, math.log(max(k, 1e-12)), math.log(t), 0.3, 2.0]
    lower = [-0.5, -50.0, math.log(1e-12), math.log(1e-4), 0.0, 0.3]
    upper = [0.5, first_depth * (1.0 - 1e-3), math.log(1e12), math.log(1e3), 1.0, 4.0]
    for _ in range(model.n_cycles):
        theta += [0.2, 2.0, 1.8]
        lower += [0.0, 1.0, 1.0]
        upper += [0.99, 8.0, 8.0]
    for i in model.free_peaks:
        theta.append(float(np.max(model.f[max(0, model.parts.cycle[i][0] - 3):
                                         model.parts.cycle[i][0] + 4])))
        lower.append(0.0)
        upper.append(2.0)
    theta = np.clip(theta, lower, upper)
    # a start strictly inside the bounds
    theta = np.minimum(np.maximum(theta, np.add(lower, 1e-9)), np.subtract(upper, 1e-9))
    return theta, lower, upper


def _standard_errors(model: _Model, theta, scale) -> np.ndarray:
    """Standard errors of theta from the Gauss-Newton covariance of the plain residuals
    (forward differences; the robust loss's reweighted Jacobian would understate them)."""
    r = model.residual(theta, scale)
    jac = np.empty((r.size, theta.size))
    for j in range(theta.size):
        h = 1e-7 * max(abs(theta[j]), 1e-3)
        step = theta.copy()
        step[j] += h
        jac[:, j] = (model.residual(step, scale) - r) / h
    s2 = float(np.sum(r**2)) / max(r.size - theta.size, 1)
    try:
        return np.sqrt(np.clip(np.diag(np.linalg.pinv(jac.T @ jac)) * s2, 0.0, None))
    except (np.linalg.LinAlgError, ValueError):
        return np.full(theta.size, np.nan)


def _result(fit, model: _Model, parts: Branches, u_ref, span, f_ref, fp, scale, sigma,
            first_depth) -> dict:
    f0, u0, k, t, q, p, per, _ = model.unpack(fit.x)
    se = _standard_errors(model, fit.x, scale)
    u0_se = float(se[1] * span)
    depth = (first_depth - u0) * span
    if not fit.success or not math.isfinite(u0_se) or u0_se > UNDETERMINED * depth:
        raise InputError(f"curve: the contact point is not determined by the record (±"
                         f"{u0_se:.3g} m against a first peak {depth:.3g} m deep): it needs a "
                         "loading that rises from zero force, or unloadings that reach it")
    residual = model.predict(fit.x) - model.f
    contact_u = u_ref + u0 * span
    return {
        "offset_N": f_ref + f0 * fp,
        "stiffness": k * fp / span**HERTZ_EXPONENT,
        "contact_displacement_m": contact_u,
        "offset_se_N": float(se[0] * fp),
        "stiffness_se_relative": float(se[2]),
        "contact_displacement_se_m": u0_se,
        "envelope": {"transition_displacement_m": t * span, "exponent_drop": float(q),
                     "sharpness": float(p)},
        "residual_ratios": [float(v) for v in per[:, 0]],
        "points": int(model.u.size),
        "points_in_contact": int(np.sum(model.u > u0)),
        "points_above_noise": int(np.sum(model.f - f0 > NOISE_SIGMAS * scale)),
        "cycles": model.n_cycles,
        "rms_N": float(np.sqrt(np.mean(residual**2)) * fp),
        "robust_scale_N": loss_scale(scale) * scale * fp,
        "method": "least squares (soft_l1) of every branch of the record: virgin envelope "
                  "f0 + K (u - u0)_+^1.5 (1 + ((u - u0)/d_t)^p)^(-q/p), unloading and "
                  "reloading power laws from each peak to a residual r_k >= u0 "
                  "(labtest.contact); u after machine compliance",
    }


MIN_ONSET_POINTS = 20  # points of the Hertz onset above the noise floor to refine on it


def fit_onset(approach, force, sigma: float, upto: float, first_peak: int) -> dict | None:
    """The contact refined on the Hertz onset alone: F = g + K (d - e)_+^1.5 by least squares
    over the first loading's points (pre-contact included) below ``upto`` (the force where the
    record leaves Hertz), in the approach d of the whole-record contact: e and g are the
    corrections of the contact point and the offset. None with fewer than MIN_ONSET_POINTS
    points above the noise floor there (the whole-record contact stands)."""
    d = np.asarray(approach, dtype=float)[: first_peak + 1]
    f = np.asarray(force, dtype=float)[: first_peak + 1]
    use = f < upto
    d, f = d[use], f[use]
    if int(np.sum(f > NOISE_SIGMAS * sigma)) < MIN_ONSET_POINTS:
        return None
    top = float(d.max())
    k0 = max(float(f.max()), sigma) / top**HERTZ_EXPONENT
    scale = max(sigma, RESOLUTION_FLOOR * float(f.max()))

    def residual(theta):
        g, log_k, e = theta
        return (g + math.exp(log_k) * np.maximum(d - e * top, 0.0) ** HERTZ_EXPONENT - f) / scale

    with _one_blas_thread():
        fit = least_squares(residual, [0.0, math.log(k0), 0.0], method="trf",
                            bounds=([-np.inf, -np.inf, -0.5], [np.inf, np.inf, 0.5]),
                            x_scale=[scale, 1.0, 0.01])
    jac = fit.jac
    s2 = 2.0 * fit.cost / max(fit.fun.size - 3, 1)
    try:
        se = np.sqrt(np.clip(np.diag(np.linalg.pinv(jac.T @ jac)) * s2, 0.0, None))
    except (np.linalg.LinAlgError, ValueError):
        return None
    g, log_k, e = fit.x
    return {"approach_shift_m": float(e * top), "approach_shift_se_m": float(se[2] * top),
            "offset_shift_N": float(g), "coefficient": math.exp(log_k),
            "points": int(d.size), "upto_N": float(upto)}
