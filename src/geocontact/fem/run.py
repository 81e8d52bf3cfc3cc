"""A force history on the FE model: load stepping, yield detection, outputs (docs/model.md §2, 5).

Public entry point::

    result = run_history(material, forces, mesh="coarse", out=None)
    result.curve    # dict of numpy arrays (the columns of curve.csv)
    result.summary  # dict (summary.json)

All user-facing values are for the ball-ball pair: approach = 2 x the ball-wall interference of
the half model, energies = 2 x the half model's (docs/model.md §2). The force is the same.
"""

from __future__ import annotations

import csv
import dataclasses
import json
import math
import shutil
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from .._version import __version__
from ..errors import ContactBeyondMeshError, ConvergenceError, InputError
from ..files import atomic_directory, atomic_path, check_replaceable, write_json_atomic
from ..grain.force_history import (
    cycle_peak,
    cycle_windows,
    history_from_dict,
    load_history,
    preset_history,
)
from ..grain.hertz import contact_radius, hertz_approach, incipient_yield
from ..grain.material import Material
from . import roundoff as resolution
from .checkpoint import (
    checkpoint_path,
    field_name,
    fields_beside,
    read_checkpoint,
    remove_checkpoint,
    remove_pending_fields,
    save_checkpoint,
    warn_checkpoint,
)
from .mesh import (
    CONTACT_RADIUS_LIMIT,
    ELEMENTS_ACROSS_SMALLEST_CONTACT,
    MIN_ELEMENTS_ACROSS_CONTACT,
    PRESETS,
    build_mesh,
    elements_across,
    mesh_preset,
)
from .plasticity import APEX, ELASTIC
from .result import (
    CURVE_COLUMNS,
    STEP_RULES,
    STEPS_PER_SEGMENT,
    VOLUMETRIC,
    FemResult,
)
from .settings import FeSettings, settings_choice
from .solver import ContactSolver
from .state import State

MAX_CUTBACKS = 8
RESCUE_FAILURES = 16 * MAX_CUTBACKS  # failed solves a step in rescue mode may take in all
PAIR = 2.0  # ball-ball approach and pair energies = 2 x the half model (docs/model.md §2)
# Fully plastic onset Fp (docs/model.md §4): the first load at which FULLY_PLASTIC_FRACTION of the
# core of the contact area, the disc r < FULLY_PLASTIC_CORE * a, is yielding at the surface.
# The outer ring is left out because there, one or two elements behind the contact edge, the
# yield state flickers with the node-by-node advance of the contact edge on every mesh (a node
# entering contact unloads its neighbours elastically; on the default mesh this reaches in to
# 0.71 a); the core is where the last elastic patch closes (around the axis for the reference
# grain). 95 %, not 100 %: the last few per cent of the area are decided by a single quadrature
# point. Measured on the reference cycle with the same load steps on every mesh
# (docs/verification.md): with a core of 0.5-0.7 a, Fp of the default mesh is within 1.5 % of the
# fine one; with 0.8 a it is 23 % off, and over the whole contact area it does not converge.
FULLY_PLASTIC_FRACTION = 0.95
FULLY_PLASTIC_CORE = 0.7
# The "contact" mesh rule refines the surface from the contact radius at this multiple of the
# first-yield force on (contact_band_radius).
CONTACT_BAND_FORCE_RATIO = 10.0
# First yield at the contact edge (_Run._locate_first_yield): elastic solves between the last
# elastic and the first plastic step until the bracket is this narrow (relative), at most this many
FIRST_YIELD_FORCE_RTOL = 1e-3
FIRST_YIELD_SOLVES = 12


# --- sizing ------------------------------------------------------------------------------------
def yield_contact_radius_estimate(material: Material) -> float:
    """Contact radius used to size the mesh and the first load steps: 0.7 of the analytic
    first-yield contact radius (geocontact.grain.hertz), the margin with which the meshes were
    verified (docs/fem.md). The FE run detects the actual first yield itself."""
    return 0.7 * float(incipient_yield(material).contact_radius)


def largest_contact_radius_estimate(material: Material, force: float) -> float:
    """Upper estimate of the contact radius at ``force``: Hertz, or a mean contact pressure of
    2.5 sigma_c (a fully plastic contact carries more), whichever is larger."""
    hertz = (3.0 * force * material.effective_radius / (4.0 * material.effective_modulus)) ** (
        1.0 / 3.0)
    plastic = math.sqrt(force / (math.pi * 2.5 * material.compressive_yield_stress))
    return 1.2 * max(hertz, plastic)


def hertz_contact_radius(material: Material, force: float) -> float:
    """Hertz contact radius at ``force`` (grain.hertz): the contact radius of a load below
    yield, and a lower bound above it (a plastic contact is wider)."""
    return float(contact_radius(material, hertz_approach(material, force)))


def smallest_resolved_force(material: Material, forces, steps_per_segment: int,
                            step_rule: str = "segment") -> float:
    """The smallest positive load step of the history ``forces`` with ``steps_per_segment``
    steps per segment (``load_schedule`` with the analytic first-yield force; the run's own
    schedule uses the FE-probed one, a few per cent away): the smallest load whose contact the
    mesh must resolve."""
    targets, _ = load_schedule(list(forces), steps_per_segment,
                               float(incipient_yield(material).force), step_rule)
    return min(f for f in targets if f > 0.0)


def tip_contact_radius(material: Material, min_force: float, mesh: str) -> float:
    """The ``a_min`` of ``mesh.build_mesh`` (h_tip = a_min / per_tip_radius) for a history whose
    smallest load step is ``min_force``: 0.7 x the analytic yield contact radius (the rule the
    meshes were verified with), made smaller only where that would leave fewer than
    ``ELEMENTS_ACROSS_SMALLEST_CONTACT`` (3) elements across the Hertz contact radius at
    ``min_force``.

    A yielding run's first load steps are close below Fy (load_schedule: geometric from Fy / 2,
    points at 0.8 and 0.95 Fy; contact radius 0.85-0.93 a_y), which the 0.7 a_y rule already
    spans with >= per_tip_radius >= 3 elements: the meshes of ordinary runs, the verified results
    and the FE runs of the reference material are unchanged (docs/fem.md lists the histories
    checked). A
    strong grain, or a history that stays below yield, reaches contacts far smaller than a_y (for
    sigma_c -> infinity a_y is even clipped to R/2); there the first load step decides.
    """
    per_tip = mesh_preset(mesh).per_tip_radius
    first_step = per_tip / ELEMENTS_ACROSS_SMALLEST_CONTACT * hertz_contact_radius(material,
                                                                                 min_force)
    return min(yield_contact_radius_estimate(material), first_step)


def contact_band_radius(material: Material) -> float:
    """Where the "contact" mesh rule's surface band starts (``mesh.MESH_RULES``): the contact
    radius at CONTACT_BAND_FORCE_RATIO x the analytic first-yield force, where the contact is
    flattened plastically and the node-by-node growth of the contact shows in the force."""
    return largest_contact_radius_estimate(
        material, CONTACT_BAND_FORCE_RATIO * float(incipient_yield(material).force)) / 1.2


def history_mesh(material: Material, max_force: float, mesh: str = "default",
                 min_force: float | None = None, rule: str = "yield",
                 resolve_from: float | None = None):
    """The mesh of a history whose largest force is ``max_force`` and smallest load step
    ``min_force``: it resolves every contact radius from the smallest (``tip_contact_radius``)
    to the largest one (``mesh.build_mesh``).

    ``min_force`` None: the first step of a ramp 0 -> ``max_force`` with the preset's steps.
    ``rule``: "yield" (the verified meshes), "contact" or "contact-dense" (``mesh.MESH_RULES``;
    a surface band from ``contact_band_radius`` to the largest contact radius).
    ``resolve_from``: None, or the smallest contact radius resolved as a fraction of R
    (``FeSettings.resolve_from``), where that is above the tip rule's.
    """
    if min_force is None:
        min_force = smallest_resolved_force(material, [0.0, max_force], STEPS_PER_SEGMENT[mesh])
    a_min = tip_contact_radius(material, min_force, mesh)
    if resolve_from is not None:
        a_min = max(a_min, resolve_from * material.radius)
    a_max = max(largest_contact_radius_estimate(material, max_force), 2.0 * a_min)
    return build_mesh(material.radius, a_min, a_max, mesh, rule=rule,
                      a_band=max(contact_band_radius(material), a_min))


def contact_resolution(material: Material, fe_mesh, curve: dict[str, np.ndarray],
                       first_yield: dict[str, Any] | None) -> tuple[dict[str, Any], list[str]]:
    """Surface elements spanning the contact radius (``mesh.elements_across``) at the first
    loaded step, at first yield and at the peak, and a warning if any is below
    ``MIN_ELEMENTS_ACROSS_CONTACT`` (the ~2 % accuracy limit, docs/fem.md).

    The radius counted is the FE contact radius, and at elastic points (before first yield)
    the smaller of it and Hertz's: an under-resolved FE contact is too wide (40 % at one element),
    which would hide the under-resolution. First yield: the Hertz radius at the FE first-yield
    force.
    """
    force, radius = curve["force_N"], curve["contact_radius_m"]
    yield_force = first_yield["force_N"] if first_yield else math.inf

    def point(k: int) -> dict[str, Any]:
        a = float(radius[k])
        if force[k] < yield_force:
            a = min(a, hertz_contact_radius(material, float(force[k])))
        return {"step": int(curve["step"][k]), "force_N": float(force[k]),
                "contact_radius_m": a, "elements": elements_across(fe_mesh, material.radius, a)}

    loaded = np.nonzero(force > 0.0)[0]
    points: dict[str, Any] = {"first_loaded_step": None, "first_yield": None, "peak": None}
    if loaded.size:
        points["first_loaded_step"] = point(int(loaded[0]))
        points["peak"] = point(int(np.argmax(force)))
    if first_yield:
        a = hertz_contact_radius(material, first_yield["force_N"])
        points["first_yield"] = {"force_N": first_yield["force_N"], "contact_radius_m": a,
                                 "elements": elements_across(fe_mesh, material.radius, a)}
    low = [(name, p) for name, p in points.items()
           if p is not None and p["elements"] < MIN_ELEMENTS_ACROSS_CONTACT]
    warnings = []
    if low:
        where = "; ".join(f"{p['elements']:.2g} at the {name.replace('_', ' ')} "
                          f"(F = {p['force_N']:.4g} N, a = {p['contact_radius_m']:.3g} m)"
                          for name, p in low)
        warnings.append(
            f"under-resolved contact: surface elements across the contact radius {where}; "
            f"below {MIN_ELEMENTS_ACROSS_CONTACT:g} the approach and contact radius can be off "
            f"by more than 2 % (docs/fem.md, 'Mesh resolution of the contact')")
    summary = {"elements_across_contact_radius": points,
               "minimum_elements": MIN_ELEMENTS_ACROSS_CONTACT}
    return summary, warnings


def _hertz_force(material: Material, contact_radius: float) -> float:
    return 4.0 * material.effective_modulus * contact_radius**3 / (3.0 * material.effective_radius)


# --- load schedule ---------------------------------------------------------------------------
def _segment(start: float, end: float, n: int, yield_force: float,
             per_decade: float = 0.0) -> list[float]:
    """Targets of one monotonic segment (excluding ``start``, including ``end``).

    Uniform in F^(2/3) (about uniform in approach); on loading, also geometric from near the
    yield force (the elastic-plastic transition spans decades of F / Fy) with points just below
    the predicted first yield; the geometric part has ``n`` points, or ``per_decade`` points
    per decade of force if that is more (the "decade" step rule).
    """
    u = np.linspace(start ** (2 / 3), end ** (2 / 3), n + 1)[1:] ** 1.5
    points = list(u)
    if end > start:
        lo = max(start, 0.5 * yield_force)
        if end > lo * 1.05:
            count = max(n, math.ceil(per_decade * math.log10(end / lo)))
            points += list(np.geomspace(lo, end, count + 1)[1:])
        points += [f for f in (0.8 * yield_force, 0.95 * yield_force) if start < f < end]
    points = sorted(set(points), reverse=end < start)
    out: list[float] = []
    last = start
    span = abs(end - start)
    for f in points:
        # merge near-duplicates: 2 % of the local force level (loading), 1 % of the segment
        # (unloading, where the response is close to linear in F^(2/3))
        gap = 0.02 * max(f, last) if end > start else 0.01 * span
        if abs(f - last) < gap:
            continue
        out.append(float(f))
        last = f
    if out and abs(out[-1] - end) < 0.01 * span:
        out[-1] = end
    if not out or out[-1] != end:
        out.append(end)
    return out


def load_schedule(forces: list[float], n: int, yield_force: float,
                  step_rule: str = "segment") -> tuple[list[float], list[int]]:
    """Step targets and, for each waypoint of ``forces`` after the first, its step index.

    ``step_rule``: "segment" (``n`` steps per monotonic segment and ``n`` geometric ones on
    loading, the verified schedule) or "decade" (the geometric loading steps at least
    ``n / 2`` per decade of force: a weak grain's loading spans 6-7 decades of F / Fy, where
    ``n`` steps alone are a factor ~2 apart and the perfectly plastic contact depends on that
    step by several per cent, docs/fem.md "The staircase of a growing contact")."""
    if step_rule not in STEP_RULES:
        raise ValueError(f"step_rule must be one of {', '.join(STEP_RULES)}, got {step_rule!r}")
    per_decade = 0.5 * n if step_rule == "decade" else 0.0
    targets: list[float] = []
    marks: list[int] = []
    for a, b in zip(forces[:-1], forces[1:], strict=True):
        if b != a:
            targets += _segment(a, b, n, yield_force, per_decade)
        marks.append(len(targets))  # 1-based step number of the waypoint
    return targets, marks


def run_schedule(identity, yield_force: float) -> tuple[list[float], list[int]]:
    """``load_schedule`` of a run's identity (``fem.identity.FeRunIdentity``). A branch
    (``identity.follows``) takes its base's steps up to the step it follows (the base's
    schedule, so the two runs are the same there) and then its own history's from that step's
    force; the step must be one of the base's, at the force the branch's history goes to first
    (one-line InputError otherwise)."""
    forces, n, rule = list(identity.forces), identity.steps_per_segment, identity.step_rule
    if identity.follows is None:
        return load_schedule(forces, n, yield_force, rule)
    base, step = identity.follows
    base_targets = load_schedule(list(base), n, yield_force, rule)[0]
    if step > len(base_targets):
        raise InputError(f"follows: the base has {len(base_targets)} load steps, so no step "
                         f"{step}")
    fork = base_targets[step - 1]
    if not math.isclose(forces[1], fork, rel_tol=1e-12, abs_tol=0.0):
        raise InputError(f"follows: the base's step {step} is at {fork!r} N; the branch's "
                         f"history must go to that force first, not to {forces[1]!r} N")
    targets, marks = load_schedule(forces[1:], n, yield_force, rule)
    return base_targets[:step] + targets, [step] + [step + m for m in marks]


def sub_steps(start: float, target: float, yield_force: float,
              max_step_ratio: float | None) -> list[float]:
    """The forces one load step ``start -> target`` is solved through (``target`` last).

    ``max_step_ratio`` None: the step itself. Else, on loading above the first-yield force,
    geometric sub-steps no larger than ``max_step_ratio`` in force (a step crossing
    ``yield_force`` first goes to it in one elastic solve): a large backward-Euler force step
    flattens a perfectly plastic contact too far and pushes the contact edge a node further, an
    error of first order in the step that the requested steps alone do not make small (docs/fem.md,
    "The staircase of a growing contact"). Unloading and elastic loading are not divided.
    """
    if max_step_ratio is None or target <= start or target <= yield_force:
        return [target]
    low = max(start, yield_force)
    count = math.ceil(math.log(target / low) / math.log(max_step_ratio) - 1e-9)
    goals = [float(f) for f in np.geomspace(low, target, max(count, 1) + 1)[1:]]
    goals[-1] = target
    return ([low] if start < low else []) + goals


def sub_step_record(targets: list[float], yield_force: float,
                    max_step_ratio: float | None) -> dict[str, Any]:
    """What the step control did over the schedule ``targets`` (from 0 N): the cap, the force
    it applies from, the solves it takes (before any cutback) and the largest loading force
    ratio of one solve above the yield force (summary.json, ``step_control``)."""
    solves, largest, last = 0, 1.0, 0.0
    for target in targets:
        for goal in sub_steps(last, target, yield_force, max_step_ratio):
            if last >= yield_force and goal > last:
                largest = max(largest, goal / last)
            solves += 1
            last = goal
    return {"max_step_ratio": max_step_ratio, "from_force_N": yield_force, "solves": solves,
            "requested_steps": len(targets), "largest_loading_ratio_above_yield": largest}


# --- adaptive load steps (step_control="adaptive") ------------------------------------------
# What makes a force-controlled answer depend on the load step, each bounded per solve (docs/fem.md,
# "Adaptive load steps"):
# - the contact edge's advance. A backward-Euler step flattens a perfectly plastic contact too
#   far and pushes the contact edge a node further, which the next steps keep (the probe of
#   docs/fem.md "The staircase of a growing contact": 13-17 % in approach for one step of x1.26
#   in force): the edge may advance at most ADAPTIVE_EDGE_ADVANCE of the surface element it is
#   in per solve, so each engagement of a node is met by a few solves. Only a solve with plastic
#   flow counts it: an elastic solution does not depend on the path to it.
# - the plastic increment. The return mapping integrates the flow over the step (backward
#   Euler, first order in the increment): the largest equivalent plastic strain increment of
#   one solve is held to ADAPTIVE_PLASTIC_INCREMENT of the largest plastic strain already there
#   (at least ADAPTIVE_PLASTIC_FLOOR yield strains sigma_c / E, for the first plastic solves): a
#   solve adds at most a tenth of the plastic deformation of the contact. Measured on the weak
#   grain at 100 N (coarse contact-dense mesh, one solve from the same state): x1.005 / 1.01 /
#   1.02 / 1.04 in force add 0.7 / 3.2 / 11 / 45 % of the largest eqps, and advance the edge
#   0.02 / 0.07 / 0.33 / 1.34 surface elements: both grow faster than the step (the overshoot of
#   a large backward-Euler step), so the bounds mark where a step stops being small.
# - Newton's effort. A solve that converges in few iterations is far from the limits of the
#   linearisation and the next may be larger; many iterations, or none converging, mean the step
#   crosses contact or yield changes the iteration barely follows: cut.
# The step is a force ratio (the loading of a contact is close to a power law in F, so equal
# ratios are equal changes of state); a requested step is cut into equal ratios no larger than
# the controller's, so the recorded forces are the requested ones whatever the control.
ADAPTIVE_EDGE_ADVANCE = 0.5  # surface elements the contact edge may advance per plastic solve
ADAPTIVE_PLASTIC_INCREMENT = 0.1  # largest eqps increment of one solve / largest eqps ...
ADAPTIVE_PLASTIC_FLOOR = 10.0  # ... or these many yield strains, if more
# Newton: a node-contact solve takes 6-8 iterations at any small step (the contact set settles
# in the first ones; 8 at x1.0025 and 11 at x1.04 on the weak grain at 100 N, coarse
# contact-dense mesh), so effort is counted above that.
ADAPTIVE_EASY_ITERATIONS = 8  # a solve within this many Newton iterations may be followed by ...
ADAPTIVE_GROWTH = 1.5  # ... one this much larger in ln F (also the most any solve grows by)
ADAPTIVE_HARD_ITERATIONS = 15  # above this, the next step is cut in proportion
ADAPTIVE_SAFETY = 0.9  # the next step aims at this fraction of the measured bound
ADAPTIVE_REJECT = 0.5  # a solve past its bound by more than 1 / this is solved again smaller
ADAPTIVE_CUT = 0.5  # a failed solve (no convergence) is tried again at this fraction
ADAPTIVE_FIRST_RATIO = 1.02  # the first plastic solve, from the first-yield force
ADAPTIVE_MAX_RATIO = 1.25  # the largest step without max_step_ratio (the fixed cap's range)
ADAPTIVE_MIN_RATIO = 1.0 + 1e-6  # a step that must be smaller than this fails the run
# The plastic bound of step_control="dissipation" (the default since issue 36's second pass): the
# plastic dissipation one solve adds is held to DISSIPATION_INCREMENT of the dissipation already
# there (at least DISSIPATION_FLOOR of the work of the force, for the first plastic solves, where
# there is none yet). The largest eqps increment of "adaptive" jumps as single points at the
# contact edge yield, so its bound is not a smooth function of the step (a sawtooth of cut and
# regrown steps, docs/fem.md); the dissipation is an integral of the plastic flow over the body
# and grows as a power of the force above a few Fy (d ln D / d ln F = 1.9-2.2 on the reference
# grain to 6 kN and the weak grain in finite strain to 300 N, the committed runs of
# datasets/staircase-auto), so the bound holds a loading solve near x exp(0.9 * 0.1 / 2) = x1.046
# in force, steadily, where the edge's advance allows it (on the contact-dense meshes the edge
# sets most deep steps; docs/fem.md "The dissipation bound": 0.04 cost 1.2-1.9x the solves for
# the same answer within 0.07 %).
DISSIPATION_INCREMENT = 0.1  # plastic dissipation of one solve / dissipation before it ...
DISSIPATION_FLOOR = 0.1  # ... or this fraction of the work of the force, if more
# The control "envelope" (issues 36 and 37: the reloads of a cyclic history) is "dissipation" with
# both bounds measured on the reload below the envelope, where a solve starts below the largest
# force the run has reached at the end of a load step: the edge bound counts only the contact
# edge's advance beyond the largest contact radius of those step ends (fresh surface), not its
# advance back over the dent the envelope flattened; the dissipation bound holds a solve's
# plastic dissipation to DISSIPATION_INCREMENT of the dissipation since the reload began (at
# least DISSIPATION_FLOOR of the work since then), not of all the dissipation of the run, which
# first loading made 100 times larger than a reload's. A reload of the weak grain's repeated
# history to 410 kN (point 0 of the campaign of record) re-enters the dent node by node from a/R
# 0.129 to 0.227 at a plastic flow of 0.8 % of the dissipation: "dissipation" cut the reloads
# into solves mostly edge- and growth-limited, with steps down to x1.0000028 (docs/fem.md "The
# envelope control"). On a loading solve from the envelope (a monotonic ramp, a new peak) the
# two controls are the same solves. Within ENVELOPE_RIM_ELEMENTS surface elements of the envelope's
# contact radius (the dent's rim) the edge bound counts the edge's whole advance, as
# "dissipation" does: a shakedown cycle's plastic flow is there, at the ring the peak re-yields,
# and without it the late cycles' ratchet drifted from a step-converged reference by up to 23 %
# (1 element: not tried; 2: 4.8 %; 5: 2.4 %, at 1.05x the solves of 2; docs/fem.md "The envelope
# control", docs/verification/envelope-control.json).
ENVELOPE_RIM_ELEMENTS = 5.0
ADAPTIVE_MEASURES = {"adaptive": "eqps", "dissipation": "dissipation",
                     "envelope": "dissipation"}
# The controls whose edge bound counts only fresh surface below the envelope.
ENVELOPE_CONTROLS = ("envelope",)


@dataclasses.dataclass
class AdaptiveSteps:
    """The adaptive load-step control of one run (``step_control`` "adaptive" or
    "dissipation", ``ADAPTIVE_MEASURES``): the next loading step above the first-yield force as
    ln F_next / F (``log_ratio``), sized after each solve by ``judge``; its counters go to
    summary.json ``step_control`` and, with ``log_ratio``, into the checkpoint (a resumed run
    takes the same steps). ``control`` names it; the two differ only in the plastic bound."""

    yield_force: float
    yield_strain: float  # sigma_c / E, the unit of the plastic increment
    surface_ends: np.ndarray  # radii of the surface element ends (mesh.surface_vertex_radii)
    max_log_ratio: float
    control: str = "adaptive"  # a key of ADAPTIVE_MEASURES
    log_ratio: float = math.log(ADAPTIVE_FIRST_RATIO)
    solves: int = 0
    rejected: int = 0
    failed: int = 0
    limited_by: dict[str, int] = dataclasses.field(default_factory=lambda: dict.fromkeys(
        ("edge", "plastic", "newton", "growth", "largest"), 0))
    smallest_ratio: float = math.inf
    largest_ratio: float = 1.0

    @classmethod
    def of_run(cls, material: Material, fe_mesh, yield_force: float,
               max_step_ratio: float | None, saved: dict[str, Any] | None = None,
               step_control: str = "adaptive") -> AdaptiveSteps:
        from .mesh import surface_vertex_radii

        control = cls(yield_force, material.compressive_yield_stress / material.youngs_modulus,
                      surface_vertex_radii(fe_mesh, material.radius),
                      math.log(ADAPTIVE_MAX_RATIO if max_step_ratio is None else max_step_ratio),
                      step_control)
        if saved:
            for name in ("log_ratio", "solves", "rejected", "failed", "smallest_ratio",
                         "largest_ratio"):
                setattr(control, name, saved[name])
            control.limited_by = dict(saved["limited_by"])
        return control

    def element_at(self, radius: float) -> float:
        """Length of the surface element (in r) the contact edge at ``radius`` is in."""
        ends = self.surface_ends
        k = int(np.clip(np.searchsorted(ends, radius, side="right") - 1, 0, len(ends) - 2))
        return float(ends[k + 1] - ends[k])

    def judge(self, used: float, edge_advance: float, element: float,
              plastic_increment: float, plastic_strain: float, iterations: int,
              dissipation_increment: float = 0.0, dissipation: float = 0.0,
              work: float = 0.0) -> tuple[bool, str]:
        """After a converged solve of ln F ratio ``used``: whether to keep it, and the next step
        (``log_ratio``, set here) from the edge's advance in that solve against the surface
        ``element`` there, the plastic bound and the Newton ``iterations``. The plastic bound of
        "adaptive": the largest eqps increment against the largest eqps before the solve
        (``plastic_strain``); of "dissipation": the plastic ``dissipation_increment`` of the
        solve against the ``dissipation`` before it, or DISSIPATION_FLOOR of the ``work`` of the
        force before it if more. Returns (accepted, the criterion that set the next step: edge,
        plastic, newton, growth or largest)."""
        allowed = ADAPTIVE_PLASTIC_INCREMENT * max(plastic_strain,
                                                   ADAPTIVE_PLASTIC_FLOOR * self.yield_strain)
        plastic = plastic_increment > 1e-6 * allowed  # any plastic flow, not round-off
        if ADAPTIVE_MEASURES[self.control] == "dissipation":
            budget = DISSIPATION_INCREMENT * max(dissipation, DISSIPATION_FLOOR * work)
            plastic_bound = (budget / dissipation_increment
                             if plastic and dissipation_increment > 0.0 else math.inf)
        else:
            plastic_bound = allowed / plastic_increment if plastic else math.inf
        bounds = {
            "edge": (ADAPTIVE_EDGE_ADVANCE * element / edge_advance
                     if plastic and edge_advance > 0.0 else math.inf),
            "plastic": plastic_bound,
        }
        accepted = min(bounds.values()) >= ADAPTIVE_REJECT
        factors = {name: ADAPTIVE_SAFETY * b for name, b in bounds.items()}
        factors["newton"] = (ADAPTIVE_GROWTH if iterations <= ADAPTIVE_EASY_ITERATIONS else
                             min(1.0, ADAPTIVE_HARD_ITERATIONS / max(iterations, 1)))
        reason = min(factors, key=factors.get)
        scale = min(max(factors[reason], ADAPTIVE_CUT * ADAPTIVE_REJECT), ADAPTIVE_GROWTH)
        if factors[reason] >= ADAPTIVE_GROWTH:
            reason = "growth"
        proposed = used * scale
        if accepted and scale >= 1.0:
            # a step cut short by a requested force keeps the size the control had
            proposed = max(proposed, self.log_ratio)
        if proposed >= self.max_log_ratio:
            proposed, reason = self.max_log_ratio, "largest"
        self.log_ratio = proposed
        return accepted, reason

    def record(self) -> dict[str, Any]:
        """The state to carry over a checkpoint."""
        return {"log_ratio": self.log_ratio, "solves": self.solves, "rejected": self.rejected,
                "failed": self.failed, "smallest_ratio": self.smallest_ratio,
                "largest_ratio": self.largest_ratio, "limited_by": dict(self.limited_by)}

    def summary(self, requested_steps: int) -> dict[str, Any]:
        """summary.json ``step_control`` of an adaptive run."""
        return {"control": self.control, "max_ratio": math.exp(self.max_log_ratio),
                "from_force_N": self.yield_force, "solves": self.solves,
                "rejected_solves": self.rejected, "failed_solves": self.failed,
                "requested_steps": requested_steps,
                "largest_loading_ratio_above_yield": self.largest_ratio,
                "smallest_loading_ratio_above_yield": (None if math.isinf(self.smallest_ratio)
                                                       else self.smallest_ratio),
                "next_step_set_by": dict(self.limited_by),
                "criteria": {"edge_advance_elements": ADAPTIVE_EDGE_ADVANCE,
                             "plastic_increment_of_largest": ADAPTIVE_PLASTIC_INCREMENT,
                             "plastic_floor_yield_strains": ADAPTIVE_PLASTIC_FLOOR,
                             "yield_strain": self.yield_strain,
                             "easy_iterations": ADAPTIVE_EASY_ITERATIONS,
                             "hard_iterations": ADAPTIVE_HARD_ITERATIONS,
                             "growth": ADAPTIVE_GROWTH, "first_ratio": ADAPTIVE_FIRST_RATIO,
                             **({"dissipation_increment_of_dissipation": DISSIPATION_INCREMENT,
                                 "dissipation_floor_of_work": DISSIPATION_FLOOR}
                                if ADAPTIVE_MEASURES[self.control] == "dissipation" else {})}}


def fully_plastic_onset(force, approach, fraction,
                        threshold: float = FULLY_PLASTIC_FRACTION) -> dict[str, Any] | None:
    """Fp (docs/model.md §4): the first step of virgin loading (above every force before it)
    on which the yielded fraction reaches ``threshold``, interpolated linearly in the force (and
    the approach) from the step before. A reload below the envelope is not virgin loading: at a
    small force on the flattened dent the yielded fraction of the small contact can be high
    (the repeated history of the campaign of record's point 0 read Fp = 0.30 N, below its first
    yield, off its first reload step).

    ``force``, ``approach``, ``fraction``: per step, in step order (curve.csv columns). None if
    the threshold is never reached on a step of virgin loading.
    """
    force, approach, fraction = (np.asarray(x, dtype=float) for x in (force, approach, fraction))
    top = -math.inf
    for k in range(1, len(force)):
        top = max(top, force[k - 1])
        if force[k] > top and fraction[k] >= threshold:
            f0, f1 = fraction[k - 1], fraction[k]
            t = min(max((threshold - f0) / (f1 - f0), 0.0), 1.0) if f1 > f0 else 1.0
            return {"force_N": float(force[k - 1] + t * (force[k] - force[k - 1])),
                    "approach_m": float(approach[k - 1] + t * (approach[k] - approach[k - 1])),
                    "bracket_N": [float(force[k - 1]), float(force[k])]}
    return None


class _Run:
    """Bookkeeping of one history run (curve rows, yield detection, cycles)."""

    def __init__(self, solver: ContactSolver, material: Material):
        self.solver = solver
        self.material = material
        self.rows: list[list[float]] = []
        self.first_yield: dict[str, Any] | None = None
        self.fully_plastic: dict[str, float] | None = None
        self.last_elastic: tuple[float, float, float, tuple[float, float]] | None = None
        # where the analytic first yield is on the surface at the contact edge (beta above the
        # critical angle, grain.hertz) the F^(1/3) scaling of _interpolate_first_yield fails
        self.at_edge = bool(incipient_yield(material).at_surface)

    def record(self, step: int, state: State) -> None:
        s = self.solver
        r, pressure = s.contact_pressure(state)
        plastic_points = int(np.count_nonzero(state.status != ELASTIC))
        core_fraction = s.yielded_contact_fraction(state, FULLY_PLASTIC_CORE)
        self.rows.append([
            step, state.force, PAIR * state.top_displacement, s.contact_radius(state),
            PAIR * state.plastic_dissipation, PAIR * s.elastic_energy(state),
            PAIR * state.work, float(np.max(pressure, initial=0.0)), plastic_points,
            state.iterations, s.yielded_contact_fraction(state), core_fraction,
        ])
        self._detect_yield(state, plastic_points)
        self._detect_fully_plastic()

    def _detect_yield(self, state: State, plastic_points: int) -> None:
        s = self.solver
        if self.first_yield is None:
            if self.at_edge:
                self._detect_edge_yield(state, plastic_points)
            elif plastic_points == 0:
                ratio = s.yield_ratio(state)
                k = np.unravel_index(np.argmax(ratio), ratio.shape)
                if state.force > 0:
                    self.last_elastic = (state.force, PAIR * state.top_displacement,
                                         float(ratio[k]),
                                         (float(s.radius_qp[k]), float(s.z_qp[k])))
            else:
                self.first_yield = self._interpolate_first_yield(state)

    def _detect_edge_yield(self, state: State, plastic_points: int) -> None:
        """At the contact edge the first yield is where the elastic solution's yield measure
        (``_edge_measure``: the quadrature points and the surface at the edge) reaches 1,
        which can be before the first plastic quadrature point: located between the last step
        below it and the first step at it or plastic."""
        measure, where = self._edge_measure(state)
        if plastic_points == 0 and measure < 1.0:
            if state.force > 0:
                self.last_elastic = (state.force, PAIR * state.top_displacement, measure, where)
        else:
            self.first_yield = self._locate_first_yield(state)

    def _edge_measure(self, state: State) -> tuple[float, tuple[float, float]]:
        """The largest yield ratio of an elastic state and where: over the quadrature points
        and on the surface at the contact edge (``ContactSolver.edge_surface_ratio``)."""
        s = self.solver
        ratio = s.yield_ratio(state)
        k = np.unravel_index(np.argmax(ratio), ratio.shape)
        edge, a = s.edge_surface_ratio(state)
        if edge > ratio[k]:
            return edge, (a, self._surface_height(a))
        return float(ratio[k]), (float(s.radius_qp[k]), float(s.z_qp[k]))

    def _surface_height(self, r: float) -> float:
        """Height of the undeformed spherical surface (centre at z = R) at radius r."""
        radius = self.material.radius
        return radius - math.sqrt(max(radius**2 - r**2, 0.0))

    def _detect_fully_plastic(self) -> None:
        if self.fully_plastic is not None or len(self.rows) < 2:
            return
        force = CURVE_COLUMNS.index("force_N")
        if self.rows[-1][force] <= max(row[force] for row in self.rows[:-1]):
            return  # not virgin loading (fully_plastic_onset)
        columns = [CURVE_COLUMNS.index(c) for c in
                   ("force_N", "approach_m", "yielded_core_fraction")]
        last_two = np.array(self.rows[-2:])[:, columns]
        self.fully_plastic = fully_plastic_onset(*last_two.T)

    def _interpolate_first_yield(self, state: State) -> dict[str, Any]:
        """First yield between the last elastic step and this one.

        Below yield the FE field is elastic and scales as in Hertz: stresses ~ F^(1/3), approach
        ~ F^(2/3); so from the last elastic step (ratio phi < 1) Fy = F phi^-3, dy = d phi^-2.
        """
        if self.last_elastic is None:
            return {"force_N": state.force, "approach_m": PAIR * state.top_displacement,
                    "location_m": None, "bracket_N": [0.0, state.force]}
        force, approach, phi, where = self.last_elastic
        fy = min(force / phi**3, state.force)
        return {"force_N": fy, "approach_m": approach * (fy / force) ** (2.0 / 3.0),
                "location_m": {"r": where[0], "z": where[1]},
                "bracket_N": [force, state.force]}

    def _locate_first_yield(self, state: State) -> dict[str, Any]:
        """First yield at the contact edge: the force between the last step below yield and
        this one at which the yield measure of the elastic solution (``_edge_measure``: the
        largest ratio over the quadrature points and on the surface at the edge) reaches 1.

        At the edge the ratio at the yielding point grows faster than the F^(1/3) of Hertz
        scaling (the edge moves onto the point; docs/verification/edge_first_yield.md), so it is
        not extrapolated: the crossing is found by elastic solves (elastic below the crossing,
        so each solve from the unloaded state is the run's own solution up to the Newton
        tolerance) at forces chosen by the Illinois variant of regula falsi on measure - 1, to
        ``FIRST_YIELD_FORCE_RTOL`` of the force; the value is interpolated linearly in the
        measure between the two closest solves. ``solves`` counts them.
        """
        low = (0.0, 0.0, 0.0) if self.last_elastic is None else self.last_elastic[:3]
        high_state = self._elastic_solve(state.force)
        measure, where = self._edge_measure(high_state)
        high = (state.force, PAIR * high_state.top_displacement, measure)
        solves, replaced = 1, 0
        g_low, g_high = low[2] - 1.0, high[2] - 1.0  # Illinois: an end kept twice is halved
        while (high[2] > 1.0 and solves < FIRST_YIELD_SOLVES
               and high[0] - low[0] > FIRST_YIELD_FORCE_RTOL * high[0]):
            force = high[0] - g_high * (high[0] - low[0]) / (g_high - g_low)
            trial = self._elastic_solve(force)
            solves += 1
            trial_measure, trial_where = self._edge_measure(trial)
            point = (force, PAIR * trial.top_displacement, trial_measure)
            if point[2] >= 1.0:
                high, where, g_high = point, trial_where, point[2] - 1.0
                g_low = g_low / 2.0 if replaced == 1 else g_low
                replaced = 1
            else:
                low, g_low = point, point[2] - 1.0
                g_high = g_high / 2.0 if replaced == -1 else g_high
                replaced = -1
        t = 1.0 if high[2] <= low[2] else min(max((1.0 - low[2]) / (high[2] - low[2]), 0.0), 1.0)
        bracket_low = self.last_elastic[0] if self.last_elastic is not None else 0.0
        return {"force_N": low[0] + t * (high[0] - low[0]),
                "approach_m": low[1] + t * (high[1] - low[1]),
                "location_m": {"r": float(where[0]), "z": float(where[1])},
                "bracket_N": [bracket_low, state.force], "solves": solves}

    def _elastic_solve(self, force: float) -> State:
        solver = self.solver
        solver.plastic = False
        try:
            return solver.solve_step(solver.initial_state(), force,
                                     label="first-yield search: ")
        finally:
            solver.plastic = True

    def curve(self) -> dict[str, np.ndarray]:
        data = np.array(self.rows, dtype=float).reshape(-1, len(CURVE_COLUMNS))
        out = {name: data[:, i] for i, name in enumerate(CURVE_COLUMNS)}
        for name in ("step", "plastic_points", "iterations"):
            out[name] = out[name].astype(int)
        return out


def _cycles(curve: dict[str, np.ndarray], forces: list[float], marks: list[int]) -> list[dict]:
    """Per cycle (``force_history.cycle_windows``, over the step numbers of the waypoints):
    peak, residual approach (None for an open last cycle), plastic work and energies."""
    index = {int(s): i for i, s in enumerate(curve["step"])}
    cycles = []
    for a, b in cycle_windows(forces, [0, *marks]):
        if a not in index or b not in index:
            continue
        window = (index[a], index[b])
        max_force, max_approach = cycle_peak(curve["force_N"], curve["approach_m"], window)
        closed = curve["force_N"][index[b]] == 0.0
        cycles.append({
            "max_force_N": max_force,
            "max_approach_m": max_approach,
            "residual_approach_m": float(curve["approach_m"][index[b]]) if closed else None,
            "plastic_work_J": float(curve["plastic_dissipation_J"][index[b]]
                                    - curve["plastic_dissipation_J"][index[a]]),
            "loop_work_J": float(curve["work_J"][index[b]] - curve["work_J"][index[a]]),
            "residual_elastic_energy_J": float(curve["elastic_energy_J"][index[b]]),
            "steps": [int(a), int(b)],
        })
    return cycles


# --- the run -----------------------------------------------------------------------------------
def _solver(material: Material, fe_mesh, identity, linear_solver: str) -> ContactSolver:
    bbar, order = VOLUMETRIC[identity.volumetric]
    kind = ContactSolver
    if identity.kernels == "compiled":  # the node contact's default (fem.settings.default_kernels)
        from .compiled import CompiledSmallStrainSolver, compiled_solver

        kind = compiled_solver if identity.kinematics == "finite" else CompiledSmallStrainSolver
    elif identity.kinematics == "finite":
        from .finite_strain import FiniteStrainSolver as kind
    if identity.contact != "node":  # the default's arguments as they were
        return kind(material, fe_mesh, force_scale=max(identity.forces),
                    tolerance=identity.tolerance, bbar=bbar, volumetric_order=order,
                    linear_solver=linear_solver, contact=identity.contact,
                    backtracking=identity.newton == "backtracking")
    return kind(material, fe_mesh, force_scale=max(identity.forces),
                tolerance=identity.tolerance, bbar=bbar, volumetric_order=order,
                linear_solver=linear_solver, backtracking=identity.newton == "backtracking")


def run_history(
    material: Material,
    forces,
    mesh: str | None = None,
    out: str | Path | None = None,
    *,
    settings: FeSettings | None = None,
    resume: bool = False,
    progress: bool = False,
    write_fields: bool = True,
    keep_states: bool = False,
    overwrite: bool = False,
    checkpoint: str | Path | None = None,
    linear_solver: str = "fast",
    notify: Callable[[str], None] | None = None,
    follows: tuple | None = None,
    snapshots: str | Path | None = None,
    start: str | Path | None = None,
    **model: Any,
) -> FemResult:
    """Run the force history ``forces`` (N, piecewise linear waypoints) on the FE model.

    ``settings``: how (``fem.settings.FeSettings``: mesh preset, load steps, tolerance,
    volumetric treatment, mesh force, mesh rule, kinematics, step rule and cap, contact,
    kernels; all part of the run's identity), or else ``mesh`` and ``model`` its keywords
    (``run_history(material, forces, "default", kinematics="finite")``; the defaults are the
    settings'). ``out``: result directory (curve.csv, summary.json, fields/*.vtu), written
    atomically; an existing ``out`` is replaced only if it is an FE result of ours
    (``io.check_replaceable``, checked before any work; ``overwrite`` lifts it). A checkpoint
    ``<out>.checkpoint.npz`` (or ``checkpoint``) is written after every converged step (the
    ParaView files of the waypoints passed wait beside it in ``<out>.checkpoint.fields/``); the
    default one is removed when the result has landed, an explicit ``checkpoint`` is left to
    the caller (who lands the result later: ``checkpoint.remove_checkpoint``). ``resume=True``:
    reuse a finished run in ``out`` of the same identity (``fem.reuse``: inputs, FE code,
    library versions), else go on from the checkpoint if it is one of this identity; an
    unusable checkpoint is reported in one line and the run starts over. ``write_fields`` and
    ``progress`` do not change the result. Raises ConvergenceError (one line, naming the step
    and load) if a step fails after ``MAX_CUTBACKS`` halvings; the checkpoint then holds the
    last converged state. ``linear_solver``: "fast" (default) or "reference", the earlier
    linear-algebra path kept for side-by-side comparison (``ContactSolver``); both give the
    same result within the Newton tolerance, so it is not part of the run's identity.
    ``notify``: what is done with the run's messages (a reused or not reused result, an
    unusable checkpoint, an under-resolved contact: one line each); default: printed to
    stderr.

    **Branches.** ``follows=(base forces, step)`` makes the run a branch of the loading ramp
    ``base forces`` = (0, F) (same material and settings): it takes that run's load steps up
    to its recorded step ``step``, whose force must be ``forces[1]``, then goes on with
    ``forces[1:]``. Its identity records ``follows``; its mesh is the base's. ``snapshots``: a
    folder where a run also saves its checkpoint after every step (``snapshot_path``), for the
    branches that follow it; ``start``: the base's snapshot at the branch's step, which a
    branch starts from instead of computing the base's steps again (a missing or unusable one
    costs only that work: the result is the same to the bit, as a resumed run's is).

    The run is three parts: ``prepare_run`` (the identity, a finished run to reuse, the mesh
    and solver or the checkpoint to go on from), ``step_loop`` (the load steps) and
    ``run_summary`` (summary.json).
    """
    from .identity import FeRunIdentity

    started = RunClock.start()
    if settings is None:
        settings = FeSettings("coarse" if mesh is None else mesh, **model)
    elif mesh is not None or model:
        raise TypeError("run_history: the settings as settings= or as keywords, not both")
    notify = _to_stderr if notify is None else notify
    identity = FeRunIdentity.of_settings(material, forces, settings, follows)
    if resume and out is not None and not keep_states:
        finished = _finished(out, identity, write_fields, progress, notify)
        if finished is not None:
            return finished
    if out is not None:
        check_replaceable(out, "fem", overwrite=overwrite)  # before any work
    prepared = prepare_run(material, identity, out, resume=resume, checkpoint=checkpoint,
                           write_fields=write_fields, linear_solver=linear_solver,
                           shared_mesh=settings.mesh_force is not None, notify=notify,
                           start=start)
    states = step_loop(prepared, started, keep_states=keep_states, progress=progress,
                       snapshots=snapshots)
    curve = prepared.run.curve()
    summary = run_summary(prepared, curve, started, notify)
    result = FemResult(curve=curve, summary=summary, states=states, solver=prepared.solver)
    if out is not None:
        write_result(result, Path(out), prepared.solver, {},
                     field_files=[prepared.pending / field_name(s)
                                  for s in prepared.field_steps],
                     overwrite=overwrite)
        if checkpoint is None:
            remove_checkpoint(prepared.ckpt)
    return result


def _to_stderr(message: str) -> None:
    print(message, file=sys.stderr)


def _finished(out, identity, write_fields: bool, progress: bool,
              notify: Callable[[str], None]) -> FemResult | None:
    """The finished run in ``out`` of ``identity`` (``fem.identity.finished_run``), or None."""
    from .identity import finished_run

    why: list[str] = []
    finished = finished_run(out, identity, fields=write_fields, why=why)
    if finished is not None:
        if progress:
            notify(f"fem: reusing the finished run in {out} (same inputs, FE code and "
                   "libraries)")
        return finished
    if why:
        notify(f"fem: not reusing the run in {out}: {why[0]}; running it again")
    return None


@dataclasses.dataclass
class PreparedRun:
    """A run ready for its load steps (``prepare_run``): new, or going on from a checkpoint."""

    identity: Any  # fem.identity.FeRunIdentity
    material: Material
    solver: ContactSolver
    run: _Run
    state: State
    done: int  # load steps already made
    yield_force: float  # the elastic probe's first-yield force (the load schedule's)
    targets: list[float]
    marks: list[int]
    field_steps: list[int]  # steps whose ParaView files are written
    ckpt: Path | None
    pending: Path | None
    write_fields: bool
    elapsed_before: float  # wall time of the checkpointed part
    control: AdaptiveSteps | None = None  # step_control "adaptive" or "dissipation"
    cpu_before: float | None = 0.0  # CPU time of the checkpointed part (None: not recorded)
    branched: bool = False  # a branch that started from its base's snapshot


@dataclasses.dataclass(frozen=True)
class RunClock:
    """When this session of a run started, by the wall clock and by the process's CPU time (all
    its threads: the FE's and the BLAS's); what a run reports adds the checkpointed part's."""

    wall_started: float
    cpu_started: float

    @classmethod
    def start(cls) -> RunClock:
        return cls(time.perf_counter(), time.process_time())

    def wall(self, before: float) -> float:
        return before + time.perf_counter() - self.wall_started

    def cpu(self, before: float | None) -> float | None:
        """The CPU time of the run so far; None when a checkpoint it went on from did not record
        its own (written before cpu_time_s was)."""
        return None if before is None else before + time.process_time() - self.cpu_started


def prepare_run(material: Material, identity, out, *, resume: bool, checkpoint,
                write_fields: bool, linear_solver: str, shared_mesh: bool,
                notify: Callable[[str], None], start: str | Path | None = None) -> PreparedRun:
    """The mesh, solver and state of a run of ``identity``: from its checkpoint where
    ``resume`` and the checkpoint is usable, else (a branch) from its base's snapshot
    ``start`` where that is usable, else new (the mesh of ``history_mesh`` and the elastic
    probe of the first-yield force). ``shared_mesh``: the mesh force was given (the mesh is
    sized from the ramp to it, the same for every run sharing it)."""
    forces, steps = list(identity.forces), identity.steps_per_segment
    ckpt = Path(checkpoint) if checkpoint is not None else (
        checkpoint_path(out) if out is not None else None)
    pending = fields_beside(ckpt) if ckpt is not None else None
    saved, solver, branched = None, None, False
    if resume and ckpt is not None and ckpt.exists():
        saved, solver = _go_on_from(read_checkpoint(ckpt, identity, len(CURVE_COLUMNS),
                                                    notify=notify),
                                    ckpt, identity, material, linear_solver, pending,
                                    write_fields, notify)
    if saved is None and identity.follows is not None and start is not None \
            and Path(start).exists():
        base = read_checkpoint(Path(start), identity.base(), len(CURVE_COLUMNS), notify=notify)
        if base is not None and base.done != identity.follows[1]:
            warn_checkpoint(Path(start), f"it is the base's step {base.done}, not the "
                            f"branch's {identity.follows[1]}", notify)
            base = None
        saved, solver = _go_on_from(base, Path(start), identity, material, linear_solver,
                                    None, False, notify)
        if saved is not None:  # the branch's own time starts here; its fields are its own
            branched = True
            saved = dataclasses.replace(saved, wall_time_s=0.0, cpu_time_s=0.0)
            if pending is not None:
                remove_pending_fields(pending)
    if saved is None:
        # a shared mesh (mesh_force) is sized from the ramp 0 -> mesh_force, the same for every
        # run sharing it; a history starting lower is then checked (contact_resolution); a
        # branch's mesh is its base's
        sized_history = ([0.0, identity.mesh_force] if shared_mesh else
                         list(identity.follows[0]) if identity.follows is not None else forces)
        fe_mesh = history_mesh(material, identity.mesh_force, identity.mesh,
                               min_force=smallest_resolved_force(material, sized_history, steps,
                                                                 identity.step_rule),
                               rule=identity.mesh_rule, resolve_from=identity.resolve_from)
        solver = _solver(material, fe_mesh, identity, linear_solver)
        if pending is not None:
            remove_pending_fields(pending)  # files of an earlier, other run
    run = _Run(solver, material)
    if saved is not None:
        yield_force = saved.yield_force
        state = saved.state
        run.rows = saved.rows
        run.first_yield = saved.detector["first_yield"]
        run.fully_plastic = saved.detector["fully_plastic"]
        run.last_elastic = saved.detector["last_elastic"]
        done = saved.done
        elapsed_before, cpu_before = saved.wall_time_s, saved.cpu_time_s
        solver.rescued_steps = list(saved.detector.get("rescued_steps", []))
    else:
        yield_force = _probe_yield_force(solver, material)
        state = solver.initial_state()
        run.record(0, state)
        done = 0
        elapsed_before, cpu_before = 0.0, 0.0
    targets, marks = run_schedule(identity, yield_force)
    # ParaView files of the waypoints, written to the pending folder as the run passes them
    field_steps = sorted({m for m in marks if m >= 1}) if write_fields and pending else []
    control = None
    if identity.step_control in ADAPTIVE_MEASURES:
        control = AdaptiveSteps.of_run(material, solver.mesh, yield_force,
                                       identity.max_step_ratio,
                                       saved.detector.get("adaptive_steps") if saved else None,
                                       identity.step_control)
    return PreparedRun(identity, material, solver, run, state, done, yield_force, targets,
                       marks, field_steps, ckpt, pending, write_fields, elapsed_before, control,
                       cpu_before, branched)


def _go_on_from(saved, path: Path, identity, material: Material, linear_solver: str,
                pending: Path | None, write_fields: bool, notify: Callable[[str], None]):
    """(checkpoint, solver on its mesh) if the run of ``identity`` can go on from the
    checkpoint ``saved`` read from ``path`` (its own, or a branch's base snapshot), else
    (None, None) after one line saying why."""
    if saved is None:
        return None, None
    solver = _solver(material, saved.mesh, identity, linear_solver)
    targets, marks = run_schedule(identity, saved.yield_force)
    problem = saved.problem(solver.initial_state(), len(targets), marks, pending, write_fields)
    if problem is not None:
        warn_checkpoint(path, problem, notify)
        return None, None
    return saved, solver


@dataclasses.dataclass(frozen=True)
class Envelope:
    """Where a run stands against its envelope, from its curve rows (the ends of its load
    steps: a resumed run or a branch has the same): the largest force and contact radius
    reached, and the plastic dissipation and work of the force (per half model, as the state
    holds them) where the current reload began (the last step end after which the force rose)."""

    force: float
    radius: float
    dissipation: float
    work: float


def _envelope(rows: list[list[float]], control: AdaptiveSteps) -> Envelope | None:
    """The ``Envelope`` of the curve ``rows`` so far for a control of ``ENVELOPE_CONTROLS``;
    None for the others."""
    if control.control not in ENVELOPE_CONTROLS:
        return None
    force, radius = CURVE_COLUMNS.index("force_N"), CURVE_COLUMNS.index("contact_radius_m")
    start = len(rows) - 1
    while start > 0 and rows[start - 1][force] < rows[start][force]:
        start -= 1
    began = rows[start]
    return Envelope(max(row[force] for row in rows), max(row[radius] for row in rows),
                    began[CURVE_COLUMNS.index("plastic_dissipation_J")] / PAIR,
                    began[CURVE_COLUMNS.index("work_J")] / PAIR)


def snapshot_path(folder: str | Path, step: int) -> Path:
    """The snapshot of a run's state after load step ``step`` in ``folder`` (``run_history``
    ``snapshots``): a checkpoint of the run as it stood then, which a branch starts from."""
    return Path(folder) / f"step_{step:05d}.checkpoint.npz"


def step_loop(p: PreparedRun, started: RunClock, *, keep_states: bool = False,
              progress: bool = False, snapshots: str | Path | None = None) -> list[State]:
    """The load steps of the prepared run ``p`` from where it stands, a checkpoint after each
    (``started``: the wall clock of this session, for the checkpoint's time), and a snapshot in
    ``snapshots`` after each (``snapshot_path``; not for a branch: a branch is not followed).
    Returns the states when ``keep_states`` (the initial one first)."""
    if snapshots is not None and p.identity.follows is not None:
        raise ValueError("step_loop: a branch's steps are not snapshots for other branches")
    solver, run, state = p.solver, p.run, p.state
    record = json.dumps(p.identity.to_dict())
    if snapshots is not None:
        Path(snapshots).mkdir(parents=True, exist_ok=True)
    states = [state] if keep_states else []
    bar = None
    if progress:
        from tqdm import tqdm

        bar = tqdm(total=len(p.targets), initial=p.done, desc="fem", unit="step",
                   file=sys.stderr, leave=False)
    try:
        for k in range(p.done, len(p.targets)):
            step = k + 1
            if p.control is not None:
                state = _advance_adaptive(solver, state, p.targets[k], step, p.control,
                                          _envelope(run.rows, p.control))
            elif p.identity.max_step_ratio is None:
                state = _advance(solver, state, p.targets[k], step)
            else:
                state = _advance(solver, state, p.targets[k], step,
                                 sub_steps(state.force, p.targets[k], p.yield_force,
                                           p.identity.max_step_ratio))
            run.record(step, state)
            _check_contact_within_mesh(run, step)
            if keep_states:
                states.append(state)
            if step in p.field_steps:
                _save_fields(solver, state, p.pending / field_name(step))
            for path, fields in ((p.ckpt, p.write_fields),
                                 (None if snapshots is None else snapshot_path(snapshots, step),
                                  False)):
                if path is None:
                    continue
                save_checkpoint(path, record, run.rows, state, solver.mesh,
                                yield_force=p.yield_force, fields=fields,
                                wall_time_s=started.wall(p.elapsed_before),
                                cpu_time_s=started.cpu(p.cpu_before),
                                first_yield=run.first_yield, fully_plastic=run.fully_plastic,
                                last_elastic=run.last_elastic,
                                **({"rescued_steps": solver.rescued_steps}
                                   if solver.rescued_steps else {}),
                                **({"adaptive_steps": p.control.record()}
                                   if p.control is not None else {}))
            if bar is not None:
                bar.update(1)
    finally:
        if bar is not None:
            bar.close()
    p.state = state
    return states


def _check_contact_within_mesh(run: _Run, step: int) -> None:
    """Stop the run at a recorded step whose contact radius passes ``CONTACT_RADIUS_LIMIT`` R
    (before its checkpoint: the run stands for the steps before it)."""
    row = run.rows[-1]
    radius = row[CURVE_COLUMNS.index("contact_radius_m")]
    limit = CONTACT_RADIUS_LIMIT * run.material.radius
    if radius > limit:
        raise ContactBeyondMeshError(
            f"step {step}: the contact radius {radius:.4g} m passed {CONTACT_RADIUS_LIMIT:g} R "
            f"({limit:.4g} m, the mesh's refined zone) at F = "
            f"{row[CURVE_COLUMNS.index('force_N')]:.6g} N; the run stops there (its steps "
            "before are kept in its checkpoint): ask for a lower force")


def run_summary(p: PreparedRun, curve: dict[str, np.ndarray], started: RunClock,
                notify: Callable[[str], None] | None = None) -> dict[str, Any]:
    """summary.json of the finished run ``p`` with its ``curve`` (``started``: when this session
    began, for the run's wall and CPU times; ``notify``: each warning, which the summary also
    lists)."""
    identity, run, solver, material = p.identity, p.run, p.solver, p.material
    forces, fe_mesh = list(identity.forces), solver.mesh
    first = run.first_yield or {}
    contact, warnings = contact_resolution(material, fe_mesh, curve, run.first_yield)
    for message in warnings:
        (notify or _to_stderr)(f"warning: {message}")
    # per-cycle values below the run's resolution are round-off: 0 here, raw in curve.csv
    resolutions = resolution.fe_resolutions(float(np.max(curve["force_N"])),
                                            float(np.max(curve["approach_m"])))
    summary = {
        "first_yield_force_N": first.get("force_N"),
        "first_yield_approach_m": first.get("approach_m"),
        "first_yield_location_m": first.get("location_m"),
        "first_yield_bracket_N": first.get("bracket_N"),
        "first_yield_force_predicted_N": p.yield_force,
        "fully_plastic_force_N": run.fully_plastic["force_N"] if run.fully_plastic else None,
        "fully_plastic_approach_m": (run.fully_plastic["approach_m"] if run.fully_plastic
                                     else None),
        "fully_plastic_bracket_N": (run.fully_plastic["bracket_N"] if run.fully_plastic
                                    else None),
        "fully_plastic_criterion": {"yielded_core_fraction": FULLY_PLASTIC_FRACTION,
                                    "core_radius_over_contact_radius": FULLY_PLASTIC_CORE},
        "cycles": resolution.clean_fe_cycles(_cycles(curve, forces, p.marks), resolutions),
        "resolution": resolution.fe_summary_record(resolutions),
        "mesh": {"elements": int(fe_mesh.t.shape[1]), "nodes": int(fe_mesh.doflocs.shape[1]),
                 "preset": identity.mesh, "rule": identity.mesh_rule,
                 "element": f"P2 triangle (6-node, isoparametric), {identity.volumetric}"
                            + (" (F-bar)" if identity.kinematics == "finite" else "")},
        "kinematics": identity.kinematics,
        # the mesh rule and step control the run has, and why "auto" gives its rule or not
        "choice": settings_choice(material, identity.settings),
        "contact_resolution": contact,
        "warnings": warnings,
        "steps": int(len(p.targets)),
        "step_control": (p.control.summary(len(p.targets)) if p.control is not None else
                         sub_step_record(p.targets, p.yield_force, identity.max_step_ratio)),
        **({"rescued_steps": solver.rescued_steps} if solver.rescued_steps else {}),
        **({"first_yield_search": {"elastic_solves": first["solves"],
                                   "force_rtol": FIRST_YIELD_FORCE_RTOL}}
           if "solves" in first else {}),
        "newton_iterations": int(np.sum(curve["iterations"])),
        "wall_time_s": started.wall(p.elapsed_before),
        # the process CPU time of the run (the same span): a cost, compared nowhere
        "cpu_time_s": started.cpu(p.cpu_before),
        "version": __version__,
        "inputs": identity.inputs(),
        "conventions": "approach is ball-ball (2 x ball-wall); energies are for the pair",
    }
    # what made this result (FemJob.key, checkpoints and --resume compare it: fem.reuse)
    summary["identity"] = identity.to_dict()
    summary["fields"] = [f"fields/{field_name(s)}" for s in p.field_steps]
    if identity.follows is not None:
        # a branch: its curve's steps 0 ... step are its base's; started from the base's
        # snapshot, its wall and CPU times are those of the steps after (the solves and Newton
        # iterations above count the whole curve)
        summary["branch"] = {"base_key": identity.base().key(), "step": identity.follows[1],
                             "started_from_base_snapshot": p.branched}
    return summary


def _save_fields(solver: ContactSolver, state: State, path: Path) -> None:
    with atomic_path(path) as tmp:
        write_fields(solver, state, tmp)


def _probe_yield_force(solver: ContactSolver, material: Material) -> float:
    """Predicted first-yield force from one elastic solve (stresses scale as F^(1/3))."""
    probe_force = _hertz_force(material, 2.0 * yield_contact_radius_estimate(material) / 0.7)
    probe_force = min(probe_force, solver.force_scale)
    solver.plastic = False
    try:
        state = solver.solve_step(solver.initial_state(), probe_force, label="yield probe: ")
    finally:
        solver.plastic = True
    phi = float(np.max(solver.yield_ratio(state)))
    return probe_force / phi**3


def _advance(solver: ContactSolver, state: State, target: float, step: int,
             goals: list[float] | None = None) -> State:
    """One load step through the forces ``goals`` (``sub_steps``; default: ``target``) with
    cutback: halve the increment on non-convergence. With ``goals`` the state returned counts
    the Newton iterations of all the step's solves (curve.csv ``iterations``).

    A step that still fails after ``MAX_CUTBACKS`` halvings in all is solved again from its
    start in rescue mode (``ContactSolver.line_search``: Newton updates halved until no element
    is inside out; at most ``MAX_CUTBACKS`` halvings at any one state, not in all) and noted in
    ``solver.rescued_steps`` (summary.json ``rescued_steps``). A step that passes without it
    takes exactly the arithmetic it always took."""
    try:
        return _solve_step_goals(solver, state, target, step, goals, rescue=False)
    except ConvergenceError as exc:
        first_failure = str(exc)
    return _rescue(solver, state, target, step, goals, first_failure)


def _rescue(solver: ContactSolver, state: State, target: float, step: int,
            goals: list[float] | None, failure: str) -> State:
    """The load step from ``state`` to ``target`` (through ``goals``) solved in rescue mode
    (``ContactSolver.line_search``), noted in ``solver.rescued_steps`` with the halvings it
    took and ``failure``, the error that sent it there."""
    solver.line_search = True
    halvings = solver.line_search_halvings
    try:
        done = _solve_step_goals(solver, state, target, step, goals, rescue=True)
    finally:
        solver.line_search = False
    solver.rescued_steps.append({"step": step, "force_N": target,
                                 "line_search_halvings": solver.line_search_halvings - halvings,
                                 "failure": failure})
    return done


def _advance_adaptive(solver: ContactSolver, state: State, target: float, step: int,
                      control: AdaptiveSteps,
                      envelope: Envelope | None = None) -> State:
    """One requested load step with the adaptive control: unloading and loading below the
    first-yield force in one solve (``_advance``, elastic: path independent), loading above it
    through solves sized by ``control`` (``AdaptiveSteps.judge``). A requested step is cut into
    equal force ratios no larger than the control's, so it ends on ``target`` exactly. A solve
    that does not converge is tried again at ``ADAPTIVE_CUT`` of its step; after
    ``MAX_CUTBACKS`` such cuts in a row the rest of the step is solved in rescue mode
    (``_advance``). The state returned counts the Newton iterations of all the step's converged
    solves, the rejected ones too. ``envelope``: the run's ``Envelope`` for the "envelope"
    control (``ENVELOPE_CONTROLS``): a solve that starts below its force counts only the edge's
    advance beyond its radius (the whole advance on its rim, ``ENVELOPE_RIM_ELEMENTS``), and the
    dissipation and work since the reload began."""
    if target <= state.force or target <= control.yield_force:
        control.solves += 1
        return _advance(solver, state, target, step)
    current, iterations = state, 0
    if current.force < control.yield_force:  # elastic to the first-yield force in one solve
        current = _advance(solver, current, control.yield_force, step)
        control.solves += 1
        iterations += current.iterations
    cuts, edge = 0, solver.contact_radius(current)
    while current.force < target:
        remaining = math.log(target / current.force)
        parts = max(1, math.ceil(remaining / control.log_ratio - 1e-9))
        goal = target if parts == 1 else current.force * math.exp(remaining / parts)
        used = math.log(goal / current.force)
        try:
            trial = solver.solve_step(current, goal)
        except ConvergenceError as exc:
            control.failed += 1
            cuts += 1
            if cuts > MAX_CUTBACKS:
                return _rescue_rest(solver, current, target, step, iterations, str(exc))
            control.log_ratio = used * ADAPTIVE_CUT
            if control.log_ratio < math.log(ADAPTIVE_MIN_RATIO):
                raise ConvergenceError(
                    f"step {step}: no convergence towards F = {target:.6g} N with load steps "
                    f"down to x{math.exp(used):.7g} (last converged F = {current.force:.6g} N): "
                    f"{exc}") from None
            continue
        cuts = 0
        control.solves += 1
        iterations += trial.iterations
        trial_edge = solver.contact_radius(trial)
        if envelope is None or current.force >= envelope.force:
            advance = abs(trial_edge - edge)
            dissipation, work = current.plastic_dissipation, current.work
        else:  # below the envelope: fresh surface, and the reload's own dissipation and work
            rim = envelope.radius - ENVELOPE_RIM_ELEMENTS * control.element_at(envelope.radius)
            advance = (abs(trial_edge - edge) if max(edge, trial_edge) >= rim else
                       max(0.0, trial_edge - max(edge, envelope.radius)))
            dissipation = current.plastic_dissipation - envelope.dissipation
            work = current.work - envelope.work
        accepted, reason = control.judge(
            used, advance, control.element_at(max(edge, trial_edge)),
            float(np.max(trial.eqps - current.eqps, initial=0.0)),
            float(np.max(current.eqps, initial=0.0)), trial.iterations,
            trial.plastic_dissipation - current.plastic_dissipation, dissipation, work)
        control.limited_by[reason] += 1
        if not accepted:
            control.rejected += 1
            continue
        ratio = goal / current.force
        control.smallest_ratio = min(control.smallest_ratio, ratio)
        control.largest_ratio = max(control.largest_ratio, ratio)
        current, edge = trial, trial_edge
    return dataclasses.replace(current, iterations=iterations)


def _rescue_rest(solver: ContactSolver, current: State, target: float, step: int,
                 iterations: int, failure: str) -> State:
    """The rest of an adaptive step that failed ``MAX_CUTBACKS`` times in a row, solved in
    rescue mode (``_rescue``, as ``_advance`` does)."""
    done = _rescue(solver, current, target, step, None, failure)
    return dataclasses.replace(done, iterations=iterations + done.iterations)


def _solve_step_goals(solver: ContactSolver, state: State, target: float, step: int,
                      goals: list[float] | None, *, rescue: bool) -> State:
    """The solves of ``_advance``; ``rescue``: count the halvings at each state, not in all."""
    current = state
    pending = list(reversed(goals)) if goals else [target]
    cutbacks = failures = 0
    iterations = 0
    while pending:
        goal = pending[-1]
        try:
            current = solver.solve_step(current, goal)
            iterations += current.iterations
            pending.pop()
            if rescue:
                cutbacks = 0
        except ConvergenceError as exc:
            cutbacks += 1
            failures += 1
            if cutbacks > MAX_CUTBACKS or failures > RESCUE_FAILURES:
                raise ConvergenceError(
                    f"step {step}: no convergence towards F = {target:.6g} N after "
                    f"{MAX_CUTBACKS} cutbacks{' in rescue mode' if rescue else ''} "
                    f"(last converged F = {current.force:.6g} N): {exc}"
                ) from None
            pending.append(0.5 * (current.force + goal))
    if goals:
        current = dataclasses.replace(current, iterations=iterations)
    return current


# --- output files ------------------------------------------------------------------------------
def write_result(result: FemResult, out: Path, solver: ContactSolver | None,
                 fields: dict[int, State], field_files=(), *, overwrite: bool = False) -> None:
    """Write the run directory atomically (io.atomic_directory); ``fields``: states to write as
    ParaView files, ``field_files``: ParaView files already written (copied into fields/).
    ``overwrite``: replace ``out`` even if it is not an FE result of ours."""
    inputs = result.summary.get("inputs")
    with atomic_directory(out, "fem", overwrite=overwrite, inputs=inputs) as tmp:
        with open(tmp / "curve.csv", "w", newline="") as fh:
            writer = csv.writer(fh)
            writer.writerow(CURVE_COLUMNS)
            curve = result.curve
            for i in range(len(curve["step"])):
                writer.writerow([repr(curve[c][i].item()) if curve[c].dtype.kind == "f"
                                 else int(curve[c][i]) for c in CURVE_COLUMNS])
        if fields or field_files:
            (tmp / "fields").mkdir()
            for step, state in fields.items():
                write_fields(solver, state, tmp / "fields" / field_name(step))
            for path in field_files:
                shutil.copyfile(path, tmp / "fields" / Path(path).name)
        write_json_atomic(tmp / "summary.json", result.summary)


def write_fields(solver: ContactSolver, state: State, path: Path) -> None:
    """ParaView file: quadratic triangles, nodal displacement, element stress / eps_p / yield."""
    import meshio

    from .plasticity import invariants

    mesh = solver.mesh
    basis = solver.basis
    npts = mesh.doflocs.shape[1]
    dofs_r = np.concatenate([basis.nodal_dofs[0], basis.facet_dofs[0]])
    dofs_z = np.concatenate([basis.nodal_dofs[1], basis.facet_dofs[1]])
    displacement = np.zeros((npts, 3))
    displacement[:, 0] = state.displacement[dofs_r]
    displacement[:, 1] = state.displacement[dofs_z]
    # Element (triangle6) connectivity in skfem's point order: vertices, edges 0-1, 1-2, 0-2.
    cells = np.vstack([mesh.t, mesh.t2f + mesh.t.max() + 1]).T
    stress = state.stress.mean(axis=2)
    p, q = invariants(state.stress)
    yielding = np.where(np.any(state.status == APEX, axis=1), 2,
                        np.where(np.any(state.status != ELASTIC, axis=1), 1, 0))
    points = np.zeros((npts, 3))
    points[:, :2] = mesh.doflocs.T
    out = meshio.Mesh(
        points, [("triangle6", cells)],
        point_data={"displacement": displacement},
        cell_data={
            "stress_rr": [stress[0]], "stress_zz": [stress[1]], "stress_tt": [stress[2]],
            "stress_rz": [stress[3]], "pressure": [p.mean(axis=1)],
            "mises": [q.mean(axis=1)], "eqps": [state.eqps.max(axis=1)],
            "yield_ratio": [solver.yield_ratio(state).max(axis=1)],
            "yield_state": [yielding.astype(np.int32)],
        },
    )
    out.write(path)


__all__ = [
    "AdaptiveSteps", "CURVE_COLUMNS", "FULLY_PLASTIC_CORE", "FULLY_PLASTIC_FRACTION", "FemResult",
    "PRESETS",
    "contact_resolution", "fully_plastic_onset", "history_from_dict", "history_mesh",
    "load_history",
    "load_schedule", "preset_history", "run_history", "sub_step_record", "sub_steps",
    "write_result",
]
