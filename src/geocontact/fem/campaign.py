"""Many independent FE runs at once: a Dask campaign with a result cache.

A calibration, a material sweep or a set of held-out checks is a list of FE runs that do not
depend on each other. ``run_campaign`` runs them on a Dask cluster (a local one by default, or
an existing scheduler by address, so a campaign scales past one machine) and caches every result
under its identity (``fem.reuse``: inputs, FE source hash, library versions): a rerun of the
same campaign is instant, a run interrupted half-way resumes from its FE checkpoint, and a run
that fails leaves the others finished and cached.

    jobs = [FemJob(material, (0, 1000, 0, 1000)), FemJob(material, (0, 3000, 0, 3000))]
    results = run_campaign(jobs, cache_dir="out/cache/fem")   # list of FemResult, same order
"""

from __future__ import annotations

import asyncio
import json
import logging
import os
import sys
import threading
from dataclasses import dataclass, replace
from pathlib import Path
from urllib.parse import urlsplit

import numpy as np

from ..errors import GeocontactError, InputError
from ..grain.force_history import validate_forces
from ..grain.material import Material
from .checkpoint import checkpoint_path, fields_beside
from .identity import (
    FeRunIdentity,
    check_follows,
    difference,
    equivalent_run,
    fe_code_hash,
    finished_run,
    recorded_identities,
    reused_message,
)
from .result import CURVE_COLUMNS, TOLERANCE, VOLUMETRIC_DEFAULT, FemResult
from .run import run_history, run_schedule, snapshot_path, sub_step_record, write_result
from .settings import DEFAULT_STEP_CONTROL, RECORD_DEFAULTS, FeSettings

DEFAULT_CACHE = Path("out/cache/fem")
SCHEDULER_SCHEMES = ("tcp", "tls", "ws", "wss", "ucx")
MESSAGE_FAILURES = 3  # failed runs described in a CampaignError's message (all in .failures)
PROGRESS_EVERY_S = 300.0  # how often a campaign reports its runs under way (their checkpoints)


class CampaignError(GeocontactError):
    """Some runs of a campaign failed; the others finished and are cached. ``failures``: one
    dict per failed run (name, key, inputs, error)."""

    def __init__(self, message: str, failures: list[dict]):
        super().__init__(message)
        self.failures = failures


@dataclass(frozen=True)
class FemJob:
    """One FE run: a material, a piecewise-linear force history (N) and the FE settings of
    ``run_history``. ``label`` names it in messages; it is not part of its identity."""

    material: Material
    forces: tuple[float, ...]
    mesh: str = "coarse"
    steps_per_segment: int | None = None
    label: str = ""
    mesh_force: float | None = None  # size the mesh for this force (default: the largest)
    tolerance: float = TOLERANCE
    volumetric: str = VOLUMETRIC_DEFAULT
    kinematics: str = "small"  # "small" | "finite" (fem.finite_strain)
    # "auto" (chosen from the material and the load: fem.settings.chosen_mesh_rule) | "yield" |
    # "contact" | "contact-dense" (fem.mesh.MESH_RULES)
    mesh_rule: str = "auto"
    step_rule: str = "segment"  # "segment" | "decade" (fem.run.load_schedule)
    max_step_ratio: float | None = None  # loading sub-step cap (fem.run.sub_steps)
    contact: str = "node"  # "node" | "facet" (fem.solver.CONTACTS)
    kernels: str | None = None  # "numpy" | "compiled" | None: the contact's default
    # "dissipation" | "adaptive" | "fixed" (fem.settings.STEP_CONTROLS, fem.run.AdaptiveSteps)
    step_control: str = DEFAULT_STEP_CONTROL
    newton: str = "full"  # "full" | "backtracking" (fem.settings.NEWTON_UPDATES)
    resolve_from: float | None = None  # smallest resolved contact over R (FeSettings)
    # a branch: (base forces, step) of the loading ramp it follows (fem.run.run_history); the
    # base job is this one with those forces and no ``follows``
    follows: tuple | None = None
    # save a snapshot after every step (``snapshots_folder``), for branches that follow this
    # run; not part of its identity
    snapshots: bool = False

    def __post_init__(self) -> None:
        if self.follows is not None:
            base, step = check_follows(self.follows)
            object.__setattr__(self, "follows", (base, step))
        object.__setattr__(self, "forces", tuple(validate_forces(list(self.forces))))
        self.identity()  # one-line InputError on a setting the FE would refuse

    @classmethod
    def of_inputs(cls, inputs: dict, **changes) -> FemJob:
        """The job of a run's recorded identity inputs (``summary.json`` ``identity.inputs``),
        with ``changes`` (FemJob fields) applied: the same run, or its twin in one setting."""
        job = cls(Material(**inputs["material"]), tuple(inputs["forces_N"]), inputs["mesh"],
                  steps_per_segment=inputs.get("steps_per_segment"),
                  mesh_force=inputs.get("mesh_force_N"), tolerance=inputs["tolerance"],
                  volumetric=inputs["volumetric"], kinematics=inputs.get("kinematics", "small"),
                  mesh_rule=inputs.get("mesh_rule", RECORD_DEFAULTS["mesh_rule"]),
                  step_rule=inputs.get("step_rule", "segment"),
                  max_step_ratio=inputs.get("max_step_ratio"),
                  contact=inputs.get("contact", "node"),
                  kernels=inputs.get("kernels"),
                  step_control=inputs.get("step_control", RECORD_DEFAULTS["step_control"]),
                  newton=inputs.get("newton", RECORD_DEFAULTS["newton"]),
                  resolve_from=inputs.get("resolve_from"),
                  follows=(None if "follows" not in inputs else (
                      tuple(inputs["follows"]["forces_N"]), inputs["follows"]["step"])))
        return replace(job, **changes) if changes else job

    def settings(self) -> FeSettings:
        """The job's FE settings (``fem.settings.FeSettings``)."""
        return FeSettings(**{name: getattr(self, name) for name in FeSettings.names()
                             if hasattr(self, name)})

    def identity(self) -> FeRunIdentity:
        return FeRunIdentity.of_settings(self.material, self.forces, self.settings(),
                                         self.follows)

    def base(self) -> FemJob:
        """The job a branch follows (``follows``), making the snapshots it starts from."""
        if self.follows is None:
            raise ValueError("FemJob.base: not a branch")
        return replace(self, forces=self.follows[0], follows=None, snapshots=True,
                       label=f"{self.name()} (base)")

    def inputs(self) -> dict:
        """The identity record: inputs, FE code hash, library versions, key."""
        return self.identity().to_dict()

    def key(self) -> str:
        """Hash of everything that decides the result (``fem.reuse.FeRunIdentity``)."""
        return self.identity().key()

    def name(self) -> str:
        return self.label or f"Fmax={max(self.forces):g}N"


def check_scheduler_address(address: str) -> str:
    """``address`` of a Dask scheduler as ``[scheme://]host:port``; a one-line InputError on
    anything else, before any connection is tried."""
    text = str(address).strip()
    url = urlsplit(text if "://" in text else f"tcp://{text}")
    try:
        port = url.port
    except ValueError:
        port = None
    if (url.scheme not in SCHEDULER_SCHEMES or not url.hostname or port is None
            or port < 1 or url.path not in ("", "/") or url.query or url.fragment
            or " " in text):
        raise InputError(f"scheduler: expected a Dask scheduler address "
                         f"[{'|'.join(SCHEDULER_SCHEMES)}://]host:port, got {address!r}")
    return text


def snapshots_folder(cache: str | Path, job: FemJob) -> Path:
    """Where a job with ``snapshots`` saves them in the cache (``<key>.steps/``), so a branch
    that follows it starts from its step instead of computing the base's steps again. They are
    a saving only, not a result: not committed with the cache, and removable
    (``remove_snapshots``) once the branches are done."""
    return Path(cache) / f"{job.key()}.steps"


def remove_snapshots(cache: str | Path, job: FemJob) -> None:
    """Remove the snapshots a job saved (the files the FE wrote there, then the folder if it
    is empty: anything else is left)."""
    folder = snapshots_folder(cache, job)
    if not folder.is_dir():
        return
    for path in folder.glob("step_*.checkpoint.npz"):
        path.unlink(missing_ok=True)
    try:
        folder.rmdir()
    except OSError:
        pass


def _run_job(job: FemJob, directory: str) -> FemResult:
    """On a worker: run (resuming from a checkpoint if one is there), without fields; a job
    with ``snapshots`` saves them beside its result, a branch starts from its base's."""
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    cache = Path(directory).parent
    extra = {}
    if job.snapshots and job.follows is None:
        extra["snapshots"] = snapshots_folder(cache, job)
    if job.follows is not None:
        extra["follows"] = job.follows
        extra["start"] = snapshot_path(snapshots_folder(cache, job.base()), job.follows[1])
    result = run_history(job.material, list(job.forces), out=directory,
                         settings=job.settings(), resume=True, write_fields=False,
                         overwrite=True, **extra)  # the cache folder is the program's own
    return FemResult(curve=result.curve, summary=result.summary)


def _cached(cache: Path, job: FemJob) -> Path:
    return cache / job.key()


def run_progress(checkpoint: str | Path) -> dict:
    """How far a run under way has come, from its checkpoint alone (``<key>.checkpoint.npz``):
    the load steps done of those requested, the solves they took of the run's total (before any
    cutback; with ``max_step_ratio`` a weak grain's steps differ in solves by a factor of 100 or
    more, so the solves are the fairer share of the work), the force reached and the FE time so
    far. Raises on a checkpoint that cannot be read."""
    with np.load(checkpoint, allow_pickle=False) as data:
        identity = json.loads(str(data["identity"]))
        done = int(data["done"])
        yield_force = float(data["yield_force_estimate"])
        wall = float(data["wall_time_s"])
        last = data["rows"][-1]
    run = FemJob.of_inputs(identity["inputs"]).identity()
    targets, _ = run_schedule(run, yield_force)
    return {"key": identity["key"], "step": done, "steps": len(targets),
            "solves_done": sub_step_record(targets[:done], yield_force,
                                           run.max_step_ratio)["solves"],
            "solves": sub_step_record(targets, yield_force, run.max_step_ratio)["solves"],
            "force_N": float(last[CURVE_COLUMNS.index("force_N")]), "wall_time_s": wall}


def describe_progress(progress: dict, since: dict | None = None) -> str:
    """One line of ``run_progress``: steps, share of the solves, force, FE time and its cost per
    solve so far; with ``since`` (an earlier ``run_progress`` of the same run), the time left at
    the rate between the two. The rate changes along a run (an elastic reload's solves are
    cheaper than those of a growing plastic contact), so that is a guide, not a promise."""
    done, total, wall = progress["solves_done"], progress["solves"], progress["wall_time_s"]
    text = (f"step {progress['step']} of {progress['steps']}, {done} of {total} solves "
            f"({100.0 * done / max(total, 1):.0f} %), F = {progress['force_N']:.4g} N, "
            f"{_duration(wall)} of FE so far")
    if done > 0:
        text += f" ({wall / done:.2g} s per solve)"
    if since is not None and since["solves_done"] < done < total and wall > since["wall_time_s"]:
        rate = (wall - since["wall_time_s"]) / (done - since["solves_done"])
        text += (f", about {_duration(rate * (total - done))} to go at the rate of its last "
                 f"{_duration(wall - since['wall_time_s'])}")
    return text


def _duration(seconds: float) -> str:
    return f"{seconds:.0f} s" if seconds < 120 else (
        f"{seconds / 60:.0f} min" if seconds < 7200 else f"{seconds / 3600:.1f} h")


def _watch(cache: Path, jobs: list[FemJob], every: float, stop: threading.Event) -> None:
    """Every ``every`` seconds until ``stop``: one line for each run whose checkpoint has moved
    on since the last report (a run on a remote cluster writes its checkpoint there, unseen).
    A checkpoint there at the start is where its run stands, not a report: a run waiting for a
    worker is not shown until it moves on."""
    paths = {checkpoint_path(_cached(cache, job)): job for job in jobs}
    last = {path: now for path in paths if (now := _progress_or_none(path)) is not None}
    while not stop.wait(every):
        for path, job in paths.items():
            now = _progress_or_none(path)
            before = last.get(path)
            if now is None or (before is not None and now["step"] == before["step"]):
                continue
            last[path] = now
            print(f"campaign: {job.name()}: {describe_progress(now, before)}", file=sys.stderr)


def _progress_or_none(checkpoint: Path) -> dict | None:
    """``run_progress``, or None for a checkpoint not there yet, gone (its run finished) or
    being replaced."""
    try:
        return run_progress(checkpoint)
    except Exception:  # noqa: BLE001 - any unreadable checkpoint is "nothing to report"
        return None


def _same_run(path: Path, identity) -> dict | None:
    """The identity record of the checkpoint (or snapshot) ``path`` if it is of the run
    ``identity`` under another key (inputs equal to rounding, or written by FE code whose runs
    the current code reproduces: ``fem.reuse.difference``), else None."""
    try:
        with np.load(path, allow_pickle=False) as data:
            recorded = json.loads(str(data["identity"]))
    except Exception:  # noqa: BLE001 - not a checkpoint this campaign can use
        return None
    return recorded if difference(recorded, identity, rounding=True) is None else None


def _adopt_checkpoint(cache: Path, job: FemJob, progress: bool) -> None:
    """Move the checkpoint of the same run under another key (inputs equal to rounding, or
    written by FE code whose runs the current code reproduces: ``fem.reuse.difference``) to
    this job's checkpoint path, with its pending ParaView folder and its snapshots
    (``snapshots_folder``: the branches that follow it start from them), so the run goes on
    from it."""
    target = checkpoint_path(_cached(cache, job))
    if target.exists():
        return
    identity = job.identity()
    for path in sorted(cache.glob("*.checkpoint.npz")):
        recorded = _same_run(path, identity)
        if recorded is None:
            continue
        fields = fields_beside(path)
        path.rename(target)
        if fields.exists():
            fields.rename(fields_beside(target))
        steps, own_steps = cache / f"{recorded['key']}.steps", snapshots_folder(cache, job)
        if steps.is_dir() and not own_steps.exists():
            steps.rename(own_steps)
        if progress:
            print(f"campaign: {job.name()}: going on from the checkpoint of {recorded['key']}, "
                  "the same run (inputs equal to rounding, or FE code whose runs the current "
                  "code reproduces)", file=sys.stderr)
        return


def adopt_snapshots(cache: str | Path, job: FemJob, progress: bool = False) -> Path:
    """The snapshots folder of ``job`` (``snapshots_folder``); where there is none, the folder
    of the same run under another key (its snapshots' identity equal to rounding, or written by
    FE code whose runs the current code reproduces: ``fem.reuse.difference``) is renamed to it
    first, so the branches start from those snapshots instead of a run of the base again."""
    cache = Path(cache)
    own = snapshots_folder(cache, job)
    if own.exists():
        return own
    identity = job.identity()
    for folder in sorted(cache.glob("*.steps")):
        snapshot = next(iter(sorted(folder.glob("step_*.checkpoint.npz"))), None)
        recorded = None if snapshot is None else _same_run(snapshot, identity)
        if recorded is None:
            continue
        folder.rename(own)
        if progress:
            print(f"campaign: {job.name()}: its snapshots are those of {recorded['key']}, the "
                  "same run (FE code whose runs the current code reproduces)", file=sys.stderr)
        break
    return own


def run_campaign(jobs: list[FemJob], cache_dir: str | Path = DEFAULT_CACHE, *,
                 scheduler: str | None = None, workers: int | None = None,
                 progress: bool = True,
                 progress_every: float | None = PROGRESS_EVERY_S) -> list[FemResult]:
    """Run every job (cached ones are read back) and return their results in order.

    ``scheduler``: address of an existing Dask scheduler (``tcp://host:8786``); None starts a
    local cluster of ``workers`` processes (default: one per core, at most one per job). With a
    remote cluster the workers write their results where ``cache_dir`` points on their machine;
    the results also come back over the wire and are cached here.

    A run that fails (no convergence, a gmsh error, any exception, its worker killed or out of
    memory) does not stop the others: they finish and are cached, then ``CampaignError`` names
    every failed run with its inputs and says how to resume (rerun: finished runs come from the
    cache, an interrupted run goes on from its checkpoint).

    ``progress``: report on stderr what is reused and what finishes, and every
    ``progress_every`` seconds (None: never) how far each run under way has come
    (``run_progress``: steps, solves, force, FE time; the time left at the rate since the
    previous report).
    """
    jobs = list(jobs)
    if not jobs:
        raise InputError("campaign: no FE runs to do")
    if scheduler is not None:
        scheduler = check_scheduler_address(scheduler)
    if progress_every is not None and (isinstance(progress_every, bool) or not (
            isinstance(progress_every, (int, float)) and 0 < progress_every < float("inf"))):
        raise InputError(f"progress_every: must be a number of seconds > 0, or None; "
                         f"got {progress_every!r}")
    cache = Path(cache_dir)
    cache.mkdir(parents=True, exist_ok=True)
    results: list[FemResult | None] = [finished_run(_cached(cache, job), job.identity())
                                       for job in jobs]
    recorded = recorded_identities(cache) if None in results else []
    for i, job in enumerate(jobs):
        if results[i] is None:
            found = equivalent_run(cache, job.identity(), recorded)
            if found is not None:
                results[i] = found[0]
                if progress and "reused" in found[0].summary:  # within a tolerance
                    print(f"campaign: {job.name()}: "
                          f"{reused_message(found[0].summary['reused'])}", file=sys.stderr)
                elif progress:
                    made_by = found[0].summary["identity"]["fe_code"]
                    why = ("inputs equal to rounding (computed on another machine)"
                           if made_by == fe_code_hash() else
                           f"made by FE code {made_by}, which the current code reproduces "
                           f"(fem.reuse.REPRODUCED_FE_CODE)")
                    print(f"campaign: {job.name()}: reusing {found[1]}, the same run: {why}",
                          file=sys.stderr)
    todo = [i for i, result in enumerate(results) if result is None]
    for i in todo:
        _adopt_checkpoint(cache, jobs[i], progress)
        if jobs[i].follows is not None:
            adopt_snapshots(cache, jobs[i].base(), progress)
    if progress:
        print(f"campaign: {len(jobs)} FE runs, {len(jobs) - len(todo)} cached, "
              f"{len(todo)} to run", file=sys.stderr)
    failures: dict[int, BaseException] = {}
    stop = threading.Event()
    watcher = None
    if todo and progress and progress_every is not None:
        watcher = threading.Thread(target=_watch, args=(cache, [jobs[i] for i in todo],
                                                        progress_every, stop), daemon=True)
        watcher.start()
    try:
        _run_todo(jobs, todo, cache, results, scheduler, workers, progress, failures)
    finally:
        stop.set()
        if watcher is not None:
            watcher.join()  # no progress line after the campaign's own last words
    if failures:
        raise _campaign_error(jobs, failures, cache)
    return results  # type: ignore[return-value]


def _run_todo(jobs, todo, cache, results, scheduler, workers, progress, failures) -> None:
    if todo:
        if scheduler is None and (len(todo) == 1 or workers == 1):
            for n, i in enumerate(todo, 1):
                job = jobs[i]
                try:
                    results[i] = _finish(cache, job, _run_job(job, str(_cached(cache, job))))
                except Exception as exc:  # reported with the run; the others go on
                    _failed(failures, i, jobs[i], exc, progress)
                    continue
                if progress:
                    print(f"campaign: {n}/{len(todo)} done ({job.name()})", file=sys.stderr)
        else:
            _run_on_dask(jobs, todo, cache, results, scheduler, workers, progress, failures)


def _finish(cache: Path, job: FemJob, result: FemResult) -> FemResult:
    path = _cached(cache, job)
    if not (path / "summary.json").exists():  # a remote worker wrote on its own disk
        write_result(result, path, None, {}, overwrite=True)
    reason = difference(result.summary.get("identity"), job.identity())
    if reason is not None:  # e.g. a remote worker with other library versions
        print(f"campaign: warning: {job.name()} was {reason} on its worker; its result is "
              "used here but will not be reused from the cache", file=sys.stderr)
    return result


def _describe_error(exc: BaseException) -> str:
    """One line: the error's type and message."""
    if type(exc).__name__ == "KilledWorker":
        return ("KilledWorker: the worker running it died on every attempt (killed, or out "
                "of memory)")
    if isinstance(exc, asyncio.CancelledError):
        return f"{type(exc).__name__}: the cluster cancelled it (scheduler lost?)"
    text = " ".join(str(exc).split())
    return f"{type(exc).__name__}: {text[:240] + ' ...' if len(text) > 240 else text}"


def _failed(failures: dict[int, BaseException], i: int, job: FemJob, exc: BaseException,
            progress: bool) -> None:
    failures[i] = exc
    if progress:
        print(f"campaign: FAILED {job.name()} ({job.identity().describe()}): "
              f"{_describe_error(exc)}", file=sys.stderr)


def _campaign_error(jobs: list[FemJob], failures: dict[int, BaseException],
                    cache: Path) -> CampaignError:
    records = [{"name": jobs[i].name(), "key": jobs[i].key(),
                "inputs": jobs[i].identity().describe(), "error": _describe_error(exc)}
               for i, exc in sorted(failures.items())]
    shown = MESSAGE_FAILURES
    runs = "; ".join(f"{r['name']} ({r['inputs']}): {r['error']}" for r in records[:shown])
    if len(records) > shown:
        runs += f"; and {len(records) - shown} more"
    others = len(jobs) - len(records)
    finished = ("no other run" if others == 0 else "the other run is" if others == 1
                else f"the other {others} runs are")
    return CampaignError(
        f"campaign: {len(records)} of {len(jobs)} FE runs failed: {runs}; {finished} finished "
        f"and cached in {cache}; rerun the same command to resume (finished runs come from the "
        "cache, an interrupted run goes on from its checkpoint)", records)


def local_cluster(workers: int):
    """The local Dask cluster of a campaign: one single-threaded process a worker, quiet.

    silence_logs: a run that fails is reported in one line (``_failed``); the workers' own
    "Compute Failed" log would print its traceback on the user's terminal as well. No
    dashboard, and the scheduler's HTTP server (health and metrics routes, on even without
    the dashboard) on a free port: on its default 8787, a second campaign on the machine
    printed a "Port 8787 is already in use" warning."""
    from dask.distributed import LocalCluster

    return LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                        dashboard_address=None, silence_logs=logging.CRITICAL,
                        scheduler_kwargs={"dashboard_address": "127.0.0.1:0"})


def _run_on_dask(jobs, todo, cache, results, scheduler, workers, progress, failures) -> None:
    from dask.distributed import Client, as_completed

    cluster = None
    if scheduler is None:
        cluster = local_cluster(workers or min(len(todo), os.cpu_count() or 1))
        client = Client(cluster)
    else:
        try:
            client = Client(scheduler, timeout=30)
        except OSError as exc:
            raise InputError(f"scheduler: cannot connect to {scheduler} ({exc})") from None
    try:
        same: dict[str, list[int]] = {}  # a run asked for twice is run once
        for i in todo:
            same.setdefault(jobs[i].key(), []).append(i)
        futures = {}
        for key, indices in same.items():
            job = jobs[indices[0]]
            future = client.submit(_run_job, job, str(_cached(cache, job).resolve()),
                                   key=f"fem-{key}", pure=False)
            futures[future] = indices
        for n, future in enumerate(as_completed(futures), 1):
            indices = futures[future]
            job = jobs[indices[0]]
            try:
                result = _finish(cache, job, future.result())
            except (Exception, asyncio.CancelledError) as exc:  # reported with the run (_failed)
                for i in indices:
                    _failed(failures, i, jobs[i], exc, progress)
                continue
            for i in indices:
                results[i] = result
            if progress:
                print(f"campaign: {n}/{len(futures)} done ({job.name()}, "
                      f"{result.summary['wall_time_s']:.1f} s)", file=sys.stderr)
    finally:
        client.close()
        if cluster is not None:
            cluster.close()
