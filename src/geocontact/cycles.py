"""Cyclic loading histories: per-cycle hysteresis, power laws in N, critical cycles, shakedown
(SPEC sections 6 and 8; the paper's section "Influence of loading history").

Input is a list of cycles as the FE engine reports them (``summary["cycles"]``: a cycle runs from
one zero-force waypoint through its peak to the next) or as the law reports them
(:func:`law_cycles_by_force`, :func:`law_cycles_along_path`)::

    analysis = analyse(fe_result.summary["cycles"], tolerance=0.01, source="fe")
    analysis.state, analysis.critical_cycle, analysis.residual_fit.power

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
import shutil
import sys
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from ._version import __version__
from .errors import InputError
from .io import atomic_directory, provenance, write_csv, write_json_atomic
from .law.params import power_law_critical_cycle

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
    """The shakedown state from late growth against a reference growth (SPEC section 6).

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
        """First N >= 2 with c q^N < tolerance; None if the ratio does not decay."""
        if self.coefficient * self.factor**2 < tolerance:
            return 2
        if self.factor >= 1.0:
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


def _first_below(rows: list[dict], key: str, tolerance: float) -> int | None:
    for row in rows[1:]:
        if row[key] is not None and row[key] < tolerance:
            return int(row["cycle"])
    return None


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
    "critical_cycle": "first N >= 2 whose ratio is below the tolerance (measured; and "
                      "ceil((c/tol)^(1/p)) from the fitted power law); elastic_shakedown = "
                      "the later of the two ratios' critical cycles",
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

    measured_res = _first_below(rows, "residual_increment_ratio", tolerance)
    measured_wp = _first_below(rows, "plastic_work_ratio", tolerance)
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
def law_cycles_by_force(params, forces) -> tuple[list[dict], dict[str, np.ndarray]]:
    """The law driven by the force history (``histories.drive_by_force``): cycles and path."""
    from .histories import drive_by_force

    run = drive_by_force(params, list(forces))
    cycles = [{**c, "loop_work_J": c["plastic_work_J"]} for c in run.cycles]
    return cycles, {"approach_m": run.approach, "force_N": run.force}


def law_cycles_along_path(params, approach, windows) -> tuple[list[dict], dict[str, np.ndarray]]:
    """The law driven along an approach path (the FE's), with cycles cut at the given
    ``windows`` [(start index, end index)] of the path (the FE's cycles).

    Per cycle: the largest force and approach, the law's residual approach at the end of the
    window (its envelope's, plus any ratchet), and the loop area (work of the force over the
    window) as the plastic work; the dissipated-energy difference is reported beside it."""
    from .law import Contact

    approach = np.asarray(approach, dtype=float)
    contact = Contact(params)
    force = np.empty(approach.size)
    work = np.empty(approach.size)
    dissipated = np.empty(approach.size)
    residual = np.empty(approach.size)
    for i, a in enumerate(approach):
        force[i] = contact.update(float(a))[0]
        s = contact.state
        work[i] = s.work
        dissipated[i] = contact.dissipated_energy
        residual[i] = s.residual_approach + s.ratchet_shift
    cycles = []
    for a, b in windows:
        sl = slice(a, b + 1)
        k = a + int(np.argmax(force[sl]))
        cycles.append({
            "max_force_N": float(force[k]),
            "max_approach_m": float(approach[k]),
            "residual_approach_m": float(residual[b]),
            "plastic_work_J": float(work[b] - work[a]),
            "loop_work_J": float(work[b] - work[a]),
            "dissipated_energy_J": float(dissipated[b] - dissipated[a]),
            "end_force_N": float(force[b]),
        })
    return cycles, {"approach_m": approach, "force_N": force,
                    "residual_approach_m": residual, "dissipated_energy_J": dissipated}


def fe_cycle_windows(curve: dict[str, np.ndarray], cycles: list[dict]) -> list[tuple[int, int]]:
    """Row indices of the FE curve where each FE cycle starts and ends."""
    index = {int(s): i for i, s in enumerate(curve["step"])}
    try:
        return [(index[int(c["steps"][0])], index[int(c["steps"][1])]) for c in cycles]
    except (KeyError, TypeError) as exc:
        raise InputError(f"cycles: FE cycle step marks do not match the curve ({exc})") from None


# --- the cyclic extension of a law parameter set -----------------------------------------------
def with_cyclic(params, analysis: CycleAnalysis, provenance: dict[str, Any] | None = None):
    """``params`` with ``cyclic`` filled from an analysis of repeated loading (SPEC 6, 7).

    The residual-increment and plastic-work power laws become the law's ratio laws, the
    analysis tolerance its tolerance; the fit errors and where they came from are recorded."""
    from .law import CyclicLaw

    missing = [name for name, fit in (("residual_increment_ratio", analysis.residual_fit),
                                      ("plastic_work_ratio", analysis.plastic_work_fit))
               if fit is None]
    if missing:
        raise InputError(f"fit-params: no power law for {missing[0]} (need at least two cycles "
                         "after the first with a positive ratio)")
    for name, fit in (("residual_increment_ratio", analysis.residual_fit),
                      ("plastic_work_ratio", analysis.plastic_work_fit)):
        if fit.power <= 0.0:
            raise InputError(f"fit-params: {name} does not decay with N (power "
                             f"{fit.power:.3g}): the history ratchets, no cyclic law to fit")
        if fit(2.0) > 1.0:
            raise InputError(f"fit-params: {name} fitted cycle-2 ratio {float(fit(2.0)):.3g} > 1 "
                             "(the law bounds cycle N's increment by cycle 1's)")
    cyclic = CyclicLaw(
        enabled=True,
        residual_ratio_coefficient=analysis.residual_fit.coefficient,
        residual_ratio_power=analysis.residual_fit.power,
        plastic_work_ratio_coefficient=analysis.plastic_work_fit.coefficient,
        plastic_work_ratio_power=analysis.plastic_work_fit.power,
        tolerance=analysis.tolerance,
    )
    fit_errors = copy.deepcopy(params.fit_errors)
    fit_errors["cyclic"] = {
        "residual_increment_ratio": _fit_error(analysis.residual_fit),
        "plastic_work_ratio": _fit_error(analysis.plastic_work_fit),
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


def _fit_error(fit: PowerLaw) -> dict[str, Any]:
    return {"rms_log10": fit.rms_log10_error, "max_relative": fit.max_relative_error,
            "power_standard_error": fit.power_standard_error, "cycles_used": fit.cycles_used}


# --- reloading stiffness ---------------------------------------------------------------------
def reloading_stiffness(curve: dict[str, np.ndarray], windows: list[tuple[int, int]],
                        force_level: float) -> list[dict[str, Any]]:
    """How stiffly each cycle's loading branch reaches ``force_level``.

    Per cycle: the approach it takes from the cycle's start (the previous residual approach;
    0 for the virgin loading) to reach ``force_level`` (linear interpolation between steps),
    and the secant stiffness ``force_level / that approach``; None where the cycle stays below
    the level. ``prior_peak_N`` is the largest force of the earlier cycles (0 for cycle 1)."""
    force, approach = np.asarray(curve["force_N"]), np.asarray(curve["approach_m"])
    out = []
    prior = 0.0
    for k, (a, b) in enumerate(windows, 1):
        f, d = force[a:b + 1], approach[a:b + 1]
        top = int(np.argmax(f))
        rising_f, rising_d = f[:top + 1], d[:top + 1]
        row: dict[str, Any] = {"cycle": k, "prior_peak_N": prior, "force_level_N": force_level,
                               "approach_to_level_m": None, "secant_stiffness_N_per_m": None}
        if rising_f.size and rising_f[-1] >= force_level:
            j = int(np.argmax(rising_f >= force_level))
            if j == 0:
                reach = float(rising_d[0])
            else:
                t = (force_level - rising_f[j - 1]) / (rising_f[j] - rising_f[j - 1])
                reach = float(rising_d[j - 1] + t * (rising_d[j] - rising_d[j - 1]))
            rise = reach - float(d[0])
            row["approach_to_level_m"] = rise
            row["secant_stiffness_N_per_m"] = force_level / rise if rise > 0 else None
        out.append(row)
        prior = max(prior, float(f.max()))
    return out


# --- the whole job: FE (and law) on a history, written to a directory ------------------------
CSV_COLUMNS = ("source", "cycle", "max_force_N", "max_approach_m", "residual_approach_m",
               "residual_approach_increment_m", "residual_increment_ratio", "plastic_work_J",
               "plastic_work_ratio", "loop_work_J", "max_approach_ratio")


def write_cycles_csv(path, analyses: dict[str, CycleAnalysis]) -> None:
    """One row per (source, cycle) of every analysis, atomically."""
    rows = [[name, *["" if r[c] is None else r[c] for c in CSV_COLUMNS[1:]]]
            for name, a in analyses.items() for r in a.cycles]
    write_csv(path, {c: np.array([r[i] for r in rows], dtype=object)
                     for i, c in enumerate(CSV_COLUMNS)})


def check_cyclic_history(forces: list[float]) -> None:
    """A cycle analysis needs the history to come back to zero force at its end."""
    if forces[-1] != 0.0:
        raise InputError("history.forces: must end at zero force (the last cycle must close) "
                         f"for a cycle analysis, got {forces[-1]:g} N")


def checkpoint_of(out: str | Path) -> Path:
    """The FE checkpoint of ``run_cycles(out=...)``: beside ``out`` (the folder itself is
    replaced whole when the analysis lands), removed once it has."""
    out = Path(out)
    return out.parent / f"{out.name}.fe.checkpoint.npz"


def run_cycles(material, forces, out, *, params=None, mesh: str = "default",
               steps_per_segment: int | None = None, tolerance: float = DEFAULT_TOLERANCE,
               resume: bool = False, fit_params=None, progress: bool = False,
               inputs: dict[str, Any] | None = None, overwrite: bool = False) -> dict[str, Any]:
    """FE run of ``forces`` in ``out/fe`` (checkpointed), the law beside it when ``params`` is
    given (driven by the FE's approach path and by the force history), the cycle analysis of
    each, and ``out/summary.json``, ``out/cycles.csv`` (and law paths as CSV). With
    ``fit_params`` (a path) also ``params`` with its cyclic extension fitted to the FE.

    ``out`` is written as one unit (``io.atomic_directory``): an interrupted rerun never leaves
    new files beside old ones, and an existing ``out`` is replaced only if it is a cycles
    result of ours (unless ``overwrite``). The FE checkpoint (``checkpoint_of(out)``) lives
    beside ``out`` until the analysis has landed. Returns the summary."""
    forces = [float(f) for f in forces]
    check_cyclic_history(forces)
    if not (isinstance(tolerance, (int, float)) and 0.0 < tolerance < 1.0):
        raise InputError(f"tolerance: must be in (0, 1), got {tolerance!r}")
    if params is not None and params.material.to_dict() != material.to_dict():
        theirs, ours = params.material.to_dict(), material.to_dict()
        key = next(k for k in ours if ours[k] != theirs[k])
        raise InputError(f"params.material.{key}: {theirs[key]:g} differs from the material's "
                         f"{ours[key]:g} (the law must describe the FE's material)")
    out = Path(out)
    checkpoint = checkpoint_of(out)
    with atomic_directory(out, "cycles", overwrite=overwrite) as work:
        summary = _write_cycles(work, material, forces, params=params, mesh=mesh,
                                steps_per_segment=steps_per_segment, tolerance=tolerance,
                                resume=resume, fit_params=fit_params, progress=progress,
                                inputs=inputs, previous_fe=out / "fe", checkpoint=checkpoint)
    from .fem.checkpoint import remove_checkpoint

    remove_checkpoint(checkpoint)  # the analysis has landed
    return summary


def _write_cycles(out: Path, material, forces, *, params, mesh, steps_per_segment, tolerance,
                  resume, fit_params, progress, inputs, previous_fe: Path, checkpoint: Path
                  ) -> dict[str, Any]:
    """The body of ``run_cycles``, writing into the (temporary) folder ``out``."""
    from .fem.run import run_history  # the FE is an optional extra: imported when used

    fe_dir = out / "fe"
    # resume: a finished FE run of the same identity (inputs, FE code, libraries: fem.reuse)
    # in the previous folder is reused, else the FE goes on from its checkpoint
    result = None
    if resume:
        from .fem.reuse import FeRunIdentity, finished_run

        identity = FeRunIdentity.of(material, forces, mesh, steps_per_segment=steps_per_segment)
        why: list[str] = []
        result = finished_run(previous_fe, identity, fields=True, why=why)
        if why:
            print(f"cycles: not reusing the FE run in {previous_fe}: {why[0]}; running it "
                  "again", file=sys.stderr)
    if result is None:
        result = run_history(material, forces, mesh=mesh, out=fe_dir,
                             steps_per_segment=steps_per_segment, resume=resume,
                             progress=progress, write_fields=True, checkpoint=checkpoint)
    else:
        shutil.copytree(previous_fe, fe_dir)
        if progress:
            print(f"cycles: reusing the finished FE run in {previous_fe}", file=sys.stderr)
    fe_cycles = result.summary["cycles"]
    analyses = {"fe": analyse(fe_cycles, tolerance=tolerance, source="fe")}
    if params is not None:
        windows = fe_cycle_windows(result.curve, fe_cycles)
        along, path = law_cycles_along_path(params, result.curve["approach_m"], windows)
        analyses["law_along_fe_approach"] = analyse(along, tolerance=tolerance,
                                                    source="law driven by the FE approach path")
        by_force, force_path = law_cycles_by_force(params, forces)
        analyses["law_by_force"] = analyse(by_force, tolerance=tolerance,
                                           source="law driven by the force history")
        write_csv(out / "law_along_fe_approach.csv", {
            "step": result.curve["step"], "approach_m": path["approach_m"],
            "fe_force_N": result.curve["force_N"], "law_force_N": path["force_N"],
            "law_residual_approach_m": path["residual_approach_m"],
            "law_dissipated_energy_J": path["dissipated_energy_J"]})
        write_csv(out / "law_by_force.csv", force_path)
    write_cycles_csv(out / "cycles.csv", analyses)
    fs = result.summary
    summary = {
        "version": __version__,
        "analyses": {name: a.to_dict() for name, a in analyses.items()},
        "fe_run": {k: fs.get(k) for k in ("first_yield_force_N", "first_yield_approach_m",
                                          "fully_plastic_force_N", "mesh", "steps",
                                          "wall_time_s", "version", "inputs")},
        "law": None if params is None else {"label": params.label,
                                            "cyclic": params.cyclic.to_dict()},
        "files": {"fe": "fe/", "cycles": "cycles.csv",
                  **({"law_along_fe_approach": "law_along_fe_approach.csv",
                      "law_by_force": "law_by_force.csv"} if params is not None else {})},
        "provenance": provenance("cycles", {**(inputs or {}), "forces_N": forces, "mesh": mesh,
                                            "steps_per_segment": steps_per_segment,
                                            "tolerance": tolerance}),
    }
    if fit_params is not None:
        fitted = with_cyclic(params, analyses["fe"], provenance={
            "fe_inputs": fs.get("inputs"), "fe_version": fs.get("version"),
            "command": "geocontact cycles --fit-params"})
        fitted.save(fit_params)
        summary["fitted_params"] = {"path": str(fit_params), "cyclic": fitted.cyclic.to_dict(),
                                    "critical_cycle": fitted.cyclic.critical_cycle()}
    write_json_atomic(out / "summary.json", summary)
    return summary


__all__ = [
    "DEFAULT_TOLERANCE", "ELASTIC", "ELASTIC_SHAKEDOWN", "PLASTIC_SHAKEDOWN", "RATCHETTING",
    "RESOLUTION", "UNDETERMINED", "CycleAnalysis", "GeometricLaw", "PowerLaw", "analyse",
    "cycle_table", "fe_cycle_windows", "fit_geometric", "fit_power_law", "law_cycles_along_path",
    "law_cycles_by_force", "ratchetting_cycles", "reloading_stiffness", "run_cycles",
    "shakedown_rule", "with_cyclic", "write_cycles_csv",
]
