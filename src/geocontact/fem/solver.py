"""Axisymmetric elastic-plastic hemisphere on a rigid frictionless flat (docs/model.md §5).

Kinematics: small strain, axisymmetric, strain ``[e_rr, e_zz, e_tt = u_r / r, gamma_rz]``;
every integral carries the 2 pi r of the full ring, so forces and energies are those of the whole
(3-D) hemisphere, i.e. of one sphere of the ball-wall model.

Element: isoparametric 6-node triangle (skfem ``ElementTriP2`` on ``MeshTri2``) with the
mean-dilatation B-bar (Hughes 1980): the volumetric strain is replaced by its r-weighted element
mean, the stable P2/P0 displacement-pressure pair, so the element does not lock under isochoric
plastic flow (beta = 0) while the deviatoric strain keeps its quadratic accuracy.

Boundary conditions:
- u_r = 0 on the axis r = 0;
- the equatorial face z = R moves down by one extra unknown ``w`` (the paper's multi-point
  constraint), free in r; its generalized reaction is the contact force F, and the force is the
  load: the equation ``F(u, w) = F_target`` closes the system (load control without arc length);
- the rigid flat z = 0 is an exact unilateral constraint on the surface nodes, gap
  g = z0 + u_z >= 0 with z0 the initial height (small strain), contact force lambda >= 0,
  g lambda = 0, solved by a primal-dual active set (semismooth Newton) inside the Newton loop of
  the plasticity: active nodes are prescribed u_z = -z0, the others are free; a node enters the
  set when it penetrates and leaves when its reaction turns tensile. Opt-in
  (``contact="facet"``, ``fem.facet_contact``): a penalty pressure integrated over the surface
  facets, clipped at the zero of the quadratic gap, so the contact edge moves continuously inside
  an element; Newton then has no active set (``_iterate_facet``).

Linear systems (``linear_solver``): "fast" (default) assembles the reduced, bordered system
straight from the element matrices through index maps cached per contact set, keeps the
constant elastic factorisation of the predictor per contact set, and factorises with CHOLMOD
(scikit-sparse, simplicial LDL^T, symbolic analysis reused; the system is symmetric: associated
flow, B-bar) when it is installed, else SuperLU; "reference" is the earlier path (global CSR,
slicing, SuperLU every iteration), kept to compare the two side by side (docs/benchmarks.md,
scripts/compare_fe_solvers.py).

Rescue mode (``line_search``, set by ``run._advance`` only for a load step that failed with
``MAX_CUTBACKS`` halvings): a Newton update whose iterate the engine cannot evaluate
(``admissible``: with finite strain, an element turned inside out, J <= 0) is halved until it can
(at most ``LINE_SEARCH_HALVINGS`` times), and so is the predictor's increment. Off, the arithmetic
is the one the engine always had, so a run that converges without it is unchanged bit for bit.

Backtracking (``backtracking``, FE setting ``newton="backtracking"``, opt-in): from the third
Newton iteration of a plastic solve on, an update that does not lower the largest residual is
halved (at most ``BACKTRACK_HALVINGS`` times; the last trial is taken if none lowers it), each trial
one evaluation that is the next iterate's own (no evaluation is repeated). It cures the stall of a
perfectly plastic, nearly incompressible grain, where full updates cycle between the elastic and
the plastic branch of the points at the rim of the plastic zone (docs/fem.md "Backtracking"); a
solve whose full updates all lower the residual takes the arithmetic it had without it.
"""

from __future__ import annotations

import math
from collections import OrderedDict
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import splu

from ..errors import ConvergenceError
from ..grain.material import Material
from .plasticity import (
    DruckerPrager,
    elastic_energy_density,
    elastic_strain,
    return_mapping,
    yield_ratio,
)

TWO_PI = 2.0 * math.pi
_IDENTITY = np.array([1.0, 1.0, 1.0, 0.0])
CONTACT_CANDIDATE_HEIGHT = 0.3  # surface nodes with z0 < 0.3 R may touch the flat
# A point counts as yielding (fully plastic onset, docs/model.md §4) when its Drucker-Prager ratio
# is within 1 % of the yield surface: a point that yielded and unloads by round-off still counts.
YIELD_RATIO_AT_YIELD = 0.99
# The surface stress at the contact edge (edge_surface_ratio) is extrapolated from this many
# surface facets just outside the contact (measured on the default mesh at 50 and 55 deg, 0.95-1.05
# Fy: 2 facets differ from 3 by up to 1.2 %, 3, 4 and 6 agree within 0.4 %)
EDGE_SURFACE_FACETS = 3
# Rescue mode: halvings of a Newton update (or of the predictor's increment) whose iterate is not
# admissible before the solve is given up (the caller then cuts the load step back).
LINE_SEARCH_HALVINGS = 12
# Backtracking (newton="backtracking"): halvings of a plastic Newton update that does not lower the
# largest residual, from iteration BACKTRACK_FROM on (the first iterations change the contact set
# and the plastic zone, where a rising residual is Newton's normal path). Two halvings and the
# third iteration: the setting of the point-3 trace (docs/fem.md "Backtracking").
BACKTRACK_HALVINGS = 2
BACKTRACK_FROM = 3
# Facet contact: the line search of the elastic iterations (``_facet_line_search``) stops when the
# slope of the potential is down to this fraction of its start, or after this many evaluations.
FACET_SEARCH_SLOPE = 1e-2
FACET_SEARCH_STEPS = 30


@dataclass
class State:
    """Converged state at the end of a load step (plain arrays; the half-model = one sphere)."""

    displacement: np.ndarray  # (ndofs,)
    top_displacement: float  # w: downward motion of the equatorial face = ball-wall approach
    stress: np.ndarray  # (4, elements, points)
    strain: np.ndarray  # (4, elements, points)
    eqps: np.ndarray  # (elements, points)
    status: np.ndarray  # (elements, points) ELASTIC / CONE / APEX in the last increment
    active: np.ndarray  # (candidates,) bool, nodes in contact
    force: float = 0.0  # N
    plastic_dissipation: float = 0.0  # J, cumulative, one sphere
    work: float = 0.0  # J, cumulative work of the force, one sphere
    iterations: int = 0

    def arrays(self) -> dict[str, np.ndarray]:
        return {
            "displacement": self.displacement, "top_displacement": np.array(self.top_displacement),
            "stress": self.stress, "strain": self.strain, "eqps": self.eqps,
            "status": self.status, "active": self.active, "force": np.array(self.force),
            "plastic_dissipation": np.array(self.plastic_dissipation),
            "work": np.array(self.work),
        }

    @classmethod
    def from_arrays(cls, data) -> State:
        return cls(
            displacement=np.array(data["displacement"]),
            top_displacement=float(data["top_displacement"]),
            stress=np.array(data["stress"]), strain=np.array(data["strain"]),
            eqps=np.array(data["eqps"]), status=np.array(data["status"]),
            active=np.array(data["active"], dtype=bool), force=float(data["force"]),
            plastic_dissipation=float(data["plastic_dissipation"]), work=float(data["work"]),
        )


@dataclass
class _Assembly:
    """Sparse pattern of the global stiffness, reused by every assembly."""

    rows: np.ndarray
    cols: np.ndarray
    slot: np.ndarray  # position of each element entry in the CSR data
    indptr: np.ndarray
    indices: np.ndarray


@dataclass
class _Reduced:
    """Maps of the global pattern into the bordered system of one contact set."""

    free: np.ndarray  # free global dofs, in reduced order
    n: int  # free unknowns; unknown n is w
    keep: np.ndarray  # global CSR entries that enter the reduced system
    slot: np.ndarray  # their position in the reduced CSC data
    weight: np.ndarray  # +-1: u_top = -w
    indices: np.ndarray
    indptr: np.ndarray
    nnz: int
    symbolic: object = None  # CHOLMOD's symbolic analysis (ordering, supernodes) of the pattern


LINEAR_SOLVERS = ("fast", "reference")
CONTACTS = ("node", "facet")  # the flat's contact: node-to-flat (default) | segment-based penalty
REDUCED_CACHE = 8  # contact sets whose index maps are kept
ELASTIC_FACTOR_CACHE = 4  # contact sets whose elastic factorisation is kept


@dataclass
class ContactSolver:
    """Newton / active-set solver of the hemisphere-on-flat problem for one material and mesh."""

    material: Material
    mesh: object  # skfem MeshTri2
    bbar: bool = True
    volumetric_order: int = 0  # B-bar projection of the volumetric strain: 0 (P2/P0) or 1
    plastic: bool = True  # False: linear elastic material (verification, yield probes)
    tolerance: float = 1e-8  # relative residual (to the force scale)
    max_iterations: int = 40
    force_scale: float = 1.0  # N, the history's largest force
    linear_solver: str = "fast"  # "fast" | "reference" (see the module docstring)
    line_search: bool = False  # rescue mode (see the module docstring): off by default
    backtracking: bool = False  # newton="backtracking" (see the module docstring): off by default
    contact: str = "node"  # "node" | "facet" (see the module docstring)
    _cache: dict = field(default_factory=dict, repr=False)

    def __post_init__(self) -> None:
        from skfem import Basis, ElementTriP2, ElementVector

        if self.linear_solver not in LINEAR_SOLVERS:
            raise ValueError(f"linear_solver must be one of {', '.join(LINEAR_SOLVERS)}, "
                             f"got {self.linear_solver!r}")

        if self.contact not in CONTACTS:
            raise ValueError(f"contact must be one of {', '.join(CONTACTS)}, "
                             f"got {self.contact!r}")

        self.model = DruckerPrager.from_material(self.material)
        basis = Basis(self.mesh, ElementVector(ElementTriP2()), intorder=4)
        self.basis = basis
        self.ndofs = basis.N
        self.element_dofs = basis.element_dofs  # (12, elements)
        r = basis.mapping.F(basis.X)[0]  # (elements, points) quadrature radii
        self.dvolume = TWO_PI * r * np.abs(basis.mapping.detDF(basis.X)) * basis.W[None, :]
        self.radius_qp = r
        self.z_qp = basis.mapping.F(basis.X)[1]
        self.B = self._strain_matrices(basis, r)
        self._assembly = self._pattern()

        radius = self.material.radius
        points = self.mesh.doflocs  # vertices then edge midpoints
        dofs_r = np.concatenate([basis.nodal_dofs[0], basis.facet_dofs[0]])
        dofs_z = np.concatenate([basis.nodal_dofs[1], basis.facet_dofs[1]])
        x, z = points
        scale = radius * 1e-9
        self.axis_dofs = dofs_r[np.abs(x) < scale]
        self.top_dofs = dofs_z[np.abs(z - radius) < scale]
        on_sphere = np.abs(np.hypot(x, z - radius) - radius) < 1e-7 * radius
        cand = np.nonzero(on_sphere & (z < CONTACT_CANDIDATE_HEIGHT * radius))[0]
        cand = cand[np.argsort(x[cand])]
        self.candidate_r = x[cand]
        self.candidate_z0 = z[cand]
        self.candidate_dofs = dofs_z[cand]
        self.candidate_dofs_r = dofs_r[cand]
        self.candidate_points = cand
        self.candidate_area = self._tributary_areas(cand)
        self.elastic_matrix = self.model.elastic_matrix()
        # fast path: B per point as (elements, points, 12, 4) for batched matrix products
        self._B_eq = np.ascontiguousarray(self.B.transpose(2, 3, 0, 1))
        self._reduced_maps: OrderedDict = OrderedDict()  # contact set -> _Reduced
        self._elastic_factors: OrderedDict = OrderedDict()  # contact set -> factor
        self.factorisations = 0  # linear systems factorised (both paths)
        self.line_search_halvings = 0  # Newton updates halved in rescue mode, in all
        self.backtracked_updates = 0  # Newton updates halved by backtracking, in all (halvings)
        self.rescued_steps: list[dict] = []  # load steps solved in rescue mode (run._advance)
        if self.contact == "facet":
            from .facet_contact import FacetContact

            facets = self.sphere_facets()
            ends_z = self.mesh.p[1, self.mesh.facets[:, facets]]
            facets = facets[np.all(ends_z < CONTACT_CANDIDATE_HEIGHT * radius, axis=0)]
            # E / (1 - nu^2): the ball-wall contact modulus (2 E* of the ball-ball pair)
            self.facet_contact = FacetContact.build(self.mesh, basis, facets,
                                                    2.0 * self.material.effective_modulus)

    # --- set-up -----------------------------------------------------------------------------
    def _strain_matrices(self, basis, r: np.ndarray) -> np.ndarray:
        """B (or B-bar) of every local shape function: (12, 4, elements, points)."""
        rows = []
        for phi in basis.basis:
            f = phi[0]
            rows.append(np.stack([f.grad[0, 0], f.grad[1, 1], np.asarray(f)[0] / r,
                                  f.grad[0, 1] + f.grad[1, 0]]))
        B = np.stack(rows)
        if self.bbar:
            vol = B[:, 0] + B[:, 1] + B[:, 2]  # (12, elements, points)
            projected = self._project_volumetric(vol)
            B = B + ((projected - vol) / 3.0)[:, None] * _IDENTITY[None, :, None, None]
        return np.ascontiguousarray(B)

    def _project_volumetric(self, vol: np.ndarray) -> np.ndarray:
        """r-weighted L2 projection of the volumetric strain per element (P0 or P1)."""
        dv = self.dvolume
        if self.volumetric_order == 0:
            mean = np.sum(vol * dv, axis=2) / np.sum(dv, axis=1)
            return np.broadcast_to(mean[:, :, None], vol.shape)
        return np.matmul(self._projection_operator(), vol[..., None])[..., 0]

    def _projection_operator(self) -> np.ndarray:
        """The P1 projection as a matrix per element, (e, q, q): the value at point q of the
        projection of a field given at the points p (psi M^-1 psi^T dv, formed once)."""
        if "projection" not in self._cache:
            dv = self.dvolume
            r, z = self.radius_qp, self.z_qp
            rc = np.sum(r * dv, axis=1, keepdims=True) / np.sum(dv, axis=1, keepdims=True)
            zc = np.sum(z * dv, axis=1, keepdims=True) / np.sum(dv, axis=1, keepdims=True)
            size = np.sqrt(np.abs(np.max(r, axis=1, keepdims=True)
                                  - np.min(r, axis=1, keepdims=True)) ** 2
                           + (np.max(z, axis=1, keepdims=True)
                              - np.min(z, axis=1, keepdims=True)) ** 2)
            psi = np.stack([np.ones_like(r), (r - rc) / size, (z - zc) / size])  # (3, e, q)
            mass = np.einsum("meq,neq,eq->emn", psi, psi, dv)
            weights = np.linalg.solve(mass, np.einsum("meq,eq->emq", psi, dv))  # (e, 3, q)
            self._cache["projection"] = np.einsum("meq,emp->eqp", psi, weights)
        return self._cache["projection"]

    def _pattern(self) -> _Assembly:
        edofs = self.element_dofs
        nloc = edofs.shape[0]
        rows = np.repeat(edofs.T, nloc, axis=1).ravel()  # element-major, (e, j, k)
        cols = np.tile(edofs.T, (1, nloc)).ravel()
        key = rows.astype(np.int64) * self.ndofs + cols
        unique, slot = np.unique(key, return_inverse=True)
        urows = unique // self.ndofs
        indices = (unique % self.ndofs).astype(np.int32)
        indptr = np.zeros(self.ndofs + 1, dtype=np.int64)
        np.add.at(indptr, urows + 1, 1)
        return _Assembly(rows, cols, slot, np.cumsum(indptr), indices)

    def sphere_facets(self) -> np.ndarray:
        """Boundary facets on the spherical surface (both end vertices on the sphere)."""
        radius = self.material.radius
        facets = self.mesh.boundary_facets()
        ends = self.mesh.p[:, self.mesh.facets[:, facets]]  # (2, 2, facets)
        dist = np.hypot(ends[0], ends[1] - radius)
        on = np.all(np.abs(dist - radius) < 1e-7 * radius, axis=0)
        return facets[on & (np.max(ends[0], axis=0) > 0.0)]

    def _tributary_areas(self, cand_points: np.ndarray,
                         displacement: np.ndarray | None = None) -> np.ndarray:
        """Ring area carried by each contact node: integral of its z shape function * 2 pi r
        over the sphere's surface; with ``displacement``, over the surface of the current
        configuration (r = R + u_r, line element |F t| dS with t the reference unit tangent)."""
        from skfem import ElementTriP2, ElementVector, FacetBasis, LinearForm

        facets = self.sphere_facets()
        fb = FacetBasis(self.mesh, ElementTriP2(), facets=facets, intorder=6)

        @LinearForm
        def ring(v, w):
            return TWO_PI * w.x[0] * v

        if displacement is None:
            return ring.assemble(fb)[cand_points]
        vb = FacetBasis(self.mesh, ElementVector(ElementTriP2()), facets=facets, intorder=6)
        u = vb.interpolate(displacement)

        @LinearForm
        def current_ring(v, w):
            t_r, t_z = -w.n[1], w.n[0]  # reference unit tangent
            du = w.u.grad  # (2, 2, ...): du_i/dX_k
            stretch = np.hypot(t_r + du[0, 0] * t_r + du[0, 1] * t_z,
                               t_z + du[1, 0] * t_r + du[1, 1] * t_z)
            return TWO_PI * (w.x[0] + w.u[0]) * stretch * v

        return current_ring.assemble(fb, u=u)[cand_points]

    # --- element kernels --------------------------------------------------------------------
    def strain(self, displacement: np.ndarray) -> np.ndarray:
        return np.einsum("jceq,je->ceq", self.B, displacement[self.element_dofs], optimize=True)

    def internal_force(self, stress: np.ndarray) -> np.ndarray:
        local = np.einsum("jceq,ceq,eq->je", self.B, stress, self.dvolume, optimize=True)
        return np.bincount(self.element_dofs.ravel(), weights=local.ravel(),
                           minlength=self.ndofs)

    def stiffness(self, tangent: np.ndarray | None) -> sp.csr_matrix:
        """Global tangent; ``tangent`` (4, 4, elements, points) or None for elastic."""
        if tangent is None:
            db = np.einsum("cd,kdeq->kceq", self.elastic_matrix, self.B, optimize=True)
        else:
            db = np.einsum("cdeq,kdeq->kceq", tangent, self.B, optimize=True)
        local = np.einsum("jceq,kceq,eq->ejk", self.B, db, self.dvolume, optimize=True)
        a = self._assembly
        data = np.bincount(a.slot, weights=local.ravel(), minlength=len(a.indices))
        return sp.csr_matrix((data, a.indices, a.indptr), shape=(self.ndofs, self.ndofs))

    def element_matrices(self, tangent: np.ndarray | None) -> np.ndarray:
        """Element stiffness matrices (elements, 12, 12): sum over points of B^T D B dV."""
        if tangent is None:
            if "elastic_local" not in self._cache:
                self._cache["elastic_local"] = self.element_matrices(
                    np.broadcast_to(self.elastic_matrix[:, :, None, None],
                                    (4, 4, *self.dvolume.shape)))
            return self._cache["elastic_local"]
        d = np.ascontiguousarray(tangent.transpose(2, 3, 0, 1)) * self.dvolume[:, :, None, None]
        b = self._B_eq  # (e, q, 12, 4)
        return np.einsum("eqjc,eqkc->ejk", b, np.matmul(b, d), optimize=True)

    def _reduced(self, active: np.ndarray) -> _Reduced:
        """Index maps of the bordered system [u_free, w] for one contact set (LRU cache)."""
        key = active.tobytes()
        maps = self._reduced_maps
        if key in maps:
            maps.move_to_end(key)
            return maps[key]
        free_mask = np.ones(self.ndofs, dtype=bool)
        free_mask[self.axis_dofs] = False
        free_mask[self.top_dofs] = False
        free_mask[self.candidate_dofs[active]] = False
        free = np.nonzero(free_mask)[0]
        n = len(free)
        index = np.full(self.ndofs, -1, dtype=np.int64)  # global dof -> reduced unknown
        index[free] = np.arange(n)
        index[self.top_dofs] = n  # u_top = -w
        sign = np.ones(self.ndofs)
        sign[self.top_dofs] = -1.0
        a = self._assembly
        grows = np.repeat(np.arange(self.ndofs), np.diff(a.indptr))
        gcols = a.indices
        rr, rc = index[grows], index[gcols]
        keep = np.nonzero((rr >= 0) & (rc >= 0))[0]
        # CSC of the symmetric bordered matrix: key column-major
        rkey = rc[keep] * (n + 1) + rr[keep]
        unique, slot = np.unique(rkey, return_inverse=True)
        indptr = np.zeros(n + 2, dtype=np.int64)
        np.add.at(indptr, unique // (n + 1) + 1, 1)
        reduced = _Reduced(free=free, n=n, keep=keep, slot=slot,
                           weight=sign[grows[keep]] * sign[gcols[keep]],
                           indices=(unique % (n + 1)).astype(np.int32),
                           indptr=np.cumsum(indptr), nnz=len(unique))
        maps[key] = reduced
        if len(maps) > REDUCED_CACHE:
            maps.popitem(last=False)
        return reduced

    def _bordered_system(self, local: np.ndarray, reduced: _Reduced) -> sp.csc_matrix:
        a = self._assembly
        data = np.bincount(a.slot, weights=local.ravel(), minlength=len(a.indices))
        rdata = np.bincount(reduced.slot, weights=data[reduced.keep] * reduced.weight,
                            minlength=reduced.nnz)
        size = reduced.n + 1
        return sp.csc_matrix((rdata, reduced.indices, reduced.indptr), shape=(size, size))

    def _local_product(self, local: np.ndarray, vector: np.ndarray) -> np.ndarray:
        """K @ vector from the element matrices, without the global matrix."""
        product = np.einsum("ejk,ke->je", local, vector[self.element_dofs], optimize=True)
        return np.bincount(self.element_dofs.ravel(), weights=product.ravel(),
                           minlength=self.ndofs)

    # --- states -----------------------------------------------------------------------------
    def initial_state(self) -> State:
        shape = self.dvolume.shape
        active = np.zeros(len(self.candidate_dofs), dtype=bool)
        active[0] = True  # the tip touches the flat
        return State(
            displacement=np.zeros(self.ndofs), top_displacement=0.0,
            stress=np.zeros((4, *shape)), strain=np.zeros((4, *shape)), eqps=np.zeros(shape),
            status=np.zeros(shape, dtype=np.int8), active=active,
        )

    def _constitutive(self, old: State, strain: np.ndarray, tangent: bool = True):
        trial = old.stress + np.einsum("cd,deq->ceq", self.elastic_matrix, strain - old.strain)
        if not self.plastic:
            return trial, old.eqps, np.zeros_like(old.status), None
        res = return_mapping(self.model, trial, old.eqps, tangent=tangent)
        return res.stress, res.eqps, res.status, res.tangent

    def _response(self, old: State, u: np.ndarray, *, elastic: bool):
        """Stress, strain, eqps, status, internal force and tangent at the displacement ``u``
        (``elastic``: the linear elastic increment from ``old``, tangent None)."""
        strain = self.strain(u)
        if elastic:
            stress = old.stress + np.einsum("cd,deq->ceq", self.elastic_matrix,
                                            strain - old.strain)
            eqps, status, tangent = old.eqps, np.zeros_like(old.status), None
        else:
            stress, eqps, status, tangent = self._constitutive(old, strain)
        return stress, strain, eqps, status, self.internal_force(stress), tangent

    def gaps(self, displacement: np.ndarray) -> np.ndarray:
        return self.candidate_z0 + displacement[self.candidate_dofs]

    def solve_step(self, old: State, force: float, *, label: str = "") -> State:
        """Equilibrium at the target force from the converged state ``old``.

        Two stages: an elastic predictor (linear elastic increment from ``old``, iterating only
        on the contact active set) gives a displacement and contact set close to the solution;
        then Newton with the return mapping and its consistent tangent. Raises
        ConvergenceError (the caller cuts the step back) if Newton does not converge.
        """
        if self.contact == "facet":
            # The elastic predictor only from an open contact: it has no factorisation to reuse
            # (the penalty tangent changes with every iterate), and from a loaded state Newton
            # with the line search needs fewer factorisations without it (measured: 7 per solve).
            u, w = old.displacement.copy(), old.top_displacement
            if old.force == 0.0:
                u, w, _ = self._iterate_facet(old, force, u, w, elastic=True, label=label)
            return self._iterate_facet(old, force, u, w, elastic=not self.plastic, label=label,
                                       final=True)[2]
        u, w, active, _ = self._iterate(old, force, old.displacement.copy(),
                                        old.top_displacement, old.active.copy(), elastic=True,
                                        label=label)
        if not self.plastic:
            u, w, active, result = self._iterate(old, force, u, w, active, elastic=True,
                                                 label=label, final=True)
        else:
            u, w, active, result = self._iterate(old, force, u, w, active, elastic=False,
                                                 label=label, final=True)
        return result

    def _iterate(self, old: State, force: float, u: np.ndarray, w: float, active: np.ndarray,
                 *, elastic: bool, label: str, final: bool = False):
        z0 = self.candidate_z0
        cdofs = self.candidate_dofs
        scale = max(abs(force), 1e-3 * self.force_scale, 1e-30)
        tol = self.tolerance * scale
        top = self.top_dofs
        residual_norm = math.inf
        evaluated = None  # the evaluation at u the backtracking made (``_backtracked_update``)
        for iteration in range(1, self.max_iterations + 1):
            u[top] = -w
            if evaluated is None:
                evaluated = self._response(old, u, elastic=elastic)
            stress, strain, eqps, status, f_int, tangent = evaluated
            evaluated = None
            reaction = f_int[cdofs]  # contact force on each candidate node (>0 compressive)
            gaps = z0 + u[cdofs]
            # Active-set update (primal-dual, complementarity lambda - c g with g = 0 or
            # lambda = 0 on either side): keep compressive contacts, add penetrating nodes.
            new_active = np.where(active, reaction > 0.0, gaps < 0.0)
            if not new_active.any():
                new_active[np.argmin(gaps)] = True  # F >= 0: the lowest node stays touching
            changed = bool(np.any(new_active != active))
            active = new_active

            free_mask = np.ones(self.ndofs, dtype=bool)
            free_mask[self.axis_dofs] = False
            free_mask[top] = False
            free_mask[cdofs[active]] = False
            free = np.nonzero(free_mask)[0]
            r_free = f_int[free]
            r_top = -np.sum(f_int[top]) - force
            prescribed = np.zeros(self.ndofs)
            prescribed[cdofs[active]] = -z0[active] - u[cdofs[active]]
            residual_norm = max(np.max(np.abs(r_free), initial=0.0), abs(r_top))
            if (not changed and residual_norm <= tol and iteration > 1
                    and np.all(prescribed == 0.0)):
                if not final:
                    return u, w, active, None
                return u, w, active, self._finish(old, u, w, stress, strain, eqps, status,
                                                  active, force, iteration)
            if not (np.all(np.isfinite(r_free)) and math.isfinite(r_top)):
                # an element turned inside out (finite strain, J <= 0): no correction can come
                # from this iterate (a NaN right-hand side gives a NaN step), so give up here
                # instead of handing the solver a NaN matrix
                break

            if self.linear_solver == "fast":
                step = self._fast_step(tangent, active, prescribed, r_free, r_top, elastic)
                n = len(free)
                if not np.all(np.isfinite(step)):
                    break
                if self.line_search:
                    u, w = self._searched_update(u, w, step, free, cdofs[active], -z0[active])
                    if u is None:
                        break
                    continue
                if self.backtracking and not elastic and iteration >= BACKTRACK_FROM:
                    u, w, evaluated = self._backtracked_update(
                        old, force, u, w, step, free, cdofs[active], -z0[active], residual_norm)
                    continue
                u[free] += step[:n]
                u[cdofs[active]] = -z0[active]
                w += step[n]
                continue
            K = self.stiffness(tangent)
            # Extended unknowns [u_free, w]: u_top = -w couples the top column.
            k_free = K[free]
            k_ff = k_free[:, free]
            k_ft = -np.asarray(k_free[:, top].sum(axis=1)).ravel()
            k_top = K[top]
            k_tt = float(k_top[:, top].sum())
            k_pre = k_free @ prescribed
            k_tpre = -float(np.sum(k_top @ prescribed))
            n = len(free)
            A = sp.bmat([[k_ff, sp.csr_matrix(k_ft[:, None])],
                         [sp.csr_matrix(k_ft[None, :]), sp.csr_matrix([[k_tt]])]],
                        format="csc")
            rhs = np.concatenate([-r_free - k_pre, [-r_top - k_tpre]])
            self.factorisations += 1
            step = solve_linear(A, rhs)
            if not np.all(np.isfinite(step)):
                break
            if self.line_search:
                u, w = self._searched_update(u, w, step, free, cdofs[active], -z0[active])
                if u is None:
                    break
                continue
            if self.backtracking and not elastic and iteration >= BACKTRACK_FROM:
                u, w, evaluated = self._backtracked_update(
                    old, force, u, w, step, free, cdofs[active], -z0[active], residual_norm)
                continue
            u[free] += step[:n]
            u[cdofs[active]] = -z0[active]
            w += step[n]
        if not final:  # the predictor only has to get close
            return u, w, active, None
        raise ConvergenceError(
            f"{label}Newton did not converge at F = {force:.6g} N in {self.max_iterations} "
            f"iterations (residual {residual_norm:.3g} N, tolerance {tol:.3g} N)"
        )

    def _iterate_facet(self, old: State, force: float, u: np.ndarray, w: float, *,
                       elastic: bool, label: str, final: bool = False):
        """Newton with the segment-based penalty contact (``contact="facet"``): no active set,
        the contact forces and their tangent are part of the residual and of the matrix; every
        candidate dof is free. Returns (u, w, State or None)."""
        contact = self.facet_contact
        scale = max(abs(force), 1e-3 * self.force_scale, 1e-30)
        tol = self.tolerance * scale
        top = self.top_dofs
        reduced = self._reduced(np.zeros(len(self.candidate_dofs), dtype=bool))
        free, n = reduced.free, reduced.n
        residual_norm = math.inf
        self.facet_residuals = []
        for iteration in range(1, self.max_iterations + 1):
            u[top] = -w
            stress, strain, eqps, status, f_int, tangent = self._response(old, u,
                                                                          elastic=elastic)
            if force == 0.0:
                # F = 0: the contact opens; the lowest surface node stays on the flat (as with
                # the node contact), held by a spring that carries no force at equilibrium
                gaps = self.gaps(u)
                lowest = self.candidate_dofs[np.argmin(gaps)]
                f_contact = np.zeros(self.ndofs)
                f_contact[lowest] = -self._touch_stiffness * np.min(gaps)
            else:
                f_contact = contact.forces(u)
            r_free = (f_int - f_contact)[free]
            r_top = -np.sum(f_int[top]) - force
            residual_norm = max(np.max(np.abs(r_free), initial=0.0), abs(r_top))
            self.facet_residuals.append(residual_norm)  # of the last solve (tests)
            if residual_norm <= tol and iteration > 1:
                if not final:
                    return u, w, None
                active = f_contact[self.candidate_dofs] > 0.0
                return u, w, self._finish(old, u, w, stress, strain, eqps, status, active,
                                          force, iteration)
            bulk = self.element_matrices(tangent)
            if force == 0.0:
                local = bulk.copy()
                self._add_touch(local, lowest)
            else:
                local = contact.add_to(bulk, contact.stiffness(u, self._hertz_radius(force)))
            factor = self._factor(local, reduced)
            if factor is None:
                break
            step = factor(np.concatenate([-r_free, [-r_top]]))
            if not np.all(np.isfinite(step)):
                break
            direction = np.zeros(self.ndofs)
            direction[free] = step[:n]
            direction[top] = -step[n]
            reach = self._admissible_length(u, direction)
            if reach is None:
                break
            if reach < 1.0:  # finite strain: the full step would turn an element inside out
                direction *= reach
                step = step * reach
            bulk_force = self._bulk_force_along(old, u, direction, f_int, bulk,
                                                elastic=elastic)
            length = 1.0 if force == 0.0 else self._facet_line_search(
                u, direction, bulk_force, force * step[n],
                float(np.dot(f_int - f_contact, direction)))
            u += length * direction
            w += length * step[n]
        if not final:
            return u, w, None
        raise ConvergenceError(
            f"{label}Newton did not converge at F = {force:.6g} N in {self.max_iterations} "
            f"iterations (residual {residual_norm:.3g} N, tolerance {tol:.3g} N)"
        )

    def _bulk_force_along(self, old: State, u: np.ndarray, direction: np.ndarray,
                          f_int: np.ndarray, bulk: np.ndarray, *, elastic: bool):
        """The internal force at u + a d as a function of a, for the facet line search
        (elastic small strain: linear in a, from the element matrices ``bulk``; else the
        return mapping at every a). ``FiniteStrainSolver`` evaluates its own kinematics."""
        if elastic:
            k_direction = self._local_product(bulk, direction)

            def bulk_force(a):
                return f_int + a * k_direction
            return bulk_force

        def bulk_force(a):
            stress = self._constitutive(old, self.strain(u + a * direction), tangent=False)[0]
            return self.internal_force(stress)
        return bulk_force

    def _admissible_length(self, u: np.ndarray, direction: np.ndarray) -> float | None:
        """The largest of 1, 1/2, 1/4, ... whose step along ``direction`` keeps the iterate
        admissible (small strain: always 1); None after ``LINE_SEARCH_HALVINGS`` halvings."""
        length = 1.0
        for _ in range(LINE_SEARCH_HALVINGS + 1):
            if self.admissible(u + length * direction):
                return length
            length *= 0.5
        return None

    def _hertz_radius(self, force: float) -> float:
        """Hertz contact radius of the hemisphere on the flat at ``force`` (ball-wall)."""
        e_wall = 2.0 * self.material.effective_modulus
        return (0.75 * force * self.material.radius / e_wall) ** (1.0 / 3.0)

    @property
    def _touch_stiffness(self) -> float:
        """Spring that keeps the lowest node on the flat at F = 0 (``contact="facet"``): the
        penalty factor times the hemisphere's stiffness scale E R."""
        from .facet_contact import PENALTY_FACTOR

        return PENALTY_FACTOR * 2.0 * self.material.effective_modulus * self.material.radius

    def _add_touch(self, local: np.ndarray, dof: int) -> None:
        element = int(np.nonzero(np.any(self.element_dofs == dof, axis=0))[0][0])
        position = int(np.nonzero(self.element_dofs[:, element] == dof)[0][0])
        local[element, position, position] += self._touch_stiffness

    def _facet_line_search(self, u: np.ndarray, direction: np.ndarray, bulk_force,
                           load_rate: float, start: float) -> float:
        """Step length along a Newton direction with the penalty contact (``contact="facet"``).

        The increment (elastic, or with the return mapping of associated flow) is the minimum of
        a convex incremental potential, whose slope along the direction d is
        (f_int(u + a d) - f_contact(u + a d)) . d - F dw (``bulk_force(a)``: f_int at u + a d;
        elastic: linear in a, no constitutive evaluation; ``start``: the first term at a = 0).
        The full step is taken unless it
        passes the minimum by more than ``FACET_SEARCH_SLOPE`` of the starting slope, else the
        zero of the slope is found by regula falsi (Illinois). Without it Newton wanders for ~30
        iterations when the contact zone starts far from its size (the first step from an open
        contact), and fails on large plastic steps; near the solution a = 1, so the quadratic
        convergence is kept.
        """
        contact = self.facet_contact

        def slope(a: float) -> float:
            return float(np.dot(bulk_force(a) - contact.forces(u + a * direction),
                                direction)) - load_rate

        low, s_low = 0.0, start - load_rate
        if s_low >= 0.0:  # not a descent direction: the plain Newton step
            return 1.0
        enough = FACET_SEARCH_SLOPE * -s_low
        high, s_high = 1.0, slope(1.0)
        if s_high <= enough:
            return 1.0
        side = 0
        length = 1.0
        for _ in range(FACET_SEARCH_STEPS):
            length = (low * s_high - high * s_low) / (s_high - s_low)
            s = slope(length)
            if abs(s) <= enough:
                break
            if s < 0.0:
                low, s_low = length, s
                if side == -1:
                    s_high *= 0.5
                side = -1
            else:
                high, s_high = length, s
                if side == 1:
                    s_low *= 0.5
                side = 1
        return length

    def admissible(self, displacement: np.ndarray) -> bool:
        """Whether the engine can evaluate the state at ``displacement`` (small strain: always;
        ``FiniteStrainSolver`` checks that no element is turned inside out)."""
        return True

    def _searched_update(self, u: np.ndarray, w: float, step: np.ndarray, free: np.ndarray,
                         contact_dofs: np.ndarray, contact_values: np.ndarray):
        """Rescue mode: the Newton update ``step`` ([du_free, dw], the active contact dofs moved
        to ``contact_values``) scaled by 1, 1/2, 1/4, ... until its iterate is admissible;
        (None, None) after ``LINE_SEARCH_HALVINGS`` halvings."""
        scale = 1.0
        for _ in range(LINE_SEARCH_HALVINGS + 1):
            trial, trial_w = self._trial(u, w, step, free, contact_dofs, contact_values, scale)
            if self.admissible(trial):
                return trial, trial_w
            scale *= 0.5
            self.line_search_halvings += 1
        return None, None

    def _trial(self, u: np.ndarray, w: float, step: np.ndarray, free: np.ndarray,
               contact_dofs: np.ndarray, contact_values: np.ndarray, scale: float):
        """The iterate ``scale`` x the Newton update ``step`` ([du_free, dw]) from (u, w): the
        active contact dofs moved to ``contact_values`` (at scale 1 exactly), the top column
        at -w; a new array."""
        n = len(free)
        trial = u.copy()
        trial[free] += scale * step[:n]
        if scale == 1.0:
            trial[contact_dofs] = contact_values
        else:
            trial[contact_dofs] += scale * (contact_values - trial[contact_dofs])
        trial_w = w + scale * step[n]
        trial[self.top_dofs] = -trial_w
        return trial, trial_w

    def _backtracked_update(self, old: State, force: float, u: np.ndarray, w: float,
                            step: np.ndarray, free: np.ndarray, contact_dofs: np.ndarray,
                            contact_values: np.ndarray, residual: float):
        """Backtracking: the Newton update ``step`` scaled by 1, 1/2, ... (at most
        ``BACKTRACK_HALVINGS`` halvings) until the largest residual of the iterate, on the same
        free dofs and the same load, is below ``residual``, the current one; the last trial
        if none is. Returns (u, w, the evaluation at u: ``_response``'s tuple, the next
        iteration's own). A full update that lowers the residual is the plain Newton iterate
        (``_trial`` at scale 1 is the arithmetic of the plain update)."""
        scale = 1.0
        for halving in range(BACKTRACK_HALVINGS + 1):
            trial, trial_w = self._trial(u, w, step, free, contact_dofs, contact_values, scale)
            response = self._response(old, trial, elastic=False)
            if halving == BACKTRACK_HALVINGS:
                break
            f_int = response[4]
            r_top = -np.sum(f_int[self.top_dofs]) - force
            largest = max(np.max(np.abs(f_int[free]), initial=0.0), abs(r_top))
            if largest < residual:  # NaN (an element inside out) compares False: halved
                break
            scale *= 0.5
            self.backtracked_updates += 1
        return trial, trial_w, response

    def _fast_step(self, tangent, active, prescribed, r_free, r_top, elastic) -> np.ndarray:
        """Newton correction [du_free, dw] on the fast path (see the module docstring)."""
        reduced = self._reduced(active)
        local = self.element_matrices(tangent)
        rhs = np.concatenate([-r_free, [-r_top]])
        if np.any(prescribed != 0.0):
            k_pre = self._local_product(local, prescribed)
            rhs[:-1] -= k_pre[reduced.free]
            rhs[-1] += float(np.sum(k_pre[self.top_dofs]))
        factors = self._elastic_factors
        key = active.tobytes()
        if tangent is None and key in factors:  # the elastic matrix is one per contact set
            factors.move_to_end(key)
            factor = factors[key]
        else:
            factor = self._factor(local, reduced)
            if tangent is None and factor is not None:
                factors[key] = factor
                if len(factors) > ELASTIC_FACTOR_CACHE:
                    factors.popitem(last=False)
        if factor is None:
            return np.full_like(rhs, np.nan)
        return factor(rhs)

    def _factor(self, local: np.ndarray, reduced: _Reduced):
        self.factorisations += 1
        return factorise(self._bordered_system(local, reduced), reduced)

    def _dissipation(self, old: State, u: np.ndarray, stress: np.ndarray,
                     strain: np.ndarray) -> float:
        # Plastic dissipation of the increment, trapezoidal in the stress:
        # 1/2 (sigma_n + sigma_n+1) : d(eps_p) keeps work = elastic energy + dissipation exact
        # for the discrete increments (see docs/fem.md).
        d_plastic = (strain - old.strain) - elastic_strain(self.model, stress - old.stress)
        return float(0.5 * np.sum(np.sum((old.stress + stress) * d_plastic, axis=0)
                                  * self.dvolume))

    def _finish(self, old, u, w, stress, strain, eqps, status, active, force,
                iterations) -> State:
        dissipation = self._dissipation(old, u, stress, strain) if self.plastic else 0.0
        if old.force == 0.0 or force == 0.0:
            # A contact that closes from, or opens to, zero force follows a Hertz-like power
            # law F ~ (w - w0)^(3/2) (virgin loading, reloading from the residual shape, last
            # unloading step): its exact integral replaces the trapezoid, which would be off
            # by 25 % over such a step.
            work = max(old.force, force) * (w - old.top_displacement) / 2.5
        else:
            work = 0.5 * (old.force + force) * (w - old.top_displacement)
        return State(
            displacement=u.copy(), top_displacement=float(w), stress=stress, strain=strain,
            eqps=eqps, status=status, active=active, force=float(force),
            plastic_dissipation=old.plastic_dissipation + float(dissipation),
            work=old.work + float(work), iterations=iterations,
        )

    # --- outputs ----------------------------------------------------------------------------
    def elastic_energy(self, state: State) -> float:
        """Stored energy: the elastic strain energy (with ``contact="facet"`` plus the energy of
        the penalty layer, 1/2 int epsilon g^2 over the contact)."""
        energy = float(np.sum(elastic_energy_density(self.model, state.stress) * self.dvolume))
        if self.contact == "facet":
            energy += self.facet_contact.energy(state.displacement)
        return energy

    def state_internal_force(self, state: State) -> np.ndarray:
        """Nodal internal forces of a converged state."""
        return self.internal_force(state.stress)

    def reaction_force(self, state: State) -> float:
        return float(-np.sum(self.state_internal_force(state)[self.top_dofs]))

    def candidate_radii(self, state: State) -> np.ndarray:
        """Radii of the contact candidate nodes (in the configuration of ``state``)."""
        return self.candidate_r

    def contact_forces(self, state: State) -> np.ndarray:
        if self.contact == "facet":  # at F = 0 open (``_iterate_facet``)
            if state.force == 0.0:
                return np.zeros(len(self.candidate_dofs))
            return self.facet_contact.forces(state.displacement)[self.candidate_dofs]
        f = self.state_internal_force(state)[self.candidate_dofs]
        return np.where(state.active, f, 0.0)

    def contact_pressure(self, state: State) -> tuple[np.ndarray, np.ndarray]:
        """(r, pressure) at the surface nodes: nodal force / tributary ring area (with
        ``contact="facet"`` the same: the penalty pressure at a node, epsilon times a gap of
        ~1e-10 m, carries the displacement's discretisation error and is ~10 % off; the far node
        of the facet the contact edge is in can carry a small negative consistent force)."""
        return self.candidate_r, self._pressure(self.contact_forces(state), self.candidate_area)

    def _pressure(self, force: np.ndarray, area: np.ndarray) -> np.ndarray:
        """Nodal force / ring area; the axis node's ring area is zero (its P2 shape function
        gives int N r ds = 0 on the first edge; round-off leaves ~1e-10 of the largest, which
        made a 700 sigma_c spike), so it takes its neighbour's pressure."""
        axis = self.candidate_r <= 1e-12 * self.material.radius
        pressure = np.divide(force, area, out=np.zeros_like(area), where=~axis & (area > 0.0))
        pressure[axis] = pressure[1]
        return pressure

    def contact_radius(self, state: State) -> float:
        """Radius of the contact circle.

        The outermost touching node bounds it from below, the first open node from above; in
        between the edge is placed where the gap of the next two open nodes, extrapolated with
        the Hertzian edge law g ~ (r - a)^(3/2), vanishes. The same with ``contact="facet"``
        (a node touches when its penalty force does): the zero of the interpolated gap lags the
        edge by up to an element, the gap inside being the small penetration.
        """
        # nodes carrying more than the equilibrium tolerance (at F = 0 none does)
        threshold = 10.0 * self.tolerance * max(state.force, 1e-3 * self.force_scale)
        active = state.active & (self.contact_forces(state) > threshold)
        if not active.any():
            return 0.0
        last = int(np.nonzero(active)[0][-1])
        r = self.candidate_radii(state)
        if last + 2 >= len(r):
            return float(r[last])
        g = self.gaps(state.displacement)
        g1, g2 = g[last + 1], g[last + 2]
        if not (g1 > 0 and g2 > g1):
            return float(r[last])
        k = (g1 / g2) ** (2.0 / 3.0)
        a = (r[last + 1] - k * r[last + 2]) / (1.0 - k)
        return float(np.clip(a, r[last], r[last + 1]))

    def yield_ratio(self, state: State) -> np.ndarray:
        """Drucker-Prager measure at every point (1 on the yield surface)."""
        return yield_ratio(self.model, state.stress, state.eqps)

    def edge_surface_ratio(self, state: State) -> tuple[float, float]:
        """(ratio, a): the Drucker-Prager ratio on the surface at the contact edge r = a
        (``contact_radius``), where the analytic first yield is above the critical friction
        angle (grain.hertz); 0 without contact. Used only to locate first yield.

        The ratio has a cusp there (a square-root fall inside the contact and under the
        surface), which the quadrature points, off the surface, sample below its peak
        (docs/verification/edge_first_yield.md). Outside the contact the surface is traction
        free and its field smooth (Hertz: sigma_rr = -sigma_tt ~ (a / r)^2, Johnson 1985
        §3.4), so the edge value is recovered from outside: on each of the first
        ``EDGE_SURFACE_FACETS`` surface facets beyond a, the surface strains at the facet's two
        Gauss points (where the derivative of the P2 displacement is superconvergent) from the
        displacement of its three nodes, e_ss = t . du/ds, e_tt = u_r / r, give the plane
        stress of a free surface; each component, fitted linearly in (a / r)^2, is taken to
        r = a. From the displacement rather than the quadrature stresses: those carry the
        element-constant volumetric part of B-bar, which is not the surface's.
        """
        a = self.contact_radius(state)
        if a <= 0.0:
            return 0.0, 0.0
        facets = self.sphere_facets()
        ends = self.mesh.facets[:, facets]
        nodes = np.stack([ends[0], facets, ends[1]])  # (vertex, facet, vertex) of each facet
        inner = np.min(self.mesh.p[0, ends], axis=0)
        beyond = np.nonzero(inner >= a)[0]
        beyond = beyond[np.argsort(inner[beyond])][:EDGE_SURFACE_FACETS]
        if len(beyond) < 2:
            return 0.0, a
        r, s_ss, s_tt = self._free_surface_stress(state, nodes[:, beyond])
        x = (a / r) ** 2
        at_edge = [np.polyval(np.polyfit(x, s, 1), 1.0) for s in (s_ss, s_tt)]
        stress = np.array([[at_edge[0]], [0.0], [at_edge[1]], [0.0]])  # (tangent, normal, hoop)
        return float(yield_ratio(self.model, stress, np.zeros(1))[0]), a

    def _free_surface_stress(self, state: State, nodes: np.ndarray):
        """Radius and plane stress (tangent, hoop) of a traction-free surface at the two Gauss
        points of each P2 surface facet, ``nodes`` (3, facets): its first vertex, itself (its
        middle dof), its second vertex."""
        basis, u = self.basis, state.displacement
        dofs = [np.stack([basis.nodal_dofs[c][nodes[0]], basis.facet_dofs[c][nodes[1]],
                          basis.nodal_dofs[c][nodes[2]]]) for c in (0, 1)]
        position = np.stack([basis.doflocs[c, dofs[c]] for c in (0, 1)])  # (2, 3, facets)
        displacement = np.stack([u[dofs[c]] for c in (0, 1)])
        modulus, nu = self.material.youngs_modulus, self.material.poissons_ratio
        radii, tangent, hoop = [], [], []
        for xi in 0.5 + np.array([-0.5, 0.5]) / math.sqrt(3.0):
            n = np.array([(1.0 - xi) * (1.0 - 2.0 * xi), 4.0 * xi * (1.0 - xi),
                          xi * (2.0 * xi - 1.0)])
            dn = np.array([4.0 * xi - 3.0, 4.0 - 8.0 * xi, 4.0 * xi - 1.0])
            dx = np.einsum("n,cnf->cf", dn, position)
            ds = np.hypot(dx[0], dx[1])
            r = n @ position[0]
            e_ss = np.einsum("cf,cf->f", dx / ds, np.einsum("n,cnf->cf", dn, displacement)) / ds
            e_tt = (n @ displacement[0]) / r
            radii.append(r)
            tangent.append(modulus / (1.0 - nu**2) * (e_ss + nu * e_tt))
            hoop.append(modulus / (1.0 - nu**2) * (e_tt + nu * e_ss))
        return np.concatenate(radii), np.concatenate(tangent), np.concatenate(hoop)

    def surface_layer(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """The quadrature points just under the spherical surface and the strip each stands for.

        For every surface facet, the three quadrature points of its element nearest the facet
        (with the 6-point rule about 0.1 of the element height deep, so the layer thins with the
        mesh); each represents the part of the facet between the radii halfway to its
        neighbours. Returns flat arrays (elements, points, r_inner, r_outer).
        """
        key = "surface_layer"
        if key not in self._cache:
            facets = self.sphere_facets()
            ends = self.mesh.p[:, self.mesh.facets[:, facets]]  # (r/z, end, facet)
            elements = self.mesh.f2t[0, facets]
            (r1, r2), (z1, z2) = ends
            qr, qz = self.radius_qp[elements], self.z_qp[elements]
            chord = np.hypot(r2 - r1, z2 - z1)[:, None]
            depth = np.abs((r2 - r1)[:, None] * (z1[:, None] - qz)
                           - (z2 - z1)[:, None] * (r1[:, None] - qr)) / chord
            points = np.argsort(depth, axis=1)[:, :3]
            radii = np.take_along_axis(qr, points, axis=1)
            order = np.argsort(radii, axis=1)
            points = np.take_along_axis(points, order, axis=1)
            radii = np.take_along_axis(radii, order, axis=1)
            bounds = np.stack([np.minimum(r1, r2), 0.5 * (radii[:, 0] + radii[:, 1]),
                               0.5 * (radii[:, 1] + radii[:, 2]), np.maximum(r1, r2)], axis=1)
            self._cache[key] = (np.repeat(elements, 3), points.ravel(),
                                bounds[:, :3].ravel(), bounds[:, 1:].ravel())
        return self._cache[key]

    def yielded_contact_fraction(self, state: State, extent: float = 1.0) -> float:
        """Fraction of the projected area of the disc r < extent * a (a the contact radius)
        whose surface layer (:meth:`surface_layer`) is at yield, i.e. within
        ``YIELD_RATIO_AT_YIELD`` of the yield surface (docs/model.md §4, Fp); 0 without contact.
        """
        a = extent * self.contact_radius(state)
        if a <= 0.0:
            return 0.0
        elements, points, r_inner, r_outer = self.surface_layer()
        area = np.clip(r_outer, 0.0, a) ** 2 - np.clip(r_inner, 0.0, a) ** 2
        at_yield = self.yield_ratio(state)[elements, points] >= YIELD_RATIO_AT_YIELD
        return float(np.sum(area[at_yield]) / a**2)


def solve_linear(matrix: sp.csc_matrix, rhs: np.ndarray) -> np.ndarray:
    """SuperLU with the symmetric-mode minimum-degree ordering on A^T + A.

    Measured on this problem (docs/fem.md): 2-3x faster than COLAMD / MMD_ATA on the default
    and fine meshes. The tangent is symmetric (associated flow, B-bar), so SuperLU's symmetric
    mode (diagonal pivots) applies; a failed or non-finite factor is retried with partial
    pivoting.
    """
    try:
        x = splu(matrix, permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0,
                 options={"SymmetricMode": True}).solve(rhs)
        if np.all(np.isfinite(x)):
            return x
    except RuntimeError:
        pass
    try:
        return splu(matrix, permc_spec="COLAMD").solve(rhs)
    except RuntimeError:
        return np.full_like(rhs, np.nan)


def factorise(matrix: sp.csc_matrix, reduced: _Reduced | None = None):
    """A solve function for the symmetric positive definite bordered system, or None.

    CHOLMOD (scikit-sparse) when installed: simplicial LDL^T with AMD ordering, measured the
    fastest here (docs/benchmarks.md; the supernodal mode leans on BLAS and is slower on these
    2-D systems), its symbolic analysis done once per contact set (``reduced``) and reused by
    every numeric factorisation of that pattern. Without CHOLMOD, if it fails, or if its
    solution is not finite: SuperLU (:func:`_lu`).
    """
    cholmod = _cholmod()
    if cholmod is None:
        return _lu(matrix)
    analyze, errors = cholmod
    try:
        if reduced is None or reduced.symbolic is None:
            symbolic = analyze(matrix, mode="simplicial", ordering_method="amd")
            if reduced is not None:
                reduced.symbolic = symbolic
        else:
            symbolic = reduced.symbolic
        factor = symbolic.cholesky(matrix)
    except errors:  # e.g. a zero pivot: LU below
        return _lu(matrix)

    def solve(rhs: np.ndarray) -> np.ndarray:
        x = factor.solve_A(rhs)
        if np.all(np.isfinite(x)):
            return x
        lu = _lu(matrix)
        return lu(rhs) if lu is not None else x

    return solve


def _lu(matrix: sp.csc_matrix):
    """SuperLU as in :func:`solve_linear` (symmetric mode, then COLAMD with partial pivoting)."""
    for kwargs in ({"permc_spec": "MMD_AT_PLUS_A", "diag_pivot_thresh": 0.0,
                    "options": {"SymmetricMode": True}}, {"permc_spec": "COLAMD"}):
        try:
            lu = splu(matrix, **kwargs)
        except RuntimeError:
            continue
        probe = lu.solve(np.ones(matrix.shape[0]))
        if np.all(np.isfinite(probe)):
            return lu.solve
    return None


def _cholmod():
    """(sksparse.cholmod.analyze, its error class), or None without scikit-sparse."""
    try:
        from sksparse.cholmod import CholmodError, analyze
    except ImportError:
        return None
    return analyze, CholmodError
