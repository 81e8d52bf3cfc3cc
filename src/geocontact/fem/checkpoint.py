"""The checkpoint of an FE run: its state after every converged step, so an interrupted run goes
on where it stopped (``run_history(resume=True)``).

``<out>.checkpoint.npz`` holds the converged state, the curve rows so far, the yield detector's
memory, the mesh and the run's identity (``fem.reuse``); ``<out>.checkpoint.fields/`` holds the
ParaView files of the waypoints already passed, so a resumed run writes the same files as an
uninterrupted one. Both are written atomically and removed when the run finishes.

A checkpoint only saves work: one that cannot be used (truncated, keys missing, an older
format, another run's) is reported in one line and the run starts over. One of the same run
written by FE code whose runs the current code reproduces, or with inputs equal to rounding
(``fem.reuse.difference(rounding=True)``), is used.
"""

from __future__ import annotations

import json
import re
import sys
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..files import atomic_path
from .state import State

FORMAT = 2  # 1: before fem.reuse (a hash of the inputs only, no fields)


def checkpoint_path(out: str | Path) -> Path:
    out = Path(out)
    return out.parent / (out.name + ".checkpoint.npz")


def pending_fields_path(out: str | Path) -> Path:
    """The folder beside the checkpoint that keeps the ParaView files of the waypoints a run has
    passed until it finishes (they then move into ``out/fields``)."""
    return fields_beside(checkpoint_path(out))


def fields_beside(checkpoint: str | Path) -> Path:
    """The pending ParaView folder of the checkpoint ``checkpoint`` (``X.npz`` -> ``X.fields``)."""
    checkpoint = Path(checkpoint)
    return checkpoint.with_name(checkpoint.name.removesuffix(".npz") + ".fields")


def remove_pending_fields(folder: str | Path) -> None:
    """Remove the pending ParaView files a run wrote (``step_NNNNN.vtu`` and their hidden
    temporaries), and the folder if nothing else is left in it: a file the program did not
    write there is never touched."""
    folder = Path(folder)
    if not folder.is_dir():
        return
    for entry in folder.iterdir():
        if entry.is_file() and (_FIELD.match(entry.name) or _FIELD_TEMP.match(entry.name)):
            entry.unlink(missing_ok=True)
    try:
        folder.rmdir()
    except OSError:  # not empty: something of someone else's is in it
        pass


def remove_checkpoint(checkpoint: str | Path) -> None:
    """Remove a checkpoint and its pending ParaView files (once the result has landed)."""
    Path(checkpoint).unlink(missing_ok=True)
    remove_pending_fields(fields_beside(checkpoint))


_FIELD = re.compile(r"^step_\d{5,}\.vtu$")
_FIELD_TEMP = re.compile(r"^\.step_\d{5,}\.vtu\.tmp-\d+-\w+\.vtu$")


def field_name(step: int) -> str:
    return f"step_{step:05d}.vtu"


@dataclass
class Checkpoint:
    """A run after ``done`` converged steps."""

    done: int
    state: State
    rows: list[list[float]]  # curve.csv rows of steps 0 ... done
    detector: dict[str, Any]  # first_yield, fully_plastic, last_elastic (run._Run), and
    # rescued_steps (run._advance; absent from checkpoints written before it: none), and
    # adaptive_steps (run.AdaptiveSteps.record, only for step_control "adaptive" or "dissipation")
    yield_force: float  # the yield probe's prediction, which placed the load steps
    mesh: Any  # the skfem mesh the run was on
    fields: bool  # the pending folder holds the ParaView files of the waypoints passed
    wall_time_s: float
    cpu_time_s: float | None  # None: written before the CPU time was recorded

    def problem(self, initial: State, steps: int, marks: list[int], pending: Path | None,
                write_fields: bool) -> str | None:
        """Why the run cannot go on from here (None: it can). ``initial``: the solver's initial
        state (the shapes the mesh needs), ``steps``: the run's number of load steps, ``marks``:
        the waypoints' steps."""
        fresh = initial.arrays()
        for name, value in self.state.arrays().items():
            if np.shape(value) != np.shape(fresh[name]):
                return f"inconsistent (state {name} has shape {np.shape(value)})"
        if not 0 <= self.done <= steps:
            return f"inconsistent ({self.done} steps done of {steps})"
        passed = [m for m in marks if 1 <= m <= self.done]
        if write_fields and passed and pending is not None and not (self.fields and all(
                (pending / field_name(m)).is_file() for m in passed)):
            return "it lacks the ParaView fields of the waypoints already passed"
        return None


def save_checkpoint(path: Path, identity_record: str, rows: list[list[float]], state: State,
                    mesh, *, yield_force: float, fields: bool, wall_time_s: float,
                    cpu_time_s: float | None, **detector) -> None:
    """Write the checkpoint atomically (a reader never sees half a file)."""
    with atomic_path(path) as tmp:
        np.savez(tmp, format=np.array(FORMAT), identity=np.array(identity_record),
                 done=np.array(len(rows) - 1), rows=np.array(rows),
                 yield_force_estimate=np.array(yield_force), fields=np.array(fields),
                 mesh_doflocs=mesh.doflocs, mesh_t=mesh.t,
                 meta=np.array(json.dumps(detector)), wall_time_s=np.array(wall_time_s),
                 **({} if cpu_time_s is None else {"cpu_time_s": np.array(cpu_time_s)}),
                 **{f"state_{name}": value for name, value in state.arrays().items()})


def read_checkpoint(path: Path, identity, columns: int,
                    notify: Callable[[str], None] | None = None) -> Checkpoint | None:
    """The checkpoint at ``path`` if it is a readable one of the run ``identity``
    (``fem.reuse.FeRunIdentity``) with ``columns`` curve columns; else None after one line
    saying why (``warn_checkpoint``)."""
    try:
        checkpoint, reason = _parse(path, identity, columns)
    except Exception as exc:  # any defect of the file is the same: unusable
        detail = " ".join(str(exc).split())[:160]
        checkpoint, reason = None, f"unreadable ({type(exc).__name__}: {detail})"
    if reason is not None:
        warn_checkpoint(path, reason, notify)
    return checkpoint


def warn_checkpoint(path: Path, reason: str,
                    notify: Callable[[str], None] | None = None) -> None:
    """One line on an unusable checkpoint, to ``notify`` (default: printed to stderr)."""
    message = f"warning: checkpoint {path} not used: {reason}; starting afresh"
    if notify is None:
        print(message, file=sys.stderr)
    else:
        notify(message)


def _parse(path: Path, identity, columns: int) -> tuple[Checkpoint | None, str | None]:
    from skfem import MeshTri2

    from .identity import difference

    with np.load(path, allow_pickle=False) as data:
        saved = {k: data[k] for k in data.files}
    if "identity" not in saved or int(saved.get("format", 1)) != FORMAT:
        return None, "written by an older FE (old checkpoint format)"
    # the same run: inputs equal to rounding, FE code the current code reproduces (fem.reuse)
    reason = difference(json.loads(str(saved["identity"])), identity, rounding=True)
    if reason is not None:
        return None, reason
    done = int(saved["done"])
    rows = np.asarray(saved["rows"], dtype=float)
    if rows.shape != (done + 1, columns):
        raise ValueError(f"curve rows of shape {rows.shape} for {done} steps")
    detector = json.loads(str(saved["meta"]))
    return Checkpoint(
        done=done,
        state=State.from_arrays({k[6:]: v for k, v in saved.items() if k.startswith("state_")}),
        rows=[list(r) for r in rows],
        detector={**{k: detector[k] for k in ("first_yield", "fully_plastic", "last_elastic")},
                  "rescued_steps": detector.get("rescued_steps", []),
                  **({"adaptive_steps": detector["adaptive_steps"]}
                     if "adaptive_steps" in detector else {})},
        yield_force=float(saved["yield_force_estimate"]),
        mesh=MeshTri2(np.ascontiguousarray(saved["mesh_doflocs"]),
                      np.ascontiguousarray(saved["mesh_t"])),
        fields=bool(saved["fields"]),
        wall_time_s=float(saved["wall_time_s"]),
        cpu_time_s=float(saved["cpu_time_s"]) if "cpu_time_s" in saved else None,
    ), None
