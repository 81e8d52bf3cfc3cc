"""The finite-strain FE engine on compiled element kernels and a factorisation that fits its
tangent (issue 36).

:class:`CompiledFiniteStrainSolver` is :class:`~geocontact.fem.finite_strain.FiniteStrainSolver`
with two of its pieces replaced, the equations unchanged:

- the evaluation at a Newton iterate (``_evaluate``: kinematics with F-bar, the Hencky update
  with the Drucker-Prager return mapping and its consistent tangent, internal force, element
  matrices) is one call of ``geocontact.fem._kernels.finite_strain``, C++ written line by line
  after the numpy of ``fem/finite_strain.py`` and ``fem/plasticity.py``, a loop over elements and
  their points with no temporary arrays; it agrees with the numpy path to round-off
  (tests/test_fem_kernels.py);
- the bordered system of a contact set is assembled by ``_kernels.scatter`` straight from the
  element matrices through one precomputed map (element entry -> position in the reduced CSC
  data, with the sign of u_top = -w), and factorised by ``factoriser``: "cholmod" (default:
  CHOLMOD's supernodal LL^T on OpenBLAS, the tangent being symmetric to round-off, with the
  LDL^T of :func:`~geocontact.fem.linear_algebra.factorise` for a matrix that is not positive
  definite;
  a Newton step may instead be solved by CG preconditioned with an earlier factorisation,
  ``reuse_factor``), "cholmod-simplicial" (that LDL^T alone: the compiled path before),
  "umfpack" or "klu" (``geocontact.fem._sparse_lu``, SuiteSparse),
  "pardiso" or "pardiso-sym" (Intel MKL PARDISO's LU or LDL^T through pypardiso, if installed)
  or "superlu" (the numpy path's :func:`~geocontact.fem.linear_algebra._lu`); all but SuperLU keep
  the symbolic analysis of a contact set's pattern and reuse it at every iteration.

Everything else (contact, load control, the predictor with its cached CHOLMOD factorisation,
outputs) is the engine's own. :class:`CompiledSmallStrainSolver` (below) is the small-strain
engine on the same route. They are the node contact's default kernels
(``fem.settings.default_kernels``; ``kernels="numpy"``, ``--kernels numpy`` for the numpy path),
recorded in the run's identity with ``compiled_code``. Their results equal the numpy paths'
within round-off, not bit for bit: the committed datasets rerun on them agree to ~1e-13
(docs/verification/fe-kernels-agreement.json), and a job on them reuses a committed numpy run
under the agreement rule (``fem.identity.AGREED_FE_CODE``, within 1e-10; docs/fem.md, "The
compiled default and the agreement rule").
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from .finite_strain import FiniteStrainSolver
from .solver import ContactSolver, State, _cholmod, _lu, _Reduced

FACTORISERS = ("cholmod", "cholmod-simplicial", "umfpack", "klu", "pardiso", "pardiso-sym",
               "superlu")
# run_history(kernels=...): the numpy path of fem/finite_strain.py and fem/solver.py, or this
# module's (the node contact's default: fem.settings.default_kernels)
KERNELS = ("numpy", "compiled")
# The factoriser of kernels="compiled", the first available: CHOLMOD's supernodal LL^T of the
# symmetric tangent on OpenBLAS (what `make` installs). Measured on the 22 624-unknown tangent
# (docs/benchmarks.md "Newton iteration"): 0.78x its simplicial LDL^T; PARDISO's LDL^T
# (pypardiso, not installed by `make`: ~1 GB of MKL) was ~25 % faster than the simplicial one;
# UMFPACK, KLU and SuperLU 3x slower. Not "whichever is installed", so that a
# run's arithmetic does not depend on an optional package.
PREFERRED_FACTORISERS = ("cholmod", "superlu")
# Reuse of the factorisation (``reuse_factor``): a Newton step is solved by conjugate gradients
# preconditioned with the last factorisation of a tangent of the same contact set (the previous
# iteration's or the previous load step's) when at most STATUS_CHANGES points changed their
# return (elastic, cone, apex) since that tangent, and while that takes at most
# KRYLOV_ITERATIONS iterations; else the tangent is factorised again. A point that changes its
# return changes the tangent by a matrix of rank <= 4 in its element, and CG preconditioned with
# the old factor converges in about as many iterations as the change has rank; measured on the
# weak grain's run (coarse, 699 Krylov solves): 3.8 iterations and no refactorisation with no
# change, 4.5 and 10 % with 1-5, 7.1 and 48 % with 6-20, > 80 % refactorised beyond. One
# iteration costs a product with the matrix and a solve with the factor (~2.5 ms on the 22 624-
# unknown tangent against ~40 ms for a factorisation).
STATUS_CHANGES = 5
KRYLOV_ITERATIONS = 8
# The linear residual each step is solved to (inexact Newton, Eisenstat & Walker 1996): its max
# norm at most ETA_MAX and at most |r| / F (the residual relative to the Newton's force scale,
# which keeps Newton's quadratic convergence) times the Newton residual |r|, and never below
# NEWTON_FRACTION of the Newton tolerance (the step that converges is solved to well within it).
# ETA_MAX = 0.1 let a run's early Newton iterations take another course (one cut-back fewer,
# the answer 1e-5 away); 0.01 keeps the course of the direct solves (1e-10 away).
ETA_MAX = 0.01
NEWTON_FRACTION = 0.1


def kernels():
    """The compiled kernels module (built with the package: CMakeLists.txt)."""
    from . import _kernels

    return _kernels


def sparse_lu():
    """``geocontact.fem._sparse_lu`` (UMFPACK, KLU), or None if it was not built (no
    SuiteSparse at install time)."""
    try:
        from . import _sparse_lu
    except ImportError:
        return None
    return _sparse_lu


def available_factorisers() -> tuple[str, ...]:
    names = ["cholmod", "cholmod-simplicial"] if _cholmod() is not None else []
    if sparse_lu() is not None:
        names += ["umfpack", "klu"]
    try:
        import pypardiso  # noqa: F401

        names += ["pardiso", "pardiso-sym"]
    except ImportError:
        pass
    return (*names, "superlu")


@dataclass
class PointUpdate:
    """The constitutive update at every point, as ``FiniteUpdate`` gives it to the solver."""

    stress: np.ndarray  # (4, e, q) Kirchhoff
    cp: np.ndarray  # (4, e, q) C_p^-1 - I
    eqps: np.ndarray  # (e, q)
    status: np.ndarray  # (e, q) int8
    plastic_strain: np.ndarray  # (4, e, q) eps_e^trial - eps_e, the logarithmic increment


@dataclass
class _Plan:
    """One contact set's bordered system: where each element-matrix entry goes, and its
    factoriser (which keeps the symbolic analysis of the pattern)."""

    reduced: _Reduced
    slot: np.ndarray  # (e * 144,) position in the reduced CSC data, -1: not in the system
    weight: np.ndarray  # (e * 144,) +-1 (u_top = -w)
    factoriser: object = None
    preconditioner: object = None  # the last LDL^T of a tangent of this pattern (a Factor)
    status: np.ndarray | None = None  # the points' returns at that tangent


class _Pardiso:
    """pypardiso's solver for one pattern: analysis (phase 11) once, numeric factorisation
    (phase 22) per matrix, solve (phase 33). PARDISO takes CSR: the CSC data of the system are
    permuted into the CSR order of the same matrix (the permutation found once). ``symmetric``:
    the symmetric indefinite mode (mtype -2, Bunch-Kaufman pivoting) on the upper triangle, half
    the work of the LU (mtype 11) for the finite-strain tangent, symmetric to round-off."""

    def __init__(self, indptr: np.ndarray, indices: np.ndarray, *, symmetric: bool = False):
        import pypardiso

        n = len(indptr) - 1
        order = sp.csc_matrix((np.arange(len(indices), dtype=float), indices, indptr),
                              shape=(n, n)).tocsr()
        order.sort_indices()
        if symmetric:
            order = sp.triu(order, format="csr")
            order.sort_indices()
        self.order = order.data.astype(np.int64)  # CSR entry -> CSC entry
        self.indptr, self.indices = order.indptr, order.indices
        self.solver = pypardiso.PyPardisoSolver(mtype=-2 if symmetric else 11)
        self.matrix = None
        self.analysed = False

    def factor(self, data: np.ndarray) -> bool:
        n = len(self.indptr) - 1
        self.matrix = sp.csr_matrix((data[self.order], self.indices, self.indptr), shape=(n, n))
        dummy = np.zeros(n)
        try:
            if not self.analysed:
                self.solver.set_phase(11)
                self.solver._call_pardiso(self.matrix, dummy)
                self.analysed = True
            self.solver.set_phase(22)
            self.solver._call_pardiso(self.matrix, dummy)
        except Exception:  # pypardiso raises its own error class on a singular matrix
            return False
        return True

    def solve(self, rhs: np.ndarray) -> np.ndarray:
        self.solver.set_phase(33)
        return self.solver._call_pardiso(self.matrix, np.ascontiguousarray(rhs, dtype=float))


class _Cholmod:
    """CHOLMOD (scikit-sparse) for a symmetric matrix of one pattern: the symbolic analysis (AMD
    ordering; supernodes in the supernodal mode) once, a numeric factorisation per matrix.
    ``factor`` keeps the last factorisation for ``solve``; ``factorise`` returns it as a Factor
    of its own (a later ``factor`` does not change it).

    The supernodal mode (the default) is CHOLMOD's LL^T with the dense blocks of the factor done
    by BLAS; with an optimised BLAS under CHOLMOD (OpenBLAS, which the Makefile installs) it is
    the fastest of the modes and orderings on the 22 624-unknown tangent (docs/benchmarks.md
    "Newton iteration"; docs/fem.md "Compiled finite-strain kernels"). A matrix that is not
    positive definite (LL^T fails) gets the simplicial LDL^T of the engine's
    :func:`~geocontact.fem.linear_algebra.factorise`, which takes an indefinite one;
    "simplicial" uses only that."""

    def __init__(self, indptr: np.ndarray, indices: np.ndarray, *, mode: str = "supernodal"):
        self.indptr, self.indices, self.mode = indptr, indices, mode
        self.symbolic, self.indefinite, self.factor_ = None, None, None

    def factorise(self, data: np.ndarray):
        """The factorisation of the matrix with these values (a sksparse Factor), or None if
        CHOLMOD cannot factorise it (a zero pivot)."""
        analyze, errors = _cholmod()
        n = len(self.indptr) - 1
        matrix = sp.csc_matrix((data, self.indices, self.indptr), shape=(n, n))
        try:
            if self.symbolic is None:
                self.symbolic = analyze(matrix, mode=self.mode, ordering_method="amd")
            return self.symbolic.cholesky(matrix)
        except errors:  # not positive definite (LL^T), or a zero pivot (LDL^T)
            if self.mode == "simplicial":
                return None
        try:
            if self.indefinite is None:
                self.indefinite = analyze(matrix, mode="simplicial", ordering_method="amd")
            return self.indefinite.cholesky(matrix)
        except errors:
            return None

    def factor(self, data: np.ndarray) -> bool:
        self.factor_ = self.factorise(data)
        return self.factor_ is not None

    def solve(self, rhs: np.ndarray) -> np.ndarray:
        return self.factor_.solve_A(rhs)


def make_factoriser(name: str, indptr: np.ndarray, indices: np.ndarray):
    """A factoriser object with ``factor(data) -> bool`` and ``solve(rhs)`` for one CSC
    pattern (the symbolic analysis is made at the first ``factor`` and kept)."""
    if name in ("cholmod", "cholmod-simplicial"):
        if _cholmod() is None:
            raise ValueError(f"factoriser {name!r} needs scikit-sparse (make cholmod)")
        return _Cholmod(indptr, indices,
                        mode="simplicial" if name == "cholmod-simplicial" else "supernodal")
    if name in ("umfpack", "klu"):
        module = sparse_lu()
        if module is None:
            raise ValueError(f"factoriser {name!r} needs geocontact.fem._sparse_lu (SuiteSparse "
                             "at install time: make .venv/.installed)")
        kind = module.Umfpack if name == "umfpack" else module.Klu
        return kind(np.asarray(indptr, dtype=np.int64), np.asarray(indices, dtype=np.int64))
    if name == "pardiso":
        return _Pardiso(indptr, indices)
    if name == "pardiso-sym":
        return _Pardiso(indptr, indices, symmetric=True)
    raise ValueError(f"factoriser must be one of {', '.join(FACTORISERS)}, got {name!r}")


class CompiledFiniteStrainSolver(FiniteStrainSolver):
    """The finite-strain solver on the compiled kernels (the module docstring). ``factoriser``
    is set after construction (``solver.factoriser = "klu"``) or by :func:`compiled_solver`."""

    factoriser: str = "cholmod"
    # CHOLMOD: Krylov solves preconditioned with the last factorisation. Off by default: its
    # inexact solves move a finite-strain run by more than round-off (a cycle's loop work by
    # 5.4e-7 on weak-finite-coarse bcc780a, docs/fem.md "The agreement rule"), so a run with it
    # does not reproduce the direct solves' committed runs, for 2-7 % of a run's time
    reuse_factor: bool = False

    def __post_init__(self) -> None:
        super().__post_init__()
        self.krylov_solves = 0  # Newton steps solved by preconditioned CG (reuse_factor)
        self.krylov_iterations = 0  # their CG iterations, in all
        self.krylov_refactorisations = 0  # of them, those that needed a new factorisation
        self._newton_tolerance = self.tolerance * self.force_scale
        self._status = None  # the points' returns at the last tangent evaluated
        self._grad0 = np.ascontiguousarray(self.G0.transpose(2, 3, 1, 0))  # (e, q, 5, 12)
        self._dofs = np.ascontiguousarray(self.element_dofs.T, dtype=np.int64)  # (e, 12)
        self._projection = self._projection_matrices()
        self._plans: dict[int, _Plan] = {}

    def _projection_matrices(self) -> np.ndarray:
        """The B-bar / F-bar projection of a point field as a matrix per element (e, q, q):
        the P1 operator, the r-weighted mean (P0) or the identity (no projection)."""
        dv = self.dvolume
        e, q = dv.shape
        if not self.bbar:
            return np.ascontiguousarray(np.broadcast_to(np.eye(q), (e, q, q)))
        if self.volumetric_order == 0:
            weights = dv / np.sum(dv, axis=1, keepdims=True)
            return np.ascontiguousarray(np.broadcast_to(weights[:, None, :], (e, q, q)))
        return np.ascontiguousarray(self._projection_operator())

    # --- the evaluation at an iterate -----------------------------------------------------
    def _evaluate(self, old: State, u: np.ndarray, *, elastic: bool, tangent: bool = True):
        e, q = self.dvolume.shape
        update = PointUpdate(stress=np.empty((4, e, q)), cp=np.empty((4, e, q)),
                             eqps=np.empty((e, q)), status=np.empty((e, q), dtype=np.int8),
                             plastic_strain=np.empty((4, e, q)))
        f_int = np.empty(self.ndofs)
        local = np.empty((e, 12, 12) if tangent else (0, 12, 12))
        m = self.model
        kernels().finite_strain(
            self._grad0, self._dofs, np.ascontiguousarray(u, dtype=float), self._projection,
            self.dvolume, np.ascontiguousarray(old.strain), np.ascontiguousarray(old.eqps),
            m.shear_modulus, m.bulk_modulus, m.tan_beta, m.yield_stress, m.hardening_modulus,
            self.plastic and not elastic, update.stress, update.cp, update.eqps, update.status,
            update.plastic_strain, f_int, local)
        if tangent:
            self._status = update.status  # the returns of this tangent (reuse_factor)
        return update, f_int, (local if tangent else None)

    def _dissipation(self, old: State, u: np.ndarray, stress: np.ndarray,
                     strain: np.ndarray) -> float:
        update = self._evaluate(old, u, elastic=False, tangent=False)[0]
        return 0.5 * float(np.sum(np.sum((old.stress + stress) * update.plastic_strain, axis=0)
                                  * self.dvolume))

    # --- the linear system ----------------------------------------------------------------
    def _plan(self, reduced: _Reduced) -> _Plan:
        """The element-entry map of a contact set's bordered system (made once per set)."""
        plan = self._plans.get(id(reduced))
        if plan is not None and plan.reduced is reduced:
            return plan
        a = self._assembly
        where = np.full(len(a.indices), -1, dtype=np.int64)  # global CSR entry -> kept entry
        where[reduced.keep] = np.arange(len(reduced.keep))
        kept = where[a.slot]
        inside = kept >= 0
        slot = np.where(inside, reduced.slot[np.where(inside, kept, 0)], -1).astype(np.int64)
        weight = np.where(inside, reduced.weight[np.where(inside, kept, 0)], 0.0)
        plan = _Plan(reduced=reduced, slot=slot, weight=weight)
        live = {id(r) for r in self._reduced_maps.values()}
        self._plans = {k: p for k, p in self._plans.items() if k in live}
        self._plans[id(reduced)] = plan
        return plan

    def _bordered_data(self, local: np.ndarray, plan: _Plan) -> np.ndarray:
        data = np.empty(plan.reduced.nnz)
        kernels().scatter(local.reshape(-1), plan.slot, plan.weight, data)
        return data

    def _bordered_system(self, local: np.ndarray, reduced: _Reduced) -> sp.csc_matrix:
        data = self._bordered_data(local, self._plan(reduced))
        size = reduced.n + 1
        return sp.csc_matrix((data, reduced.indices, reduced.indptr), shape=(size, size))

    def _iterate(self, old, force, u, w, active, **kwargs):
        # the Newton tolerance in force units, as ContactSolver._iterate sets it, for the
        # inexact solves of reuse_factor
        self._newton_tolerance = self.tolerance * max(abs(force), 1e-3 * self.force_scale,
                                                      1e-30)
        return super()._iterate(old, force, u, w, active, **kwargs)

    def _factor(self, local, reduced):
        elastic = local is self._cache.get("elastic_local")
        if self.factoriser == "superlu" or (elastic and not self.factoriser.startswith("cholmod")):
            return super()._factor(local, reduced)  # the engine's CHOLMOD, or SuperLU
        plan = self._plan(reduced)
        if plan.factoriser is None:
            plan.factoriser = make_factoriser(self.factoriser, reduced.indptr, reduced.indices)
        data = self._bordered_data(local, plan)
        if not np.all(np.isfinite(data)):  # not finite: SuperLU's verdict, as before
            self.factorisations += 1
            return _lu(self._csc(data, reduced))
        if not isinstance(plan.factoriser, _Cholmod):
            self.factorisations += 1
            if not plan.factoriser.factor(data):  # singular: SuperLU's verdict, as before
                return _lu(self._csc(data, reduced))
            return plan.factoriser.solve
        if not elastic and self._reusable(plan):
            return lambda rhs: self._krylov_solve(plan, data, rhs)
        return self._ldlt(plan, data, keep=not elastic)

    @staticmethod
    def _csc(data: np.ndarray, reduced: _Reduced) -> sp.csc_matrix:
        size = reduced.n + 1
        return sp.csc_matrix((data, reduced.indices, reduced.indptr), shape=(size, size))

    def _ldlt(self, plan: _Plan, data: np.ndarray, *, keep: bool):
        """The solve function of CHOLMOD's LDL^T of the matrix (``keep``: it becomes the
        contact set's preconditioner); as :func:`~geocontact.fem.linear_algebra.factorise`,
        SuperLU if CHOLMOD fails or its solution is not finite."""
        self.factorisations += 1
        factor = plan.factoriser.factorise(data)
        if factor is None:  # e.g. a zero pivot
            return _lu(self._csc(data, plan.reduced))
        if keep:
            plan.preconditioner, plan.status = factor, self._status

        def solve(rhs: np.ndarray) -> np.ndarray:
            x = factor.solve_A(rhs)
            if np.all(np.isfinite(x)):
                return x
            lu = _lu(self._csc(data, plan.reduced))
            return lu(rhs) if lu is not None else x

        return solve

    def _reusable(self, plan: _Plan) -> bool:
        """Whether the contact set's last factorisation preconditions this tangent well: at
        most STATUS_CHANGES points changed their return since (``STATUS_CHANGES``)."""
        return (self.reuse_factor and plan.preconditioner is not None
                and plan.status is not None and self._status is not None
                and np.count_nonzero(self._status != plan.status) <= STATUS_CHANGES)

    def _krylov_solve(self, plan: _Plan, data: np.ndarray, rhs: np.ndarray) -> np.ndarray:
        """The Newton step by conjugate gradients preconditioned with the contact set's last
        factorisation, to the inexact-Newton target (ETA_MAX, NEWTON_FRACTION); if that takes
        more than KRYLOV_ITERATIONS iterations (or breaks down), the matrix is factorised and
        the step solved directly, as without reuse."""
        r = float(np.max(np.abs(rhs)))
        tolerance = self._newton_tolerance
        scale = tolerance / self.tolerance  # the Newton's force scale
        target = max(NEWTON_FRACTION * tolerance, min(ETA_MAX, r / scale) * r)
        self.krylov_solves += 1
        x, iterations = preconditioned_cg(self._csc(data, plan.reduced), rhs,
                                          plan.preconditioner.solve_A, target, KRYLOV_ITERATIONS)
        self.krylov_iterations += iterations
        if x is not None:
            return x
        self.krylov_refactorisations += 1
        return self._ldlt(plan, data, keep=True)(rhs)


def preconditioned_cg(matrix, rhs: np.ndarray, precondition, target: float,
                      max_iterations: int) -> tuple[np.ndarray | None, int]:
    """Conjugate gradients on ``matrix @ x = rhs`` (symmetric) preconditioned with
    ``precondition`` (x ~ matrix^-1 r, symmetric positive definite), from x = 0, until the max
    norm of the residual is at most ``target`` (Saad 2003, Algorithm 9.1; the residual updated
    by the recurrence). (x, iterations), x None if not reached within ``max_iterations`` or if
    the iteration breaks down (a direction of non-positive curvature: an indefinite matrix or
    preconditioner)."""
    x = np.zeros_like(rhs)
    r = rhs.copy()
    z = precondition(r)
    p = z.copy()
    rz = float(r @ z)
    for iteration in range(1, max_iterations + 1):
        ap = matrix @ p
        curvature = float(p @ ap)
        if not (rz > 0.0 and curvature > 0.0):
            return None, iteration
        alpha = rz / curvature
        x += alpha * p
        r -= alpha * ap
        if np.max(np.abs(r)) <= target:
            return x, iteration
        z = precondition(r)
        rz, previous = float(r @ z), rz
        p = z + (rz / previous) * p
    return None, max_iterations


def default_factoriser() -> str:
    available = available_factorisers()
    return next(name for name in PREFERRED_FACTORISERS if name in available)


def compiled_solver(material, mesh, *, factoriser: str | None = None,
                    **kwargs) -> CompiledFiniteStrainSolver:
    """A :class:`CompiledFiniteStrainSolver` with ``factoriser`` (one of ``FACTORISERS``;
    default: :func:`default_factoriser`)."""
    if factoriser is None:
        factoriser = default_factoriser()
    if factoriser not in FACTORISERS:
        raise ValueError(f"factoriser must be one of {', '.join(FACTORISERS)}, "
                         f"got {factoriser!r}")
    solver = CompiledFiniteStrainSolver(material, mesh, **kwargs)
    solver.factoriser = factoriser
    return solver


class CompiledSmallStrainSolver(ContactSolver):
    """The small-strain engine (:class:`~geocontact.fem.solver.ContactSolver`, node contact) with
    its evaluation at a Newton iterate compiled: strains with the engine's B-bar strain matrices,
    the trial stress, the Drucker-Prager return mapping with its consistent tangent, the internal
    force and the element matrices are one call of ``_kernels.small_strain`` (a loop over
    elements and points, no temporary arrays; equal to ``ContactSolver._response`` and
    ``element_matrices`` to round-off, tests/test_fem_kernels.py). The bordered system is
    assembled by ``_kernels.scatter`` through the map of :class:`CompiledFiniteStrainSolver` and
    factorised as the engine does (CHOLMOD's LDL^T, symbolic analysis per contact set; the
    tangent is symmetric). The elastic predictor is the engine's own (its element matrices and
    factorisations cached per contact set), so only the plastic iterations change."""

    # the reduced system straight from the element matrices (the finite-strain solver's map)
    _plan = CompiledFiniteStrainSolver._plan
    _bordered_data = CompiledFiniteStrainSolver._bordered_data
    _bordered_system = CompiledFiniteStrainSolver._bordered_system

    def __post_init__(self) -> None:
        super().__post_init__()
        if self.contact != "node":
            raise ValueError("the compiled small-strain kernels solve the node contact, "
                             f"got contact {self.contact!r}")
        self._strain_rows = np.ascontiguousarray(self.B.transpose(2, 3, 1, 0))  # (e, q, 4, 12)
        self._dofs = np.ascontiguousarray(self.element_dofs.T, dtype=np.int64)  # (e, 12)
        self._plans: dict[int, _Plan] = {}

    def _evaluate(self, old: State, u: np.ndarray, *, plastic: bool, tangent: bool):
        """(stress, strain, eqps, status, internal force, element matrices or None) at ``u``:
        with ``plastic`` the return mapping, else the elastic trial state."""
        e, q = self.dvolume.shape
        stress, strain = np.empty((4, e, q)), np.empty((4, e, q))
        eqps, status = np.empty((e, q)), np.empty((e, q), dtype=np.int8)
        f_int = np.empty(self.ndofs)
        local = np.empty((e, 12, 12) if tangent else (0, 12, 12))
        m = self.model
        kernels().small_strain(
            self._strain_rows, self._dofs, np.ascontiguousarray(u, dtype=float), self.dvolume,
            np.ascontiguousarray(old.stress), np.ascontiguousarray(old.strain),
            np.ascontiguousarray(old.eqps), m.shear_modulus, m.bulk_modulus, m.tan_beta,
            m.yield_stress, m.hardening_modulus, plastic, stress, strain, eqps, status, f_int,
            local)
        return stress, strain, eqps, status, f_int, (local if tangent else None)

    def _response(self, old: State, u: np.ndarray, *, elastic: bool):
        # elastic (the predictor) or an elastic material: no tangent, the engine's cached
        # elastic element matrices and factorisations (ContactSolver._fast_step)
        plastic = self.plastic and not elastic
        return self._evaluate(old, u, plastic=plastic, tangent=plastic)

    def element_matrices(self, tangent):
        if tangent is None or tangent.ndim == 4:  # the elastic matrices, or a (4, 4, e, q) D
            return super().element_matrices(tangent)
        return tangent  # (elements, 12, 12): _evaluate assembled them

    def stiffness(self, tangent):
        if tangent is None or tangent.ndim == 4:
            return super().stiffness(tangent)
        a = self._assembly
        data = np.bincount(a.slot, weights=tangent.ravel(), minlength=len(a.indices))
        return sp.csr_matrix((data, a.indices, a.indptr), shape=(self.ndofs, self.ndofs))
