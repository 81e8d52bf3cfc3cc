"""The campaign of record (``record``): per point the probe, the levels by contact size and the
repeated history on the FE of record, appended to the dataset point by point.

    python -m geocontact.universal.campaign --design record --points 64 \\
        [--dataset datasets/universal/record] [--cache datasets/fe-runs/universal-record] \\
        [--mesh default] [--kinematics finite]

Resumable and committed point by point, as the committed FE datasets are (datasets/fe-runs/
README.md): the FE cache is a folder of the repository, a point already in points.csv is skipped,
its finished runs come from the cache and an interrupted run goes on from its checkpoint. Each
finished point lands in points.csv and provenance.json by atomic rewrites (provenance first),
with its cost: the process CPU time (one worker runs the FE in this process), the solves and
Newton iterations of every run.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import InputError
from ..fem.settings import FeSettings
from ..files import folder_lock, write_json_atomic, write_text_atomic
from ..files import provenance as provenance_record
from . import record
from .record_dataset import RECORD_FORMAT, format_rows, point_row, read_points

DEFAULT_DATASET = Path("datasets/universal/record")
DEFAULT_CACHE = Path("datasets/fe-runs/universal-record")


def _cpu() -> float:
    """CPU time of this process and its finished children (gmsh runs in-process)."""
    import resource

    own = resource.getrusage(resource.RUSAGE_SELF)
    children = resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + children.ru_utime + children.ru_stime


def run_probes(point: record.RecordPoint, settings: FeSettings, cache: Path,
               progress: bool = True) -> tuple[list[Any], list[Any]]:
    """The probes of one point (``record.probe_job``, ``record.next_probe_force``: each next
    one deeper until the contact reaches the top target, at most ``record.MAX_PROBES``), run
    or read from ``cache``; returns the jobs and their results (``record.contact_curve`` of
    the results is the point's a(F)).

    A probe the FE cannot finish (Newton fails past every cutback and rescue mode, as a grain
    that has yielded through does) ends the probing: its converged steps, read from its
    checkpoint (``FailedRun``), stand for it, and the point's depth is what the FE reached
    (``record.base_force`` aims the base below it). A probe that fails before its first
    loaded step with a contact fails the point; so does a base (``run_point``)."""
    from ..fem.campaign import CampaignError, run_campaign

    material = point.material()
    probes, probe_results = [], []
    force = None
    for attempt in range(record.MAX_PROBES):  # a probe saves no snapshots: no branch follows it
        probes.append(record.probe_job(point, settings, force, attempt))
        try:
            probe_results.append(run_campaign([probes[-1]], cache, workers=1,
                                              progress=progress)[0])
        except CampaignError as exc:
            probe_results.append(FailedRun.of(probes[-1], cache, exc))
            if progress:
                print(f"record campaign: point {point.index}: {probes[-1].name()} failed; its "
                      f"converged steps (to {probe_results[-1].reached_N:.4g} N) are the "
                      "point's reach", file=sys.stderr)
            break
        force = record.next_probe_force(material, *record.contact_curve(
            *[r.curve for r in probe_results]))
        if force is None:
            break
    return probes, probe_results


class FailedRun:
    """The converged part of a run the FE could not finish (a probe or a base): its curve up to
    the last converged step (from its checkpoint in the cache), the force of that step and the
    error. Stands for the run's result in the level rule and the branches (``curve``); it has
    no summary."""

    def __init__(self, curve: dict[str, np.ndarray], error: str):
        self.curve, self.error = curve, error
        self.reached_N = float(curve["force_N"][-1])

    @classmethod
    def of(cls, job, cache: Path, error: Exception) -> FailedRun:
        """The failed run ``job``'s converged steps from its checkpoint in ``cache``; the
        ``error`` again when there is none, or no loaded step with a contact in it."""
        from ..fem.checkpoint import checkpoint_path, read_checkpoint
        from ..fem.result import CURVE_COLUMNS

        saved = read_checkpoint(checkpoint_path(cache / job.key()), job.identity(),
                                len(CURVE_COLUMNS), notify=lambda _message: None)
        if saved is None:
            raise error
        rows = np.asarray(saved.rows, dtype=float)
        curve = {name: rows[:, k] for k, name in enumerate(CURVE_COLUMNS)}
        if record.contact_curve(curve)[0].size < 2:
            raise error
        return cls(curve, str(error))


def run_point(point: record.RecordPoint, settings: FeSettings, cache: Path,
              progress: bool = True) -> tuple[dict[str, Any], dict[str, Any]]:
    """The probe, the levels and the repeated history of one point (one worker, in this
    process); returns the dataset row and the point's provenance record."""
    from ..calibrate.campaign import extract_run
    from ..fem.campaign import CampaignError, remove_snapshots, run_campaign
    from ..fem.identity import fe_code_hash

    material = point.material()
    cpu0, wall0 = _cpu(), time.perf_counter()
    # the probes (coarse mesh) find the force of the base, one loading on the FE of record whose
    # curve places the levels and from which they branch
    probes, probe_results = run_probes(point, record.probe_settings(settings), cache, progress)
    failed = isinstance(probe_results[-1], FailedRun)
    base = record.base_job(point, settings, record.base_force(material, *record.contact_curve(
        *[r.curve for r in probe_results]), failed=failed))
    try:
        base_result = run_campaign([base], cache, workers=1, progress=progress)[0]
    except CampaignError as exc:  # its converged steps and their snapshots are the base
        base_result = FailedRun.of(base, cache, exc)
        if progress:
            print(f"record campaign: point {point.index}: its base failed; its converged steps "
                  f"(to {base_result.reached_N:.4g} N) are the point's reach", file=sys.stderr)
    levels = record.level_forces(material, *_level_curve(material, base_result, probe_results))
    if failed:  # the base's reach is the campaign's choice below a failure, not the FE's limit
        levels["top"] = (f"the contact the base reached at {record.FAILED_PROBE_FORCE:g} x "
                         f"{probe_results[-1].reached_N:.4g} N, the last converged force of a "
                         f"probe the FE could not finish ({levels['top']})")
    jobs, cyclic = record.point_jobs(point, settings, levels, base, base_result.curve)
    _snapshots_for(base, [*jobs, cyclic], cache, progress,
                   failed=isinstance(base_result, FailedRun))
    results = run_campaign([*jobs, cyclic], cache, workers=1, progress=progress)
    remove_snapshots(cache, base)  # a saving only, not committed: the branches are done
    runs = [extract_run(j, r) for j, r in zip(jobs, results[:-1], strict=True)]
    row = point_row(point, runs, results[-1])
    every = [r for r in (*probe_results, base_result, *results) if not isinstance(r, FailedRun)]
    info = {
        "coordinates": dict(zip(record.AXIS_NAMES, point.coordinates, strict=True)),
        "material": {k: getattr(material, k) for k in (
            "youngs_modulus", "poissons_ratio", "compressive_yield_stress",
            "friction_angle_deg", "hardening_ratio", "radius")},
        "fe_settings": settings.as_dict(),
        "probe_mesh": record.PROBE_MESH,
        "probes": [{"forces_N": list(p.forces), "cache_key": p.key(),
                    "contact_over_radius_reached": float(
                        record.contact_curve(r.curve)[1][-1] / material.radius),
                    **({"failed": r.error, "converged_to_N": r.reached_N}
                       if isinstance(r, FailedRun) else {})}
                   for p, r in zip(probes, probe_results, strict=True)],
        "base": {"forces_N": list(base.forces), "cache_key": base.key(),
                 "contact_over_radius_reached": float(
                     record.contact_curve(base_result.curve)[1][-1] / material.radius),
                 **({"failed": base_result.error, "converged_to_N": base_result.reached_N}
                    if isinstance(base_result, FailedRun) else {})},
        "levels": {**levels, "achieved_contact_over_radius": [
            float(10.0 ** row[f"contact_{k}"]) for k in range(record.LEVELS)]},
        "repeated_history_forces_N": list(cyclic.forces),
        "cache_keys": [j.key() for j in [*probes, base, *jobs, cyclic]],
        "fe_code_hash": fe_code_hash(),  # the campaign's
        # the key, FE code and step control each result was made under (a reused run's own,
        # which may be older code that the campaign's reproduces)
        "runs": [{"key": r.summary["identity"]["key"], "fe_code": r.summary["identity"]["fe_code"],
                  "step_control": r.summary["identity"]["inputs"].get("step_control")}
                 for r in every],
        "elements": [r.summary["mesh"]["elements"] for r in every],
        "solves": [(r.summary.get("step_control") or {}).get("solves") for r in every],
        "newton_iterations": [r.summary.get("newton_iterations") for r in every],
        "run_wall_time_s": [r.summary["wall_time_s"] for r in every],
        "point_wall_time_s": time.perf_counter() - wall0,
        # CPU of this process over the point: the FE runs it computed (cached runs cost ~0)
        "point_cpu_time_s": _cpu() - cpu0,
        "warnings": sorted({w for r in every for w in r.summary.get("warnings", [])}),
    }
    return row, info


def _level_curve(material, base_result, probe_results) -> tuple[np.ndarray, np.ndarray]:
    """The a(F) the level rule reads: the base's (``record.contact_curve``), or, where the
    base's mesh resolves no contact at the lowest level's force (a deep base's first steps),
    the base's merged with the probes' below its first resolved contact (where they do not
    reach down to it either, ``record.lowest_contact`` takes Hertz's contact there)."""
    force, radius = record.contact_curve(base_result.curve)
    if force.size >= 2 and force[0] <= record.lowest_force(material) <= force[-1]:
        return force, radius
    low_force, low_radius = record.contact_curve(*[r.curve for r in probe_results])
    below = low_force < force[0]
    return (np.concatenate([low_force[below], force]),
            np.maximum.accumulate(np.concatenate([low_radius[below], radius])))


def _snapshots_for(base, branches, cache: Path, progress: bool, failed: bool = False) -> None:
    """The base's snapshots at the steps of those ``branches`` not yet in the cache: a base run
    reused from the cache (a new clone, or a session that stopped after it) has none, and each
    branch would compute the base's loading again; the base is then run again, once, only for
    them (the same run, so the same states to the bit). ``failed``: the base is one the FE
    could not finish (``FailedRun``), whose run again fails where it failed, after the
    snapshots of its converged steps (the branches' steps are among them)."""
    from ..errors import ConvergenceError
    from ..fem.campaign import adopt_snapshots
    from ..fem.checkpoint import checkpoint_path
    from ..fem.identity import equivalent_run, finished_run
    from ..fem.run import run_history, snapshot_path

    folder = adopt_snapshots(cache, base, progress)
    missing = [b for b in branches
               if finished_run(cache / b.key(), b.identity()) is None
               and equivalent_run(cache, b.identity()) is None
               and not checkpoint_path(cache / b.key()).exists()  # under way: goes on from it
               and not snapshot_path(folder, b.follows[1]).is_file()]
    if not missing:
        return
    if progress:
        print(f"record campaign: {base.name()}: its snapshots for {len(missing)} branches are "
              "not here; running it again for them", file=sys.stderr)
    try:
        run_history(base.material, list(base.forces), settings=base.settings(),
                    write_fields=False, snapshots=folder)
    except ConvergenceError:
        if not failed:
            raise


def run_points(count: int, directory: str | Path = DEFAULT_DATASET,
               cache_dir: str | Path = DEFAULT_CACHE, settings: FeSettings | None = None,
               progress: bool = True, only: list[int] | None = None) -> list[int]:
    """Run the first ``count`` points of the design of record not yet in the dataset (or the
    points ``only`` of them); returns the indices added. A point whose FE fails is recorded
    under ``failed`` and retried by the next call. A point made with other FE settings than
    ``settings`` (its provenance's ``fe_settings``) is made again (``_done``): its runs that
    those settings leave as they were come from the cache."""
    from ..fem.campaign import CampaignError
    from ..fem.identity import fe_code_hash

    settings = settings or record.fe_settings()
    directory, cache = Path(directory), Path(cache_dir)
    directory.mkdir(parents=True, exist_ok=True)
    done = _done(directory, settings)
    todo = [p for p in record.design_points(count)
            if p.index not in done and (only is None or p.index in only)]
    if progress:
        print(f"record campaign: {len(todo)} points to run ({settings.mesh} mesh, "
              f"{settings.kinematics} strain, {settings.kernels} kernels)", file=sys.stderr)
    added = []
    for point in todo:
        try:
            row, info = run_point(point, settings, cache, progress)
        except (CampaignError, InputError) as exc:
            with folder_lock(directory):
                provenance = _provenance(directory)
                provenance.setdefault("failed", {})[str(point.index)] = {
                    "coordinates": dict(zip(record.AXIS_NAMES, point.coordinates, strict=True)),
                    "error": str(exc)}
                write_json_atomic(directory / "provenance.json", provenance)
            if progress:
                print(f"record campaign: point {point.index} FAILED: {exc}", file=sys.stderr)
            continue
        # several processes (``--only``) may add points to one dataset: each rewrite is made
        # from the files as they are under the folder's lock, so none loses another's point
        with folder_lock(directory):
            provenance = _provenance(directory)
            provenance.update(_header(settings, fe_code_hash()))
            provenance.setdefault("failed", {}).pop(str(point.index), None)
            provenance["points"][str(point.index)] = info
            write_json_atomic(directory / "provenance.json", provenance)
            rows = [r for r in _rows(directory) if int(r["index"]) != point.index] + [row]
            write_text_atomic(directory / "points.csv", format_rows(rows))
            added.append(point.index)
            _prepare(directory, progress)
        if progress:
            print(f"record campaign: point {point.index} done ({info['point_cpu_time_s']:.0f} "
                  f"s CPU, {info['point_wall_time_s']:.0f} s wall; top a/R "
                  f"{info['levels']['achieved_contact_over_radius'][-1]:.3f})", file=sys.stderr)
    return added


def _done(directory: Path, settings: FeSettings) -> set[int]:
    """The points of the dataset made with ``settings`` (their provenance's ``fe_settings``)
    whose every run (their provenance's ``runs``) was made by the current FE code or one whose
    runs it reproduces (``fem.identity.REPRODUCED_FE_CODE``): a change of the FE of record (e.g.
    the step control "envelope" for the repeated history, or a change of that control) makes
    the others again (their runs that it leaves as they were come from the cache), so every
    point of the dataset is of one FE. A point recorded before ``runs`` is made again."""
    import json

    from ..fem.identity import fe_code_hash, reproduced_code

    made = _provenance(directory)["points"]
    wanted = json.loads(json.dumps(settings.as_dict()))

    def current(run: dict) -> bool:
        code = run.get("fe_code")
        return code == fe_code_hash() or reproduced_code(
            code, {"step_control": run.get("step_control")}) is not None

    def same_fe(info: dict) -> bool:
        return (info.get("fe_settings") == wanted and bool(info.get("runs"))
                and all(current(run) for run in info["runs"]))

    return {int(i) for i in read_points(directory)["index"]
            if same_fe(made.get(str(int(i)), {}))}


def _prepare(directory: Path, progress: bool) -> None:
    """fits.json brought up to date (``record_law.prepare``) once there are 2 points."""
    from .record_law import prepare

    if read_points(directory)["index"].size < 2:
        return
    try:
        prepare(directory)
    except InputError as exc:
        if progress:
            print(f"record campaign: fits.json not updated ({exc})", file=sys.stderr)


def _rows(directory: Path) -> list[dict[str, Any]]:
    data = read_points(directory)
    return [{c: (int(data[c][i]) if c == "index" else
                 (None if not np.isfinite(data[c][i]) else data[c][i])) for c in data}
            for i in range(data["index"].size)]


def _provenance(directory: Path) -> dict[str, Any]:
    import json

    path = directory / "provenance.json"
    return json.loads(path.read_text()) if path.exists() else {"format": RECORD_FORMAT,
                                                                "points": {}}


def _header(settings: FeSettings, code_hash: str) -> dict[str, Any]:
    return {"format": RECORD_FORMAT, "design": record.describe(),
            "fe": {**settings.as_dict(), "fe_code_hash": code_hash,
                   "history_shape": "0 -> F -> 0 -> F -> 0 (data/calibration.toml)",
                   "shared_mesh": "the levels share one mesh sized for the top level"},
            "command": "python -m geocontact.universal.campaign --design record",
            "last_update": provenance_record("universal record campaign", {})["created_utc"]}
