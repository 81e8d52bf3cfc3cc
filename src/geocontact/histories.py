"""Load histories of the paper (SPEC section 8) and a force-controlled driver for the law.

The law is approach-driven (what DEM needs); the paper's experiments are force-controlled. The
driver walks each monotone segment of a piecewise-linear force history in approach, finding the
approach of each force target by bisection on a copy of the contact state (the force is
monotone along any branch while the approach moves one way).
"""

from __future__ import annotations

import copy
import tomllib
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .errors import InputError
from .law import Contact, LawParams

PRESETS = ("repeated", "mono-increasing", "mono-decreasing", "single")


def preset_forces(name: str, peak_force: float = 3000.0) -> list[float]:
    """The paper's histories (SPEC 8) as force targets, scaled to ``peak_force`` (N)."""
    if name == "single":
        levels = [peak_force]
    elif name == "repeated":
        levels = [peak_force] * 10
    elif name == "mono-decreasing":
        levels = [peak_force * f for f in (1.0, 2500 / 3000, 2000 / 3000, 1500 / 3000,
                                           1000 / 3000, 500 / 3000, 100 / 3000)]
    elif name == "mono-increasing":
        levels = list(np.linspace(100.0 / 3000.0, 1.0, 7) * peak_force)
    else:
        raise InputError(f"history.preset: unknown {name!r} (allowed: {', '.join(PRESETS)})")
    forces = [0.0]
    for level in levels:
        forces += [float(level), 0.0]
    return forces


def load_history(path: str | Path) -> list[float]:
    """Force targets from ``H.toml`` (INTERFACES): ``forces = [...]`` or ``preset = "..."``."""
    p = Path(path)
    if not p.exists():
        raise InputError(f"history: file not found: {path}")
    try:
        data = tomllib.loads(p.read_text())
    except tomllib.TOMLDecodeError as exc:
        raise InputError(f"history: malformed TOML in {path}: {exc}") from None
    h = data.get("history")
    if not isinstance(h, dict):
        raise InputError("history: missing [history] table")
    unknown = set(h) - {"forces", "preset", "peak_force"}
    if unknown:
        raise InputError(f"history.{sorted(unknown)[0]}: unknown key "
                         "(allowed: forces, preset, peak_force)")
    if "forces" in h:
        forces = h["forces"]
        if not isinstance(forces, list) or len(forces) < 2:
            raise InputError("history.forces: must be a list of at least two forces (N)")
        out = []
        for i, f in enumerate(forces):
            if isinstance(f, bool) or not isinstance(f, (int, float)) or not np.isfinite(f):
                raise InputError(f"history.forces[{i}]: must be a finite number, got {f!r}")
            if f < 0:
                raise InputError(f"history.forces[{i}]: must be >= 0 N (compression), got {f}")
            out.append(float(f))
        return out
    if "preset" in h:
        peak = h.get("peak_force", 3000.0)
        if isinstance(peak, bool) or not isinstance(peak, (int, float)) or not peak > 0:
            raise InputError(f"history.peak_force: must be > 0 N, got {peak!r}")
        return preset_forces(str(h["preset"]), float(peak))
    raise InputError("history: needs forces = [...] or preset = \"...\"")


@dataclass
class LawRun:
    approach: np.ndarray
    force: np.ndarray
    cycles: list[dict]


def _approach_at_force(contact: Contact, target: float, upper: float) -> float:
    """Approach (above the current one) at which the force reaches ``target`` on loading."""
    low = contact.state.approach
    high = max(upper, low + 1e-12)
    while _probe(contact, high) < target:
        high = low + 2.0 * (high - low)
    for _ in range(200):
        mid = 0.5 * (low + high)
        if _probe(contact, mid) < target:
            low = mid
        else:
            high = mid
        if high - low <= 1e-13 * high:
            break
    return high


def _probe(contact: Contact, approach: float) -> float:
    trial = copy.copy(contact)
    trial.state = copy.copy(contact.state)
    return trial.update(approach)[0]


def drive_by_force(params: LawParams, forces: list[float], points: int = 60) -> LawRun:
    """The law under a piecewise-linear force history (each segment monotone in force).

    Returns the approach-force path and per cycle (each return to zero force) the maximum
    force and approach, the residual approach and the plastic work dissipated in the cycle."""
    contact = Contact(params)
    path_d, path_f = [0.0], [0.0]
    cycles: list[dict] = []
    cycle_start_dissipation, cycle_max_f, cycle_max_d = 0.0, 0.0, 0.0
    guess = params.yield_approach
    for f0, f1 in zip(forces[:-1], forces[1:], strict=True):
        if f1 > f0:
            for ft in np.linspace(f0, f1, points + 1)[1:]:
                d = _approach_at_force(contact, ft, contact.state.approach + guess)
                contact.update(d)
                path_d.append(d)
                path_f.append(contact.state.force)
            cycle_max_f = max(cycle_max_f, contact.state.force)
            cycle_max_d = max(cycle_max_d, contact.state.approach)
        elif f1 < f0:
            # unloading: the force falls monotonically with the approach; bisect downwards
            for ft in np.linspace(f0, f1, points + 1)[1:]:
                if ft <= 0.0:
                    d = contact.state.residual_approach + contact.state.ratchet_shift
                else:
                    low = contact.state.residual_approach + contact.state.ratchet_shift
                    high = contact.state.approach
                    for _ in range(200):
                        mid = 0.5 * (low + high)
                        if _probe(contact, mid) > ft:
                            high = mid
                        else:
                            low = mid
                        if high - low <= 1e-13 * high:
                            break
                    d = low
                contact.update(d)
                path_d.append(d)
                path_f.append(contact.state.force)
            if f1 == 0.0:
                dissipated = contact.dissipated_energy
                cycles.append({
                    "max_force_N": cycle_max_f,
                    "max_approach_m": cycle_max_d,
                    "residual_approach_m": contact.state.residual_approach
                    + contact.state.ratchet_shift,
                    "plastic_work_J": dissipated - cycle_start_dissipation,
                })
                cycle_start_dissipation, cycle_max_f, cycle_max_d = dissipated, 0.0, 0.0
    return LawRun(np.array(path_d), np.array(path_f), cycles)
