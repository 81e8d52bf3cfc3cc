"""Cyclic loading histories: the FE and the law on a cyclic force history, their per-cycle
analysis and shakedown (docs/model.md §6 and 8; the paper's section "Influence of loading
history"); ``geocontact cycles``.

The per-cycle analysis itself (cycle table, power laws in N, critical cycles, the shakedown
classification, the law's cyclic extension fitted from it) is ``calibrate.cyclic_fit``, shared
with the calibration; its names are re-exported here. This module adds the law's own cycles
(:func:`law_cycles_by_force`, :func:`law_cycles_along_path`), the FE's cycle windows, the
reloading stiffness, and :func:`run_cycles` (FE + law + analysis, written as one folder).
"""

from __future__ import annotations

import shutil
import sys
from pathlib import Path
from typing import Any

import numpy as np

from .._version import __version__
from ..calibrate.cyclic_fit import (
    DEFAULT_TOLERANCE,
    ELASTIC,
    ELASTIC_SHAKEDOWN,
    PLASTIC_SHAKEDOWN,
    RATCHETTING,
    RESOLUTION,
    UNDETERMINED,
    CycleAnalysis,
    GeometricLaw,
    PowerLaw,
    analyse,
    cycle_table,
    fit_geometric,
    fit_power_law,
    ratchetting_cycles,
    shakedown_rule,
    with_cyclic,
)
from ..errors import InputError
from ..fem.settings import FeSettings
from ..files import atomic_directory, provenance, write_csv, write_json_atomic
from ..grain.force_history import cycle_peak


def law_cycles_by_force(params, forces) -> tuple[list[dict], dict[str, np.ndarray]]:
    """The law driven by the force history (``histories.drive_by_force``): cycles and path."""
    from .force_driven import drive_by_force

    run = drive_by_force(params, list(forces))
    cycles = [{**c, "loop_work_J": c["plastic_work_J"]} for c in run.cycles]
    return cycles, {"approach_m": run.approach, "force_N": run.force}


def law_cycles_along_path(params, approach, windows) -> tuple[list[dict], dict[str, np.ndarray]]:
    """The law driven along an approach path (the FE's), with cycles cut at the given
    ``windows`` [(start index, end index)] of the path (the FE's cycles, from the one
    segmentation ``force_history.cycle_windows``: ``fe_cycle_windows``).

    Per cycle: the largest force and approach, the law's residual approach at the end of the
    window (its envelope's, plus any ratchet), and the loop area (work of the force over the
    window) as the plastic work; the dissipated-energy difference is reported beside it."""
    from ..law import Contact

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
        max_force, max_approach = cycle_peak(force, approach, (a, b))
        cycles.append({
            "max_force_N": max_force,
            "max_approach_m": max_approach,
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
               inputs: dict[str, Any] | None = None, overwrite: bool = False,
               **fe_model: Any) -> dict[str, Any]:
    """FE run of ``forces`` in ``out/fe`` (checkpointed), the law beside it when ``params`` is
    given (driven by the FE's approach path and by the force history), the cycle analysis of
    each, and ``out/summary.json``, ``out/cycles.csv`` (and law paths as CSV). With
    ``fit_params`` (a path) also ``params`` with its cyclic extension fitted to the FE.

    ``out`` is written as one unit (``io.atomic_directory``): an interrupted rerun never leaves
    new files beside old ones, and an existing ``out`` is replaced only if it is a cycles
    result of ours (unless ``overwrite``). The FE checkpoint (``checkpoint_of(out)``) lives
    beside ``out`` until the analysis has landed. ``fe_model``: the FE run's other settings
    (``fem.settings.FeSettings`` keywords: kinematics, mesh_rule, step_control, newton, ...;
    their defaults the FE's). Returns the summary."""
    unknown = sorted(set(fe_model) - set(FeSettings.names()))
    if unknown:
        raise TypeError(f"run_cycles: unknown FE settings {', '.join(unknown)}")
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
                                fe_model=fe_model, resume=resume, fit_params=fit_params,
                                progress=progress, inputs=inputs, previous_fe=out / "fe",
                                checkpoint=checkpoint)
    from ..fem.checkpoint import remove_checkpoint

    remove_checkpoint(checkpoint)  # the analysis has landed
    return summary


def _write_cycles(out: Path, material, forces, *, params, mesh, steps_per_segment, tolerance,
                  fe_model: dict[str, Any], resume, fit_params, progress, inputs,
                  previous_fe: Path, checkpoint: Path) -> dict[str, Any]:
    """The body of ``run_cycles``, writing into the (temporary) folder ``out``."""
    from ..fem.run import run_history  # the FE is an optional extra: imported when used

    fe_dir = out / "fe"
    # resume: a finished FE run of the same identity (inputs, FE code, libraries: fem.reuse)
    # in the previous folder is reused, else the FE goes on from its checkpoint
    result = None
    if resume:
        from ..fem.identity import FeRunIdentity, finished_run

        identity = FeRunIdentity.of(material, forces, mesh, steps_per_segment=steps_per_segment,
                                    **fe_model)
        why: list[str] = []
        result = finished_run(previous_fe, identity, fields=True, why=why)
        if why:
            print(f"cycles: not reusing the FE run in {previous_fe}: {why[0]}; running it "
                  "again", file=sys.stderr)
    if result is None:
        result = run_history(material, forces, mesh=mesh, out=fe_dir,
                             steps_per_segment=steps_per_segment, resume=resume,
                             progress=progress, write_fields=True, checkpoint=checkpoint,
                             **fe_model)
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
    from ..fem.settings import recorded_choice

    fs = result.summary
    summary = {
        "version": __version__,
        "analyses": {name: a.to_dict() for name, a in analyses.items()},
        "fe_run": {k: fs.get(k) for k in ("first_yield_force_N", "first_yield_approach_m",
                                          "fully_plastic_force_N", "mesh", "steps",
                                          "wall_time_s", "version", "inputs")},
        # the mesh rule and step control of the FE run and why (docs/fem.md "Defaults")
        "fe_choice": recorded_choice(fs),
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
