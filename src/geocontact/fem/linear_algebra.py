"""The linear systems of :class:`~geocontact.fem.solver.ContactSolver`: the fixed sparsity pattern
of the global stiffness, the reduced bordered system [u_free, w] of one contact set (index maps
cached per contact set), the Newton correction on the fast path, and the factorisers (CHOLMOD
with its symbolic analysis reused, SuperLU as the fallback and on the reference path).

``LinearSystems`` is the part of the solver that assembles and solves; it reads the solver's
mesh data (``element_dofs``, ``ndofs``, ``axis_dofs``, ``top_dofs``, ``candidate_dofs``) and
its element matrices (``element_matrices``). The subclasses of the solver override
``_bordered_system`` and ``_factor`` (fem.compiled, fem.finite_strain) and ``_fast_step``
(fem.two_spheres).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import splu

REDUCED_CACHE = 8  # contact sets whose index maps are kept
ELASTIC_FACTOR_CACHE = 4  # contact sets whose elastic factorisation is kept


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


class LinearSystems:
    """Assembly and solution of the bordered Newton system (mixed into ``ContactSolver``)."""

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
