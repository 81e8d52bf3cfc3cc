"""Per-cycle analysis of repeated loading, shared by the calibration and the analyses: the
cycle table, power laws in N, critical cycles, the shakedown classification, and the law's
cyclic extension fitted from it (docs/model.md §6-8; the paper's eqs. 17-20).

Input is a list of cycles as the FE engine reports them (``summary["cycles"]``: a cycle runs from
one zero-force waypoint through its peak to the next) or as the law reports them
(``geocontact.analyses.cycles.law_cycles_by_force``, ``law_cycles_along_path``)::

    analysis = analyse(fe_result.summary["cycles"], tolerance=0.01, source="fe")
    analysis.state, analysis.critical_cycle, analysis.residual_fit.power
    params = with_cyclic(params, analysis)   # the law's cyclic power laws from it

Definitions (cycle N = 1, 2, ...):

* ``residual_approach_increment_m`` of cycle N = its residual approach minus cycle N-1's;
  cycle 1's is its residual approach;
* ``residual_increment_ratio`` = increment_N / increment_1,
  ``plastic_work_ratio`` = Wp_N / Wp_1 (FE: the plastic dissipation of the cycle; law: its loop
  area, which is its dissipation because a cycle starts and ends at zero force);
* power laws ``ratio = c N^-p`` fitted by least squares in log-log over cycles N >= 2 with a
  positive ratio (the paper's eqs. 17-20; cycle 1's ratio is 1 by definition);
* critical cycle Nc: the first N >= 2 whose ratio is below ``tolerance`` - measured in the run,
  and extrapolated from the fit, ceil((c/tol)^(1/p)) (the formula of ``CyclicLaw``);
* shakedown state (:func:`shakedown_rule`, shared with ``seismic.classify``): from the last cycle,
  **ratchetting** if its residual increment is above ``tolerance`` x cycle 1's, else **plastic
  shakedown** if its plastic work is above ``tolerance`` x cycle 1's (a closed loop that still
  dissipates), else **elastic shakedown**; **elastic** if even cycle 1 left neither residual
  approach nor plastic work. The *eventual* state applies the same rule to the fitted power laws
  within ``horizon`` cycles: a ratio that decays (p > 0) below the tolerance by then counts as
  gone.
"""

from __future__ import annotations

import copy
import math
from dataclasses import asdict, dataclass, field, replace
from typing import Any

import numpy as np

from ..errors import InputError
from ..law.params import power_law_critical_cycle

ELASTIC = "elastic"
ELASTIC_SHAKEDOWN = "elastic shakedown"
PLASTIC_SHAKEDOWN = "plastic shakedown"
RATCHETTING = "ratchetting"
UNDETERMINED = "undetermined (one cycle)"

DEFAULT_TOLERANCE = 0.01
# Cycles within which a decaying power law must reach the tolerance to count as "eventual"
# shakedown (a DEM or seismic history rarely loads one contact more often than this).
DEFAULT_HORIZON = 1000
# Ratios below this are round-off, not data, and are not fitted (the law's force-driven cycles
# leave ~1e-13 from the bisection; the smallest FE ratio seen in the paper study is ~1e-8).
ROUND_OFF = 1e-10
# Cycle 1 counts as elastic when its residual approach and plastic work are below this fraction
# of its max approach and of Fmax x max approach (the FE leaves < 1e-6 after elastic unloading).
ELASTIC_FLOOR = 1e-6
# A residual increment below this fraction of cycle 1's residual approach is at the FE's
# resolution (its sign flips between cycles): no ratchetting in that cycle.
RESOLUTION = 1e-5


def shakedown_rule(residual_growth: float, residual_reference: float, dissipation: float,
                   dissipation_reference: float, tolerance: float) -> str:
    """The shakedown state from late growth against a reference growth (docs/model.md §6).

    Ratchetting while the residual approach still grows by more than ``tolerance`` of the
    reference; plastic shakedown when it has stopped but the dissipation has not (closed loops);
    elastic shakedown when both have stopped."""
    if residual_growth > tolerance * residual_reference:
        return RATCHETTING
    if dissipation > tolerance * dissipation_reference:
        return PLASTIC_SHAKEDOWN
    return ELASTIC_SHAKEDOWN


@dataclass(frozen=True)
class PowerLaw:
    """ratio(N) = coefficient * N^-power, fitted in log-log, with its fit errors."""

    coefficient: float
    power: float
    cycles_used: list[int]
    cycles_excluded: list[int]  # N >= 2 whose ratio was <= ROUND_OFF (zero or negative)
    rms_log10_error: float
    max_relative_error: float
    power_standard_error: float | None  # None with two points (an exact fit)

    def __call__(self, cycle):
        return self.coefficient * np.asarray(cycle, dtype=float) ** (-self.power)

    def critical_cycle(self, tolerance: float) -> int | None:
        return power_law_critical_cycle(self.coefficient, self.power, tolerance)

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


def _log_fit(cycles, ratios, abscissa):
    """Least squares of log(ratio) against abscissa(N) over N >= 2 with ratio > ROUND_OFF."""
    n = np.asarray(cycles, dtype=float)
    r = np.asarray(ratios, dtype=float)
    later = n >= 2
    use = later & (r > ROUND_OFF) & np.isfinite(r)
    if np.count_nonzero(use) < 2:
        return None
    x, y = abscissa(n[use]), np.log(r[use])
    slope, intercept = np.polyfit(x, y, 1)
    residual = y - (intercept + slope * x)
    se = None
    if x.size > 2:
        sxx = float(np.sum((x - x.mean()) ** 2))
        se = float(math.sqrt(float(np.sum(residual**2)) / (x.size - 2) / sxx))
    errors = {
        "cycles_used": [int(k) for k in n[use]],
        "cycles_excluded": [int(k) for k in n[later & ~use]],
        "rms_log10_error": float(np.sqrt(np.mean(residual**2)) / math.log(10.0)),
        "max_relative_error": float(np.max(np.abs(np.expm1(-residual)))),
    }
    return float(slope), float(intercept), se, errors


def fit_power_law(cycles, ratios) -> PowerLaw | None:
    """Least-squares fit of log(ratio) = log(c) - p log(N) over N >= 2 with ratio > 0.

    Returns None with fewer than two usable cycles."""
    fit = _log_fit(cycles, ratios, np.log)
    if fit is None:
        return None
    slope, intercept, se, errors = fit
    return PowerLaw(coefficient=math.exp(intercept), power=-slope, power_standard_error=se,
                    **errors)


@dataclass(frozen=True)
class GeometricLaw:
    """ratio(N) = coefficient * factor^N: a constant factor per cycle. A diagnostic beside the
    power law (the paper's form, which the law uses): FE ratios that fall by a steady factor
    per cycle are fitted better by it, and its critical cycle is then the better estimate."""

    coefficient: float
    factor: float
    cycles_used: list[int]
    cycles_excluded: list[int]
    rms_log10_error: float
    max_relative_error: float

    def __call__(self, cycle):
        return self.coefficient * self.factor ** np.asarray(cycle, dtype=float)

    def critical_cycle(self, tolerance: float) -> int | None:
        """First N >= 2 from which c q^N stays below tolerance; None if it never does (q > 1:
        the ratio grows; q = 1 above it)."""
        if self.factor > 1.0:
            return None
        if self.coefficient * self.factor**2 < tolerance:
            return 2
        if self.factor == 1.0:
            return None
        n = math.log(tolerance / self.coefficient) / math.log(self.factor)
        return max(2, math.floor(n) + 1)

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


def fit_geometric(cycles, ratios) -> GeometricLaw | None:
    """Least-squares fit of log(ratio) = log(c) + N log(q) over N >= 2 with ratio > 0."""
    fit = _log_fit(cycles, ratios, lambda n: n)
    if fit is None:
        return None
    slope, intercept, _, errors = fit
    return GeometricLaw(coefficient=math.exp(intercept), factor=math.exp(slope), **errors)


def cycle_table(cycles: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """Per-cycle rows: the input values plus increments and ratios to cycle 1."""
    if not cycles:
        raise InputError("cycles: the history has no complete cycle (no return to zero force)")
    rows = []
    previous = 0.0
    for k, c in enumerate(cycles, 1):
        residual = c.get("residual_approach_m")
        if residual is None:
            raise InputError(f"cycles[{k}]: not closed (the history must end at zero force)")
        rows.append({
            "cycle": k,
            "max_force_N": float(c["max_force_N"]),
            "max_approach_m": float(c["max_approach_m"]),
            "residual_approach_m": float(residual),
            "residual_approach_increment_m": float(residual) - previous,
            "plastic_work_J": float(c["plastic_work_J"]),
            "loop_work_J": float(c.get("loop_work_J", c["plastic_work_J"])),
        })
        previous = float(residual)
    first = rows[0]
    for row in rows:
        row["residual_increment_ratio"] = _ratio(row["residual_approach_increment_m"],
                                                 first["residual_approach_increment_m"])
        row["plastic_work_ratio"] = _ratio(row["plastic_work_J"], first["plastic_work_J"])
        row["max_approach_ratio"] = _ratio(row["max_approach_m"], first["max_approach_m"])
    return rows


def _ratio(value: float, reference: float) -> float | None:
    return value / reference if reference > 0.0 else None


def _stays_below(rows: list[dict], key: str, tolerance: float) -> int | None:
    """First cycle N >= 2 from which the ratio is below ``tolerance`` in every cycle run; None
    if the last one is not (a ratio that dips below and rises again, as over a ratchet's
    onset, has not reached its critical cycle)."""
    first = None
    for row in rows[1:]:
        if row[key] is not None and row[key] < tolerance:
            first = int(row["cycle"]) if first is None else first
        else:
            first = None
    return first


@dataclass
class CycleAnalysis:
    """Everything :func:`analyse` derives from one run's cycles."""

    source: str
    tolerance: float
    horizon: int
    cycles: list[dict[str, Any]]
    residual_fit: PowerLaw | None
    plastic_work_fit: PowerLaw | None
    critical_cycles: dict[str, Any]
    state: str
    eventual_state: str
    rules: dict[str, str] = field(default_factory=dict)
    geometric_fits: dict[str, Any] = field(default_factory=dict)  # diagnostic, see GeometricLaw

    @property
    def critical_cycle(self) -> int | None:
        """Nc of elastic shakedown as measured (both ratios below the tolerance)."""
        return self.critical_cycles["measured"]["elastic_shakedown"]

    def to_dict(self) -> dict[str, Any]:
        return {
            "source": self.source,
            "tolerance": self.tolerance,
            "horizon_cycles": self.horizon,
            "cycles": self.cycles,
            "fits": {
                "residual_increment_ratio": (self.residual_fit.to_dict()
                                             if self.residual_fit else None),
                "plastic_work_ratio": (self.plastic_work_fit.to_dict()
                                       if self.plastic_work_fit else None),
                "form": "ratio = coefficient * N^-power, least squares in log-log over N >= 2",
                "geometric": self.geometric_fits,
                "geometric_form": "ratio = coefficient * factor^N (diagnostic)",
            },
            "critical_cycles": self.critical_cycles,
            "state": self.state,
            "eventual_state": self.eventual_state,
            "rules": self.rules,
        }


RULES = {
    "residual_approach_increment_m": "cycle N's residual approach minus cycle N-1's "
                                     "(cycle 1: its residual approach)",
    "ratios": "cycle N's value over cycle 1's",
    "critical_cycle": "first N >= 2 from which the ratio stays below the tolerance (measured: "
                      "in every later cycle run; fitted: ceil((c/tol)^(1/p)) from the power "
                      "law, none if p < 0); elastic_shakedown = the later of the two ratios' "
                      "critical cycles",
    "state": "last cycle: ratchetting if residual_increment_ratio > tol; else plastic "
             "shakedown if plastic_work_ratio > tol; else elastic shakedown; elastic if cycle "
             "1 left no residual approach and no plastic work (below 1e-6 of its scale)",
    "eventual_state": "the same rule with the fitted power laws at min(horizon, the later "
                      "fitted critical cycle); a ratio below tol in the measured last cycle "
                      "stays below",
}


def ratchetting_cycles(analysis: CycleAnalysis) -> int:
    """Cycles after the first whose residual increment is above the FE's resolution
    (``RESOLUTION`` of cycle 1's residual approach); 0: shakedown at once."""
    return sum(abs(c["residual_increment_ratio"]) > RESOLUTION for c in analysis.cycles[1:])


def analyse(cycles: list[dict[str, Any]], *, tolerance: float = DEFAULT_TOLERANCE,
            source: str = "fe", horizon: int = DEFAULT_HORIZON) -> CycleAnalysis:
    """Per-cycle hysteresis, power-law fits, critical cycles and the shakedown state."""
    if not (isinstance(tolerance, (int, float)) and 0.0 < tolerance < 1.0):
        raise InputError(f"tolerance: must be in (0, 1), got {tolerance!r}")
    rows = cycle_table(cycles)
    first, last = rows[0], rows[-1]
    n = [r["cycle"] for r in rows]
    elastic = (first["residual_approach_m"] <= ELASTIC_FLOOR * first["max_approach_m"]
               and first["plastic_work_J"]
               <= ELASTIC_FLOOR * first["max_force_N"] * first["max_approach_m"])
    residual_fit = plastic_fit = None
    geometric: dict[str, Any] = {}
    if not elastic:
        residual_fit = fit_power_law(n, [r["residual_increment_ratio"] for r in rows])
        plastic_fit = fit_power_law(n, [r["plastic_work_ratio"] for r in rows])
        for key in ("residual_increment_ratio", "plastic_work_ratio"):
            g = fit_geometric(n, [r[key] for r in rows])
            geometric[key] = None if g is None else {
                **g.to_dict(), "critical_cycle": g.critical_cycle(tolerance)}

    measured_res = _stays_below(rows, "residual_increment_ratio", tolerance)
    measured_wp = _stays_below(rows, "plastic_work_ratio", tolerance)
    fitted_res = residual_fit.critical_cycle(tolerance) if residual_fit else None
    fitted_wp = plastic_fit.critical_cycle(tolerance) if plastic_fit else None
    critical = {
        "tolerance": tolerance,
        "measured": {"residual_increment": measured_res, "plastic_work": measured_wp,
                     "elastic_shakedown": _later(measured_res, measured_wp)},
        "fitted": {"residual_increment": fitted_res, "plastic_work": fitted_wp,
                   "elastic_shakedown": _later(fitted_res, fitted_wp)},
        "cycles_run": len(rows),
    }

    if elastic:
        state = eventual = ELASTIC
    elif len(rows) < 2:
        state = eventual = UNDETERMINED
    else:
        inc1, wp1 = first["residual_approach_increment_m"], first["plastic_work_J"]
        state = shakedown_rule(last["residual_approach_increment_m"], inc1,
                               last["plastic_work_J"], wp1, tolerance)
        eventual = shakedown_rule(
            _eventual(last["residual_increment_ratio"], residual_fit, tolerance, horizon), 1.0,
            _eventual(last["plastic_work_ratio"], plastic_fit, tolerance, horizon), 1.0,
            tolerance)
    return CycleAnalysis(source=source, tolerance=float(tolerance), horizon=int(horizon),
                         cycles=rows, residual_fit=residual_fit, plastic_work_fit=plastic_fit,
                         critical_cycles=critical, state=state, eventual_state=eventual,
                         rules=dict(RULES), geometric_fits=geometric)


def _later(a: int | None, b: int | None) -> int | None:
    return None if a is None or b is None else max(a, b)


def _eventual(last_ratio: float | None, fit: PowerLaw | None, tolerance: float,
              horizon: int) -> float:
    """The ratio the power law predicts at the horizon (or the measured one if already below)."""
    if last_ratio is not None and last_ratio <= tolerance:
        return last_ratio
    if fit is None or fit.power <= 0.0:
        return math.inf
    return float(fit(horizon))


# --- the law on the same history ---------------------------------------------------------------


@dataclass(frozen=True)
class CyclicFit:
    """A power law ``c N^-p`` of what the law's cycle N adds, fitted in the quantity itself:
    the FE's per-cycle value (metres of residual approach, joules of plastic work) over the
    *law's own* cycle 1 at the same peak force, so that c absorbs the law's cycle-1 error and
    the law's cycle N lands on the FE's in metres and joules. Minimax in log-log (the worst
    cycle's factor as small as a power law allows), with the factor per cycle."""

    coefficient: float
    power: float
    max_log10_error: float
    per_cycle: list[dict[str, float]]
    from_cycle: int = 2  # the first cycle fitted (fit_ratio_law: after a ratchet's onset)

    def __call__(self, cycle):
        return self.coefficient * np.asarray(cycle, dtype=float) ** (-self.power)


def fit_power_law_minimax(cycles, values, reference: float) -> CyclicFit | None:
    """Minimax fit of ln(value / reference) = ln c - p ln N over N >= 2 with a value above
    ``ROUND_OFF`` x reference (a linear programme, scipy's HiGHS); None with fewer than two."""
    from scipy.optimize import linprog

    n = np.asarray(cycles, dtype=float)
    ratio = np.asarray(values, dtype=float) / reference
    use = (n >= 2) & np.isfinite(ratio) & (ratio > ROUND_OFF)
    if np.count_nonzero(use) < 2:
        return None
    x, y = np.log(n[use]), np.log(ratio[use])
    # unknowns (ln c, p, t): minimise t with |y - ln c + p x| <= t
    ones = np.ones_like(x)
    a_ub = np.vstack([np.column_stack([-ones, x, -ones]), np.column_stack([ones, -x, -ones])])
    b_ub = np.concatenate([-y, y])
    solution = linprog([0.0, 0.0, 1.0], A_ub=a_ub, b_ub=b_ub,
                       bounds=[(None, None), (None, None), (0.0, None)], method="highs")
    if not solution.success:  # pragma: no cover - a feasible bounded LP by construction
        raise InputError(f"fit-params: minimax power-law fit failed ({solution.message})")
    log_c, power, _ = (float(v) for v in solution.x)
    fit = np.exp(log_c - power * x)
    per_cycle = [{"cycle": int(k), "fe": float(r), "law": float(f), "law_over_fe": float(f / r)}
                 for k, r, f in zip(n[use], ratio[use], fit, strict=True)]
    return CyclicFit(coefficient=math.exp(log_c), power=power,
                     max_log10_error=float(np.max(np.abs(np.log10(fit / ratio[use])))),
                     per_cycle=per_cycle)


def fit_ratio_law(cycles, values, reference: float) -> CyclicFit | None:
    """The power law of one per-cycle ratio: :func:`fit_power_law_minimax` over N >= 2, unless
    that fit does not decay (power <= 0) because the ratio first rises and then decays: the
    onset of a ratchet. The weak grain with finite strain does that (docs/cycles.md, "The weak
    grain's repeated history with finite strain": its residual increment grows over cycles 2-5,
    then decays slowly, on two meshes alike). Then the law is fitted to the cycles from the
    largest ratio on (at least two of them), and ``per_cycle`` also holds the earlier cycles
    (where the law overestimates the rising ratio) so the error there is reported, not hidden.
    A fit that decayed over all cycles is returned as it was, bit for bit."""
    fit = fit_power_law_minimax(cycles, values, reference)
    if fit is None or fit.power > 0.0:
        return fit
    n = np.asarray(cycles, dtype=float)
    ratio = np.asarray(values, dtype=float) / reference
    use = (n >= 2) & np.isfinite(ratio) & (ratio > ROUND_OFF)
    peak = float(n[use][np.argmax(ratio[use])])
    later = n >= peak
    if peak == n[use].min() or np.count_nonzero(later & use) < 2:
        return fit  # rises to its last cycles, or never rises: no onset to leave out
    onset = fit_power_law_minimax(n[later], np.asarray(values, dtype=float)[later], reference)
    if onset is None or onset.power <= 0.0:
        return fit
    before = use & ~later
    law = onset(n[before])
    per_cycle = [{"cycle": int(k), "fe": float(r), "law": float(f), "law_over_fe": float(f / r),
                  "fitted": False} for k, r, f in zip(n[before], ratio[before], law, strict=True)]
    per_cycle += [{**row, "fitted": True} for row in onset.per_cycle]
    return replace(onset, per_cycle=per_cycle, from_cycle=int(peak))


def law_first_cycle(params, peak_force: float) -> tuple[float, float]:
    """The law's cycle 1 to ``peak_force`` and back: (residual approach m, dissipation J)."""
    dmax = params.virgin_approach(peak_force)
    residual = float(params.residual_ratio(dmax / params.yield_approach)) * dmax
    return residual, float(params.envelope_plastic_work(dmax))


def with_cyclic(params, analysis: CycleAnalysis, provenance: dict[str, Any] | None = None,
                ratchet: bool = True):
    """``params`` with ``cyclic`` filled from an analysis of repeated loading (docs/model.md §6,
    7), in
    the shakedown form (docs/law.md): cycle N's residual increment and plastic work, in metres
    and joules, over the law's own cycle 1 at the FE's peak force (:class:`CyclicFit`), become
    the law's ratio laws; the analysis tolerance its tolerance (the envelope band); the fit
    errors per cycle and where they came from are recorded. With ``ratchet=False`` (the FE's
    residual approach stops at cycle 1, within its resolution) only the loops are fitted and the
    residual ratio is zero."""
    from ..law import SHAKEDOWN, CyclicLaw

    rows = analysis.cycles
    residual_1, dissipation_1 = law_first_cycle(params, rows[0]["max_force_N"])
    n = [r["cycle"] for r in rows]
    fits = {"plastic_work_ratio": fit_ratio_law(
        n, [r["plastic_work_J"] for r in rows], dissipation_1)}
    if ratchet:
        fits["residual_increment_ratio"] = fit_ratio_law(
            n, [r["residual_approach_increment_m"] for r in rows], residual_1)
    missing = [name for name, fit in fits.items() if fit is None]
    if missing:
        raise InputError(f"fit-params: no power law for {missing[0]} (need at least two cycles "
                         "after the first with a positive ratio)")
    for name, fit in fits.items():
        if fit.power <= 0.0:
            raise InputError(f"fit-params: {name} does not decay with N (power "
                             f"{fit.power:.3g}): the history ratchets, no cyclic law to fit")
        if fit(2.0) > 1.0:
            raise InputError(f"fit-params: {name} fitted cycle-2 ratio {float(fit(2.0)):.3g} > 1 "
                             "(the law bounds cycle N's increment by cycle 1's)")
    residual_fit, work_fit = fits.get("residual_increment_ratio"), fits["plastic_work_ratio"]
    cyclic = CyclicLaw(
        enabled=True,
        residual_ratio_coefficient=residual_fit.coefficient if residual_fit else 0.0,
        residual_ratio_power=residual_fit.power if residual_fit else 1.0,
        plastic_work_ratio_coefficient=work_fit.coefficient,
        plastic_work_ratio_power=work_fit.power,
        tolerance=analysis.tolerance,
        form=SHAKEDOWN,
    )
    fit_errors = copy.deepcopy(params.fit_errors)
    fit_errors["cyclic"] = {
        "form": "value_N / law's cycle 1 = coefficient N^-power, minimax in log-log over N >= 2 "
                "(from the largest ratio on where the ratio first rises: a ratchet's onset)",
        "law_cycle_1": {"residual_approach_m": residual_1, "dissipation_J": dissipation_1},
        **{name: {"max_log10": fit.max_log10_error, "per_cycle": fit.per_cycle,
                  **({"fitted_from_cycle": fit.from_cycle,
                      "max_log10_before": max(abs(math.log10(row["law_over_fe"]))
                                              for row in fit.per_cycle if not row["fitted"])}
                     if fit.from_cycle > 2 else {})}
           for name, fit in fits.items()},
    }
    prov = copy.deepcopy(params.provenance)
    prov["cyclic"] = {
        "source": f"{analysis.source} cycles analysed by geocontact.cycles",
        "cycles": len(analysis.cycles),
        "max_force_N": max(c["max_force_N"] for c in analysis.cycles),
        "critical_cycles": analysis.critical_cycles,
        "state": analysis.state,
        **(provenance or {}),
    }
    label = f"{params.label} | cyclic: fitted to {analysis.source} ({len(analysis.cycles)} cycles)"
    return replace(params, cyclic=cyclic, fit_errors=fit_errors, provenance=prov,
                   label=label.lstrip(" |"))
