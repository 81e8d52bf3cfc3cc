"""The calibration campaign (docs/model.md §7): FE cycles at several peak loads -> law parameters.

Each calibration run is one FE force history ``0 -> F -> 0 -> F -> 0`` (data/calibration.toml),
so one run gives the virgin loading curve, the unloading curve, the residual approach and the
loop work of the first cycle, and the reloading curve. The peaks are geometric from ~2 Fy into
the fully plastic range. The runs go through ``geocontact.fem.campaign`` (Dask, cached by their
inputs), then ``fit_law`` fits the forms of docs/law.md.

    params, runs = calibrate(material, mesh="default")   # LawParams, list of CalibrationRun
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass, replace
from importlib import resources
from typing import Any

import numpy as np

from ..errors import InputError
from ..fem.campaign import DEFAULT_CACHE, FemJob, run_campaign
from ..fem.identity import run_key
from ..fem.result import FemResult
from ..grain.force_history import preset_history
from ..grain.hertz import hertz_coefficient, incipient_yield
from ..grain.material import Material
from ..law.params import LawParams
from .contact_radius import RadiusLevel, fit_contact_radius, level_from_curve
from .fit import LOADING_FORMS, REGIMES, RESIDUAL_FORMS, SATURATING, LevelData, fit_law

MIN_LEVELS = 3
# The shipped calibrations use 7 and 13 levels (two per decade); 50 levels is ~8 per decade
# over the widest range, each one a full FE run: more is a typo, not a finer fit.
MAX_LEVELS = 50


def settings() -> dict[str, Any]:
    """The defaults of data/calibration.toml (campaign and acceptance)."""
    text = (resources.files("geocontact") / "data" / "calibration.toml").read_text()
    return tomllib.loads(text)


def force_range(material: Material, max_force: float | None = None) -> tuple[float, float]:
    """Lowest and highest calibration peak (N): lowest_peak_over_yield x the analytic Fy and
    max_force (default from data/calibration.toml)."""
    campaign = settings()["campaign"]
    high = campaign["max_force_N"] if max_force is None else max_force
    _check_positive("max_force", high)
    low = campaign["lowest_peak_over_yield"] * incipient_yield(material).force
    if high <= low:
        raise InputError(f"max_force: {high:g} N is not above the lowest calibration peak "
                         f"{low:.4g} N (= {campaign['lowest_peak_over_yield']:g} Fy)")
    return low, high


def peak_forces(material: Material, levels: int | None = None,
                max_force: float | None = None) -> list[float]:
    """Geometric peak loads from ~2 Fy to max_force (docs/model.md §7)."""
    n = settings()["campaign"]["levels"] if levels is None else levels
    if isinstance(n, bool) or not isinstance(n, int) or not MIN_LEVELS <= n <= MAX_LEVELS:
        raise InputError(f"levels: need an integer in [{MIN_LEVELS}, {MAX_LEVELS}] (each "
                         f"level is one FE run), got {n!r}")
    low, high = force_range(material, max_force)
    return [float(f) for f in np.geomspace(low, high, n)]


def check_peaks(material: Material, peaks) -> list[float]:
    """User-given peak loads: >= MIN_LEVELS distinct values, all above the analytic Fy."""
    peaks = sorted(float(p) for p in peaks)
    for p in peaks:
        _check_positive("peaks", p)
    if not MIN_LEVELS <= len(set(peaks)) <= MAX_LEVELS:
        raise InputError(f"peaks: need {MIN_LEVELS} to {MAX_LEVELS} distinct peak loads "
                         f"(each is one FE run), got {len(set(peaks))}")
    fy = incipient_yield(material).force
    if peaks[0] <= 1.2 * fy:
        raise InputError(f"peaks: {peaks[0]:g} N is within 20 % of first yield "
                         f"(Fy = {fy:.4g} N); the lowest level must be plastic")
    return sorted(set(peaks))


def _check_positive(what: str, value) -> None:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not (
            math.isfinite(value) and value > 0):
        raise InputError(f"{what}: must be a positive number of newtons, got {value!r}")


def _auto_choice(summary: dict) -> dict:
    """provenance.fe.mesh_rule_choice of a calibration asked with the mesh rule "auto": what it
    chose for the top level's run (the levels share its mesh, ``shared_mesh_force``) and why."""
    from ..fem.settings import recorded_choice

    choice = recorded_choice(summary)
    return {"asked": "auto", "chose": choice["mesh_rule"],
            "mesh_force_over_first_yield": choice["mesh_force_over_first_yield"],
            "auto_dense_above": choice["auto_dense_above"], "reason": choice["reason"]}


def shared_mesh_force(peaks) -> float | None:
    """The force every run's mesh is sized for when data/calibration.toml asks for one shared
    mesh (``shared_mesh = true``): the highest peak; else None (each run sized for its own)."""
    return float(max(peaks)) if settings()["campaign"].get("shared_mesh", False) else None


def calibration_jobs(material: Material, peaks, mesh: str = "default",
                     steps_per_segment: int | None = None,
                     fe_model: dict[str, str] | None = None,
                     mesh_force: float | None = None) -> list[FemJob]:
    """The calibration levels' FE runs; ``fe_model``: kinematics, mesh_rule, step_rule,
    max_step_ratio of ``FemJob`` (the FE defaults when None: small strain, the mesh rule "auto",
    adaptive load steps). ``mesh_force``: the force the shared mesh is sized for (default the
    highest peak, ``shared_mesh_force``): a campaign whose top is moved keeps its runs when it
    keeps their mesh."""
    shape = settings()["campaign"]["history"]
    mesh_force = shared_mesh_force(peaks) if mesh_force is None else float(mesh_force)
    return [FemJob(material, tuple(float(s) * peak for s in shape), mesh=mesh,
                   steps_per_segment=steps_per_segment, label=f"calibration F={peak:.4g}N",
                   mesh_force=mesh_force, **(fe_model or {}))
            for peak in peaks]


# --- extraction -------------------------------------------------------------------------------
@dataclass
class CalibrationRun:
    """One FE calibration run and what the fit takes from it."""

    job: FemJob
    result: FemResult
    level: LevelData
    loading_approach: np.ndarray  # the virgin loading segment (from zero force to the peak)
    loading_force: np.ndarray
    plastic_dissipation: float  # FE plastic dissipation of the first cycle (pair, J)
    second_residual_approach: float | None  # residual approach after the reload cycle
    radius: RadiusLevel | None = None  # the FE's contact radius (None: not recorded)


def _rows(result: FemResult, steps: tuple[int, int]) -> slice:
    index = {int(s): i for i, s in enumerate(result.curve["step"])}
    return slice(index[steps[0]], index[steps[1]] + 1)


def extract_run(job: FemJob, result: FemResult) -> CalibrationRun:
    """LevelData of a ``0 -> F -> 0 -> F [-> 0]`` FE run: ball-ball approach, pair energies.

    Plastic work is what unloading does not give back (docs/model.md §6): the work of the force
    over the
    closed first cycle (the FE's loop work); the FE plastic dissipation is kept beside it (the
    two differ by the elastic energy locked in by residual stresses)."""
    cycles = result.summary["cycles"]
    if len(cycles) < 2 or cycles[0]["residual_approach_m"] is None:
        raise InputError(f"calibration run {job.name()}: needs a closed first cycle and a "
                         f"reload (history 0 -> F -> 0 -> F), got {len(cycles)} cycle(s)")
    c = result.curve
    d, f, work = c["approach_m"], c["force_N"], c["work_J"]
    first, second = _rows(result, tuple(cycles[0]["steps"])), _rows(result, tuple(
        cycles[1]["steps"]))
    peak = first.start + int(np.argmax(f[first]))
    repeak = second.start + int(np.argmax(f[second]))
    level = LevelData(
        max_approach=float(d[peak]),
        max_force=float(f[peak]),
        residual_approach=float(cycles[0]["residual_approach_m"]),
        plastic_work=float(cycles[0]["loop_work_J"]),
        total_work=float(work[peak] - work[first.start]),
        unloading_approach=d[peak:first.stop].copy(),
        unloading_force=f[peak:first.stop].copy(),
        reloading_approach=d[second.start:repeak + 1].copy(),
        reloading_force=f[second.start:repeak + 1].copy(),
    )
    return CalibrationRun(
        job=job, result=result, level=level,
        loading_approach=d[first.start:peak + 1].copy(),
        loading_force=f[first.start:peak + 1].copy(),
        plastic_dissipation=float(cycles[0]["plastic_work_J"]),
        second_residual_approach=cycles[1]["residual_approach_m"],
        radius=radius_level(result),
    )


def radius_level(result: FemResult) -> RadiusLevel | None:
    """The contact radius of a calibration run's first cycle and reload (``extract_run``'s
    rows); None when the curve does not record it."""
    c, cycles = result.curve, result.summary["cycles"]
    if "contact_radius_m" not in c:
        return None
    return level_from_curve(c["approach_m"], c["force_N"], c["contact_radius_m"],
                            _rows(result, tuple(cycles[0]["steps"])),
                            _rows(result, tuple(cycles[1]["steps"])))


def fe_yield(material: Material, runs: list[CalibrationRun]) -> dict[str, Any]:
    """First yield as the FE detected it (median over the runs) beside the analytic value.

    The law's yield approach is the Hertz approach of the FE first-yield force, so that
    Fy = Kh dy^1.5 holds exactly and the law's Fy is the FE's (docs/calibration.md)."""
    forces = np.array([r.result.summary["first_yield_force_N"] for r in runs
                       if r.result.summary.get("first_yield_force_N")], dtype=float)
    analytic = incipient_yield(material)
    if forces.size == 0:
        raise InputError("calibration: no FE run detected first yield; raise the peak loads")
    fy = float(np.median(forces))
    approach = (fy / hertz_coefficient(material)) ** (2.0 / 3.0)
    fe_approaches = [r.result.summary["first_yield_approach_m"] for r in runs
                     if r.result.summary.get("first_yield_approach_m")]
    return {
        "approach_m": approach,
        "source": "FE first yield (median over the calibration runs); approach = Hertz "
                  "approach of that force",
        "fe_force_N": fy,
        "fe_force_spread_N": [float(forces.min()), float(forces.max())],
        "fe_approach_m": float(np.median(fe_approaches)),
        "analytic_force_N": analytic.force,
        "analytic_approach_m": analytic.approach,
        "fe_over_analytic_force": fy / analytic.force,
        "analytic": analytic.to_dict(),
    }


def fe_fully_plastic(runs: list[CalibrationRun]) -> dict[str, Any]:
    """The FE's fully plastic onset Fp per run (the detector is the FE engine's, docs/fem.md)."""
    values = [(r.level.max_force, r.result.summary.get("fully_plastic_force_N"),
               r.result.summary.get("fully_plastic_approach_m")) for r in runs]
    reached = [(p, f, d) for p, f, d in values if f is not None]
    top = max(runs, key=lambda r: r.level.max_force).result.summary
    return {
        "force_N": top.get("fully_plastic_force_N"),
        "approach_m": top.get("fully_plastic_approach_m"),
        "source": "FE run with the highest peak",
        "per_run": [{"peak_force_N": p, "force_N": f, "approach_m": d} for p, f, d in values],
        "reached_in_runs": len(reached),
    }


def calibrate(material: Material, *, peaks=None, levels: int | None = None,
              max_force: float | None = None, mesh: str = "default",
              steps_per_segment: int | None = None, cache_dir=DEFAULT_CACHE,
              scheduler: str | None = None, workers: int | None = None,
              progress: bool = True, fe_model: dict[str, str] | None = None,
              residual_form: str = SATURATING, loading_form: str = REGIMES,
              mesh_force: float | None = None,
              ) -> tuple[LawParams, list[CalibrationRun]]:
    """FE campaign + extraction + fit. Returns the law and the runs it was fitted to.
    ``fe_model``: the FE's kinematics, mesh_rule, step_rule and max_step_ratio (``FemJob``;
    default the FE's). ``residual_form``, ``loading_form``: of the residual approach and the
    virgin curve (``fit_law``). ``mesh_force``: see ``calibration_jobs``."""
    if residual_form not in RESIDUAL_FORMS:  # before the FE work
        raise InputError(f"residual form: must be one of {', '.join(RESIDUAL_FORMS)}, got "
                         f"{residual_form!r}")
    if loading_form not in LOADING_FORMS:
        raise InputError(f"loading form: must be one of {', '.join(LOADING_FORMS)}, got "
                         f"{loading_form!r}")
    peaks = (check_peaks(material, peaks) if peaks is not None
             else peak_forces(material, levels, max_force))
    jobs = calibration_jobs(material, peaks, mesh, steps_per_segment, fe_model, mesh_force)
    cyclic = cyclic_job(material, max(peaks), mesh, steps_per_segment, fe_model)
    results = run_campaign(jobs + ([cyclic] if cyclic else []), cache_dir, scheduler=scheduler,
                           workers=workers, progress=progress)
    runs = [extract_run(job, result)
            for job, result in zip(jobs, results[:len(jobs)], strict=True)]
    params = fit_runs(material, runs, residual_form, loading_form)
    if cyclic is not None:
        params = fit_cyclic(params, cyclic, results[-1])
    return params, runs


def cyclic_job(material: Material, max_force: float, mesh: str = "default",
               steps_per_segment: int | None = None,
               fe_model: dict[str, str] | None = None) -> FemJob | None:
    """The FE run the cyclic laws are fitted to (data/calibration.toml ``cyclic_history``:
    the paper's repeated history to ``cyclic_peak_over_max`` x the highest peak); None when the
    settings name no history."""
    campaign = settings()["campaign"]
    name = campaign.get("cyclic_history")
    if not name:
        return None
    peak = float(campaign["cyclic_peak_over_max"]) * max_force
    return FemJob(material, tuple(preset_history(name, peak)), mesh=mesh,
                  steps_per_segment=steps_per_segment, label=f"cyclic {name} F={peak:.4g}N",
                  **(fe_model or {}))


def fit_cyclic(params: LawParams, job: FemJob, result: FemResult) -> LawParams:
    """``params`` with the cyclic power laws fitted to the FE run of ``cyclic_job`` (docs/model.md
    §6-7).

    When the run does not support a decaying power law (the residual increments do not fall
    with N: the history ratchets, or too few cycles), the cyclic extension stays disabled and
    the provenance says why; the analysis is recorded either way."""
    from .cyclic_fit import analyse

    analysis = analyse(result.summary["cycles"], source=f"FE {job.label}")
    return fit_cyclic_analysis(params, analysis, {
        "history_forces_N": list(job.forces), "mesh": job.mesh,
        "cache_key": run_key(result, job.identity())})


def fit_cyclic_analysis(params: LawParams, analysis, info: dict[str, Any]) -> LawParams:
    """``fit_cyclic`` on an analysis of repeated loading (``cyclic_fit.analyse``) from any
    source (an FE run, or the universal law's interpolated cycles); ``info`` goes into
    ``provenance.cyclic``."""
    from .cyclic_fit import ratchetting_cycles, with_cyclic

    info = {**info, "state": analysis.state, "critical_cycles": analysis.critical_cycles}
    if len(analysis.cycles) > 1 and ratchetting_cycles(analysis) == 0:
        second = analysis.cycles[1]["residual_increment_ratio"]
        no_ratchet = (f"the residual approach stops at cycle 1 (cycle-2 residual increment "
                      f"{second:.2g} of cycle 1's, within the FE's resolution)")
        try:  # the loops may still shake down (sigma_c = 1 MPa): fit them, no ratchet
            fitted = with_cyclic(params, analysis, provenance=info, ratchet=False)
        except InputError:
            return replace(params, provenance={**params.provenance, "cyclic": {
                **info, "status": "not needed",
                "reason": f"elastic shakedown from cycle 2: {no_ratchet}, and no decaying loop "
                          "work: the law without the extension already repeats the first "
                          "unloading-reloading curve"}})
        return replace(fitted, provenance={**fitted.provenance, "cyclic": {
            **fitted.provenance["cyclic"], "status": "fitted",
            "reason": f"loops only: {no_ratchet}, residual ratio zero"}})
    try:
        fitted = with_cyclic(params, analysis, provenance=info)
    except InputError as exc:
        return replace(params, provenance={**params.provenance, "cyclic": {
            **info, "status": "not fitted", "reason": str(exc)}})
    return replace(fitted, provenance={**fitted.provenance, "cyclic": {
        **fitted.provenance["cyclic"], "status": "fitted"}})


def virgin_curve(runs: list[CalibrationRun]) -> tuple[np.ndarray, np.ndarray, list[float]]:
    """The virgin loading curve stitched from every run's loading segment: between the peaks of
    levels k-1 and k it is run k's.

    Monotone loading is path-independent, so one run to the highest peak would do in exact
    arithmetic; in the FE it does not: each run's mesh is sized for its own peak and its load
    steps are spread over its own force range, so the highest run resolves low forces worst
    (sigma_c = 1 MPa, coarse mesh: its curve lies 20 % below the 592 N run's at 500 N and
    steps in a staircase as contact nodes engage). The run with the smallest peak above a force
    is the best-resolved one there. Returns approach, force and the stitch forces."""
    ordered = sorted(runs, key=lambda r: r.level.max_force)
    approach, force, stitches = [], [], []
    below = 0.0
    for run in ordered:
        keep = (run.loading_force > below) | (below == 0.0)
        approach.append(run.loading_approach[keep])
        force.append(run.loading_force[keep])
        if below > 0.0:
            stitches.append(below)
        below = run.level.max_force
    return np.concatenate(approach), np.concatenate(force), stitches


def fit_runs(material: Material, runs: list[CalibrationRun],
             residual_form: str = SATURATING, loading_form: str = REGIMES) -> LawParams:
    """Fit the law to extracted calibration runs (no FE work: reruns from cached results).
    ``residual_form``, ``loading_form``: of the residual approach and the virgin curve
    (``fit_law``); recorded in the provenance when not the default (files of the default
    forms read as before)."""
    yield_info = fe_yield(material, runs)
    top = max(runs, key=lambda r: r.level.max_force)
    job = top.job
    loading_approach, loading_force, stitches = virgin_curve(runs)
    provenance = {
        "source": "FE calibration (geocontact calibrate)",
        "fe": {
            "mesh": job.mesh,
            # the rule the runs were meshed with ("auto" recorded as what it chose)
            "kinematics": job.kinematics, "mesh_rule": job.identity().mesh_rule,
            # asked "auto" (the default): the mesh force over the analytic first-yield force
            # that decided it (fem.settings.settings_choice); absent in files of a named rule
            **({"mesh_rule_choice": _auto_choice(top.result.summary)}
               if job.mesh_rule == "auto" else {}),
            "step_rule": job.step_rule, "max_step_ratio": job.max_step_ratio,
            # named where not "fixed": the load steps of every file written before the
            # adaptive control became the default (issue 36)
            **({"step_control": job.step_control} if job.step_control != "fixed" else {}),
            # named where not "full" (fem.settings.NEWTON_UPDATES): files before it read as before
            **({"newton": job.newton} if job.newton != "full" else {}),
            "steps_per_segment": job.steps_per_segment
            or runs[0].result.summary["inputs"]["steps_per_segment"],
            "elements": [r.result.summary["mesh"]["elements"] for r in runs],
            "history_shape": settings()["campaign"]["history"],
            "peak_forces_N": [r.level.max_force for r in runs],
            "cache_keys": [r.result.summary["identity"]["key"] for r in runs],
            "fe_versions": sorted({str(r.result.summary.get("version")) for r in runs}),
            "wall_time_s": [r.result.summary["wall_time_s"] for r in runs],
            "virgin_curve_from": "every run's loading segment, run k between the peaks of "
                                 "levels k-1 and k",
            "virgin_curve_stitches_N": stitches,
        },
        "fully_plastic_fe": fe_fully_plastic(runs),
    }
    if residual_form != SATURATING:
        provenance["residual_form"] = residual_form
    if loading_form != REGIMES:
        provenance["loading_form"] = loading_form
    params = fit_law(material, yield_info["approach_m"], loading_approach, loading_force,
                     [r.level for r in runs], provenance=provenance,
                     residual_form=residual_form, loading_form=loading_form)
    extra = {k: v for k, v in yield_info.items() if k != "approach_m"}
    errors = dict(params.fit_errors)
    fp = provenance["fully_plastic_fe"]["force_N"]
    errors["fully_plastic"] = {
        "fe_force_N": fp,
        "law_force_N": params.fully_plastic_force,
        "law_over_fe": None if fp is None else params.fully_plastic_force / fp,
    }
    errors["yield"] = {"fe_force_N": yield_info["fe_force_N"],
                       "analytic_force_N": yield_info["analytic_force_N"],
                       "fe_over_analytic": yield_info["fe_over_analytic_force"]}
    errors["per_level_energy"] = [
        {"peak_force_N": r.level.max_force, "fe_loop_work_J": r.level.plastic_work,
         "fe_plastic_dissipation_J": r.plastic_dissipation,
         "law_loop_work_J": float(params.envelope_plastic_work(r.level.max_approach)),
         "fe_total_work_J": r.level.total_work,
         "second_cycle_residual_increment_ratio": (
             None if r.second_residual_approach is None else
             (r.second_residual_approach - r.level.residual_approach)
             / r.level.residual_approach)}
        for r in runs]
    radius_levels = [r.radius for r in runs if r.radius is not None]
    radius_table, radius_errors = fit_contact_radius(radius_levels, params.yield_approach,
                                                     material.effective_radius)
    if radius_errors:
        errors["contact_radius"] = radius_errors
    deepest = int(np.argmax([r.level.max_approach for r in runs]))
    return replace(params, yield_extra=extra, fit_errors=errors, radius_table=radius_table,
                   calibrated_range_extra=fe_calibrated_range(
                       runs[deepest].level.max_approach, runs[deepest].level.max_force,
                       len(runs), runs[deepest].result.summary, material.radius))


def top_contact_radius(summary: dict) -> float | None:
    """The FE's contact radius at a run's peak (m; its summary's contact resolution), None
    when the summary does not record it."""
    peak = (summary.get("contact_resolution", {}).get("elements_across_contact_radius", {})
            .get("peak", {}))
    radius = peak.get("contact_radius_m") if isinstance(peak, dict) else None
    return float(radius) if isinstance(radius, (int, float)) else None


def fe_calibrated_range(max_approach: float, max_force: float, levels: int,
                        summary: dict | None, radius: float) -> dict:
    """What an FE calibration's ``calibrated_range`` says beside its max_depth (``fit_law``'s):
    the deepest level's approach and force, its contact radius over R when the run records it,
    and where the range comes from. One place for ``fit_runs`` and for a shipped file given
    its range from its own record (``scripts/add_calibrated_range.py``)."""
    a = None if summary is None else top_contact_radius(summary)
    return {"max_approach_m": max_approach, "max_force_N": max_force,
            **({} if a is None else {"contact_radius_ratio": a / radius}),
            "source": f"the deepest of the {levels} FE levels (peak {max_force:.6g} N)"}
