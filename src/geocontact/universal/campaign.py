"""The universal law's FE campaign: a calibration-grade set of FE runs per point of material
space, reduced to normalised data and appended to the dataset point by point.

    python -m geocontact.universal.campaign --points 40 [--workers 1] [--scheduler ADDRESS]

Each point is the set ``geocontact calibrate`` runs (``calibrate.campaign.calibration_jobs``:
cycles 0 -> F -> 0 -> F -> 0, one mesh sized for the top peak) at the peaks
``design.force_levels(s)`` x the analytic Fy, on the coarse mesh, cached by
``fem.reuse.FeRunIdentity`` in the cache folder. The paper's 10-cycle repeated history is not
part of a point (it costs as much as the seven levels together): the universal law is the
single-envelope law, with the cyclic extension off (docs/universal.md).

Resumable: a point already in points.csv is skipped, an interrupted point's finished FE runs come
from the cache (and an interrupted run from its checkpoint). Each finished point lands in
points.csv and provenance.json by atomic rewrites (provenance first, so a row never exists
without its record), and fits.json is brought up to date (``interpolate.prepare``).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

from .._version import __version__
from ..errors import InputError, run_reporting_errors
from ..fem.settings import MESH_RULE_CHOICES, NEWTON_UPDATES, STEP_CONTROLS, STEP_RULES
from ..files import provenance as provenance_record
from ..files import write_json_atomic, write_text_atomic
from ..grain.hertz import incipient_yield
from .dataset import (
    DATASET_FORMAT,
    default_directory,
    format_points,
    read_points,
    read_provenance,
    rows_of,
    virgin_force_grid,
)
from .design import (
    AXES,
    CAMPAIGN_MODULUS,
    CAMPAIGN_RADIUS,
    LEVELS,
    SOBOL_SEED,
    DesignPoint,
    design_points,
    force_levels,
)

MESH = "coarse"
DEFAULT_CACHE = Path("out/cache/universal")
# the v1 design's FE model beside the mesh (point_jobs)
V1_FE_MODEL = {"mesh_rule": "yield", "step_control": "fixed"}


def point_jobs(point: DesignPoint, mesh: str = MESH):
    """The FE runs of one point (``calibrate.campaign.calibration_jobs`` at its peaks), on the
    "yield" meshes with fixed load steps: the v1 design's FE, the defaults it was made with
    (named since issue 36 made "auto" and the adaptive control the defaults)."""
    from ..calibrate.campaign import calibration_jobs

    material = point.material()
    fy = incipient_yield(material).force
    return calibration_jobs(material, [float(p) * fy for p in force_levels(
        point.log10_modulus_over_strength)], mesh, fe_model=V1_FE_MODEL)


def point_row(point: DesignPoint, jobs, results) -> dict[str, Any]:
    """The dataset row of a point from its FE runs (see ``dataset``)."""
    from ..calibrate.campaign import extract_run, fe_fully_plastic, fe_yield
    from ..calibrate.fit import _power_exponent

    material = point.material()
    analytic = incipient_yield(material)
    fy, dy = analytic.force, analytic.approach
    runs = [extract_run(job, result) for job, result in zip(jobs, results, strict=True)]
    row: dict[str, Any] = {"index": point.index}
    row.update(zip([a[0] for a in AXES], point.coordinates, strict=True))
    row["fe_yield_ratio"] = fe_yield(material, runs)["fe_force_N"] / fy
    fp = fe_fully_plastic(runs)["force_N"]
    row["fully_plastic_ratio"] = None if fp is None else fp / fy
    row.update(virgin_samples(runs, fy, dy, point.log10_modulus_over_strength))
    for level, run in enumerate(sorted(runs, key=lambda r: r.level.max_force)):
        lv = run.level
        row[f"logx_{level}"] = np.log10(lv.max_approach / dy)
        row[f"residual_{level}"] = lv.residual_approach / lv.max_approach
        row[f"work_{level}"] = lv.plastic_work / lv.total_work
        row[f"unloading_exponent_{level}"] = _power_exponent(
            lv.unloading_approach, lv.unloading_force, lv.residual_approach, lv.max_approach,
            lv.max_force)[0]
        row[f"reloading_exponent_{level}"] = _power_exponent(
            lv.reloading_approach, lv.reloading_force, lv.residual_approach, lv.max_approach,
            lv.max_force)[0]
        second = run.second_residual_approach
        row[f"second_increment_{level}"] = (None if second is None else
                                            (second - lv.residual_approach)
                                            / lv.residual_approach)
    return row


def sample_virgin_curve(runs, fy: float, dy: float, force_grid) -> tuple[np.ndarray, float]:
    """log10(delta/delta_y) of the stitched virgin curve at F/Fy = ``force_grid`` (below the
    FE's first loaded step Hertz's, x = (F/Fy)^(2/3)), and the curve's top log10(F/Fy)."""
    from ..calibrate.campaign import virgin_curve

    d, f, _ = virgin_curve(runs)
    keep = (f > 0.0) & (d > 0.0)
    logf, logd = np.log10(f[keep] / fy), np.log10(d[keep] / dy)
    order = np.argsort(logf, kind="stable")
    logf, logd = logf[order], np.maximum.accumulate(logd[order])
    grid = np.log10(force_grid)
    values = np.interp(grid, logf, logd)
    below = grid < logf[0]
    values[below] = (2.0 / 3.0) * grid[below]
    return values, float(logf[-1])


def virgin_samples(runs, fy: float, dy: float, s: float) -> dict[str, float]:
    """log10(delta/delta_y) of the stitched virgin curve at F/Fy = ``virgin_force_grid(s)``;
    below the FE's first loaded step the curve is Hertz's (elastic, x = (F/Fy)^(2/3))."""
    force_grid = virgin_force_grid(s)
    values, top = sample_virgin_curve(runs, fy, dy, force_grid)
    grid = np.log10(force_grid)
    if grid[-1] > top + 1e-6:
        raise InputError(f"universal campaign: the virgin curve stops at F/Fy = "
                         f"{10 ** top:.4g}, below the grid's top {10 ** grid[-1]:.4g}")
    return {f"virgin_logx_{k:02d}": float(v) for k, v in enumerate(values)}


def run_points(count: int, directory: str | Path | None = None,
               cache_dir: str | Path = DEFAULT_CACHE, *, scheduler: str | None = None,
               workers: int | None = None, progress: bool = True) -> list[int]:
    """Run the first ``count`` design points not yet in the dataset; returns the indices
    added. A point whose FE runs fail is recorded as failed in provenance.json and retried by
    the next call; the others go on."""
    from ..fem.campaign import CampaignError, check_scheduler_address, local_cluster, run_campaign
    from ..fem.identity import fe_code_hash

    directory = Path(directory or default_directory())
    directory.mkdir(parents=True, exist_ok=True)
    data = read_points(directory)
    done = {int(i) for i in data["index"]}
    todo = [p for p in design_points(count) if p.index not in done]
    if progress:
        print(f"universal campaign: {count} points asked, {count - len(todo)} in the dataset, "
              f"{len(todo)} to run ({LEVELS} FE runs each, {MESH} mesh)", file=sys.stderr)
    if not todo:
        return []
    if scheduler is not None:
        scheduler = check_scheduler_address(scheduler)
    cluster = None
    if scheduler is None:
        cluster = local_cluster(workers or 2)
        scheduler = cluster.scheduler_address
    added = []
    started = time.perf_counter()
    try:
        for n, point in enumerate(todo, 1):
            jobs = point_jobs(point)
            t0 = time.perf_counter()
            try:
                results = run_campaign(jobs, cache_dir, scheduler=scheduler, progress=False)
                row = point_row(point, jobs, results)
            except (CampaignError, InputError) as exc:
                record = read_provenance(directory)
                record.setdefault("failed", {})[str(point.index)] = {
                    "coordinates": dict(zip([a[0] for a in AXES], point.coordinates,
                                            strict=True)),
                    "error": str(exc)}
                write_json_atomic(directory / "provenance.json", record)
                if progress:
                    print(f"universal campaign: point {point.index} FAILED: {exc}",
                          file=sys.stderr)
                continue
            wall = time.perf_counter() - t0
            record = read_provenance(directory)
            record.update(_header(fe_code_hash(), provenance_record))
            record.setdefault("failed", {}).pop(str(point.index), None)
            record["points"][str(point.index)] = {
                "coordinates": dict(zip([a[0] for a in AXES], point.coordinates, strict=True)),
                "material": {k: getattr(point.material(), k) for k in (
                    "youngs_modulus", "poissons_ratio", "compressive_yield_stress",
                    "friction_angle_deg", "hardening_ratio", "radius")},
                "peak_forces_N": [max(j.forces) for j in jobs],
                "cache_keys": [j.key() for j in jobs],
                "fe_code_hash": fe_code_hash(),
                "geocontact_version": _version(),
                "elements": [r.summary["mesh"]["elements"] for r in results],
                "run_wall_time_s": [r.summary["wall_time_s"] for r in results],
                "point_wall_time_s": wall,
                "warnings": sorted({w for r in results for w in r.summary.get("warnings", [])}),
            }
            write_json_atomic(directory / "provenance.json", record)
            data = read_points(directory)
            rows = [r for r in rows_of(data) if int(r["index"]) != point.index] + [row]
            write_text_atomic(directory / "points.csv", format_points(rows))
            added.append(point.index)
            _prepare(directory, progress)
            if progress:
                elapsed = time.perf_counter() - started
                eta = elapsed / n * (len(todo) - n)
                print(f"universal campaign: point {point.index} done ({n}/{len(todo)}, "
                      f"{wall:.0f} s; beta {point.friction_angle_deg:.1f}, nu "
                      f"{point.poissons_ratio:.3f}, m {point.hardening_ratio:.3f}, E/sigma_c "
                      f"{10 ** point.log10_modulus_over_strength:.0f}); "
                      f"{len(data['index']) + 1} in the dataset; ETA {eta / 60:.0f} min",
                      file=sys.stderr)
    finally:
        if cluster is not None:
            cluster.close()
    return added


def _prepare(directory: Path, progress: bool) -> None:
    """Bring fits.json up to date with the new row (the law's warm starts and LOO errors):
    the dataset is ready for `geocontact params` after every point."""
    from .interpolate import MIN_POINTS, prepare

    if read_points(directory)["index"].size < MIN_POINTS:
        return
    try:
        prepare(directory, progress=False)
    except InputError as exc:  # e.g. too few points to span the box yet
        if progress:
            print(f"universal campaign: fits.json not updated ({exc})", file=sys.stderr)


def _version() -> str:

    return __version__


def _header(code_hash: str, provenance_record) -> dict[str, Any]:
    return {
        "format": DATASET_FORMAT,
        "design": {"axes": [{"name": a[0], "low": a[1], "high": a[2]} for a in AXES],
                   "sequence": "centre of the box, 8 corners (half fraction x4 = x1 x2 x3), 8 "
                               "scrambled Sobol points (scipy.stats.qmc, seed "
                               f"{SOBOL_SEED}), the other 8 corners, then Sobol on",
                   "modulus_Pa": CAMPAIGN_MODULUS, "radius_m": CAMPAIGN_RADIUS},
        "levels_force_over_yield": "design.force_levels(s): LEVELS geometric from 2 to "
                                   "140 x 10^(s - 2), s = log10(E/sigma_c)",
        "virgin_force_over_yield": "dataset.virgin_force_grid(s): geometric from 0.5 to the top "
                                   "level",
        "fe": {"mesh": MESH, "history_shape": "0 -> F -> 0 -> F -> 0 (data/calibration.toml)",
               "shared_mesh": "one mesh per point, sized for the top peak",
               "cyclic_run": "not part of a point (the law's cyclic extension stays off)"},
        "command": "python -m geocontact.universal.campaign",
        "last_update": provenance_record("universal campaign", {})["created_utc"],
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m geocontact.universal.campaign",
        description="Run the universal law's FE campaign: the first --points points of the "
                    "design not yet in the dataset, each appended when it finishes.")
    parser.add_argument("--points", type=int, required=True, help="design points to reach")
    parser.add_argument("--design", default="v1", choices=["v1", "record"],
                        help="design version: v1 (today's shipped dataset: 4 axes, levels in "
                             "Fy, coarse mesh, small strain) or record (issue 37: the widened "
                             "box, levels by contact size, the repeated history, the FE of "
                             "record; geocontact.universal.record)")
    parser.add_argument("--dataset", default=None,
                        help="dataset folder (default: the package's data/universal; record: "
                             "datasets/universal/record)")
    parser.add_argument("--cache", default=None,
                        help=f"FE result cache (default {DEFAULT_CACHE}; record: "
                             "datasets/fe-runs/universal-record)")
    parser.add_argument("--scheduler", default=None, metavar="ADDRESS",
                        help="Dask scheduler address (default: a local cluster; v1 only)")
    parser.add_argument("--workers", type=int, default=2,
                        help="local Dask workers (default 2; record: one, in this process)")
    parser.add_argument("--mesh", default=None, choices=["coarse", "default", "fine"],
                        help="record only: the FE mesh (default: default; coarse for pilots)")
    parser.add_argument("--kinematics", default=None, choices=["small", "finite"],
                        help="record only: the FE kinematics (default: finite)")
    parser.add_argument("--mesh-rule", default=None, choices=list(MESH_RULE_CHOICES),
                        help="record only: the FE mesh rule (default: the FE's, 'auto'; the "
                             "pilot's: 'yield')")
    parser.add_argument("--step-control", default=None, choices=list(STEP_CONTROLS),
                        help="record only: the FE load-step control (default: 'envelope', "
                             "the record's; the pilot's: 'fixed')")
    parser.add_argument("--newton", default=None, choices=list(NEWTON_UPDATES),
                        help="record only: the FE's Newton updates (default: 'backtracking', "
                             "the record's; the pilot's: 'full')")
    parser.add_argument("--step-rule", default=None, choices=list(STEP_RULES),
                        help="record only: the FE load-step rule (default: 'decade', so the "
                             "levels land near their targets; the pilot's: 'segment')")
    parser.add_argument("--only", type=int, nargs="+", default=None, metavar="INDEX",
                        help="record only: run just these points of the first --points")
    args = parser.parse_args(argv)

    def run() -> int:
        from ..fem.limits import check_workers

        if args.design == "record":
            return _run_record(args)
        for flag in ("mesh", "kinematics", "mesh_rule", "step_control", "step_rule", "newton",
                     "only"):
            if getattr(args, flag) is not None:
                raise InputError(f"--{flag.replace('_', '-')}: only with --design record "
                                 "(v1 is coarse, small strain, every point)")
        check_workers(args.workers)
        added = run_points(args.points, args.dataset, args.cache or DEFAULT_CACHE,
                           scheduler=args.scheduler,
                           workers=args.workers)
        print(f"universal campaign: {len(added)} points added")
        return 0

    return run_reporting_errors(run)


def _run_record(args) -> int:
    """``--design record``: the campaign of record (``record_campaign.run_points``)."""
    from . import record, record_campaign

    if args.scheduler is not None:
        raise InputError("--scheduler: the record campaign runs one worker in this process "
                         "(resumable point by point); run several processes with --only")
    record.design_points(args.points)  # one-line error on a bad count, before any work
    settings = record.fe_settings(**{k: v for k, v in (
        ("mesh", args.mesh), ("kinematics", args.kinematics), ("mesh_rule", args.mesh_rule),
        ("step_control", args.step_control), ("step_rule", args.step_rule),
        ("newton", args.newton)) if v is not None})
    added = record_campaign.run_points(
        args.points, args.dataset or record_campaign.DEFAULT_DATASET,
        args.cache or record_campaign.DEFAULT_CACHE, settings, only=args.only)
    print(f"universal campaign (record): {len(added)} points added")
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
