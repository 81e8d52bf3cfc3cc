"""Force histories (docs/interfaces.md ``H.toml``; docs/model.md §8): the paper's named histories
and the
file parser, shared by the FE engine and the law's force-controlled driver."""

from __future__ import annotations

import tomllib
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import InputError
from ..files import read_text_input
from ..schema import finite_number

PRESETS = ("repeated", "mono-increasing", "mono-decreasing")


def preset_history(name: str, peak_force: float) -> list[float]:
    """The paper's named histories as force waypoints starting and ending at 0."""
    peak_force = finite_number("history.peak_force", peak_force)
    if not peak_force > 0:
        raise InputError(f"history.peak_force: must be > 0 N, got {peak_force:g}")
    if name == "repeated":  # 10 cycles 0 -> F -> 0
        peaks = [peak_force] * 10
    elif name == "mono-decreasing":  # 3000, 2500, ..., 500, 100 N for F = 3000 N
        peaks = [peak_force * k / 6.0 for k in range(6, 0, -1)] + [peak_force / 30.0]
    elif name == "mono-increasing":  # seven cycles rising from 100 to 3000 N for F = 3000 N
        peaks = list(np.linspace(peak_force / 30.0, peak_force, 7))
    else:
        raise InputError(
            f"history.preset: unknown name {name!r} "
            "(allowed: repeated, mono-increasing, mono-decreasing)"
        )
    forces = [0.0]
    for p in peaks:
        forces += [float(p), 0.0]
    return forces


def history_from_dict(data: dict[str, Any]) -> list[float]:
    h = data.get("history")
    if not isinstance(h, dict):
        raise InputError("history: missing [history] table")
    unknown = set(h) - {"forces", "preset", "peak_force"}
    if unknown:
        raise InputError(f"history.{sorted(unknown)[0]}: unknown key "
                         "(allowed: forces, preset, peak_force)")
    if "forces" in h and "preset" in h:
        raise InputError("history: give either forces or preset, not both")
    if "preset" in h:
        return preset_history(str(h["preset"]), h.get("peak_force", 3000.0))
    if "forces" not in h:
        raise InputError("history.forces: missing (or give preset = ...)")
    if "peak_force" in h:  # it would be ignored: the forces are the history
        raise InputError("history.peak_force: only with preset = ... (forces are in N already)")
    return validate_forces(h["forces"])


def validate_forces(forces) -> list[float]:
    if not isinstance(forces, (list, tuple, np.ndarray)) or len(forces) < 2:
        raise InputError("history.forces: need a list of at least 2 force values (N)")
    out = []
    for i, f in enumerate(forces):
        f = finite_number(f"history.forces[{i}]", f)
        if f < 0:
            raise InputError(f"history.forces[{i}]: must be a finite force >= 0 N, got {f:g}")
        out.append(f)
    if max(out) <= 0:
        raise InputError("history.forces: the largest force must be > 0 N")
    if out[0] != 0.0:
        out.insert(0, 0.0)
    return out


def load_history(path: str | Path) -> list[float]:
    try:
        data = tomllib.loads(read_text_input(path, "history"))
    except tomllib.TOMLDecodeError as exc:
        raise InputError(f"history: malformed TOML in {path}: {exc}") from None
    except RecursionError:
        raise InputError(f"history: malformed TOML in {path}: nested too deeply") from None
    return history_from_dict(data)


def cycle_windows(forces, marks, *, close_open_end: bool = True) -> list[tuple[int, int]]:
    """The one segmentation of a force history into load/unload cycles (FE, law and analyses).

    ``forces`` are the waypoints of the history (``forces[0] = 0``) and ``marks[i]`` where
    waypoint i lies along the driven path (a step number or a row index; ``marks[0]`` the
    start). A cycle runs from a zero-force waypoint through its peak to the next zero-force
    one; a history that does not end at zero closes its last cycle at its last waypoint when
    ``close_open_end``. Returns each cycle's (start mark, end mark); windows with nothing in
    between (a 0 -> 0 segment) are not cycles."""
    if len(marks) != len(forces):
        raise ValueError(f"marks: one per force waypoint ({len(forces)}), got {len(marks)}")
    ends = [marks[0]] + [m for f, m in zip(forces[1:], marks[1:], strict=True) if f == 0.0]
    if close_open_end and forces[-1] != 0.0:
        ends.append(marks[-1])
    return [(a, b) for a, b in zip(ends[:-1], ends[1:], strict=False) if b > a]


def cycle_peak(force, approach, window: tuple[int, int]) -> tuple[float, float]:
    """(largest force, approach there) of a cycle window [start, end] of a path."""
    a, b = window
    k = a + int(np.argmax(np.asarray(force[a:b + 1])))
    return float(force[k]), float(approach[k])
