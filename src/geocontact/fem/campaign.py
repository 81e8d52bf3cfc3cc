"""Many independent FE runs at once: a Dask campaign with a result cache.

A calibration, a material sweep or a set of held-out checks is a list of FE runs that do not
depend on each other. ``run_campaign`` runs them on a Dask cluster (a local one by default, or
an existing scheduler by address, so a campaign scales past one machine) and caches every result
by a hash of its inputs and the code version: a rerun of the same campaign is instant, and a run
interrupted half-way resumes from its FE checkpoint.

    jobs = [FemJob(material, (0, 1000, 0, 1000)), FemJob(material, (0, 3000, 0, 3000))]
    results = run_campaign(jobs, cache_dir="out/cache/fem")   # list of FemResult, same order
"""

from __future__ import annotations

import csv
import functools
import hashlib
import json
import os
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import ConvergenceError, InputError
from ..force_history import validate_forces
from ..material import Material
from .mesh import mesh_preset
from .run import CURVE_COLUMNS, FemResult, run_history, write_result

DEFAULT_CACHE = Path("out/cache/fem")


@dataclass(frozen=True)
class FemJob:
    """One FE run: a material, a piecewise-linear force history (N) and the mesh settings."""

    material: Material
    forces: tuple[float, ...]
    mesh: str = "coarse"
    steps_per_segment: int | None = None
    label: str = ""
    mesh_force: float | None = None  # size the mesh for this force (default: the largest)

    def __post_init__(self) -> None:
        object.__setattr__(self, "forces", tuple(validate_forces(list(self.forces))))
        mesh_preset(self.mesh)
        if self.mesh_force is not None and not (
                isinstance(self.mesh_force, (int, float)) and self.mesh_force >= max(self.forces)):
            raise InputError(f"mesh_force: must be >= the largest force {max(self.forces):g} N, "
                             f"got {self.mesh_force!r}")

    def inputs(self) -> dict:
        from .. import __version__

        inputs = {"material": self.material.to_dict(), "forces_N": list(self.forces),
                  "mesh": self.mesh, "steps_per_segment": self.steps_per_segment,
                  "version": __version__, "fe_code": fe_code_hash()}
        if self.mesh_force is not None:
            inputs["mesh_force_N"] = float(self.mesh_force)
        return inputs

    def key(self) -> str:
        """Hash of everything that decides the result (inputs and code version)."""
        text = json.dumps(self.inputs(), sort_keys=True)
        return hashlib.sha256(text.encode()).hexdigest()[:20]

    def name(self) -> str:
        return self.label or f"Fmax={max(self.forces):g}N"


# The sources that decide an FE result besides its inputs: a change to any of them (a new Fp
# detector, a solver fix) invalidates cached results even when the version string is unchanged.
_FE_SOURCES = ("fem/mesh.py", "fem/plasticity.py", "fem/run.py", "fem/solver.py",
               "force_history.py", "hertz.py", "material.py", "resolution.py")


@functools.cache
def fe_code_hash() -> str:
    """Hash of the FE engine's source files (part of every cache key)."""
    root = Path(__file__).resolve().parent.parent
    digest = hashlib.sha256()
    for name in _FE_SOURCES:
        digest.update(name.encode())
        digest.update((root / name).read_bytes())
    return digest.hexdigest()[:16]


def load_result(directory: str | Path) -> FemResult:
    """A result directory written by ``run_history(out=...)`` back as a FemResult."""
    directory = Path(directory)
    try:
        summary = json.loads((directory / "summary.json").read_text())
        with open(directory / "curve.csv", newline="") as fh:
            rows = list(csv.reader(fh))
    except (OSError, json.JSONDecodeError) as exc:
        raise InputError(f"FE result {directory}: unreadable ({exc})") from None
    header, body = rows[0], rows[1:]
    missing = [c for c in CURVE_COLUMNS if c not in header]
    if missing:
        raise InputError(f"FE result {directory}: curve.csv lacks columns {missing}")
    data = np.array(body, dtype=float).reshape(len(body), len(header))
    curve = {name: data[:, i] for i, name in enumerate(header)}
    for name in ("step", "plastic_points", "iterations"):
        if name in curve:
            curve[name] = curve[name].astype(int)
    return FemResult(curve=curve, summary=summary)


def _run_job(job: FemJob, directory: str) -> FemResult:
    """On a worker: run (resuming from a checkpoint if one is there), without fields."""
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    result = run_history(job.material, list(job.forces), mesh=job.mesh, out=directory,
                         steps_per_segment=job.steps_per_segment, resume=True,
                         write_fields=False, mesh_force=job.mesh_force,
                         overwrite=True)  # the cache folder is the program's own
    return FemResult(curve=result.curve, summary=result.summary)


def _cached(cache: Path, job: FemJob) -> Path:
    return cache / job.key()


def run_campaign(jobs: list[FemJob], cache_dir: str | Path = DEFAULT_CACHE, *,
                 scheduler: str | None = None, workers: int | None = None,
                 progress: bool = True) -> list[FemResult]:
    """Run every job (cached ones are read back) and return their results in order.

    ``scheduler``: address of an existing Dask scheduler (``tcp://host:8786``); None starts a
    local cluster of ``workers`` processes (default: one per core, at most one per job). With a
    remote cluster the workers write their results where ``cache_dir`` points on their machine;
    the results also come back over the wire and are cached here.
    """
    jobs = list(jobs)
    if not jobs:
        raise InputError("campaign: no FE runs to do")
    cache = Path(cache_dir)
    cache.mkdir(parents=True, exist_ok=True)
    results: list[FemResult | None] = [None] * len(jobs)
    todo: list[int] = []
    for i, job in enumerate(jobs):
        path = _cached(cache, job)
        if (path / "summary.json").exists():
            results[i] = load_result(path)
        else:
            todo.append(i)
    if progress:
        print(f"campaign: {len(jobs)} FE runs, {len(jobs) - len(todo)} cached, "
              f"{len(todo)} to run", file=sys.stderr)
    if todo:
        if scheduler is None and (len(todo) == 1 or workers == 1):
            for n, i in enumerate(todo, 1):
                job = jobs[i]
                results[i] = _finish(cache, job, _run_job(job, str(_cached(cache, job))))
                if progress:
                    print(f"campaign: {n}/{len(todo)} done ({jobs[i].name()})", file=sys.stderr)
        else:
            _run_on_dask(jobs, todo, cache, results, scheduler, workers, progress)
    return results  # type: ignore[return-value]


def _finish(cache: Path, job: FemJob, result: FemResult) -> FemResult:
    path = _cached(cache, job)
    if not (path / "summary.json").exists():  # a remote worker wrote on its own disk
        write_result(result, path, None, {}, overwrite=True)
    return result


def _run_on_dask(jobs, todo, cache, results, scheduler, workers, progress) -> None:
    from dask.distributed import Client, LocalCluster, as_completed

    cluster = None
    if scheduler is None:
        n = workers or min(len(todo), os.cpu_count() or 1)
        cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True,
                               dashboard_address=None)
        client = Client(cluster)
    else:
        try:
            client = Client(scheduler, timeout=30)
        except OSError as exc:
            raise InputError(f"scheduler: cannot connect to {scheduler} ({exc})") from None
    try:
        futures = {}
        for i in todo:
            job = jobs[i]
            future = client.submit(_run_job, job, str(_cached(cache, job).resolve()),
                                   key=f"fem-{job.key()}", pure=False)
            futures[future] = i
        for n, future in enumerate(as_completed(futures), 1):
            i = futures[future]
            try:
                result = future.result()
            except ConvergenceError as exc:
                raise ConvergenceError(f"campaign run {jobs[i].name()}: {exc}") from None
            results[i] = _finish(cache, jobs[i], result)
            if progress:
                print(f"campaign: {n}/{len(todo)} done ({jobs[i].name()}, "
                      f"{result.summary['wall_time_s']:.1f} s)", file=sys.stderr)
    finally:
        client.close()
        if cluster is not None:
            cluster.close()
