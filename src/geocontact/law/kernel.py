"""Vectorised many-contact kernel of the hysteretic law (numba).

Same rules, same arithmetic as the scalar reference (``reference.py``), over arrays of
contact state: one call per DEM step advances every contact to its new approach and returns the
forces and the tangent stiffnesses dF/d(approach) (DEM codes need them for the time step).
``ContactArrays.hertz`` is the plain Hertz law through the same structure (the speed floor).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ..errors import InputError
from ..material import Material
from .params import HERTZ_EXPONENT, LawParams
from .reference import APART, RATCHET, RELOADING, UNLOADING, VIRGIN

# Layout of the packed parameter vector handed to the kernel.
(P_KH, P_DY, P_DP, P_FY, P_FP, P_N1, P_N2, P_PU, P_PR, P_RHO, P_RS, P_CYC_ON, P_CYC_C,
 P_CYC_P, P_CYC_TOL, P_HERTZ_ONLY, P_RX0, P_RB, P_DQ, P_FQ, P_N3) = range(21)
N_PARAMS = 21
# Inputs are checked finite before the kernel runs, so the no-NaN/no-inf assumptions hold;
# contraction and approximate functions change results only at rounding level.
_FAST = {"nnan", "ninf", "nsz", "arcp", "contract", "afn"}

STATE_FIELDS = ("approach", "force", "max_approach", "max_force", "residual_approach",
                "unloading_exponent", "reloading_exponent", "branch_value", "ratchet_shift",
                "pending_ratchet", "cycles", "work")


def pack_params(params: LawParams) -> np.ndarray:
    p = np.zeros(N_PARAMS)
    p[P_KH] = params.hertz_coefficient
    p[P_DY] = params.yield_approach
    p[P_DP] = params.fully_plastic_approach
    p[P_FY] = params.yield_force
    p[P_FP] = params.fully_plastic_force
    p[P_N1] = params.elastic_plastic_exponent
    p[P_N2] = params.fully_plastic_exponent
    p[P_PU] = params.unloading_power
    p[P_PR] = params.reloading_power
    p[P_RHO] = params.residual_limit
    p[P_RS] = params.residual_power
    p[P_RX0] = params.residual_transition
    p[P_RB] = params.residual_log_power
    # no third loading regime: delta_q beyond any approach (finite, for the fast-math kernel)
    deep = math.isfinite(params.deep_plastic_approach_ratio)
    p[P_DQ] = params.deep_plastic_approach if deep else np.finfo(float).max
    p[P_FQ] = params.deep_plastic_force if deep else np.finfo(float).max
    p[P_N3] = params.deep_plastic_exponent
    p[P_CYC_ON] = 1.0 if params.cyclic.enabled else 0.0
    p[P_CYC_C] = params.cyclic.residual_ratio_coefficient
    p[P_CYC_P] = params.cyclic.residual_ratio_power
    p[P_CYC_TOL] = params.cyclic.tolerance
    return p


@njit(cache=True, inline="always", fastmath=_FAST)
def _virgin_force(p, d):
    if d <= 0.0:
        return 0.0
    if d <= p[P_DY]:
        return p[P_KH] * d**HERTZ_EXPONENT
    if d <= p[P_DP]:
        return p[P_FY] * (d / p[P_DY]) ** p[P_N1]
    if d <= p[P_DQ]:
        return p[P_FP] * (d / p[P_DP]) ** p[P_N2]
    return p[P_FQ] * (d / p[P_DQ]) ** p[P_N3]


@njit(cache=True, inline="always", fastmath=_FAST)
def _virgin_work_from_force(p, d, f):
    """Virgin work to d given the virgin force f at d: each regime is a power law, so
    int F = (F d - F_start d_start)/(n + 1) needs no further pow."""
    dy, dp, fy = p[P_DY], p[P_DP], p[P_FY]
    w_y = fy * dy / (HERTZ_EXPONENT + 1.0)
    if d <= dy:
        return f * d / (HERTZ_EXPONENT + 1.0)
    if d <= dp:
        return w_y + (f * d - fy * dy) / (p[P_N1] + 1.0)
    w_p = w_y + (p[P_FP] * dp - fy * dy) / (p[P_N1] + 1.0)
    if d <= p[P_DQ]:
        return w_p + (f * d - p[P_FP] * dp) / (p[P_N2] + 1.0)
    w_q = w_p + (p[P_FQ] * p[P_DQ] - p[P_FP] * dp) / (p[P_N2] + 1.0)
    return w_q + (f * d - p[P_FQ] * p[P_DQ]) / (p[P_N3] + 1.0)


@njit(cache=True, inline="always", fastmath=_FAST)
def _virgin_exponent(p, d):
    if d <= p[P_DY]:
        return HERTZ_EXPONENT
    if d <= p[P_DP]:
        return p[P_N1]
    if d <= p[P_DQ]:
        return p[P_N2]
    return p[P_N3]


@njit(cache=True, fastmath=_FAST)
def _step(p, target_in, branch, st, force_out, stiffness_out):
    """Advance every contact i to approach target_in[i]. ``st`` is the (12, n) state array in the
    order of STATE_FIELDS; ``branch`` the int8 branch per contact."""
    n = target_in.shape[0]
    kh, dy = p[P_KH], p[P_DY]
    hertz_only = p[P_HERTZ_ONLY] != 0.0
    for i in range(n):
        approach_new = target_in[i]
        if hertz_only:  # plain Hertz through the same structure: the speed floor
            if approach_new > 0.0:
                root = math.sqrt(approach_new)
                force_out[i] = kh * approach_new * root
                stiffness_out[i] = HERTZ_EXPONENT * kh * root
            else:
                force_out[i] = 0.0
                stiffness_out[i] = 0.0
            st[0, i] = approach_new
            continue
        approach = st[0, i]
        dmax = st[2, i]
        b = branch[i]
        # Fast paths (most contacts in a DEM step): no envelope change, exact same arithmetic.
        if b == APART and approach_new <= st[4, i] + st[8, i]:
            st[0, i] = approach_new  # stays apart: no force, nothing else changes
            force_out[i] = 0.0
            stiffness_out[i] = 0.0
            continue
        if dmax <= dy and approach_new <= dmax and st[9, i] == 0.0:
            # elastic envelope: Hertz; conservative, so the work is the Hertz energy
            st[0, i] = approach_new
            if approach_new > 0.0:
                root = math.sqrt(approach_new)
                f = kh * approach_new * root
                force_out[i] = f
                stiffness_out[i] = HERTZ_EXPONENT * kh * root
                st[1, i] = f
                st[11, i] = f * approach_new / (HERTZ_EXPONENT + 1.0)
                if approach_new != approach:
                    branch[i] = RELOADING if approach_new > approach else UNLOADING
                    st[7, i] = HERTZ_EXPONENT if approach_new > approach else 1.0
            else:
                force_out[i] = 0.0
                stiffness_out[i] = 0.0
                st[1, i] = 0.0
                st[11, i] = 0.0
                branch[i] = APART
            continue
        force = st[1, i]
        fmax, dres = st[3, i], st[4, i]
        nu, nr, bval = st[5, i], st[6, i], st[7, i]
        shift, pending, cycles, work = st[8, i], st[9, i], st[10, i], st[11, i]
        d = approach - shift
        target = approach_new - shift
        for _ in range(16):
            if d == target:
                break
            up = target > d
            elastic = dmax <= dy
            if b == APART:
                if (not up) or target <= dres:
                    d = target
                    continue
                if dmax == 0.0:
                    b = VIRGIN
                else:
                    force = 0.0
                    # re-contact: start reloading from full unloading (depth 1)
                    b = RELOADING
                    bval = HERTZ_EXPONENT if elastic else nr
                    if not elastic:
                        cycles += 1.0
                    pending = 0.0
                    if p[P_CYC_ON] != 0.0 and cycles >= 2.0:
                        ratio = p[P_CYC_C] * cycles ** (-p[P_CYC_P])
                        if ratio >= p[P_CYC_TOL]:
                            pending = ratio * dres
                d = dres
                continue
            if b == VIRGIN:
                if not up:
                    b = UNLOADING
                    bval = 1.0
                    continue
                # one pow for the force, the work from it; one log, three exp for the envelope
                fmax = _virgin_force(p, target)
                work += (_virgin_work_from_force(p, target, fmax)
                         - _virgin_work_from_force(p, d, force))
                dmax = target
                force = fmax
                lx = math.log(max(target / dy, 1.0))
                # residual form with transition depth x0 (params.saturating_ratio); x0 = 1: lx
                lr = lx if p[P_RX0] == 1.0 else math.log1p((max(target / dy, 1.0) - 1.0)
                                                           / p[P_RX0])
                if p[P_RB] != 1.0:
                    lr = lr ** p[P_RB]
                dres = -p[P_RHO] * math.expm1(-p[P_RS] * lr) * target
                nu = HERTZ_EXPONENT * math.exp(p[P_PU] * lx)
                nr = min(HERTZ_EXPONENT * math.exp(p[P_PR] * lx), nu)
                cycles = 1.0
                d = target
                continue
            if b == RATCHET:
                if not up:
                    shift += d - dmax
                    pending = 0.0
                    b = UNLOADING
                    bval = 1.0
                    target -= d - dmax
                    d = dmax
                    continue
                end = min(target, dmax + pending)
                work += fmax * (end - d)
                if end < dmax + pending:
                    d = end
                    continue
                shift += pending
                target -= pending
                pending = 0.0
                b = VIRGIN
                d = dmax
                continue
            if up and b == UNLOADING:
                if (not elastic) and (d - dres) >= (dmax - dres):
                    b = VIRGIN  # reversed exactly at the envelope point: load on
                    continue
                if elastic:
                    depth = 0.0  # elastic envelope: no cycle to count, nothing to ratchet
                    expo = HERTZ_EXPONENT
                else:
                    t = (d - dres) / (dmax - dres)
                    f = force / fmax
                    if t <= 0.0 or f <= 0.0:
                        depth = 1.0
                        expo = nr
                    else:
                        depth = 1.0 - f
                        expo = min(max(math.log(f) / math.log(t), nr), nu)
                b = RELOADING
                bval = expo
                cycles += depth
                pending = 0.0
                if p[P_CYC_ON] != 0.0 and cycles >= 2.0:
                    ratio = p[P_CYC_C] * cycles ** (-p[P_CYC_P])
                    if ratio >= p[P_CYC_TOL]:
                        pending = depth * ratio * dres
                continue
            if (not up) and b == RELOADING:
                if elastic:
                    bval = 1.0
                else:
                    t = (d - dres) / (dmax - dres)
                    bval = (force / fmax) / t**nu
                b = UNLOADING
                continue
            # move along UNLOADING / RELOADING: F = C (d - base)^n
            end = min(target, dmax) if up else max(target, dres)
            base = 0.0 if elastic else dres
            if elastic:
                expo = HERTZ_EXPONENT
                f_end = kh * end**HERTZ_EXPONENT if end > 0.0 else 0.0
            else:
                expo = nu if b == UNLOADING else bval
                t = (end - dres) / (dmax - dres)
                if t <= 0.0:
                    f_end = 0.0
                elif b == UNLOADING:
                    f_end = bval * fmax * t**nu
                else:
                    f_end = fmax * t**bval
            work += (f_end * (end - base) - force * (d - base)) / (expo + 1.0)
            force = f_end
            if up and end >= dmax:
                b = RATCHET if pending > 0.0 else VIRGIN
                force = fmax
            elif (not up) and end <= dres:
                b = APART
                force = 0.0
            d = end
        # Force and tangent at the end of the step, on the branch the contact is on. The last
        # move already evaluated the force at the target; only the slope is left to compute.
        stiff = 0.0
        if b == APART or target <= 0.0:
            force = 0.0
        elif b == VIRGIN:
            if target <= dy:
                stiff = HERTZ_EXPONENT * kh * math.sqrt(target)
            else:
                stiff = _virgin_exponent(p, target) * force / target
        elif b == RATCHET:
            force = fmax
        elif dmax <= dy:
            stiff = HERTZ_EXPONENT * kh * math.sqrt(target)
        elif force > 0.0:
            stiff = (nu if b == UNLOADING else bval) * force / (target - dres)
        force_out[i] = force
        stiffness_out[i] = stiff
        st[0, i], st[1, i], st[7, i], st[11, i] = approach_new, force, bval, work
        if dmax != st[2, i]:
            st[2, i], st[3, i], st[4, i], st[5, i], st[6, i] = dmax, fmax, dres, nu, nr
        if cycles != st[10, i] or pending != st[9, i] or shift != st[8, i]:
            st[8, i], st[9, i], st[10, i] = shift, pending, cycles
        branch[i] = b


class ContactArrays:
    """State of ``n`` contacts advanced together:
    ``force, stiffness = contacts.step(approach)``."""

    def __init__(self, params: LawParams | None, n: int, *, _packed: np.ndarray | None = None):
        if n < 0:
            raise InputError(f"contacts: number of contacts must be >= 0, got {n}")
        self.params = params
        self._p = pack_params(params) if _packed is None else _packed
        self.n = int(n)
        self.state = np.zeros((len(STATE_FIELDS), self.n))
        self.state[STATE_FIELDS.index("unloading_exponent")] = HERTZ_EXPONENT
        self.state[STATE_FIELDS.index("reloading_exponent")] = HERTZ_EXPONENT
        self.branch = np.zeros(self.n, dtype=np.int8)
        self.force = np.zeros(self.n)
        self.stiffness = np.zeros(self.n)

    @classmethod
    def hertz(cls, material: Material, n: int) -> ContactArrays:
        """Plain elastic Hertz through the same kernel structure (no dissipation)."""
        p = np.zeros(N_PARAMS)
        p[P_KH] = 4.0 / 3.0 * material.effective_modulus * math.sqrt(material.effective_radius)
        p[P_HERTZ_ONLY] = 1.0
        return cls(None, n, _packed=p)

    def step(self, approach: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Advance every contact to ``approach`` (m, shape (n,)); returns views of the force (N)
        and tangent stiffness (N/m) arrays, overwritten by the next call."""
        approach = np.ascontiguousarray(approach, dtype=np.float64)
        if approach.shape != (self.n,):
            raise InputError(f"approach: expected shape ({self.n},), got {approach.shape}")
        if not np.all(np.isfinite(approach)):
            raise InputError("approach: must be finite numbers of metres (found NaN or inf)")
        _step(self._p, approach, self.branch, self.state, self.force, self.stiffness)
        return self.force, self.stiffness

    def step_unchecked(self, approach: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``step`` without the input checks, for a DEM loop that guarantees finite input."""
        _step(self._p, approach, self.branch, self.state, self.force, self.stiffness)
        return self.force, self.stiffness

    def _field(self, name: str) -> np.ndarray:
        return self.state[STATE_FIELDS.index(name)]

    @property
    def max_approach(self) -> np.ndarray:
        return self._field("max_approach") + self._field("ratchet_shift")

    @property
    def residual_approach(self) -> np.ndarray:
        return self._field("residual_approach") + self._field("ratchet_shift")

    @property
    def cycles(self) -> np.ndarray:
        return self._field("cycles")

    @property
    def work(self) -> np.ndarray:
        return self._field("work")

    @property
    def elastic_energy(self) -> np.ndarray:
        f = self._field("force")
        d = self._field("approach") - self._field("ratchet_shift")
        elastic = self._field("max_approach") <= self._p[P_DY]
        base = np.where(elastic, 0.0, self._field("residual_approach"))
        n = np.where(elastic, HERTZ_EXPONENT, self._field("unloading_exponent"))
        return np.where(f > 0.0, f * (d - base) / (n + 1.0), 0.0)

    @property
    def dissipated_energy(self) -> np.ndarray:
        if self._p[P_HERTZ_ONLY] != 0.0:
            return np.zeros(self.n)
        return self.work - self.elastic_energy
