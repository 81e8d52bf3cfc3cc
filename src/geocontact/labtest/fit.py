"""The law (and the material behind it) fitted to a conditioned laboratory test.

One code path with ``geocontact calibrate``: the measured cycles become the virgin loading curve
and one ``calibrate.fit.LevelData`` per closed cycle, and ``calibrate.fit.fit_law`` fits every
form of docs/law.md to them. What the test adds:

* E* from the Hertz part: the contact-point fit F = K delta^1.5 (``labtest.curve``), re-fitted
  below the force where the record leaves Hertz (``departure``); K = (4/3) E* sqrt(R/2),
  E = 2 (1 - nu^2) E* with the given (or default) Poisson's ratio. With the FE identification
  (``labtest.identify``, the default) E* and sigma_c come together from the FE master curve
  scaled onto the whole virgin loading;
* the yield: the Hertz approach of the FE first-yield force of the identified material (as
  ``geocontact calibrate`` takes delta_y from the FE's first yield; a record has no yield
  detector, and the departure from Hertz lies far past first yield), or of the universal law's
  yield (``--identify universal``), or, without identification, the departure itself (biased);
* per cycle: the peak (delta_max, F_max) on the smoothed record, the residual approach from the
  unloading's own power law F = F_max ((d - d_res)/(d_max - d_res))^n fitted with d_res free
  (the unloading need not reach zero force), the work of the virgin curve to delta_max and the
  work the unloading gives back (their difference is the cycle's plastic work, as the FE's loop
  work of 0 -> F -> 0);
* uncertainties: a residual bootstrap (the force noise, taken from the record's residual about
  its local quadratic smoothing in time, resampled onto the smoothed record; the whole
  conditioning and fit rerun per sample with the final master curve; seeded): one standard
  error per fitted value, with the master-curve sensitivity added for sigma_c and E
  (docs/fit.md: how far to trust them);
* what one test does not separate: sigma_c against beta at the fitted yield force (analytic
  incipient yield: p0 at yield is sigma_c / C(nu, beta), so sigma_c = C p0(Fy) exactly).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from scipy.optimize import least_squares

from ..calibrate.fit import LevelData, fit_law
from ..errors import InputError
from ..grain.hertz import hertz_coefficient, incipient_yield
from ..grain.material import Material
from ..law.params import HERTZ_EXPONENT, LawParams
from .contact import fit_onset
from .curve import SMOOTH_WINDOW, LabTest, Record, condition, local_smoothing

DEFAULT_POISSONS_RATIO = 0.25
DEFAULT_FRICTION_ANGLE = 30.0
DEFAULT_HARDENING_RATIO = 0.0
MIN_LEVELS = 3
UNLOAD_KEEP = (0.05, 0.98)  # share of the peak force over which the unloading law is fitted
UNLOAD_NOISE_SIGMAS = 3.0   # and at least this many load-cell sigmas above zero
BETA_PROFILE = (0.0, 15.0, 30.0, 45.0, 60.0)


def effective_modulus_of(stiffness: float, radius: float) -> float:
    """E* of two identical spheres from K of F = K delta^1.5: K = (4/3) E* sqrt(R/2)."""
    return 0.75 * stiffness / math.sqrt(0.5 * radius)


def youngs_modulus_of(stiffness: float, radius: float, poissons_ratio: float) -> float:
    return 2.0 * (1.0 - poissons_ratio**2) * effective_modulus_of(stiffness, radius)


@functools.lru_cache(maxsize=256)
def _dp_factor(poissons_ratio: float, friction_angle_deg: float) -> float:
    """C(nu, beta) of the analytic incipient yield (p0 at yield = sigma_c / C); any E, R."""
    return incipient_yield(Material(youngs_modulus=1e9, poissons_ratio=poissons_ratio,
                                    compressive_yield_stress=1e6,
                                    friction_angle_deg=friction_angle_deg,
                                    hardening_ratio=0.0, radius=1.0)).dp_factor


def sigma_c_of_yield(yield_force: float, material: Material) -> float:
    """sigma_c at which the analytic first yield of ``material``'s elastic contact is
    ``yield_force``: p0 at yield = sigma_c / C (C = ``dp_factor`` of nu and beta), and Hertz
    p0 = (6 F E*^2 / (pi^3 R*^2))^(1/3)."""
    c = _dp_factor(material.poissons_ratio, material.friction_angle_deg)
    e_star, r_star = material.effective_modulus, material.effective_radius
    p0 = (6.0 * yield_force * e_star**2 / (math.pi**3 * r_star**2)) ** (1.0 / 3.0)
    return c * p0


@dataclass
class Peak:
    approach: float
    force: float


def _peak(test: LabTest, cycle) -> Peak:
    """The cycle's peak on the smoothed record: the largest smoothed approach, and the force
    there from a straight line through the last loading points near it (the record's cusp is
    not rounded by smoothing)."""
    d, f = test.approach, test.force
    lo = max(cycle.start, cycle.peak - SMOOTH_WINDOW)
    hi = min(cycle.end, cycle.peak + SMOOTH_WINDOW)
    dmax = float(np.median(np.sort(d[lo:hi + 1])[-3:]))
    near = slice(max(cycle.start, cycle.peak - 2 * SMOOTH_WINDOW), cycle.peak + 1)
    dd, ff = d[near], f[near]
    if dd.size >= 4 and np.ptp(dd) > 0:
        slope, icpt = np.polyfit(dd, ff, 1)
        fmax = float(slope * dmax + icpt)
    else:
        fmax = float(f[cycle.peak])
    return Peak(dmax, max(fmax, float(np.median(f[lo:hi + 1]))))


def unloading_law(approach, force, peak: Peak, noise: float = 0.0
                  ) -> tuple[float, float, float]:
    """d_res and n of F = F_max ((d - d_res)/(d_max - d_res))^n over the unloading between
    UNLOAD_KEEP of the peak force and at least UNLOAD_NOISE_SIGMAS x ``noise`` (d_res free);
    returns (d_res, n, rms of peak). Points within a few sigma of zero force are kept out: the
    ones there that pass a force threshold are those the noise lifted, which bends the law's
    foot up and moves d_res towards the peak's side (-18 % on a cycle at 4 % of the load
    cell's range with 0.4 % noise, issue 37)."""
    d, f = np.asarray(approach), np.asarray(force)
    low = max(UNLOAD_KEEP[0] * peak.force, UNLOAD_NOISE_SIGMAS * noise)
    use = (f > low) & (f < UNLOAD_KEEP[1] * peak.force) & (d < peak.approach)
    if use.sum() < 5:
        raise InputError("curve: an unloading has fewer than 5 points between 5 % and 98 % of "
                         "its peak force; sample the unloading more densely")
    dd, ff = d[use], f[use] / peak.force

    def residual(theta):
        dres, n = theta
        t = np.clip((dd - dres) / (peak.approach - dres), 0.0, None)
        return t**n - ff

    lowest = float(dd.min())
    start = [lowest - 0.3 * (peak.approach - lowest), 2.0]
    fit = least_squares(residual, start, bounds=([-peak.approach, 1.0],
                                                 [lowest - 1e-6 * peak.approach, 20.0]))
    dres, n = (float(v) for v in fit.x)
    return dres, n, float(np.sqrt(np.mean(fit.fun**2)))


def _virgin(test: LabTest):
    """The virgin loading: each cycle's loading beyond the largest approach before it."""
    d, f = test.approach, test.force
    parts_d, parts_f = [], []
    for c in test.cycles:
        s = c.loading()
        keep = (d[s] > c.previous_max_approach) & (d[s] > 0.0)
        parts_d.append(d[s][keep])
        parts_f.append(f[s][keep])
    vd, vf = np.concatenate(parts_d), np.concatenate(parts_f)
    order = np.argsort(vd)
    return vd[order], vf[order]


DEPARTURE = 0.03  # the virgin curve has left Hertz when it lies this share below it
DEPARTURE_BINS = 60


def departure(vd, vf, kh: float, noise: float) -> dict:
    """Where the virgin loading leaves Hertz: the median of F / (K d^1.5) in log bins of d
    (points above 10 sigma); the first bin after the last one within DEPARTURE of 1."""
    vd, vf = np.asarray(vd, float), np.asarray(vf, float)
    use = (vd > 0) & (vf > 10.0 * noise)
    d, f = vd[use], vf[use]
    if d.size < 20:
        raise InputError("curve: fewer than 20 virgin loading points above 10x the noise")
    ratio = f / (kh * d**HERTZ_EXPONENT)
    edges = np.geomspace(d.min(), d.max() * (1 + 1e-12), DEPARTURE_BINS + 1)
    which = np.digitize(d, edges) - 1
    centres, medians = [], []
    for i in range(DEPARTURE_BINS):
        inside = which == i
        if inside.sum() >= 3:
            centres.append(float(np.median(d[inside])))
            medians.append(float(np.median(ratio[inside])))
    ok = np.flatnonzero(np.array(medians) >= 1.0 - DEPARTURE)
    if ok.size == 0:
        raise InputError("curve: the first loading never follows Hertz (F = K d^1.5) within "
                         f"{100 * DEPARTURE:g} %: check --setup, --radius and the machine "
                         "stiffness")
    last = int(ok[-1])
    if last == len(centres) - 1:
        raise InputError("curve: the virgin loading follows Hertz to its end: the test never "
                         f"yields (peak {vf.max():.3g} N), so there is no plastic law to fit: "
                         f"load past first yield, >= {MIN_LEVELS} cycles beyond it")
    dd = centres[last + 1]
    return {"approach_m": dd, "force_N": float(kh * dd**HERTZ_EXPONENT),
            "method": f"first log bin of the virgin loading whose median F/(K d^1.5) stays "
                      f"below {1 - DEPARTURE:g} (points above 10 sigma, {DEPARTURE_BINS} "
                      "bins)",
            "ratio_profile": [{"approach_m": c, "ratio": r}
                              for c, r in zip(centres, medians, strict=True)]}


def levels_of(test: LabTest, virgin_d, virgin_f) -> tuple[list[LevelData], list[dict]]:
    """LevelData of each closed cycle (module docstring); and per cycle what was measured."""
    d, f = test.approach, test.force
    vd = np.concatenate([[0.0], virgin_d])
    vf = np.concatenate([[0.0], np.maximum(virgin_f, 0.0)])
    levels, info = [], []
    closed = [c for c in test.cycles if c.closed]
    for i, c in enumerate(closed):
        peak = _peak(test, c)
        un = c.unloading()
        dres, n, rms = unloading_law(d[un], f[un], peak, test.noise)
        # the unloading's initial slope (Oliver & Pharr 1992: the power law's at the peak)
        stiffness = n * peak.force / (peak.approach - dres)
        dres = max(dres, 0.0)
        below = vd <= peak.approach
        total = float(np.trapezoid(np.append(vf[below], peak.force),
                                   np.append(vd[below], peak.approach)))
        ud, uf = d[un], np.maximum(f[un], 0.0)
        keep = ud >= dres
        order = np.argsort(ud[keep])
        returned = float(np.trapezoid(uf[keep][order], ud[keep][order]))
        low = float(ud[keep].min()) if keep.any() else dres
        span = peak.approach - dres
        returned += peak.force * span / (n + 1.0) * ((low - dres) / span) ** (n + 1.0)
        # reloading: the next cycle's loading up to this peak (the lift-off gap left out)
        nxt = test.cycles[test.cycles.index(c) + 1] if c is not test.cycles[-1] else None
        if nxt is not None:
            s = nxt.loading()
            rel = (d[s] <= peak.approach) & (f[s] > 3.0 * test.noise)
            rd, rf = d[s][rel], f[s][rel]
        else:
            rd, rf = np.array([]), np.array([])
        if rd.size < 5:  # the last cycle has no reload: its unloading stands in (same ends)
            rd, rf = ud[::-1], f[un][::-1]
            reload_from = "unloading (no reload after the last cycle)"
        else:
            reload_from = "next cycle's loading"
        levels.append(LevelData(
            max_approach=peak.approach, max_force=peak.force, residual_approach=dres,
            plastic_work=total - returned, total_work=total,
            unloading_approach=d[un].copy(), unloading_force=f[un].copy(),
            reloading_approach=rd.copy(), reloading_force=rf.copy()))
        info.append({"cycle": i + 1, "max_approach_m": peak.approach,
                     "max_force_N": peak.force, "residual_approach_m": dres,
                     "unloading_exponent_free_fit": n, "unloading_fit_rms_of_peak": rms,
                     "unloading_stiffness_N_per_m": stiffness,
                     "total_work_J": total, "returned_work_J": returned,
                     "plastic_work_J": total - returned, "reloading_from": reload_from})
    return levels, info


@dataclass
class LabFit:
    """The law fitted to a test, with what was measured, given and assumed."""

    params: LawParams
    test: LabTest
    levels: list[dict]
    yield_info: dict
    departure: dict
    given: dict[str, Any]
    assumed: dict[str, Any]
    sigma_c_of_beta: list[dict]
    master: dict | None = None
    universal: dict | None = None
    bootstrap: dict[str, Any] = field(default_factory=dict)
    identification: dict[str, Any] = field(default_factory=dict)

    @property
    def contact(self) -> dict:
        return self.test.contact

    def values(self) -> dict[str, float]:
        return fitted_values(self.params)

    @property
    def modulus_route(self) -> dict:
        """Which route gave E (``yield_info["youngs_modulus"]``): the Hertz part, or the
        unloading stiffness where the record does not resolve its Hertz part."""
        return self.yield_info.get("youngs_modulus", {"route": "hertz_part"})

    def virgin(self):
        return _virgin(self.test)


def fitted_values(params: LawParams) -> dict[str, float]:
    """The values a fit produces (what the bootstrap gives standard errors of)."""
    residual_limit, residual_power, _, _ = params.residual_closed_form("the laboratory fit")
    out = {
        "youngs_modulus_Pa": params.material.youngs_modulus,
        "effective_modulus_Pa": params.material.effective_modulus,
        "compressive_yield_stress_Pa": params.material.compressive_yield_stress,
        "yield_force_N": params.yield_force,
        "yield_approach_m": params.yield_approach,
        "elastic_plastic_exponent": params.elastic_plastic_exponent,
        "fully_plastic_approach_ratio": params.fully_plastic_approach_ratio,
        "fully_plastic_exponent": params.fully_plastic_exponent,
        "unloading_power": params.unloading_power,
        "reloading_power": params.reloading_power,
        "residual_limit": residual_limit,
        "residual_power": residual_power,
        "plastic_work_limit": params.plastic_work_limit,
        "plastic_work_power": params.plastic_work_power,
    }
    return {k: float(v) for k, v in out.items()}


def _material(kh, radius, nu, beta, m, sigma_c=None, yield_force=None) -> Material:
    """The material of Hertz coefficient ``kh`` (E from E* and nu) with ``sigma_c``, or with the
    sigma_c whose analytic incipient yield is ``yield_force``."""
    e = youngs_modulus_of(kh, radius, nu)
    trial = Material(youngs_modulus=e, poissons_ratio=nu,
                     compressive_yield_stress=sigma_c or 1e-3 * e,
                     friction_angle_deg=beta, hardening_ratio=m, radius=radius)
    if sigma_c is not None:
        return trial
    return trial.with_(compressive_yield_stress=sigma_c_of_yield(yield_force, trial))


@dataclass
class Prepared:
    """A conditioned record with its virgin loading, Hertz coefficient and departure."""

    test: LabTest
    virgin_approach: np.ndarray
    virgin_force: np.ndarray
    hertz_coefficient: float
    departure: dict
    nu: float
    beta: float
    m: float
    # the other contact point (the whole record's, or its refinement on the Hertz onset): which
    # of the two the fit takes is decided by the model of the whole virgin loading
    # (``choose_contact``)
    alternative: Prepared | None = None

    def candidates(self) -> list[Prepared]:
        return [self] + ([self.alternative] if self.alternative is not None else [])

    @property
    def hertz_resolved(self) -> bool:
        """Does the record resolve its Hertz part (the onset refinement, or K refitted on
        enough virgin points below the departure)? Else E* comes from the unloadings."""
        hertz = self.test.contact.get("hertz_part") or {}
        return (self.contact_source == "onset_refinement"
                or hertz.get("first_loading_points", 0) >= HERTZ_PART_POINTS)

    def unloading_peaks(self) -> list[tuple[float, float]]:
        """(delta_max, S) of each closed cycle: its peak and its unloading stiffness."""
        _, info = levels_of(self.test, self.virgin_approach, self.virgin_force)
        return [(c["max_approach_m"], c["unloading_stiffness_N_per_m"]) for c in info]

    @property
    def contact_source(self) -> str:
        return "onset_refinement" if "whole_record" in self.test.contact else "whole_record"

    def first_estimate(self) -> Material:
        """The material with sigma_c analytic at the departure force (a seed: high)."""
        return _material(self.hertz_coefficient, self.test.radius, self.nu, self.beta, self.m,
                         yield_force=self.departure["force_N"])


def prepare(record: Record, setup: str, radius: float, *, machine_stiffness=None,
            poissons_ratio=None, friction_angle=None, hardening_ratio=None,
            force=None) -> Prepared:
    """Condition the record (``labtest.curve.condition``), check its cycles, find where the
    virgin loading leaves Hertz and refit the contact point below that."""
    nu = DEFAULT_POISSONS_RATIO if poissons_ratio is None else float(poissons_ratio)
    beta = DEFAULT_FRICTION_ANGLE if friction_angle is None else float(friction_angle)
    m = DEFAULT_HARDENING_RATIO if hardening_ratio is None else float(hardening_ratio)
    Material(youngs_modulus=1e9, poissons_ratio=nu, compressive_yield_stress=1e6,
             friction_angle_deg=beta, hardening_ratio=m, radius=radius)  # range checks
    test = condition(record, setup, radius, machine_stiffness, force=force)
    closed = [c for c in test.cycles if c.closed]
    if len(closed) < MIN_LEVELS:
        raise InputError(f"curve: {len(closed)} closed load-unload cycle(s) (unloading below "
                         f"10 % of the peak); fit needs >= {MIN_LEVELS} to peaks past yield: "
                         "unload each cycle to near zero force")
    scale = 1.0 if setup != "flat" else 2.0 ** -HERTZ_EXPONENT  # K of u -> K of delta
    vd, vf = _virgin(test)
    kh = _first_coefficient(test, vd, vf, scale)
    leave = departure(vd, vf, kh, test.noise)
    refined = _refine_on_onset(record, test, leave, machine_stiffness, force)
    whole = _with_hertz_part(Prepared(test, vd, vf, kh, leave, nu, beta, m))
    if refined is None:
        return whole
    vd, vf = _virgin(refined)
    # K of the onset fit (contact free, pre-contact points in): the Hertz part's own
    kh = refined.contact["stiffness"] * scale
    onset = Prepared(refined, vd, vf, kh, departure(vd, vf, kh, refined.noise), nu, beta, m)
    # before a model of the whole virgin loading can judge (choose_contact), the more precise
    # of the two comes first (what --identify departure keeps)
    pair = 2.0 if test.setup == "flat" else 1.0
    precise = (refined.contact["onset_refinement"]["approach_shift_se_m"]
               < pair * test.contact["contact_displacement_se_m"])
    first, other = (onset, whole) if precise else (whole, onset)
    first.alternative = other
    return first


def _with_hertz_part(prepared: Prepared) -> Prepared:
    """K of the Hertz part alone (the envelope's onset K carries the bend's form error), when
    enough virgin points lie below the departure."""
    vd, vf, test = prepared.virgin_approach, prepared.virgin_force, prepared.test
    hertz = hertz_part(vd, vf, prepared.departure["approach_m"], test.noise)
    if hertz is None:
        return prepared
    # the Hertz part is the first loading's: a departure found past the first peak (a K too
    # low, on a sparse first loading) would take the next cycles' plastic points for Hertz
    first = test.approach[test.cycles[0].peak] if test.cycles else math.inf
    hertz["first_loading_points"] = int(np.sum(
        (vd > 0) & (vd <= first) & (vd < prepared.departure["approach_m"])
        & (vf > 5.0 * test.noise)))
    test.contact["hertz_part"] = hertz
    kh = hertz["coefficient"]
    return replace(prepared, hertz_coefficient=kh, departure=departure(vd, vf, kh, test.noise))


def choose_contact(prepared: Prepared, misfit, by: str) -> Prepared:
    """Of the whole-record contact and its refinement on the Hertz onset, the one under which
    ``misfit`` (of a model of the whole virgin loading: the FE master curve's scale fit, the
    universal law's) is lower. The onset refinement places the contact on the first loading's
    Hertz part alone, and that part of a record can carry its own form error (on an FE-made
    record the force steps as contact nodes engage: -1.6 nm of approach on the noise-free flat
    test); the model of the whole loading says which contact the rest of the record agrees
    with. Returns the chosen candidate, its contact annotated (``choice``)."""
    options = prepared.candidates()
    scores = {p.contact_source: float(misfit(p)) for p in options}
    if len(options) == 1:
        return prepared
    best = min(options, key=lambda p: scores[p.contact_source])
    best.test.contact["choice"] = {"chosen": best.contact_source, "by": by, "misfit": scores}
    return replace(best, alternative=None)


BY_MASTER = "misfit of the FE master curve's scale fit over the virgin loading"
BY_UNIVERSAL = "misfit of the universal law along the whole record"
HERTZ_PART_POINTS = 20  # virgin points above the noise below the departure to refit K
ONSET_SHARE = 0.5  # the onset refinement: below this share of the departure force (the
                   # points between it and the departure are up to 3 % below Hertz)
HERTZ_SHARE = 0.25  # the first look for the departure: K below this share of the first peak


def _refine_on_onset(record: Record, test: LabTest, leave: dict, machine_stiffness,
                     force) -> LabTest | None:
    """The record conditioned again at the contact refined on the Hertz onset
    (``contact.fit_onset``) when the onset is resolved (enough points above the noise below the
    departure; the envelope's bend past yield carries a form error the Hertz part has not, and
    the Hertz part may carry its own: ``choose_contact``). None otherwise."""
    first_peak = test.cycles[0].peak if test.cycles else test.force.size - 1
    onset = fit_onset(test.approach, test.force, test.noise, ONSET_SHARE * leave["force_N"],
                      first_peak)
    whole = dict(test.contact)
    pair = 2.0 if test.setup == "flat" else 1.0  # approach per machine displacement
    test.contact["onset_refinement"] = onset or "too few points above the noise"
    if onset is None:
        return None
    contact = {**whole,
               "contact_displacement_m": whole["contact_displacement_m"]
               + onset["approach_shift_m"] / pair,
               "contact_displacement_se_m": onset["approach_shift_se_m"] / pair,
               "offset_N": whole["offset_N"] + onset["offset_shift_N"],
               "stiffness": onset["coefficient"] * pair**HERTZ_EXPONENT,
               "whole_record": {k: whole[k] for k in (
                   "contact_displacement_m", "contact_displacement_se_m", "offset_N",
                   "stiffness")},
               "onset_refinement": onset}
    contact.pop("noise_N", None)
    return condition(record, test.setup, test.radius, machine_stiffness, force=force,
                     contact=contact)


def _first_coefficient(test: LabTest, vd, vf, scale: float) -> float:
    """K (pair) to look for the departure from Hertz with: F = K d^1.5 over the virgin points
    below HERTZ_SHARE of the first cycle's peak force (the Hertz part on any test whose first
    peak is past yield), else the whole-record envelope's onset K (a smooth bend's onset can
    overshoot Hertz, and a K too high finds no Hertz part at all)."""
    first_peak = float(test.force[test.cycles[0].peak]) if test.cycles else float(vf.max())
    quarter = hertz_part(vd, vf, math.inf, test.noise, upto_force=HERTZ_SHARE * first_peak)
    return quarter["coefficient"] if quarter else test.contact["stiffness"] * scale


def hertz_part(vd, vf, upto: float, noise: float, *, upto_force: float = math.inf
               ) -> dict | None:
    """K of F = K d^1.5 by linear least squares over the virgin points above 5 sigma below the
    departure approach ``upto`` (and ``upto_force``; the contact point fixed); None with fewer
    than HERTZ_PART_POINTS such points."""
    use = (vd > 0) & (vd < upto) & (vf > 5.0 * noise) & (vf < upto_force)
    if use.sum() < HERTZ_PART_POINTS:
        return None
    x = vd[use] ** HERTZ_EXPONENT
    k = float(np.dot(x, vf[use]) / np.dot(x, x))
    rms = float(np.sqrt(np.mean((k * x - vf[use]) ** 2)))
    return {"coefficient": k, "points": int(use.sum()), "upto_approach_m": float(upto),
            "rms_N": rms}


def fit_once(record: Record, setup: str, radius: float, *, machine_stiffness=None,
             poissons_ratio=None, friction_angle=None, hardening_ratio=None,
             force=None, master: dict | None = None,
             prepared: Prepared | None = None, universal: dict | None = None) -> LabFit:
    """Condition the record and fit the law once (no bootstrap).

    Yield: with ``master`` (an FE master curve of ``labtest.identify``) sigma_c is its scale
    fitted to this record's virgin loading and delta_y the Hertz approach of the FE first-yield
    force scaled with it (as ``geocontact calibrate`` takes delta_y from the FE's first yield);
    without, delta_y is where the record leaves Hertz (``departure``) and sigma_c the analytic
    one at that force (a first estimate: the departure lies past the first yield)."""
    if prepared is None:
        prepared = prepare(record, setup, radius, machine_stiffness=machine_stiffness,
                           poissons_ratio=poissons_ratio, friction_angle=friction_angle,
                           hardening_ratio=hardening_ratio, force=force)
    if master is not None:
        # each candidate at the contact the master curve puts it (a record whose E comes from
        # its unloadings is refined at that E below, once chosen), then the better one
        prepared = _refined_by_master(record, prepared, master, machine_stiffness, force)
        prepared = choose_contact(prepared, lambda p: _scale_fit(master, p)[2], BY_MASTER)
    elif prepared.alternative is not None:  # nothing to judge by: the more precise one
        prepared = choose_contact(prepared, lambda p: 0.0 if p is prepared else 1.0,
                                  "standard error (no model of the whole virgin loading)")
    test, vd, vf = prepared.test, prepared.virgin_approach, prepared.virgin_force
    kh, leave = prepared.hertz_coefficient, prepared.departure
    nu, beta, m = prepared.nu, prepared.beta, prepared.m
    if universal is not None:
        sigma_c = universal["compressive_yield_stress_Pa"]
        material = _material(kh, radius, nu, beta, m, sigma_c=sigma_c)
        fy = universal["yield_force_N"] * (hertz_coefficient(material) / hertz_coefficient(
            universal["material"])) ** -2  # Fy ~ 1/E*^2 at a fixed sigma_c
        yield_info = {"source": "universal law (universal.for_material) of the identified "
                                "material", "force_N": fy}
    elif master is None:
        fy = leave["force_N"]
        material = _material(kh, radius, nu, beta, m, yield_force=fy)
        yield_info = {"source": "departure from Hertz (no identification)",
                      "force_N": fy}
    else:
        s, e, misfit, _ = _scale_fit(master, prepared)
        if not prepared.hertz_resolved:
            prepared = _contact_at_modulus(record, prepared, master, s, e, machine_stiffness,
                                           force)
        test, vd, vf = prepared.test, prepared.virgin_approach, prepared.virgin_force
        s, e, misfit, _ = _scale_fit(master, prepared)
        trial = master["material"]
        # the master curve is in units of the analytic yield: Fy ~ sigma_c^3 / E*^2
        analytic_fy = master["yield_force_N"] * s**3 / e**2
        material = trial.with_(compressive_yield_stress=s * trial.compressive_yield_stress,
                               youngs_modulus=e * trial.youngs_modulus,
                               poissons_ratio=nu, friction_angle_deg=beta, hardening_ratio=m)
        hertz_part = {"youngs_modulus_Pa": youngs_modulus_of(kh, radius, nu),
                      "note": "E from the contact-point fit of the Hertz part alone"}
        modulus = _modulus_routes(master, prepared, s, material)
        if not prepared.hertz_resolved:
            modulus.update(_sigma_c_from_factor(master, prepared, modulus))
        kh = hertz_coefficient(material)
        fy = analytic_fy * master["fe_over_analytic_yield"]
        yield_info = {"source": "FE master curve (geocontact.labtest.identify): the FE first "
                                "yield force of the identified material (as geocontact "
                                "calibrate takes it)",
                      "force_N": fy, "analytic_force_N": analytic_fy,
                      "fe_over_analytic": master["fe_over_analytic_yield"], "scale": s,
                      "modulus_scale": e, "hertz_part": hertz_part,
                      "youngs_modulus": modulus,
                      "misfit": misfit, "fe_cache_key": master["cache_key"]}
    if master is None:
        yield_info["youngs_modulus"] = {
            "route": "hertz_part",
            "why": "E* from the Hertz part" + (
                "" if prepared.hertz_resolved else
                ", which this record does not resolve (fewer than "
                f"{HERTZ_PART_POINTS} points of its first loading above 5 sigma below the "
                "departure): E is poorly fixed; --identify fe takes E* from the unloading "
                "stiffness instead")}
    dy = (fy / kh) ** (1.0 / HERTZ_EXPONENT)
    yield_info["approach_m"] = dy
    levels, info = levels_of(test, vd, vf)
    deep = [lv for lv in levels if lv.max_approach > 1.05 * dy]
    if len(deep) < MIN_LEVELS:
        raise InputError(f"curve: {len(deep)} cycle(s) peak past the yield approach "
                         f"({dy:.3g} m; the record's peak is {test.peak_force / fy:.3g} x the "
                         f"first-yield force {fy:.3g} N); fit needs >= {MIN_LEVELS}: load to "
                         "higher peaks")
    provenance = {"source": "laboratory test (geocontact fit)", "test": test.inputs()}
    with np.errstate(divide="ignore"):  # a level with no residual: its relative error is inf
        params = fit_law(material, dy, vd, vf, deep, provenance=provenance)
    # beyond the record's deepest closed cycle the law extrapolates (docs/fit.md)
    params = replace(params, calibrated_range_extra={
        **params.calibrated_range_extra,
        "source": f"the deepest of the record's {len(deep)} closed cycles past yield"})
    given = {"poissons_ratio": poissons_ratio, "friction_angle_deg": friction_angle,
             "hardening_ratio": hardening_ratio, "radius_m": radius, "setup": setup,
             "machine_stiffness_N_per_m": machine_stiffness}
    given = {k: v for k, v in given.items() if v is not None}
    assumed = {}
    if poissons_ratio is None:
        assumed["poissons_ratio"] = {"value": nu, "why": "not given; E = 2 (1 - nu^2) E* "
                                     "depends on it, E* does not"}
    if friction_angle is None:
        assumed["friction_angle_deg"] = {
            "value": beta, "why": "not given; one test fixes the yield force, not sigma_c and "
                                  "beta apart: see sigma_c_of_beta"}
    if hardening_ratio is None:
        assumed["hardening_ratio"] = {"value": m, "why": "not given; not identified from one "
                                                         "curve"}
    return LabFit(params=params, test=test, levels=info, yield_info=yield_info,
                  departure=leave, given=given, assumed=assumed, sigma_c_of_beta=[],
                  master=master, universal=universal)


def _scale_fit(master: dict, prepared: Prepared):
    """(sigma_c, E*) scales of the master curve on the record: E* from the Hertz part where the
    record resolves it (``identify.scale_fit``), else from the unloading stiffness
    (``identify.scale_fit_unloading``)."""
    from .identify import scale_fit, scale_fit_unloading

    vd, vf, noise = prepared.virgin_approach, prepared.virgin_force, prepared.test.noise
    if prepared.hertz_resolved:
        return scale_fit(master, vd, vf, noise)
    return scale_fit_unloading(master, vd, vf, noise, prepared.unloading_peaks())


def _refined_by_master(record: Record, prepared: Prepared, master: dict, machine_stiffness,
                       force) -> Prepared:
    """Each contact candidate whose record resolves its Hertz part refined by the master curve
    (``_contact_by_master``), the alternative kept: the choice between them is then made at the
    contacts the fit would use. Compared before, on the noisy ramp record the whole record's
    contact (-0.16 dy) won by 0.7 % of misfit and its refinement stayed at -0.14 dy (sigma_c
    +20 %), while the onset's refinement, -0.03 dy, fits 5 % better (sigma_c +4.9 %)."""
    refined = [_contact_by_master(record, p, master, machine_stiffness, force)
               if p.hertz_resolved else replace(p, alternative=None)
               for p in prepared.candidates()]
    first = refined[0]
    first.alternative = refined[1] if len(refined) > 1 else None
    return first


def _contact_by_master(record: Record, prepared: Prepared, master: dict, machine_stiffness,
                       force) -> Prepared:
    """The chosen contact point (``choose_contact``) refined by the FE master curve itself: the
    shift of the approach under which the master curve, scaled in (sigma_c, E*), fits the
    virgin loading best (``identify.scale_fit_contact``); the record is conditioned again
    there. The whole record's power laws and the Hertz onset each carry a form error that
    moves the contact by hundredths of dy (-0.012 dy on the flat test under its load-cell
    noise, -0.027 dy on the noise-free ramp record's onset), and sigma_c moves by several per
    cent per hundredth; the master curve is the model sigma_c is read with (docs/fit.md, "The
    contact point and the master curve")."""
    from .identify import scale_fit_contact

    test = prepared.test
    found = scale_fit_contact(master, prepared.virgin_approach, prepared.virgin_force,
                              test.noise)
    pair = 2.0 if test.setup == "flat" else 1.0
    whole = test.contact
    refinement = {
        "method": "the FE master curve's scale fit over the virgin loading with the contact "
                  "shift a third parameter (labtest.identify.scale_fit_contact)",
        **{k: found[k] for k in ("approach_shift_m", "approach_shift_se_m", "on_bound",
                                 "misfit")},
        "before": {k: whole[k] for k in ("contact_displacement_m",
                                         "contact_displacement_se_m")}}
    contact = {**whole,
               "contact_displacement_m": whole["contact_displacement_m"]
               + found["approach_shift_m"] / pair,
               "master_refinement": refinement}
    if math.isfinite(found["approach_shift_se_m"]):  # the shift absorbs the chosen's error
        contact["contact_displacement_se_m"] = found["approach_shift_se_m"] / pair
    contact.pop("noise_N", None)
    refined = condition(record, test.setup, test.radius, machine_stiffness, force=force,
                        contact=contact)
    vd, vf = _virgin(refined)
    return replace(prepared, test=refined, virgin_approach=vd, virgin_force=vf,
                   alternative=None)


def _contact_at_modulus(record: Record, prepared: Prepared, master: dict, s: float, e: float,
                        machine_stiffness, force) -> Prepared:
    """The contact point of a record without a resolved Hertz part, refined once E* is known
    from its unloadings: F = f0 + K (delta - shift)_+^1.5 with K = (4/3) E* sqrt(R*) fixed and
    the offset the whole record's, fitted for the shift alone on the first loading's points
    (pre-contact ones and those at the noise included) below ONSET_SHARE of the force where the
    master curve at the scales (s, e) leaves Hertz by DEPARTURE. With K known one parameter is
    left, which the few points of a sparse first loading fix (the whole record alone leaves
    0.24 dy on the sparse record, and sigma_c moves with it); the record is conditioned again
    there."""
    from scipy.optimize import least_squares as fit_ls

    test = prepared.test
    trial = master["material"]
    e_star = e * trial.effective_modulus
    kh = 4.0 / 3.0 * e_star * math.sqrt(trial.effective_radius)
    x, g = np.asarray(master["x"]), np.asarray(master["g"])
    left = np.flatnonzero((x > 1.0) & (g < (1.0 - DEPARTURE) * x**HERTZ_EXPONENT))
    if left.size == 0 or not test.cycles:
        return prepared
    fy = master["yield_force_N"] * s**3 / e**2
    upto = ONSET_SHARE * fy * float(x[left[0]]) ** HERTZ_EXPONENT
    first = test.cycles[0].peak
    d, f = test.approach[: first + 1], test.force[: first + 1]
    use = f < upto
    if int(np.sum(use & (f > 0.0))) < 3:
        return prepared
    d, f = d[use], f[use]
    scale = float(max(d.max(), 1e-30))

    def residual(theta):
        return kh * np.maximum(d - theta[0] * scale, 0.0) ** HERTZ_EXPONENT - f

    found = fit_ls(residual, [0.0], bounds=([-0.5], [0.5]))
    s2 = 2.0 * found.cost / max(f.size - 1, 1)
    se = float(math.sqrt(s2 / max(float(found.jac[:, 0] @ found.jac[:, 0]), 1e-300))) * scale
    shift = float(found.x[0]) * scale
    pair = 2.0 if test.setup == "flat" else 1.0
    whole = test.contact
    contact = {**whole,
               "contact_displacement_m": whole["contact_displacement_m"] + shift / pair,
               "contact_displacement_se_m": se / pair,
               "stiffness": kh * pair**HERTZ_EXPONENT,
               "modulus_refinement": {
                   "method": "F = f0 + K (delta - shift)_+^1.5, K from E* of the unloading "
                             "stiffness, on the first loading below "
                             f"{ONSET_SHARE:g} x the master curve's departure force",
                   "approach_shift_m": shift, "approach_shift_se_m": se,
                   "upto_N": upto, "points": int(f.size), "coefficient": kh,
                   "before": {k: whole[k] for k in ("contact_displacement_m",
                                                    "contact_displacement_se_m")}}}
    contact.pop("noise_N", None)
    refined = condition(record, test.setup, test.radius, machine_stiffness, force=force,
                        contact=contact)
    if whole.get("hertz_part") is not None:
        refined.contact.setdefault("hertz_part", whole["hertz_part"])
    vd, vf = _virgin(refined)
    return replace(prepared, test=refined, virgin_approach=vd, virgin_force=vf,
                   alternative=None)


def _sigma_c_from_factor(master: dict, prepared: Prepared, modulus: dict) -> dict:
    """How far sigma_c moves when E* is off by the unloading stiffness factor's own scatter
    (``stiffness.scatter``, the FE unloadings about beta(a/R)): the scale fit rerun at
    E* x (1 -+ that share); half the range is sigma_c's systematic error from it."""
    from .identify import scale_fit_unloading
    from .stiffness import scatter

    vd, vf, noise = prepared.virgin_approach, prepared.virgin_force, prepared.test.noise
    peaks = prepared.unloading_peaks()
    trial = master["material"].compressive_yield_stress
    sigma = [scale_fit_unloading(master, vd, vf, noise, peaks, modulus_factor=1.0 + k * scatter())
             [0] * trial for k in (-1.0, 1.0)]
    return {"sigma_c_from_stiffness_factor_Pa": sigma,
            "sigma_c_stiffness_factor_standard_error_Pa": 0.5 * abs(sigma[1] - sigma[0])}


def _modulus_routes(master: dict, prepared: Prepared, s: float, material: Material) -> dict:
    """Which route gave E, and the unloading stiffness's estimate of E beside it (with its
    standard error over the cycles) whichever route was taken: a cross-check."""
    from .identify import unloading_modulus

    if "a" not in master:
        return {"route": "hertz_part", "why": "the master curve has no contact radius"}
    u = unloading_modulus(master, prepared.unloading_peaks(), s)
    trial = master["material"].youngs_modulus
    route = "hertz_part" if prepared.hertz_resolved else "unloading_stiffness"
    return {"route": route,
            "why": ("the record resolves its Hertz part (onset refinement or >= "
                    f"{HERTZ_PART_POINTS} virgin points above 5 sigma below the departure)"
                    if prepared.hertz_resolved else
                    "the record does not resolve its Hertz part: E* from the unloading "
                    "stiffness S = 2 beta E* a at each peak, a the master curve's FE contact "
                    "radius, beta(a/R) the FE unloadings' (labtest.stiffness)"),
            "unloading_stiffness_Pa": u["scale"] * trial,
            "unloading_stiffness_standard_error_Pa": (u["standard_error"] * trial
                                                      if u["standard_error"] else None),
            "stiffness_factor_per_cycle": u["stiffness_factor"],
            "stiffness_factor_standard_error_Pa": u["stiffness_factor_standard_error"] * trial,
            "unloading_stiffness_per_cycle_Pa": [v * trial for v in u["per_cycle"]],
            "youngs_modulus_Pa": material.youngs_modulus}


def sigma_c_of_beta(result: LabFit) -> list[dict]:
    """sigma_c against beta at the fitted yield force (analytic incipient yield): what one
    test cannot separate."""
    material, fy = result.params.material, result.params.yield_force
    return [{"friction_angle_deg": b,
             "compressive_yield_stress_Pa": sigma_c_of_yield(
                 fy, material.with_(friction_angle_deg=b))} for b in BETA_PROFILE]


def refit(record: Record, result: LabFit, setup: str, radius: float, force,
           **options) -> LabFit:
    """One bootstrap refit: with the main fit's FE master curve, or, in the universal mode,
    sigma_c identified again from the whole resampled record (about the main fit's)."""
    if result.universal is None:
        return fit_once(record, setup, radius, force=force, master=result.master, **options)

    prepared, found = _universal(prepare(record, setup, radius, force=force, **options),
                                 beta_given=True,
                                 start_sigma=result.universal["compressive_yield_stress_Pa"])
    return fit_once(record, setup, radius, prepared=prepared, universal=found, **options)


def _universal(prepared: Prepared, **options) -> tuple[Prepared, dict]:
    """sigma_c identified with the universal law (``identify.identify_universal``) for each
    contact candidate; the one whose whole-record misfit is lower (``choose_contact``)."""
    from .identify import identify_universal

    found = {}

    def misfit(p: Prepared) -> float:
        found[p.contact_source] = identify_universal(
            p.first_estimate(), p.virgin_approach, p.virgin_force, p.test.noise,
            approach=p.test.approach, force=p.test.force, **options)
        return found[p.contact_source]["misfit"]

    chosen = choose_contact(prepared, misfit, BY_UNIVERSAL)
    return chosen, found[chosen.contact_source]


def bootstrap(record: Record, result: LabFit, setup: str, radius: float, *, samples: int,
              seed: int, progress=None, **options) -> dict[str, Any]:
    """Residual bootstrap of the force noise (module docstring): standard errors of every
    fitted value over ``samples`` refits (``refit``: the main fit's FE master curve, no new FE
    run; or sigma_c re-identified with the universal law).
    A refit that fails (a resample that breaks a condition) is counted, not hidden."""
    f = np.asarray(record.force, dtype=float)
    # in time, as the noise estimate (curve.local_smoothing: uneven sampling is not noise)
    smooth, leverage = local_smoothing(f, record.time)
    residual = (f - smooth) / np.sqrt(1.0 - leverage)
    # the pool is the noise: residuals beyond 4 sigma are the smoothing's error at the record's
    # kinks (turning points, lift-off), signal not noise
    sigma = 1.4826 * float(np.median(np.abs(residual - np.median(residual))))
    residual = residual[np.abs(residual - np.median(residual)) <= 4.0 * sigma]
    residual -= residual.mean()
    rng = np.random.default_rng(seed)
    rows, failed = [], []
    for k in range(samples):
        force = smooth + rng.choice(residual, size=f.size, replace=True)
        try:
            rows.append(fitted_values(refit(record, result, setup, radius, force,
                                             **options).params))
        except InputError as exc:
            failed.append(str(exc))
        if progress:
            progress(k + 1, samples)
    names = list(result.values())
    values = {n: np.array([r[n] for r in rows]) for n in names}
    main = result.values()
    return {
        "method": "residual bootstrap: the force noise (residual about a local quadratic "
                  "smoothing in time, rescaled to the raw noise) resampled with replacement "
                  "onto the smoothed record; contact point, segmentation, yield scale and law "
                  "fit rerun per sample",
        "samples": samples, "seed": seed, "succeeded": len(rows), "failed": len(failed),
        "failures": failed[:3],
        "standard_errors": {n: float(np.std(v, ddof=1)) if v.size > 1 else None
                            for n, v in values.items()},
        "relative_standard_errors": {
            n: (float(np.std(v, ddof=1) / abs(main[n])) if v.size > 1 and main[n] else None)
            for n, v in values.items()},
    }


IDENTIFY = ("fe", "universal", "departure")


def fit_test(record: Record, setup: str, radius: float, *, machine_stiffness=None,
             poissons_ratio=None, friction_angle=None, hardening_ratio=None,
             bootstrap_samples: int = 30, seed: int = 0, identify: str = "fe",
             mesh: str = "coarse", cache_dir=None, progress=None,
             strict_range: bool = False) -> LabFit:
    """The whole fit (module docstring): law, material, bootstrap standard errors; the
    provenance says what came from where. ``identify``: "fe" (sigma_c and delta_y from the FE
    master curve, ``labtest.identify``) or "departure" (no FE run: delta_y where the record
    leaves Hertz, sigma_c analytic there, a biased first estimate). ``strict_range``: refuse,
    before the bootstrap, a record that goes beyond the universal law's calibrated depth
    (``identify.beyond_calibrated_depth``) instead of warning."""
    if identify not in IDENTIFY:
        raise InputError(f"identify: unknown method {identify!r} (allowed: "
                         f"{', '.join(IDENTIFY)})")
    options = dict(machine_stiffness=machine_stiffness, poissons_ratio=poissons_ratio,
                   friction_angle=friction_angle, hardening_ratio=hardening_ratio)
    prepared = prepare(record, setup, radius, **options)
    start = prepared.first_estimate()
    if identify == "fe":
        from .identify import identify_by_fe

        found = identify_by_fe(start, [(p.virgin_approach, p.virgin_force,
                                        None if p.hertz_resolved else p.unloading_peaks())
                                       for p in prepared.candidates()],
                               prepared.test.noise, mesh=mesh, cache_dir=cache_dir,
                               progress=progress is not None)
        result = fit_once(record, setup, radius, master=found["master"], prepared=prepared,
                          **options)
        result.identification = {k: v for k, v in found.items() if k != "master"}
    elif identify == "universal":
        prepared, found = _universal(prepared, beta_given=friction_angle is not None)
        beyond = (found.get("calibrated_range") or {}).get("warning")
        if beyond and strict_range:
            raise InputError(f"curve: {beyond} (--strict-range)")
        result = fit_once(record, setup, radius, prepared=prepared, universal=found, **options)
        result.identification = {k: v for k, v in found.items() if k != "material"}
        result.identification["universal_law"] = {"used": True, **found["universal"]}
    else:
        result = fit_once(record, setup, radius, prepared=prepared, **options)
    result.identification["first_estimate"] = {
        "source": "departure of the virgin loading from Hertz, analytic incipient yield there",
        "yield_force_N": prepared.departure["force_N"],
        "compressive_yield_stress_Pa": start.compressive_yield_stress}
    result.sigma_c_of_beta = sigma_c_of_beta(result)
    if bootstrap_samples:
        result.bootstrap = bootstrap(record, result, setup, radius, samples=bootstrap_samples,
                                     seed=seed, progress=progress, **options)
        _add_systematic(result)
    result.params = replace(result.params, provenance=provenance_of(result),
                            label="fitted to a laboratory test")
    return result


def _add_systematic(result: LabFit) -> None:
    """Standard errors of sigma_c and E: the bootstrap's (noise) and the identification's
    master-curve sensitivity (``identify.master_sensitivity``) added in quadrature; each kept
    apart too."""
    sens = dict(result.identification.get("master_sensitivity", {}).get("standard_errors", {}))
    route = result.modulus_route
    if route["route"] == "unloading_stiffness" and route.get(
            "unloading_stiffness_standard_error_Pa"):
        # E from the unloadings: the cycles' scatter about their median is its own error
        # and beta(a/R)'s own scatter, for E and, through the scale fit, for sigma_c
        sens["youngs_modulus_Pa"] = math.hypot(sens.get("youngs_modulus_Pa", 0.0),
                                               route["unloading_stiffness_standard_error_Pa"],
                                               route.get("stiffness_factor_standard_error_Pa",
                                                         0.0))
        sens["compressive_yield_stress_Pa"] = math.hypot(
            sens.get("compressive_yield_stress_Pa", 0.0),
            route.get("sigma_c_stiffness_factor_standard_error_Pa", 0.0))
    boot = result.bootstrap
    boot["noise_standard_errors"] = dict(boot["standard_errors"])
    for key, value in sens.items():
        noise = boot["standard_errors"].get(key) or 0.0
        boot["standard_errors"][key] = float(math.hypot(noise, value))
        main = result.values()[key]
        boot["relative_standard_errors"][key] = boot["standard_errors"][key] / abs(main)
    if sens:
        boot["method"] += ("; sigma_c and E also carry the identification's master-curve "
                           "sensitivity in quadrature (noise-only values in "
                           "noise_standard_errors)")
    if route["route"] == "unloading_stiffness":
        boot["method"] += ("; E from the unloading stiffness also carries the scatter of the "
                           "cycles' values and of the FE unloadings about beta(a/R) in "
                           "quadrature, sigma_c the latter's effect through the scale fit")


def provenance_of(result: LabFit) -> dict[str, Any]:
    from .identify import universal_law

    p = result.params
    se = (result.bootstrap or {}).get("standard_errors", {})
    identified = result.master is not None
    from_curve = {
        "material.youngs_modulus": (
            "E* of the Hertz part (contact-point fit), E = 2 (1 - nu^2) E* with the given or "
            "assumed nu" if result.modulus_route["route"] == "hertz_part" else
            "E* from the unloading stiffness S = 2 beta E* a at each cycle's peak (median over "
            "the cycles; a from the FE master curve, beta(a/R) from the FE unloadings of "
            "datasets/fe-runs), E = 2 (1 - nu^2) E*: the record does not "
            "resolve its Hertz part"),
        "youngs_modulus_route": result.modulus_route,
        "material.compressive_yield_stress": (
            "FE master curve scaled onto the virgin loading at the given or assumed nu, beta, "
            "m" if identified else "analytic incipient yield at the force where the record "
                                   "leaves Hertz (biased high: docs/fit.md)"),
        "yield.approach_m": ("Hertz approach of the identified FE first-yield force"
                             if identified else "departure of the virgin loading from Hertz"),
        "loading, unloading, reloading, residual_approach, plastic_work":
            "calibrate.fit.fit_law on the measured virgin loading and cycles",
    }
    return {
        **p.provenance,
        "fitted_from_curve": from_curve,
        "given": result.given,
        "assumed": result.assumed,
        "universal_law": result.identification.get("universal_law") or {
            "used": False, "why": (
                "geocontact.universal.for_material (issue 12) is not in this installation"
                if universal_law() is None else
                "not used by this fit (--identify fe: the FE master curve instead)")},
        "contact_point": result.contact,
        "yield": result.yield_info,
        "departure_from_hertz": {k: v for k, v in result.departure.items()
                                 if k != "ratio_profile"},
        "identification": result.identification,
        "cycles": result.levels,
        "sigma_c_of_beta": result.sigma_c_of_beta,
        "values": result.values(),
        "uncertainty": {**{k: v for k, v in (result.bootstrap or {}).items()
                           if k not in ("standard_errors", "relative_standard_errors")},
                        "standard_errors": se,
                        "relative_standard_errors": (result.bootstrap or {}).get(
                            "relative_standard_errors", {})},
    }
