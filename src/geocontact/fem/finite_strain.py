"""Finite-strain option of the FE engine (``run_history(kinematics="finite")``; issue 15).

Multiplicative elastoplasticity with logarithmic (Hencky) elastic strain and the exponential map
(Eterovic & Bathe 1990; Simo 1992; de Souza Neto, Peric & Owen 2008, ch. 14): with the inverse
plastic right Cauchy-Green tensor ``C_p^-1`` of the last converged state, the elastic trial left
Cauchy-Green tensor is ``b_e^trial = F C_p^-1 F^T``, its logarithmic strain
``eps_e^trial = ln(b_e^trial) / 2`` gives the trial Kirchhoff stress ``tau = D : eps_e^trial``
(``D`` the linear isotropic elasticity of the small-strain engine), and the Drucker-Prager return
mapping of :mod:`geocontact.fem.plasticity` (cone and apex, unchanged) returns it in Kirchhoff
stress; the exponential map then gives ``b_e = exp(2 eps_e)`` and ``C_p^-1 = F^-1 b_e F^-T``.
At small strain this is the small-strain engine exactly (eps_e^trial -> eps - eps_p).

Kinematics, axisymmetric: ``F`` is block diagonal, the in-plane 2x2 ``dx/dX`` of (r, z) and the
hoop stretch ``1 + u_r / R``. Gradients are written as 5-vectors
``[rr, zz, tt, rz, zr]`` (``rz`` = d/dz of the r component). The weak form is the spatial one
pulled back to the reference volume dV0 = 2 pi R dA0::

    f_j = integral tau : g_bar_j dV0,      g_j = Grad N_j F^-1 (hoop N_j / r, r = R + u_r)

F-bar, the finite-strain analogue of the engine's B-bar (de Souza Neto et al. 2008, ch. 15):
``F_bar = (J_bar / J)^(1/3) F`` with ``ln J_bar`` the r-weighted L2 projection of ``ln J`` per
element onto the same space as the small-strain B-bar (linear, ``bbar-p1``, or constant); this
is variational (``F_bar`` of a stored-energy function), so the test gradient ``g_bar`` gets the
same projection of its trace, and the formulation reduces to the small-strain B-bar one as
F -> I.

The consistent tangent is derived in closed form (:func:`material_tangent`, the
linearisation of the return mapping through the logarithm of ``b_e^trial``, plus the geometric
term of the spatial form and of the projection) and checked against finite differences of the
internal force in ``tests/test_fem_finite_strain.py``; it is not symmetric in general, so the
linear systems are factorised with LU (SuperLU).

Contact: the flat is rigid, z = 0, and the contact is the engine's exact node-to-flat constraint;
a node's gap z0 + u_z is its current height, so the constraint is already the one of the current
configuration (frictionless: the node slides freely in r). The contact radius is measured on the
current configuration (r = R + u_r of the surface nodes). With ``contact="facet"`` the facet
contact of :mod:`geocontact.fem.facet_contact` acts unchanged: its gap z0 + u_z is the current
height of a surface point, and its penalty pressure is a nominal one (per reference area), the
first variation of the penalty energy 1/2 int epsilon <-g>^2 dA0 over the reference surface, so
the contact stays variational and its tangent the same; as epsilon grows it converges to the
same constraint as the node contact.

Outputs: ``State.stress`` is the Kirchhoff stress (its yield ratio and elastic energy
psi = tau : D^-1 : tau / 2 per reference volume are those of the Hencky model);
``State.strain`` holds ``C_p^-1 - I`` as ``[rr, zz, tt, rz]`` (zero in the virgin state).
Plastic dissipation per step: sum of (tau_n + tau_n+1) / 2 : (eps_e^trial - eps_e) dV0 (the
logarithmic plastic strain increment of the exponential map).
"""

from __future__ import annotations

import numpy as np

from .linear_algebra import _lu
from .plasticity import DruckerPrager, elastic_strain, return_mapping
from .solver import LINE_SEARCH_HALVINGS, ContactSolver
from .state import State

# 5-vector gradient components and their place in the 2x2 in-plane block
RR, ZZ, TT, RZ, ZR = range(5)
_IN_PLANE = ((RR, RZ), (ZR, ZZ))  # _IN_PLANE[i][k]: component of d(.)_i / dx_k
# tau : g (symmetric tau as [rr, zz, tt, rz]) as a 4x5 matrix: g_rz and g_zr both meet tau_rz
SYM = np.array([[1.0, 0, 0, 0, 0], [0, 1.0, 0, 0, 0], [0, 0, 1.0, 0, 0], [0, 0, 0, 1.0, 1.0]])


def block(v: np.ndarray) -> np.ndarray:
    """5-vectors (5, ...) -> in-plane 2x2 blocks (..., 2, 2)."""
    m = np.empty(v.shape[1:] + (2, 2))
    for i in range(2):
        for k in range(2):
            m[..., i, k] = v[_IN_PLANE[i][k]]
    return m


def unblock(m: np.ndarray, hoop: np.ndarray) -> np.ndarray:
    """In-plane blocks (..., 2, 2) and hoop (...) -> 5-vectors (5, ...)."""
    v = np.empty((5,) + hoop.shape)
    for i in range(2):
        for k in range(2):
            v[_IN_PLANE[i][k]] = m[..., i, k]
    v[TT] = hoop
    return v


def sym_block(t: np.ndarray) -> np.ndarray:
    """Symmetric tensors [rr, zz, tt, rz] (4, ...) -> in-plane blocks (..., 2, 2)."""
    m = np.empty(t.shape[1:] + (2, 2))
    m[..., 0, 0], m[..., 1, 1] = t[0], t[1]
    m[..., 0, 1] = m[..., 1, 0] = t[3]
    return m


def sym_unblock(m: np.ndarray, hoop: np.ndarray) -> np.ndarray:
    return np.stack([m[..., 0, 0], m[..., 1, 1], hoop, 0.5 * (m[..., 0, 1] + m[..., 1, 0])])


def _eig(m: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Eigenvalues (ascending, (..., 2)) and eigenvectors (columns, (..., 2, 2)) of symmetric
    2x2 blocks, in closed form (as numpy.linalg.eigh, without its per-matrix overhead)."""
    a, d = m[..., 0, 0], m[..., 1, 1]
    c = 0.5 * (m[..., 0, 1] + m[..., 1, 0])
    half = 0.5 * (a - d)
    radius, mean = np.hypot(half, c), 0.5 * (a + d)
    theta = 0.5 * np.arctan2(c, half)  # direction of the larger eigenvalue
    cos, sin = np.cos(theta), np.sin(theta)
    lam = np.stack([mean - radius, mean + radius], axis=-1)
    vec = np.empty(m.shape)
    vec[..., 0, 0], vec[..., 1, 0] = -sin, cos
    vec[..., 0, 1], vec[..., 1, 1] = cos, sin
    return lam, vec


def _inverse(m: np.ndarray) -> np.ndarray:
    """Inverse of 2x2 blocks (..., 2, 2) in closed form."""
    det = m[..., 0, 0] * m[..., 1, 1] - m[..., 0, 1] * m[..., 1, 0]
    inv = np.empty(m.shape)
    inv[..., 0, 0], inv[..., 1, 1] = m[..., 1, 1] / det, m[..., 0, 0] / det
    inv[..., 0, 1], inv[..., 1, 0] = -m[..., 0, 1] / det, -m[..., 1, 0] / det
    return inv


def _element_products(left: np.ndarray, a: np.ndarray, right: np.ndarray,
                      dv: np.ndarray) -> np.ndarray:
    """Element matrices sum_q left_j . (a dv) right_k, (e, 12, 12), of test gradients
    (12, 5, e, q) and a point tangent (5, 5, e, q): one batched product per element."""
    n, comps, e, q = left.shape
    weighted = np.moveaxis(a * dv, (2, 3), (0, 1))  # (e, q, 5, 5)
    lt = np.moveaxis(left, (2, 3), (0, 1))  # (e, q, 12, 5)
    y = np.matmul(lt, weighted)  # (e, q, 12, 5)
    y = np.ascontiguousarray(y.transpose(0, 2, 1, 3)).reshape(e, n, q * comps)
    rt = np.ascontiguousarray(right.transpose(2, 3, 1, 0)).reshape(e, q * comps, n)
    return np.matmul(y, rt)


def _log_derivative_weights(lam: np.ndarray) -> np.ndarray:
    """f_ab of d ln(b) = V (f o (V^T db V)) V^T: 1/lambda_a on the diagonal,
    (ln lambda_a - ln lambda_b) / (lambda_a - lambda_b) off it (its limit when they meet)."""
    l1, l2 = lam[..., 0], lam[..., 1]
    diff = l1 - l2
    close = np.abs(diff) < 1e-8 * np.abs(l1)
    mean = 0.5 * (l1 + l2)
    with np.errstate(divide="ignore", invalid="ignore"):
        off = np.where(close, 1.0 / mean, (np.log(l1) - np.log(l2)) / np.where(close, 1.0, diff))
    f = np.empty(lam.shape[:-1] + (2, 2))
    f[..., 0, 0], f[..., 1, 1] = 1.0 / l1, 1.0 / l2
    f[..., 0, 1] = f[..., 1, 0] = off
    return f


def _matrix_function(m: np.ndarray, fn) -> np.ndarray:
    lam, vec = _eig(m)
    return np.einsum("...ia,...a,...ja->...ij", vec, fn(lam), vec)


class FiniteUpdate:
    """The constitutive update at every point for displacement gradients ``H = F - I``
    (5, ...) with the plastic metric ``cp = C_p^-1 - I`` (4, ...) and eqps of the last converged
    state.

    Everything is carried as a difference from the identity (``b - I`` by ``log1p`` of its
    eigenvalues, ``C_p^-1 - I`` from ``expm1``), so that the stress of a small strain is as
    exact as the small-strain engine's: formed from F and ln(b) directly, the stress would carry
    a round-off of E x 1e-16 whatever the load, a residual floor far above the Newton tolerance
    at small forces."""

    def __init__(self, model: DruckerPrager, H: np.ndarray, cp: np.ndarray,
                 eqps_old: np.ndarray, *, plastic: bool = True, tangent: bool = True):
        hm, ht = block(H), H[TT]
        gm, gt = sym_block(cp), cp[2]
        eye = np.eye(2)
        # b - I = (G - I) + H G + G H^T + H G H^T, G = I + cp
        g_full = eye + gm
        hg = hm @ g_full
        b_minus = gm + hg + np.swapaxes(hg, -1, -2) + hg @ np.swapaxes(hm, -1, -2)
        bt_minus = gt + ht * (2.0 + ht) * (1.0 + gt)
        mu, vec = _eig(b_minus)
        self.b, self.bt, self.lam, self.vec = eye + b_minus, 1.0 + bt_minus, 1.0 + mu, vec
        eps = np.einsum("...ia,...a,...ja->...ij", vec, 0.5 * np.log1p(mu), vec)
        trial_strain = sym_unblock(eps, 0.5 * np.log1p(bt_minus))
        trial_strain[3] *= 2.0  # engineering shear
        self.trial_strain = trial_strain
        d_el = model.elastic_matrix()
        trial = np.einsum("cd,d...->c...", d_el, trial_strain)
        if plastic:
            res = return_mapping(model, trial, eqps_old, tangent=tangent)
            self.stress, self.eqps, self.status = res.stress, res.eqps, res.status
            d_ep = res.tangent
        else:
            self.stress, self.eqps = trial, np.asarray(eqps_old)
            self.status = np.zeros(trial.shape[1:], dtype=np.int8)
            d_ep = np.broadcast_to(d_el.reshape((4, 4) + (1,) * (trial.ndim - 1)),
                                   (4, 4) + trial.shape[1:]) if tangent else None
        self.elastic_strain = elastic_strain(model, self.stress)
        self.d_ep = d_ep
        # exponential map: b_e = exp(2 eps_e), C_p^-1 = F^-1 b_e F^-T; with K = F^-1 - I:
        # C_p^-1 - I = K + K^T + K K^T + F^-1 (b_e - I) F^-T
        e = sym_block(self.elastic_strain * np.array([1.0, 1.0, 1.0, 0.5]).reshape(
            (4,) + (1,) * (trial.ndim - 1)))
        be_minus = _matrix_function(e, lambda x: np.expm1(2.0 * x))
        finv = _inverse(eye + hm)
        k = -hm @ finv
        cp_new = (k + np.swapaxes(k, -1, -2) + k @ np.swapaxes(k, -1, -2)
                  + finv @ be_minus @ np.swapaxes(finv, -1, -2))
        # hoop: exp(2 e_tt) / F_tt^2 - 1
        cp_t = np.expm1(2.0 * self.elastic_strain[2] - 2.0 * np.log1p(ht))
        self.cp = sym_unblock(cp_new, cp_t)

    def material_tangent(self) -> np.ndarray:
        """d tau / d h (4, 5, ...): the change of the Kirchhoff stress [rr, zz, tt, rz] with the
        spatial velocity gradient h = dF F^-1 (a 5-vector), through
        d b_e^trial = h b + b h^T, d eps^trial = d ln(b) / 2 and the return mapping's D^ep.

        In the eigenbasis V of b (eigenvalues lambda), an in-plane unit h = e_i (x) e_m gives
        V^T db V = v_i (x) w + w (x) v_i with v_i = V^T e_i (row i of V) and w_a = lambda_a V_ma;
        then d eps = V (f o (V^T db V)) V^T / 2 with the weights f of ln."""
        lam, vec = self.lam, self.vec
        f = _log_derivative_weights(lam)
        shape = self.bt.shape
        d_strain = np.zeros((4, 5) + shape)
        for i in range(2):
            for m in range(2):
                k = _IN_PLANE[i][m]
                v = [vec[..., i, 0], vec[..., i, 1]]
                w = [lam[..., 0] * vec[..., m, 0], lam[..., 1] * vec[..., m, 1]]
                rot = [[f[..., a, b] * (v[a] * w[b] + w[a] * v[b]) for b in range(2)]
                       for a in range(2)]
                deps = [[0.5 * sum(vec[..., x, a] * rot[a][b] * vec[..., y, b]
                                   for a in range(2) for b in range(2))
                         for y in range(2)] for x in range(2)]
                d_strain[0, k], d_strain[1, k] = deps[0][0], deps[1][1]
                d_strain[3, k] = deps[0][1] + deps[1][0]  # engineering shear
        d_strain[2, TT] = 1.0  # d eps_tt = h_tt (db_t = 2 h_tt b_t)
        return np.einsum("cd...,dk...->ck...", self.d_ep, d_strain)


def geometric_tangent(stress: np.ndarray, mean_shift: np.ndarray) -> np.ndarray:
    """A (5, 5, ...) with g . A h = -tau : (g h) + (tau_m - P[tau_m]) tr(g h), the change of
    tau : g_bar under a change h of the configuration (``mean_shift`` = tau_m - P[tau_m], the
    mean stress less its projection: the F-bar term)."""
    tau = sym_block(stress)
    shape = stress.shape[1:]
    a = np.zeros((5, 5) + shape)
    for i in range(2):
        for j in range(2):
            for k in range(2):
                a[_IN_PLANE[i][k], _IN_PLANE[k][j]] -= tau[..., i, j]
    a[TT, TT] -= stress[2]
    for i in range(2):
        for k in range(2):
            a[_IN_PLANE[i][k], _IN_PLANE[k][i]] += mean_shift
    a[TT, TT] += mean_shift
    return a


class FiniteStrainSolver(ContactSolver):
    """The hemisphere-on-flat problem in finite strain (the module docstring); same interface,
    contact, force control and outputs as :class:`ContactSolver`."""

    def __post_init__(self) -> None:
        super().__post_init__()
        basis = self.basis
        r = self.radius_qp
        rows = []
        for phi in basis.basis:
            f = phi[0]
            rows.append(np.stack([f.grad[0, 0], f.grad[1, 1], np.asarray(f)[0] / r,
                                  f.grad[0, 1], f.grad[1, 0]]))
        self.G0 = np.ascontiguousarray(np.stack(rows))  # (12, 5, e, q) Grad N_j
        self._predictor = None  # internal force of the last converged state while predicting

    # --- kinematics -----------------------------------------------------------------------
    def _project(self, field: np.ndarray) -> np.ndarray:
        """The B-bar projection of a scalar field (e, q) per element (P0 or P1, r-weighted)."""
        if not self.bbar:
            return field
        return self._project_volumetric(field[None])[0]

    def _displacement_gradient(self, displacement: np.ndarray) -> np.ndarray:
        """H = F - I (5, e, q) at the quadrature points."""
        ue = displacement[self.element_dofs]  # (12, e)
        H = self.G0[0] * ue[0, :, None]
        for j in range(1, len(ue)):
            H += self.G0[j] * ue[j, :, None]
        return H

    def admissible(self, displacement: np.ndarray) -> bool:
        """No element turned inside out: J > 0 at every quadrature point (the in-plane
        determinant and the hoop stretch both positive), all finite."""
        H = self._displacement_gradient(displacement)
        in_plane = H[RR] + H[ZZ] + H[RR] * H[ZZ] - H[RZ] * H[ZR]  # det - 1
        return bool(np.all(in_plane > -1.0) and np.all(H[TT] > -1.0))

    def kinematics(self, displacement: np.ndarray):
        """H = F - I (5, e, q), H_bar = F_bar - I, and the spatial test gradients
        g (12, 5, e, q) and g_bar."""
        H = self._displacement_gradient(displacement)
        # ln J = ln det(F_in-plane) + ln F_tt, without forming 1 + small; NaN where an element
        # is turned inside out (J <= 0), which the Newton iteration takes as a failed iterate
        with np.errstate(divide="ignore", invalid="ignore"):
            log_j = (np.log1p(H[RR] + H[ZZ] + H[RR] * H[ZZ] - H[RZ] * H[ZR])
                     + np.log1p(H[TT]))
        scale_minus = np.expm1((self._project(log_j) - log_j) / 3.0)  # (J_bar / J)^(1/3) - 1
        h_bar = H * (1.0 + scale_minus)[None]
        for c in (RR, ZZ, TT):
            h_bar[c] += scale_minus
        finv = _inverse(np.eye(2) + block(H))  # (e, q, 2, 2)
        g = np.empty_like(self.G0)  # g_ik = sum_m Grad_im N F^-1_mk
        for i in range(2):
            for k in range(2):
                g[:, _IN_PLANE[i][k]] = (self.G0[:, _IN_PLANE[i][0]] * finv[..., 0, k]
                                         + self.G0[:, _IN_PLANE[i][1]] * finv[..., 1, k])
        g[:, TT] = self.G0[:, TT] / (1.0 + H[TT])
        trace = g[:, RR] + g[:, ZZ] + g[:, TT]
        shift = ((self._project_volumetric(trace) if self.bbar else trace) - trace) / 3.0
        g_bar = g.copy()
        for c in (RR, ZZ, TT):
            g_bar[:, c] += shift
        return H, h_bar, g, g_bar

    # --- the solver's hooks ---------------------------------------------------------------
    def _evaluate(self, old: State, u: np.ndarray, *, elastic: bool, tangent: bool = True):
        """Stress, C_p^-1, eqps, status, internal force and element matrices at ``u``."""
        _, h_bar, g, g_bar = self.kinematics(u)
        update = FiniteUpdate(self.model, h_bar, old.strain, old.eqps,
                              plastic=self.plastic and not elastic, tangent=tangent)
        stress = update.stress
        f_int = self._force(g_bar, stress)
        local = None
        if tangent:
            a_mat = np.einsum("cd,ck...->dk...", SYM, update.material_tangent())  # (5,5,e,q)
            mean = (stress[0] + stress[1] + stress[2]) / 3.0
            a_geo = geometric_tangent(stress, mean - self._project(mean))
            dv = self.dvolume
            local = (_element_products(g_bar, a_mat, g_bar, dv)
                     + _element_products(g, a_geo, g, dv))
        return update, f_int, local

    def _force(self, g_bar: np.ndarray, stress: np.ndarray) -> np.ndarray:
        """Nodal internal forces: integral of tau : g_bar dV0."""
        local = np.einsum("jceq,ceq,eq->je", g_bar, np.einsum("cd,d...->c...", SYM.T, stress),
                          self.dvolume, optimize=True)
        return np.bincount(self.element_dofs.ravel(), weights=local.ravel(),
                           minlength=self.ndofs)

    def _state_internal_force(self, state: State) -> np.ndarray:
        return self._force(self.kinematics(state.displacement)[3], state.stress)

    def element_matrices(self, tangent):
        if tangent is None or tangent.ndim == 4:  # the linear predictor: B^T D B
            return super().element_matrices(tangent)
        return tangent  # (elements, 12, 12): _evaluate assembled them

    def stiffness(self, tangent):
        import scipy.sparse as sp

        if tangent is None:
            return super().stiffness(None)
        a = self._assembly
        data = np.bincount(a.slot, weights=tangent.ravel(), minlength=len(a.indices))
        return sp.csr_matrix((data, a.indices, a.indptr), shape=(self.ndofs, self.ndofs))

    def _response(self, old: State, u: np.ndarray, *, elastic: bool):
        if self._predictor is not None:
            # the linear predictor: the equilibrium of ``old`` plus the small-strain elastic
            # stiffness of the reference configuration times the increment
            d_strain = self.strain(u - old.displacement)
            d_stress = np.einsum("cd,deq->ceq", self.elastic_matrix, d_strain)
            f_int = self._predictor + ContactSolver.internal_force(self, d_stress)
            return old.stress, old.strain, old.eqps, old.status, f_int, None
        update, f_int, local = self._evaluate(old, u, elastic=elastic)
        return update.stress, update.cp, update.eqps, update.status, f_int, local

    def solve_step(self, old: State, force: float, *, label: str = "") -> State:
        """A linear elastic predictor on the reference configuration (iterating only on the
        contact set: it gets the contact set and the displacement close), then Newton with the
        consistent finite-strain tangent. With ``contact="facet"``: the engine's facet
        iteration (no predictor from a loaded state), with this class's kinematics."""
        if self.contact == "facet":
            return ContactSolver.solve_step(self, old, force, label=label)
        self._predictor = self.state_internal_force(old)
        try:
            u, w, active, _ = self._iterate(old, force, old.displacement.copy(),
                                            old.top_displacement, old.active.copy(),
                                            elastic=True, label=label)
        finally:
            self._predictor = None
        if self.line_search:  # rescue mode: Newton starts from an admissible point
            u, w = self._admissible_start(old, u, w)
        _, _, _, result = self._iterate(old, force, u, w, active, elastic=not self.plastic,
                                        label=label, final=True)
        return result

    def _bulk_force_along(self, old: State, u: np.ndarray, direction: np.ndarray,
                          f_int: np.ndarray, bulk: np.ndarray, *, elastic: bool):
        """The internal force at u + a d for the facet line search: nonlinear in a with finite
        strain even when elastic (an inadmissible a gives NaN forces, which the line search
        treats as beyond the minimum)."""

        def bulk_force(a):
            trial = u + a * direction
            if not self.admissible(trial):
                return np.full(self.ndofs, np.nan)
            return self._evaluate(old, trial, elastic=elastic, tangent=False)[1]
        return bulk_force

    def _admissible_start(self, old: State, u: np.ndarray, w: float):
        """The predictor's increment from ``old`` halved until its end is admissible (the
        linear predictor on the reference configuration can overshoot a large deformation)."""
        du, dw = u - old.displacement, w - old.top_displacement
        scale = 1.0
        for _ in range(LINE_SEARCH_HALVINGS):
            if self.admissible(u):
                break
            scale *= 0.5
            self.line_search_halvings += 1
            u, w = old.displacement + scale * du, old.top_displacement + scale * dw
        return u, w

    def _factor(self, local, reduced):
        if local is self._cache.get("elastic_local"):
            return super()._factor(local, reduced)  # symmetric: CHOLMOD
        self.factorisations += 1
        return _lu(self._bordered_system(local, reduced))

    def _dissipation(self, old: State, u: np.ndarray, stress: np.ndarray,
                     strain: np.ndarray) -> float:
        update = self._evaluate(old, u, elastic=False, tangent=False)[0]
        d_plastic = update.trial_strain - update.elastic_strain
        return 0.5 * float(np.sum(np.sum((old.stress + stress) * d_plastic, axis=0)
                                  * self.dvolume))

    def candidate_radii(self, state: State) -> np.ndarray:
        return self.candidate_r + state.displacement[self.candidate_dofs_r]

    def contact_pressure(self, state: State) -> tuple[np.ndarray, np.ndarray]:
        """(current r, pressure) at the surface nodes: nodal force / tributary ring area of the
        current configuration (the Cauchy contact pressure; the small-strain engine divides by
        the reference area)."""
        area = self._tributary_areas(self.candidate_points, state.displacement)
        return self.candidate_radii(state), self._pressure(self.contact_forces(state), area)
