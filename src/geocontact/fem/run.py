"""A force history on the FE model: load stepping, yield detection, outputs (SPEC sections 2, 5).

Public entry point::

    result = run_history(material, forces, mesh="coarse", out=None)
    result.curve    # dict of numpy arrays (the columns of curve.csv)
    result.summary  # dict (summary.json)

All user-facing values are for the ball-ball pair: approach = 2 x the ball-wall interference of
the half model, energies = 2 x the half model's (SPEC section 2). The force is the same.
"""

from __future__ import annotations

import csv
import hashlib
import json
import math
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .. import resolution
from ..errors import ConvergenceError, InputError
from ..force_history import (  # noqa: F401  (re-exported for the FE's callers)
    history_from_dict,
    load_history,
    preset_history,
    validate_forces,
)
from ..hertz import incipient_yield
from ..io import atomic_directory, atomic_path, check_replaceable, write_json_atomic
from ..material import Material
from .mesh import PRESETS, build_mesh, mesh_preset
from .plasticity import APEX, ELASTIC
from .solver import ContactSolver, State

CURVE_COLUMNS = (
    "step", "force_N", "approach_m", "contact_radius_m", "plastic_dissipation_J",
    "elastic_energy_J", "work_J", "peak_pressure_Pa", "plastic_points", "iterations",
    "yielded_contact_fraction", "yielded_core_fraction",
)
# Load steps per monotonic segment of the history, by mesh preset.
STEPS_PER_SEGMENT = {"coarse": 12, "default": 24, "fine": 40}
MAX_CUTBACKS = 8
# Treatment of the volumetric strain of the P2 element (B-bar projection per element).
VOLUMETRIC = {"bbar-p1": (True, 1), "bbar-p0": (True, 0), "full": (False, 0)}
VOLUMETRIC_DEFAULT = "bbar-p1"
PAIR = 2.0  # ball-ball approach and pair energies = 2 x the half model (SPEC section 2)
# Fully plastic onset Fp (SPEC section 4): the first load at which FULLY_PLASTIC_FRACTION of the
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


@dataclass
class FemResult:
    curve: dict[str, np.ndarray]
    summary: dict[str, Any]
    states: list[State] = field(default_factory=list, repr=False)  # converged states (opt.)
    solver: ContactSolver | None = field(default=None, repr=False)


# --- sizing ------------------------------------------------------------------------------------
def yield_contact_radius_estimate(material: Material) -> float:
    """Contact radius used to size the mesh and the first load steps: 0.7 of the analytic
    first-yield contact radius (geocontact.hertz), the margin with which the meshes were
    verified (docs/fem.md). The FE run detects the actual first yield itself."""
    return 0.7 * float(incipient_yield(material).contact_radius)


def largest_contact_radius_estimate(material: Material, force: float) -> float:
    """Upper estimate of the contact radius at ``force``: Hertz, or a mean contact pressure of
    2.5 sigma_c (a fully plastic contact carries more), whichever is larger."""
    hertz = (3.0 * force * material.effective_radius / (4.0 * material.effective_modulus)) ** (
        1.0 / 3.0)
    plastic = math.sqrt(force / (math.pi * 2.5 * material.compressive_yield_stress))
    return 1.2 * max(hertz, plastic)


def history_mesh(material: Material, max_force: float, mesh: str = "default"):
    """The mesh of a history whose largest force is ``max_force``: it resolves every contact
    radius from the yield contact radius to the largest one (``mesh.build_mesh``)."""
    a_min = yield_contact_radius_estimate(material)
    a_max = max(largest_contact_radius_estimate(material, max_force), 2.0 * a_min)
    return build_mesh(material.radius, a_min, a_max, mesh)


def _hertz_force(material: Material, contact_radius: float) -> float:
    return 4.0 * material.effective_modulus * contact_radius**3 / (3.0 * material.effective_radius)


# --- load schedule ---------------------------------------------------------------------------
def _segment(start: float, end: float, n: int, yield_force: float) -> list[float]:
    """Targets of one monotonic segment (excluding ``start``, including ``end``).

    Uniform in F^(2/3) (about uniform in approach); on loading, also geometric from near the
    yield force (the elastic-plastic transition spans decades of F / Fy) with points just below
    the predicted first yield.
    """
    u = np.linspace(start ** (2 / 3), end ** (2 / 3), n + 1)[1:] ** 1.5
    points = list(u)
    if end > start:
        lo = max(start, 0.5 * yield_force)
        if end > lo * 1.05:
            points += list(np.geomspace(lo, end, n + 1)[1:])
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


def load_schedule(forces: list[float], n: int, yield_force: float) -> tuple[list[float], list[int]]:
    """Step targets and, for each waypoint of ``forces`` after the first, its step index."""
    targets: list[float] = []
    marks: list[int] = []
    for a, b in zip(forces[:-1], forces[1:], strict=True):
        if b != a:
            targets += _segment(a, b, n, yield_force)
        marks.append(len(targets))  # 1-based step number of the waypoint
    return targets, marks


# --- the run -----------------------------------------------------------------------------------
def _signature(material: Material, forces: list[float], mesh: str, steps: int) -> str:
    text = json.dumps({"material": material.to_dict(), "forces": forces, "mesh": mesh,
                       "steps": steps}, sort_keys=True)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def _atomic_savez(path: Path, **arrays) -> None:
    with atomic_path(path) as tmp:
        np.savez(tmp, **arrays)


def checkpoint_path(out: str | Path) -> Path:
    out = Path(out)
    return out.parent / (out.name + ".checkpoint.npz")


def fully_plastic_onset(force, approach, fraction,
                        threshold: float = FULLY_PLASTIC_FRACTION) -> dict[str, Any] | None:
    """Fp (SPEC section 4): the first loading step on which the yielded fraction reaches
    ``threshold``, interpolated linearly in the force (and the approach) from the step before.

    ``force``, ``approach``, ``fraction``: per step, in step order (curve.csv columns). None if
    the threshold is never reached on a loading step.
    """
    force, approach, fraction = (np.asarray(x, dtype=float) for x in (force, approach, fraction))
    for k in range(1, len(force)):
        if force[k] > force[k - 1] and fraction[k] >= threshold:
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
            if plastic_points == 0:
                ratio = s.yield_ratio(state)
                k = np.unravel_index(np.argmax(ratio), ratio.shape)
                if state.force > 0:
                    self.last_elastic = (state.force, PAIR * state.top_displacement,
                                         float(ratio[k]),
                                         (float(s.radius_qp[k]), float(s.z_qp[k])))
            else:
                self.first_yield = self._interpolate_first_yield(state)

    def _detect_fully_plastic(self) -> None:
        if self.fully_plastic is not None or len(self.rows) < 2:
            return
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

    def curve(self) -> dict[str, np.ndarray]:
        data = np.array(self.rows, dtype=float).reshape(-1, len(CURVE_COLUMNS))
        out = {name: data[:, i] for i, name in enumerate(CURVE_COLUMNS)}
        for name in ("step", "plastic_points", "iterations"):
            out[name] = out[name].astype(int)
        return out


def _cycles(curve: dict[str, np.ndarray], forces: list[float], marks: list[int]) -> list[dict]:
    """A cycle runs from a zero-force waypoint through its peak to the next zero-force one."""
    steps = curve["step"]
    index = {int(s): i for i, s in enumerate(steps)}
    zero_marks = [0] + [m for f, m in zip(forces[1:], marks, strict=True) if f == 0.0]
    if forces[-1] != 0.0:
        zero_marks.append(marks[-1])
    cycles = []
    for a, b in zip(zero_marks[:-1], zero_marks[1:], strict=True):
        if b <= a or a not in index or b not in index:
            continue
        sl = slice(index[a], index[b] + 1)
        f = curve["force_N"][sl]
        d = curve["approach_m"][sl]
        k = int(np.argmax(f))
        closed = curve["force_N"][index[b]] == 0.0
        cycles.append({
            "max_force_N": float(f[k]),
            "max_approach_m": float(d[k]),
            "residual_approach_m": float(d[-1]) if closed else None,
            "plastic_work_J": float(curve["plastic_dissipation_J"][index[b]]
                                    - curve["plastic_dissipation_J"][index[a]]),
            "loop_work_J": float(curve["work_J"][index[b]] - curve["work_J"][index[a]]),
            "residual_elastic_energy_J": float(curve["elastic_energy_J"][index[b]]),
            "steps": [int(a), int(b)],
        })
    return cycles


def _skfem_mesh_from_arrays(doflocs: np.ndarray, t: np.ndarray):
    from skfem import MeshTri2

    return MeshTri2(np.ascontiguousarray(doflocs), np.ascontiguousarray(t))


def run_history(
    material: Material,
    forces,
    mesh: str = "coarse",
    out: str | Path | None = None,
    *,
    steps_per_segment: int | None = None,
    resume: bool = False,
    progress: bool = False,
    write_fields: bool = True,
    keep_states: bool = False,
    tolerance: float = 1e-8,
    volumetric: str = VOLUMETRIC_DEFAULT,
    mesh_force: float | None = None,
    overwrite: bool = False,
    checkpoint: str | Path | None = None,
) -> FemResult:
    """Run the force history ``forces`` (N, piecewise linear waypoints) on the FE model.

    ``mesh``: "coarse" | "default" | "fine". ``mesh_force``: size the mesh for this force
    instead of the history's largest (>= it), so runs of different peaks can share one mesh
    (e.g. single loads compared with a longer history). ``out``: result directory (curve.csv,
    summary.json, fields/*.vtu), written atomically; an existing ``out`` is replaced only if it
    is an FE result of ours (``io.check_replaceable``, checked before any work; ``overwrite`` lifts
    it). A checkpoint ``<out>.checkpoint.npz`` (or ``checkpoint``) is written after every
    converged step and used by ``resume=True``; the default one is removed when the result has
    landed, an explicit ``checkpoint`` is left to the caller (who lands the result later).
    Raises ConvergenceError (one line, naming the step and load) if a step fails after
    ``MAX_CUTBACKS`` halvings; the checkpoint then holds the last converged state.
    """
    started = time.perf_counter()
    forces = validate_forces(list(forces))
    mesh_preset(mesh)
    steps = int(steps_per_segment or STEPS_PER_SEGMENT[mesh])
    if steps < 1:
        raise InputError(f"steps_per_segment: must be >= 1, got {steps}")
    fmax = max(forces)
    if mesh_force is not None and not (math.isfinite(mesh_force) and mesh_force >= fmax):
        raise InputError(f"mesh_force: must be >= the largest force {fmax:g} N, got {mesh_force!r}")
    sized_for = fmax if mesh_force is None else float(mesh_force)
    mesh_key = f"{mesh}/{volumetric}" + ("" if mesh_force is None else f"/{sized_for!r}")
    signature = _signature(material, forces, mesh_key, steps)
    if out is not None:
        check_replaceable(out, "fem", overwrite=overwrite)
    ckpt = Path(checkpoint) if checkpoint is not None else (
        checkpoint_path(out) if out is not None else None)
    saved = None
    if resume and ckpt is not None and ckpt.exists():
        with np.load(ckpt, allow_pickle=False) as data:
            if str(data["signature"]) == signature:
                saved = {k: data[k] for k in data.files}
            else:
                print("warning: checkpoint is for other inputs; starting afresh", file=sys.stderr)

    if saved is not None:
        fe_mesh = _skfem_mesh_from_arrays(saved["mesh_doflocs"], saved["mesh_t"])
    else:
        fe_mesh = history_mesh(material, sized_for, mesh)
    if volumetric not in VOLUMETRIC:
        raise InputError(f"volumetric: unknown {volumetric!r} (allowed: {', '.join(VOLUMETRIC)})")
    bbar, order = VOLUMETRIC[volumetric]
    solver = ContactSolver(material, fe_mesh, force_scale=fmax, tolerance=tolerance, bbar=bbar,
                           volumetric_order=order)
    run = _Run(solver, material)

    if saved is not None:
        yield_force = float(saved["yield_force_estimate"])
        state = State.from_arrays({k[6:]: v for k, v in saved.items() if k.startswith("state_")})
        run.rows = [list(r) for r in saved["rows"]]
        meta = json.loads(str(saved["meta"]))
        run.first_yield = meta["first_yield"]
        run.fully_plastic = meta["fully_plastic"]
        run.last_elastic = meta["last_elastic"]
        done = int(saved["done"])
        elapsed_before = float(saved["wall_time_s"])
    else:
        yield_force = _probe_yield_force(solver, material)
        state = solver.initial_state()
        run.record(0, state)
        done = 0
        elapsed_before = 0.0
    targets, marks = load_schedule(forces, steps, yield_force)
    field_steps = set(marks)

    fields: dict[int, State] = {}
    states = [state] if keep_states else []
    bar = None
    if progress:
        from tqdm import tqdm

        bar = tqdm(total=len(targets), initial=done, desc="fem", unit="step", file=sys.stderr,
                   leave=False)
    try:
        for k in range(done, len(targets)):
            step = k + 1
            state = _advance(solver, state, targets[k], step)
            run.record(step, state)
            if keep_states:
                states.append(state)
            if write_fields and step in field_steps:
                fields[step] = state
            if ckpt is not None:
                meta = {"first_yield": run.first_yield, "fully_plastic": run.fully_plastic,
                        "last_elastic": run.last_elastic}
                _atomic_savez(
                    ckpt, signature=np.array(signature), done=np.array(step),
                    rows=np.array(run.rows), yield_force_estimate=np.array(yield_force),
                    mesh_doflocs=fe_mesh.doflocs, mesh_t=fe_mesh.t, meta=np.array(json.dumps(meta)),
                    wall_time_s=np.array(elapsed_before + time.perf_counter() - started),
                    **{f"state_{k2}": v for k2, v in state.arrays().items()},
                )
            if bar is not None:
                bar.update(1)
    finally:
        if bar is not None:
            bar.close()

    curve = run.curve()
    wall = elapsed_before + time.perf_counter() - started
    from .. import __version__

    first = run.first_yield or {}
    # per-cycle values below the run's resolution are round-off: 0 here, raw in curve.csv
    resolutions = resolution.fe_resolutions(float(np.max(curve["force_N"])),
                                            float(np.max(curve["approach_m"])))
    summary = {
        "first_yield_force_N": first.get("force_N"),
        "first_yield_approach_m": first.get("approach_m"),
        "first_yield_location_m": first.get("location_m"),
        "first_yield_bracket_N": first.get("bracket_N"),
        "first_yield_force_predicted_N": yield_force,
        "fully_plastic_force_N": run.fully_plastic["force_N"] if run.fully_plastic else None,
        "fully_plastic_approach_m": (run.fully_plastic["approach_m"] if run.fully_plastic
                                     else None),
        "fully_plastic_bracket_N": (run.fully_plastic["bracket_N"] if run.fully_plastic
                                    else None),
        "fully_plastic_criterion": {"yielded_core_fraction": FULLY_PLASTIC_FRACTION,
                                    "core_radius_over_contact_radius": FULLY_PLASTIC_CORE},
        "cycles": resolution.clean_fe_cycles(_cycles(curve, forces, marks), resolutions),
        "resolution": resolution.fe_summary_record(resolutions),
        "mesh": {"elements": int(fe_mesh.t.shape[1]), "nodes": int(fe_mesh.doflocs.shape[1]),
                 "preset": mesh, "element": f"P2 triangle (6-node, isoparametric), {volumetric}"},
        "steps": int(len(targets)),
        "newton_iterations": int(np.sum(curve["iterations"])),
        "wall_time_s": wall,
        "version": __version__,
        "inputs": {"material": material.to_dict(), "forces_N": forces, "mesh": mesh,
                   "steps_per_segment": steps, "tolerance": tolerance,
                   "mesh_force_N": sized_for,
                   "volumetric": volumetric},
        "conventions": "approach is ball-ball (2 x ball-wall); energies are for the pair",
    }
    result = FemResult(curve=curve, summary=summary, states=states, solver=solver)
    if out is not None:
        write_result(result, Path(out), solver, fields, overwrite=overwrite)
        if checkpoint is None and ckpt is not None and ckpt.exists():
            ckpt.unlink()
    return result


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


def _advance(solver: ContactSolver, state: State, target: float, step: int) -> State:
    """One load step with cutback: halve the increment on non-convergence."""
    current = state
    pending = [target]
    cutbacks = 0
    while pending:
        goal = pending[-1]
        try:
            current = solver.solve_step(current, goal)
            pending.pop()
        except ConvergenceError as exc:
            cutbacks += 1
            if cutbacks > MAX_CUTBACKS:
                raise ConvergenceError(
                    f"step {step}: no convergence towards F = {target:.6g} N after "
                    f"{MAX_CUTBACKS} cutbacks (last converged F = {current.force:.6g} N): {exc}"
                ) from None
            pending.append(0.5 * (current.force + goal))
    return current


# --- output files ------------------------------------------------------------------------------
def write_result(result: FemResult, out: Path, solver: ContactSolver,
                 fields: dict[int, State], *, overwrite: bool = False) -> None:
    """Write the run directory atomically (io.atomic_directory)."""
    inputs = result.summary.get("inputs")
    with atomic_directory(out, "fem", overwrite=overwrite, inputs=inputs) as tmp:
        with open(tmp / "curve.csv", "w", newline="") as fh:
            writer = csv.writer(fh)
            writer.writerow(CURVE_COLUMNS)
            curve = result.curve
            for i in range(len(curve["step"])):
                writer.writerow([repr(curve[c][i].item()) if curve[c].dtype.kind == "f"
                                 else int(curve[c][i]) for c in CURVE_COLUMNS])
        if fields:
            (tmp / "fields").mkdir()
            for step, state in fields.items():
                write_fields(solver, state, tmp / "fields" / f"step_{step:05d}.vtu")
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
    "CURVE_COLUMNS", "FULLY_PLASTIC_CORE", "FULLY_PLASTIC_FRACTION", "FemResult", "PRESETS",
    "fully_plastic_onset", "history_from_dict", "history_mesh", "load_history",
    "load_schedule", "preset_history", "run_history", "write_result",
]
