"""Two deformable spheres of radii r1 and r2 (one material) in frictionless contact.

The pair the DEM law maps onto two identical spheres of radius r_eq = 2 r1 r2 / (r1 + r2)
(docs/dem.md, "Unequal radii"); this model measures that mapping (``scripts/verify_req_mapping.py``,
docs/req_mapping.md). It is the half model of :mod:`geocontact.fem.solver` with the rigid flat
replaced by the second sphere; everything else is the same code: mesh zones
(:func:`mesh.build_mesh`, one per sphere), elements, Drucker-Prager return mapping, Newton with the
primal-dual active set, force control, load schedule, yield and Fp detection, energies.

Geometry (axisymmetric, the r-z plane): sphere 1 (radius r1, the *upper* body) is the half model's
quarter disc, centre (0, r1), tip at the origin; sphere 2 (radius r2) is the mirror image of its
own quarter disc, centre (0, -r2), tip at the origin too (a separate node). The far face of sphere
1 (z = r1) moves by -w (the force F is its generalized reaction, as in the half model); the far
face of sphere 2 (z = -r2) is held in z. So w is the change of the centre distance: the ball-ball
approach, with no factor 2, and the energies are those of the pair (both spheres).

Contact (small strain, as the half model's g = z0 + u_z): node-to-segment. Each surface node s of
sphere 1 with r_s <= ``CANDIDATE_RADIUS`` min(r1, r2) is a slave; its gap to sphere 2 is taken at
the same radius r_s on sphere 2's quadratic surface edge (the master segment), shape functions
N_j(r_s) of that edge's three nodes::

    g_s = (z_s - z_2(r_s)) + u_z,s - sum_j N_j u_z,j      (radial displacements neglected, as
                                                          in the half model and in Hertz theory)

The change of unknowns v = S u, v_z,s = u_z,s - sum_j N_j u_z,j on the slaves (identity
elsewhere; S is unit lower triangular: the masters are not slaves), turns every gap into the half
model's form g_s = g0_s + v_z,s. In v the problem *is* the half model's: same residual and active
set logic (the reaction conjugate to v_z,s is the contact force on node s), strain B S^-1 v,
internal force S^-T f, tangent S^-T K S^-1. :class:`PairSolver` overrides only these three maps and
the geometry set-up; the Newton / active-set loop, the step, the energies and the outputs are
:class:`ContactSolver`'s. (Written as u = T v with T = S^-1: u_z,s = v_z,s + sum_j N_j u_z,j.)

For r1 = r2 the mesh of sphere 2 is the mirror image of sphere 1's, every slave sits opposite a
master node (N = 1 there), and the symmetric solution of the pair is the half model's solution:
``tests/test_fem_pair.py`` checks that the two runs agree to the Newton tolerance.
"""

from __future__ import annotations

import hashlib
import json
import math
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import scipy.sparse as sp

from .._version import __version__
from ..errors import InputError
from ..files import check_replaceable
from ..grain.material import Material
from .identity import FeRunIdentity, fe_code_hash, library_versions, load_result
from .linear_algebra import ELASTIC_FACTOR_CACHE, REDUCED_CACHE, factorise
from .mesh import build_mesh, elements_across
from .result import CURVE_COLUMNS, TOLERANCE, VOLUMETRIC, FemResult
from .run import (
    FULLY_PLASTIC_CORE,
    _advance,
    _cycles,
    _probe_yield_force,
    _Run,
    hertz_contact_radius,
    largest_contact_radius_estimate,
    load_schedule,
    smallest_resolved_force,
    tip_contact_radius,
    write_result,
)
from .solver import ContactSolver
from .state import State

SCHEMA = "geocontact.fe-pair-identity/1"
# Slave nodes: sphere 1's surface nodes out to this fraction of the smaller radius (the half
# model's candidates reach 0.71 R; the largest contact radius of the studies is < 0.15 min(r)).
CANDIDATE_RADIUS = 0.5


def equivalent_radius(r1: float, r2: float) -> float:
    """r_eq = 2 r1 r2 / (r1 + r2): the radius of the identical pair with the same R*."""
    return 2.0 * r1 * r2 / (r1 + r2)


def check_radii(r1: Any, r2: Any) -> tuple[float, float]:
    for name, value in (("r1", r1), ("r2", r2)):
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not (
                math.isfinite(value) and value > 0):
            raise InputError(f"{name}: sphere radius must be a positive number of metres, "
                             f"got {value!r}")
    return float(r1), float(r2)


# --- mesh --------------------------------------------------------------------------------------
def _quadratic_connectivity(mesh) -> tuple[np.ndarray, np.ndarray]:
    """(points (n, 2), 6-node connectivity (elements, 6)) of a skfem MeshTri2, gmsh order:
    vertices, then the edges 0-1, 1-2, 2-0 (skfem's t2f rows)."""
    nverts = int(mesh.t.max()) + 1
    conn = np.vstack([mesh.t, mesh.t2f + nverts]).T
    return np.asarray(mesh.doflocs.T), conn


def pair_mesh(material_eq: Material, r1: float, r2: float, max_force: float, preset: str,
              min_force: float):
    """Both spheres in one ``skfem.MeshTri2`` (``material_eq``: the material at r_eq).

    Each sphere is meshed by :func:`mesh.build_mesh` with its own radius and the contact radii of
    the equivalent pair (a_min from the first load step, a_max at ``max_force``, as
    ``run.history_mesh`` sizes the half model: in the half-space limit both spheres share the
    contact radius of the r_eq pair). Returns (mesh, number of sphere-1 elements, meshes of
    sphere 1 and of sphere 2 as built, before the mirror).
    """
    from skfem import MeshTri2

    a_min = tip_contact_radius(material_eq, min_force, preset)
    a_max = max(largest_contact_radius_estimate(material_eq, max_force), 2.0 * a_min)
    mesh1 = build_mesh(r1, a_min, a_max, preset)
    mesh2 = mesh1 if r2 == r1 else build_mesh(r2, a_min, a_max, preset)
    p1, c1 = _quadratic_connectivity(mesh1)
    p2, c2 = _quadratic_connectivity(mesh2)
    p2 = p2 * np.array([1.0, -1.0])  # mirror: centre (0, -r2)
    c2 = c2[:, [0, 2, 1, 5, 4, 3]]  # the mirror reverses the orientation
    points = np.vstack([p1, p2])
    conn = np.vstack([c1, c2 + len(p1)])
    mesh = MeshTri2(np.ascontiguousarray(points.T), np.ascontiguousarray(conn.T))
    return mesh, c1.shape[0], mesh1, mesh2


# --- solver ------------------------------------------------------------------------------------
def _edge_shape(xi: np.ndarray) -> np.ndarray:
    """Quadratic shape functions of an edge (end 0, end 1, middle) at xi in [0, 1]."""
    return np.stack([(1 - xi) * (1 - 2 * xi), xi * (2 * xi - 1), 4 * xi * (1 - xi)])


@dataclass
class PairSolver(ContactSolver):
    """Newton / active-set solver of two spheres in contact (module docstring).

    ``material``: the common material with ``radius`` = r1 (sphere 1, the slave, whose far face
    carries the load); ``radius_2``: r2; ``body_1_elements``: the first elements of ``mesh`` that
    belong to sphere 1 (:func:`pair_mesh`). ``linear_solver``: "fast" factorises with CHOLMOD
    (:meth:`_fast_step`), "reference" is the half model's SuperLU path; both solve T^T K T.
    """

    radius_2: float = 0.0
    body_1_elements: int = 0
    _transform: Any = field(default=None, repr=False)

    def __post_init__(self) -> None:
        super().__post_init__()
        basis = self.basis
        x, z = self.mesh.doflocs
        r1, r2 = self.material.radius, self.radius_2
        body1 = np.zeros(self.ndofs, dtype=bool)
        body1[self.element_dofs[:, :self.body_1_elements].ravel()] = True
        dofs_z = np.concatenate([basis.nodal_dofs[1], basis.facet_dofs[1]])
        # Sphere 2's far face z = -r2 is held in z: add it to the fixed dofs of the half model
        # (``axis_dofs`` is the set held at zero; u_r = 0 on the axis is there already).
        bottom = dofs_z[np.abs(z + r2) < r2 * 1e-9]
        self.axis_dofs = np.concatenate([self.axis_dofs, bottom])
        # Slaves: sphere 1's candidates (the half model's), out to CANDIDATE_RADIUS min(r1, r2).
        keep = body1[self.candidate_dofs] & (
            self.candidate_r <= CANDIDATE_RADIUS * min(r1, r2) * (1 + 1e-12))
        for name in ("candidate_r", "candidate_z0", "candidate_dofs", "candidate_dofs_r",
                     "candidate_area", "candidate_points"):
            setattr(self, name, getattr(self, name)[keep])
        # Masters: sphere 2's surface edges, the three nodes of each (ends, middle).
        on2 = (~body1[dofs_z]) & (np.abs(np.hypot(x, z + r2) - r2) < 1e-7 * r2)
        facets = self.mesh.boundary_facets()
        ends = self.mesh.facets[:, facets]
        nverts = int(self.mesh.t.max()) + 1
        middle = facets + nverts  # the mid-edge node of facet f is point nverts + f
        edge = np.all(on2[ends], axis=0) & on2[middle]
        ends, middle = ends[:, edge], middle[edge]
        lo = np.where(x[ends[0]] <= x[ends[1]], ends[0], ends[1])
        hi = np.where(x[ends[0]] <= x[ends[1]], ends[1], ends[0])
        order = np.argsort(x[lo])
        lo, hi, middle = lo[order], hi[order], middle[order]
        rs = self.candidate_r
        k = np.clip(np.searchsorted(x[lo], rs, side="right") - 1, 0, len(lo) - 1)
        if np.any(rs > x[hi[k]] * (1 + 1e-12)):
            raise InputError("pair mesh: a slave node lies outside sphere 2's surface")
        # r(xi) = sum N_j r_j on the curved edge: solve the quadratic for xi in [0, 1]
        ra, rb, rm = x[lo[k]], x[hi[k]], x[middle[k]]
        c2, c1, c0 = 2 * ra + 2 * rb - 4 * rm, -3 * ra - rb + 4 * rm, ra - rs
        # the root in [0, 1] in the form without cancellation (c1 > 0: r grows along the edge)
        disc = np.sqrt(np.maximum(c1 * c1 - 4 * c2 * c0, 0.0))
        xi = np.clip(-2.0 * c0 / (c1 + disc), 0.0, 1.0)
        shape = _edge_shape(xi)  # (3, slaves)
        nodes = np.stack([lo[k], hi[k], middle[k]])
        z_master = np.sum(shape * z[nodes], axis=0)
        self.master_nodes = nodes
        self.master_weights = shape
        self.candidate_z0 = self.candidate_z0 - z_master  # initial gap g0 between the surfaces
        # T: u = T v, u_z,s = v_z,s + sum_j N_j v_z,j (the masters' v is their u)
        rows = np.repeat(self.candidate_dofs[None, :], 3, axis=0).ravel()
        cols = dofs_z[nodes].ravel()
        coupling = sp.csr_matrix((shape.ravel(), (rows, cols)), shape=(self.ndofs, self.ndofs))
        self._transform = (sp.identity(self.ndofs, format="csr") + coupling).tocsr()
        self._transform_t = self._transform.T.tocsr()
        self.body1_dofs = body1

    # --- the three maps of the change of unknowns v -> u = T v ------------------------------
    def displacement(self, v: np.ndarray) -> np.ndarray:
        """The displacements u of both spheres from the solver's unknowns v."""
        return self._transform @ v

    def strain(self, displacement: np.ndarray) -> np.ndarray:
        return super().strain(self._transform @ displacement)

    def internal_force(self, stress: np.ndarray) -> np.ndarray:
        return self._transform_t @ super().internal_force(stress)

    def stiffness(self, tangent: np.ndarray | None) -> sp.csr_matrix:
        """T^T K T, K assembled from the batched element matrices (``element_matrices``)."""
        if tangent is None and "pair_elastic" in self._cache:
            return self._cache["pair_elastic"]
        a = self._assembly
        data = np.bincount(a.slot, weights=self.element_matrices(tangent).ravel(),
                           minlength=len(a.indices))
        k = sp.csr_matrix((data, a.indices, a.indptr), shape=(self.ndofs, self.ndofs))
        k = (self._transform_t @ k @ self._transform).tocsr()
        if tangent is None:
            self._cache["pair_elastic"] = k
        return k

    def _fast_step(self, tangent, active, prescribed, r_free, r_top, elastic) -> np.ndarray:
        """Newton correction [du_free, dw]: the bordered system of ``ContactSolver``'s reference
        path (unknowns [v_free, w], v_top = -w) from the transformed tangent, factorised as on
        its fast path (``linear_algebra.factorise``: CHOLMOD, symbolic analysis and the elastic
        factor kept per contact set)."""
        key = active.tobytes()
        maps = self._reduced_maps
        if key not in maps:
            fixed = np.concatenate([self.axis_dofs, self.top_dofs, self.candidate_dofs[active]])
            free = np.setdiff1d(np.arange(self.ndofs), fixed)
            n = len(free)
            rows = np.concatenate([free, self.top_dofs])
            cols = np.concatenate([np.arange(n), np.full(len(self.top_dofs), n)])
            vals = np.concatenate([np.ones(n), -np.ones(len(self.top_dofs))])
            border = sp.csr_matrix((vals, (rows, cols)), shape=(self.ndofs, n + 1))
            maps[key] = _Bordered(border, border.T.tocsr())
            if len(maps) > REDUCED_CACHE:
                maps.popitem(last=False)
        maps.move_to_end(key)
        system = maps[key]
        k = self.stiffness(tangent)
        rhs = np.concatenate([-r_free, [-r_top]])
        if np.any(prescribed != 0.0):
            rhs -= system.border_t @ (k @ prescribed)
        factors = self._elastic_factors
        if tangent is None and key in factors:
            factors.move_to_end(key)
            return factors[key](rhs)
        self.factorisations += 1
        matrix = (system.border_t @ k @ system.border).tocsc()
        matrix.sort_indices()
        factor = factorise(matrix, system)
        if factor is None:
            return np.full_like(rhs, np.nan)
        if tangent is None:
            factors[key] = factor
            if len(factors) > ELASTIC_FACTOR_CACHE:
                factors.popitem(last=False)
        return factor(rhs)


@dataclass
class _Bordered:
    """The map of one contact set's unknowns [v_free, w] into v (v_top = -w), and CHOLMOD's
    symbolic analysis of its system (``linear_algebra.factorise``)."""

    border: sp.csr_matrix
    border_t: sp.csr_matrix
    symbolic: object = None


# --- identity ----------------------------------------------------------------------------------
def pair_code_hash() -> str:
    """The half model's FE source hash (``reuse.fe_code_hash``) with this module's source."""
    digest = hashlib.sha256(fe_code_hash().encode())
    digest.update(Path(__file__).read_bytes())
    return digest.hexdigest()[:16]


@dataclass(frozen=True)
class PairRunIdentity:
    """Everything that decides a pair run: the half model's identity of sphere 1 (material with
    radius r1, history, mesh, steps, tolerance, volumetric treatment), r2, this module's code."""

    base: FeRunIdentity
    radius_2: float

    @classmethod
    def of(cls, material: Material, r1: float, r2: float, forces, mesh: str = "coarse", *,
           steps_per_segment: int | None = None, tolerance: float = TOLERANCE,
           volumetric: str = "bbar-p1") -> PairRunIdentity:
        r1, r2 = check_radii(r1, r2)
        base = FeRunIdentity.of(material.with_(radius=r1), forces, mesh,
                                steps_per_segment=steps_per_segment, tolerance=tolerance,
                                volumetric=volumetric)
        return cls(base, r2)

    def inputs(self) -> dict[str, Any]:
        inputs = self.base.inputs()
        inputs.pop("mesh_force_N")
        r1 = self.base.material.radius
        return {**inputs, "radii_m": [r1, self.radius_2],
                "equivalent_radius_m": equivalent_radius(r1, self.radius_2)}

    def to_dict(self) -> dict[str, Any]:
        record = {"schema": SCHEMA, "inputs": self.inputs(), "fe_code": pair_code_hash(),
                  "libraries": library_versions()}
        text = json.dumps(record, sort_keys=True)
        return {"key": hashlib.sha256(text.encode()).hexdigest()[:20], **record}


# --- the run -----------------------------------------------------------------------------------
class _PairRun(_Run):
    """The half model's bookkeeping (curve rows, first yield, Fp). It reports ball-ball values as
    2 x its ball-wall ones (``run.PAIR``), so it is handed the pair's state as its half: approach
    w / 2, work and dissipation / 2; the elastic energy, which it computes from the stresses of both
    spheres, is put back as the pair's."""

    def record(self, step: int, state: State) -> None:
        from dataclasses import replace

        from .run import PAIR

        half = replace(state, top_displacement=state.top_displacement / PAIR,
                       plastic_dissipation=state.plastic_dissipation / PAIR,
                       work=state.work / PAIR)
        super().record(step, half)
        self.rows[-1][CURVE_COLUMNS.index("elastic_energy_J")] = self.solver.elastic_energy(
            state)


def _resolution(meshes, radii, curve, first_yield, material_eq) -> dict[str, Any]:
    """Surface elements across the contact radius on each sphere (``mesh.elements_across``) at
    the first loaded step and at the peak (below yield the smaller of the FE and Hertz radius,
    as ``run.contact_resolution``)."""
    force, radius = curve["force_N"], curve["contact_radius_m"]
    yield_force = first_yield["force_N"] if first_yield else math.inf
    loaded = np.nonzero(force > 0.0)[0]
    points = {}
    if loaded.size:
        for name, k in (("first_loaded_step", int(loaded[0])), ("peak", int(np.argmax(force)))):
            a = float(radius[k])
            if force[k] < yield_force:
                a = min(a, hertz_contact_radius(material_eq, float(force[k])))
            points[name] = {"force_N": float(force[k]), "contact_radius_m": a,
                            "elements": [elements_across(m, r, a) for m, r in
                                         zip(meshes, radii, strict=True)]}
    return points


def run_pair_history(material: Material, r1: float, r2: float, forces, mesh: str = "coarse",
                     out: str | Path | None = None, *, steps_per_segment: int | None = None,
                     tolerance: float = TOLERANCE, volumetric: str = "bbar-p1",
                     resume: bool = False, progress: bool = False,
                     keep_states: bool = False) -> FemResult:
    """The force history ``forces`` (N) on two spheres of radii ``r1`` (loaded far face, slave
    surface) and ``r2`` of ``material`` (its own radius is ignored).

    Returns a FemResult whose curve has the columns of the half model's (``run.CURVE_COLUMNS``),
    for the pair: approach = change of the centre distance, energies of both spheres; yielded
    fractions are sphere 1's. ``out``: result folder written atomically (replaced only if it is an
    FE result of ours); ``resume``: reuse a finished run in ``out`` of the same identity
    (inputs, this code, library versions). The run is short on the coarse mesh (about a minute), so
    it has no per-step checkpoint: an interrupted run starts over.
    """

    started = time.perf_counter()
    identity = PairRunIdentity.of(material, r1, r2, forces, mesh, tolerance=tolerance,
                                  steps_per_segment=steps_per_segment, volumetric=volumetric)
    record = identity.to_dict()
    r1, r2 = identity.base.material.radius, identity.radius_2
    forces, steps = list(identity.base.forces), identity.base.steps_per_segment
    if resume and out is not None and (Path(out) / "summary.json").exists() and not keep_states:
        try:
            finished = load_result(out)
        except InputError:
            finished = None
        if finished is not None and finished.summary.get("identity") == record:
            return finished
    if out is not None:
        check_replaceable(out, "fem")
    r_eq = equivalent_radius(r1, r2)
    material_eq = material.with_(radius=r_eq)
    fe_mesh, body_1, mesh1, mesh2 = pair_mesh(
        material_eq, r1, r2, max(forces), mesh,
        min_force=smallest_resolved_force(material_eq, forces, steps))
    bbar, order = VOLUMETRIC[volumetric]
    solver = PairSolver(material.with_(radius=r1), fe_mesh, force_scale=max(forces),
                        tolerance=tolerance, bbar=bbar, volumetric_order=order, radius_2=r2,
                        body_1_elements=body_1)
    yield_force = _probe_yield_force(solver, material_eq)
    state = solver.initial_state()
    run = _PairRun(solver, material_eq)
    run.record(0, state)
    states = [state] if keep_states else []
    targets, marks = load_schedule(forces, steps, yield_force)
    for k, target in enumerate(targets):
        state = _advance(solver, state, target, k + 1)
        run.record(k + 1, state)
        if keep_states:
            states.append(state)
        if progress:
            print(f"\rpair r1={r1:g} r2={r2:g}: step {k + 1}/{len(targets)} F = {target:.4g} N",
                  end="", file=sys.stderr, flush=True)
    if progress:
        print(file=sys.stderr)
    curve = run.curve()
    first = run.first_yield or {}
    summary = {
        "first_yield_force_N": first.get("force_N"),
        "first_yield_approach_m": first.get("approach_m"),
        "first_yield_location_m": first.get("location_m"),
        "first_yield_force_predicted_N": yield_force,
        "fully_plastic_force_N": run.fully_plastic["force_N"] if run.fully_plastic else None,
        "fully_plastic_criterion": {"sphere": 1, "core_radius_over_contact_radius":
                                    FULLY_PLASTIC_CORE},
        "cycles": _cycles(curve, forces, marks),
        "mesh": {"elements": [body_1, int(fe_mesh.t.shape[1]) - body_1],
                 "nodes": int(fe_mesh.doflocs.shape[1]), "preset": mesh,
                 "element": f"P2 triangle (6-node, isoparametric), {volumetric}",
                 "slave_nodes": int(len(solver.candidate_dofs))},
        "contact_resolution": _resolution((mesh1, mesh2), (r1, r2), curve, run.first_yield,
                                          material_eq),
        "steps": int(len(targets)),
        "newton_iterations": int(np.sum(curve["iterations"])),
        "wall_time_s": time.perf_counter() - started,
        "version": __version__,
        "inputs": identity.inputs(),
        "conventions": "two deformable spheres: approach = change of the centre distance; "
                       "energies of both spheres",
        "identity": record,
        "fields": [],
    }
    result = FemResult(curve=curve, summary=summary, states=states, solver=solver)
    if out is not None:
        write_result(result, Path(out), solver, {})
    return result


__all__ = ["PairRunIdentity", "PairSolver", "check_radii", "equivalent_radius", "pair_mesh",
           "run_pair_history"]
