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

from ..errors import ConvergenceError
from ..grain.material import Material
from .contact_outputs import TWO_PI, ContactOutputs
from .facet_contact import FacetContact, FacetNewton
from .linear_algebra import LinearSystems, solve_linear
from .linear_algebra import _cholmod as _cholmod
from .linear_algebra import _lu as _lu
from .linear_algebra import _Reduced as _Reduced
from .plasticity import DruckerPrager, elastic_energy_density, elastic_strain, return_mapping
from .state import State

# (The names imported "as" themselves, and State, are what fem.compiled imports from here: its
# code is in its runs' identity, so its imports stay as they are.)
_IDENTITY = np.array([1.0, 1.0, 1.0, 0.0])
CONTACT_CANDIDATE_HEIGHT = 0.3  # surface nodes with z0 < 0.3 R may touch the flat
# Rescue mode: halvings of a Newton update (or of the predictor's increment) whose iterate is not
# admissible before the solve is given up (the caller then cuts the load step back).
LINE_SEARCH_HALVINGS = 12
# Backtracking (newton="backtracking"): halvings of a plastic Newton update that does not lower the
# largest residual, from iteration BACKTRACK_FROM on (the first iterations change the contact set
# and the plastic zone, where a rising residual is Newton's normal path). Two halvings and the
# third iteration: the setting of the point-3 trace (docs/fem.md "Backtracking").
BACKTRACK_HALVINGS = 2
BACKTRACK_FROM = 3

LINEAR_SOLVERS = ("fast", "reference")
CONTACTS = ("node", "facet")  # the flat's contact: node-to-flat (default) | segment-based penalty


@dataclass
class ContactSolver(FacetNewton, ContactOutputs, LinearSystems):
    """Newton / active-set solver of the hemisphere-on-flat problem for one material and mesh.

    Its parts: the set-up, element kernels, node contact's Newton iteration and state updates
    here; the linear systems in ``fem.linear_algebra``, the contact's outputs in
    ``fem.contact_outputs``, the facet contact's Newton iteration in ``fem.facet_contact``."""

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

    def _admissible_length(self, u: np.ndarray, direction: np.ndarray) -> float | None:
        """The largest of 1, 1/2, 1/4, ... whose step along ``direction`` keeps the iterate
        admissible (small strain: always 1); None after ``LINE_SEARCH_HALVINGS`` halvings."""
        length = 1.0
        for _ in range(LINE_SEARCH_HALVINGS + 1):
            if self.admissible(u + length * direction):
                return length
            length *= 0.5
        return None

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
        """Nodal internal forces of a converged state (read-only). Kept for the last state
        asked: the step control's contact radius, the record's outputs and the next load
        step's predictor ask for the same state's several times, and with finite strain each
        is a pass of the kinematics over the mesh."""
        cached = self._cache.get("state_internal_force")
        if cached is not None and cached[0] is state:
            return cached[1]
        force = self._state_internal_force(state)
        force.flags.writeable = False
        self._cache["state_internal_force"] = (state, force)
        return force

    def _state_internal_force(self, state: State) -> np.ndarray:
        return self.internal_force(state.stress)

    def reaction_force(self, state: State) -> float:
        return float(-np.sum(self.state_internal_force(state)[self.top_dofs]))

