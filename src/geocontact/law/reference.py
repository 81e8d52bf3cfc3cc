"""Scalar reference implementation of the hysteretic law: one contact, written to read like
docs/model.md §6 and docs/law.md. It is the specification: the compiled law (the C++ header behind
``ContactArrays`` and the LAMMPS plugin) must agree with it (golden vectors, tests/test_law.py).

Normalised coordinates on the current envelope (after the ratchet shift ``s``)::

    d' = d - s,   t = (d' - d_res) / (d_max - d_res),   f = F / F_max

Branches and the partial-reversal rule (docs/law.md derives why it never creates energy):

* APART     d' <= d_res: no force (no tension). Re-contact reloads along the main reloading curve.
* VIRGIN    d' >= d_max: the three-regime loading curve; the envelope grows with it.
* UNLOADING f = A t^n_u, through the reversal point (A = f_rev / t_rev^n_u >= 1): reaches zero
            force exactly at d_res, so the residual approach is that of the envelope.
* RELOADING f = t^k, through the reversal point and (d_max, F_max): k = ln f_rev / ln t_rev,
            which lies in [n_r, n_u]; from full unloading k = n_r (the main reloading curve).
            In the shakedown form (cyclic.form) from full unloading k = k_N, the exponent that
            makes closed cycle N dissipate the fitted plastic-work ratio of N; k_N -> n_u.
* RATCHET   (cyclic extension only) a reload that reaches the envelope band, t >= 1 - tol
            (tol = cyclic.tolerance), creeps at the force it has there by the cycle's
            increment of residual approach (the shift s grows, d' stays), then goes on along
            the same reloading curve, shifted by it.

The envelope band (docs/law.md, "Repeated cycles"): approaches within ``tol (d_max - d_res)`` of
d_max are the envelope point to the cyclic extension. Reaching the band is a repeated cycle; an
excursion beyond d_max grows the envelope as before, and restarts the count only once it is
wider than the band (measured from where it left the old envelope, kept in ``branch_value``),
so round-off and jitter (far below the band) change nothing and a real excursion restarts it.

With ``E = F (d' - d_res) / (n_u + 1)`` (the energy unloading would give back), every step has
dissipation ``F dd - dE >= 0``: zero on unloading, ``(n_u - k) F dd' / (n_u + 1)`` on reloading,
the growth of the envelope's plastic work on virgin loading, ``F ds`` on a ratchet (d' and so E
stay put while s grows).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from ..errors import InputError
from . import calibrated_range
from .calibrated_range import WARN
from .params import HERTZ_EXPONENT, LawParams

APART, VIRGIN, UNLOADING, RELOADING, RATCHET = 0, 1, 2, 3, 4
BRANCH_NAMES = ("apart", "virgin", "unloading", "reloading", "ratchet")


@dataclass
class ContactState:
    """Everything the law remembers about one contact (the DEM per-contact history)."""

    approach: float = 0.0  # last approach d (m)
    force: float = 0.0  # last force (N)
    max_approach: float = 0.0  # d_max of the envelope, in shifted coordinates (m)
    max_force: float = 0.0  # F_max = virgin force at d_max (N)
    residual_approach: float = 0.0  # d_res of the envelope, shifted coordinates (m)
    unloading_exponent: float = HERTZ_EXPONENT
    reloading_exponent: float = HERTZ_EXPONENT
    branch: int = APART
    branch_value: float = 0.0  # A on unloading, k on reloading, on virgin the approach d' where
    # the excursion beyond the old envelope started (m)
    ratchet_shift: float = 0.0  # s: accumulated ratchetting (m)
    pending_ratchet: float = 0.0  # increment this reload adds in the envelope band (m); the
    # part still to creep while ratchetting
    cycles: float = 0.0  # equivalent cycles at the current envelope (depth-weighted)
    work: float = 0.0  # exact work of the force since the start (J)


class Contact:
    """One contact advanced along an approach history: ``update(d) -> (force, stiffness)``.

    ``beyond_range``: when the envelope first goes beyond the law's calibrated depth
    (``calibrated_range``), ``"warn"`` (a ``BeyondCalibratedRangeWarning``, once per contact),
    ``"refuse"`` (a ``BeyondCalibratedRangeError`` from that update, the state advanced) or
    ``"ignore"``; ``range_excess()`` says how far it went and for how many steps."""

    def __init__(self, params: LawParams, *, beyond_range: str = WARN):
        self.params = params
        self.kh = params.hertz_coefficient
        self.yield_approach = params.yield_approach
        self.state = ContactState()
        self.beyond_range = calibrated_range.check_policy(beyond_range)
        self._range_top = params.calibrated_approach  # inf: no range recorded
        self.steps = 0
        self.steps_beyond = 0  # updates that left the approach beyond the calibrated top

    # --- curves of the current branch --------------------------------------------------------
    def _elastic(self) -> bool:
        return self.state.max_approach <= self.yield_approach

    def _normalised(self, d: float) -> float:
        s = self.state
        return (d - s.residual_approach) / (s.max_approach - s.residual_approach)

    def _force_on_branch(self, d: float) -> float:
        """Force at shifted approach d on the current branch."""
        s = self.state
        if s.branch == APART or d <= 0.0:
            return 0.0
        if s.branch == VIRGIN:
            return float(self.params.virgin_force(d))
        if self._elastic():
            return self.kh * d**HERTZ_EXPONENT
        t = self._normalised(d)
        if t <= 0.0:
            return 0.0
        if s.branch == UNLOADING:
            return s.branch_value * s.max_force * t**s.unloading_exponent
        return s.max_force * t**s.branch_value  # RELOADING, or RATCHET: creeping on it

    def _branch_exponent(self) -> float:
        s = self.state
        if self._elastic():
            return HERTZ_EXPONENT
        return s.unloading_exponent if s.branch == UNLOADING else s.branch_value

    def _stiffness(self, d: float, force: float) -> float:
        s, p = self.state, self.params
        if s.branch in (APART, RATCHET) or d <= 0.0:
            return 0.0
        if self._elastic() or (s.branch == VIRGIN and d <= p.yield_approach):
            return HERTZ_EXPONENT * self.kh * math.sqrt(d)  # Hertz: dF/dd = 2 E* a
        if force <= 0.0:
            return 0.0
        if s.branch == VIRGIN:
            return p.virgin_exponent(d) * force / d
        return self._branch_exponent() * force / (d - s.residual_approach)

    def _band(self) -> float:
        """Width of the envelope band, tol (d_max - d_res): approaches closer to d_max are the
        envelope point to the cyclic extension (zero without it or on an elastic envelope)."""
        s, cyclic = self.state, self.params.cyclic
        if not cyclic.enabled or self._elastic():
            return 0.0
        return cyclic.tolerance * (s.max_approach - s.residual_approach)

    def _set_envelope(self, max_approach: float) -> None:
        """Update F_max, d_res, n_u, n_r from the largest approach reached (docs/model.md §6)."""
        s, p = self.state, self.params
        x = max_approach / p.yield_approach
        s.max_approach = max_approach
        s.max_force = float(p.virgin_force(max_approach))
        s.residual_approach = float(p.residual_ratio(x)) * max_approach
        s.unloading_exponent = float(p.unloading_exponent(x))
        s.reloading_exponent = float(p.reloading_exponent(x))

    # --- reversals ------------------------------------------------------------------------
    def _shakedown_reloading_exponent(self, cycles: float) -> float:
        """Main reloading exponent k_N of closed cycle N in the shakedown form.

        Cycle N (from zero force to the envelope and back) dissipates its ratchet creep
        F_max ds_N plus the loop between the reloading curve t^k and the unloading curve t^n_u,
        F_max (d_max - d_res) (n_u - k) / ((k + 1)(n_u + 1)). k_N makes the sum equal to the
        fitted ``c_w N^-p_w`` times cycle 1's dissipation, the envelope's plastic work: as the
        ratio decays, k_N -> n_u and the loop closes (elastic shakedown). The creep happens in
        the envelope band, at F_max (1 - tol)^k, solved by fixed-point passes. Bounded to
        [min(1, n_u), n_u]: k <= n_u keeps every step's dissipation >= 0 (docs/law.md), k >= 1
        a contact stiffness that grows with the approach, as a growing contact area gives."""
        s, p = self.state, self.params
        n_u, span = s.unloading_exponent, s.max_approach - s.residual_approach
        cycles = max(cycles, 2.0)
        first = float(p.envelope_plastic_work(s.max_approach))  # cycle 1's dissipation
        target = first * p.cyclic.plastic_work_ratio(cycles)
        ratchet = p.cyclic.residual_ratio(cycles) * s.residual_approach
        k = n_u
        # the creep happens at the band's force F_max (1 - tol)^k: two fixed-point passes
        # (the creep's share of d(dissipation)/dk is ~tol ds/(d_max - d_res) of the loop's)
        for _ in range(2):
            creep = s.max_force * (1.0 - p.cyclic.tolerance) ** k * ratchet
            a = max(target - creep, 0.0) / (s.max_force * span) * (n_u + 1.0)
            k = min(max((n_u - a) / (1.0 + a), min(1.0, n_u)), n_u)
        return k

    def _start_reloading(self, d: float) -> None:
        """Reversal from unloading (or re-contact): the reloading curve through this point."""
        s = self.state
        cyclic = self.params.cyclic
        if self._elastic():
            depth, exponent = 0.0, HERTZ_EXPONENT  # no cycle to count, nothing to ratchet
        else:
            t = self._normalised(d)
            f = s.force / s.max_force
            full = t <= 0.0 or f <= 0.0
            depth = 1.0 if full else 1.0 - f
            if cyclic.shakedown:
                # from zero force the cycle's own k_N; from a partial reversal the curve through
                # the reversal point (its exponent lies in [k of the last reload, n_u])
                exponent = (self._shakedown_reloading_exponent(s.cycles + depth) if full
                            else min(math.log(f) / math.log(t), s.unloading_exponent))
            elif full:
                exponent = s.reloading_exponent
            else:
                exponent = min(max(math.log(f) / math.log(t), s.reloading_exponent),
                               s.unloading_exponent)
        s.branch, s.branch_value = RELOADING, exponent
        s.cycles += depth
        s.pending_ratchet = (depth * cyclic.residual_ratio(s.cycles) * s.residual_approach
                             if cyclic.enabled else 0.0)

    def _start_unloading(self, d: float) -> None:
        s = self.state
        if s.branch == RATCHET:
            s.pending_ratchet = 0.0  # reversal while ratchetting: the creep so far stays
        if s.branch == VIRGIN or self._elastic():
            amplitude = 1.0
        else:
            t = self._normalised(d)
            amplitude = (s.force / s.max_force) / t**s.unloading_exponent
        s.branch, s.branch_value = UNLOADING, amplitude

    # --- one monotone move along the current branch ---------------------------------------
    def _move(self, d: float, target: float) -> tuple[float, float]:
        """Advance from shifted approach d toward target along the current branch, up to the
        branch's end; accumulate the exact work and return (d, target) where it stopped, in the
        shifted coordinates after the move (a ratchet moves them)."""
        s = self.state
        up = target > d
        if s.branch == APART:
            contact_at = s.residual_approach
            if not up or target <= contact_at:
                return target, target
            if s.max_approach == 0.0:
                s.branch, s.branch_value = VIRGIN, 0.0
            else:
                s.force = 0.0
                self._start_reloading(contact_at)
            return contact_at, target
        if s.branch == VIRGIN:
            if not up:
                self._start_unloading(d)
                return d, target
            s.work += float(self.params.virgin_work(target) - self.params.virgin_work(d))
            self._set_envelope(target)
            # an excursion (from branch_value, where it left the old envelope) wider than the
            # band is a new envelope: the count restarts; within the band it is the same cycle
            if target - s.branch_value > self._band():
                s.cycles = 1.0
            return target, target
        if s.branch == RATCHET:
            if not up:
                self._start_unloading(d)
                return d, target
            # creep at constant force: s grows, d' stays (the work is F ds)
            if target - d < s.pending_ratchet:  # the step ends inside the creep
                creep, target = target - d, d
            else:
                creep, target = s.pending_ratchet, target - s.pending_ratchet
                s.branch = RELOADING  # crept by the whole increment: reload on
            s.work += s.force * creep
            s.ratchet_shift += creep
            s.pending_ratchet -= creep
            if s.branch == RELOADING:
                s.pending_ratchet = 0.0
            return d, target
        # UNLOADING or RELOADING: F = C (d - base)^n, work = [F d - F d](base) / (n + 1)
        if up and s.branch == UNLOADING:
            if not self._elastic() and self._normalised(d) >= 1.0:
                # reversed exactly at the envelope point: load on
                s.branch, s.branch_value = VIRGIN, d
            else:
                self._start_reloading(d)
            return d, target
        if not up and s.branch == RELOADING:
            self._start_unloading(d)
            return d, target
        ratchets = up and s.pending_ratchet > 0.0
        band_start = s.max_approach - self._band()
        if ratchets and d >= band_start:
            s.branch = RATCHET  # the reload starts inside the envelope band
            return d, target
        top = band_start if ratchets else s.max_approach
        end = min(target, top) if up else max(target, s.residual_approach)
        base = 0.0 if self._elastic() else s.residual_approach
        n = self._branch_exponent()
        f_end = self._force_on_branch(end)
        s.work += (f_end * (end - base) - s.force * (d - base)) / (n + 1.0)
        s.force = f_end
        if ratchets and end >= band_start:
            s.branch = RATCHET
        elif up and end >= s.max_approach:
            s.branch, s.branch_value = VIRGIN, s.max_approach  # the excursion starts here
            s.force = s.max_force
        elif not up and end <= s.residual_approach:
            s.branch, s.force = APART, 0.0
        return end, target

    def update(self, approach: float) -> tuple[float, float]:
        """Advance to a new approach; return (force N, tangent stiffness dF/d(approach) N/m)."""
        if not math.isfinite(approach):
            raise InputError(f"approach: must be a finite number of metres, got {approach}")
        s = self.state
        d, target = s.approach - s.ratchet_shift, approach - s.ratchet_shift
        for _ in range(16):  # a step crosses at most a few branch ends
            if d == target:
                break
            d, target = self._move(d, target)
        else:  # pragma: no cover - guards a logic error, never expected
            raise RuntimeError("law: step did not terminate")
        s.approach = float(approach)
        s.force = float(self._force_on_branch(target))
        self.steps += 1
        if target > self._range_top:
            self.steps_beyond += 1
            if self.steps_beyond == 1:  # the first time only: said once per contact
                calibrated_range.report(self.range_excess(), self.beyond_range)
        return s.force, self._stiffness(target, s.force)

    def range_excess(self) -> calibrated_range.RangeExcess | None:
        """How far beyond its calibrated depth this contact has been loaded: the steps whose
        approach was beyond it, and the envelope's depth; None if never."""
        return calibrated_range.excess(self.params, self.state.max_approach
                                       / self.yield_approach, self.steps_beyond, self.steps,
                                       unit="steps")

    # --- energies ---------------------------------------------------------------------------
    @property
    def elastic_energy(self) -> float:
        """Energy unloading from here would give back: F (d' - d_res) / (n_u + 1)."""
        s = self.state
        if s.force <= 0.0:
            return 0.0
        d = s.approach - s.ratchet_shift
        if self._elastic():
            return s.force * d / (HERTZ_EXPONENT + 1.0)
        return s.force * (d - s.residual_approach) / (s.unloading_exponent + 1.0)

    @property
    def dissipated_energy(self) -> float:
        return self.state.work - self.elastic_energy


def force_history(params: LawParams, approaches, *, beyond_range: str = WARN
                  ) -> tuple[list[float], list[float]]:
    """The law along an approach history, scalar path: (forces, stiffnesses). Steps beyond
    the law's calibrated depth are reported once, at the end (``beyond_range`` as
    ``Contact``'s): how many and how deep."""
    policy = calibrated_range.check_policy(beyond_range)
    contact = Contact(params, beyond_range=calibrated_range.IGNORE)
    forces, stiffnesses = [], []
    for a in approaches:
        f, k = contact.update(float(a))
        forces.append(f)
        stiffnesses.append(k)
    calibrated_range.report(contact.range_excess(), policy)
    return forces, stiffnesses
