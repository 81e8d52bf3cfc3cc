"""A force-controlled driver for the law (the paper's histories live in ``force_history``).

The law is approach-driven (what DEM needs); the paper's experiments are force-controlled. The
driver walks each monotone segment of a piecewise-linear force history in approach, finding the
approach of each force target by bisection on a copy of the contact state (the force is
monotone along any branch while the approach moves one way). The ratchet of the cyclic extension
is a creep at constant force in the envelope band; a force-controlled reload goes through all of it.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass

import numpy as np

from ..grain.force_history import (
    cycle_peak,
    cycle_windows,
)
from ..law import Contact, LawParams
from ..law.reference import RATCHET


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

    Returns the approach-force path and per cycle (each return to zero force,
    ``force_history.cycle_windows``) the maximum force and approach, the residual approach and
    the plastic work dissipated in the cycle."""
    contact = Contact(params)
    path_d, path_f = [0.0], [0.0]
    # at each waypoint: its row in the path, the residual approach and the dissipated energy
    marks, residual, dissipated = [0], [0.0], [0.0]
    guess = params.yield_approach
    for f0, f1 in zip(forces[:-1], forces[1:], strict=True):
        if f1 > f0:
            for ft in np.linspace(f0, f1, points + 1)[1:]:
                d = _approach_at_force(contact, ft, contact.state.approach + guess)
                contact.update(d)
                path_d.append(d)
                path_f.append(contact.state.force)
                if contact.state.branch == RATCHET:
                    # in the envelope band the ratchet creeps at constant force: under force
                    # control the whole creep happens at this target (bisection stops in it)
                    s = contact.state
                    d = s.approach + s.pending_ratchet
                    contact.update(d)
                    path_d.append(d)
                    path_f.append(contact.state.force)
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
        marks.append(len(path_d) - 1)
        residual.append(contact.state.residual_approach + contact.state.ratchet_shift)
        dissipated.append(contact.dissipated_energy)
    row = {m: i for i, m in enumerate(marks)}  # the last waypoint at each row
    cycles = []
    for a, b in cycle_windows(forces, marks, close_open_end=False):
        max_force, max_approach = cycle_peak(path_f, path_d, (a, b))
        cycles.append({
            "max_force_N": max_force,
            "max_approach_m": max_approach,
            "residual_approach_m": residual[row[b]],
            "plastic_work_J": dissipated[row[b]] - dissipated[row[a]],
        })
    return LawRun(np.array(path_d), np.array(path_f), cycles)
