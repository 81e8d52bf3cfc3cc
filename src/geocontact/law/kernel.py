"""Vectorised many-contact path of the hysteretic law: the C++ header, bound to Python.

One call per DEM step advances every contact to its new approach and returns the forces and the
tangent stiffnesses dF/d(approach) (DEM codes need them for the time step). Each contact is
stepped by ``geocontact::step`` of ``plugins/lammps/include/geocontact/law.hpp`` (the function
the LAMMPS pair style calls; ``arrays.hpp`` loops it over arrays, on ``threads`` threads), so
the law has one compiled implementation; the scalar reference (``reference.py``) is its
specification and test oracle. ``ContactArrays.hertz`` is the plain Hertz law through the same
structure (the speed floor).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields

import numpy as np

from ..errors import InputError
from ..grain.hertz import hertz_coefficient
from ..grain.material import Material
from . import _core, calibrated_range
from .calibrated_range import WARN
from .params import HERTZ_EXPONENT, SHAKEDOWN, LawParams

# The per-contact state (docs/law.md "State per contact"), in the order of ContactState.
STATE_FIELDS = ("approach", "force", "max_approach", "max_force", "residual_approach",
                "unloading_exponent", "reloading_exponent", "branch_value", "ratchet_shift",
                "pending_ratchet", "cycles", "work", "branch")


@dataclass(frozen=True)
class StateArrays:
    """The state of n contacts, one numpy array per field (views of the compiled core's memory:
    writing into them changes the contacts). Envelope fields are in shifted coordinates, as in
    :class:`~geocontact.law.ContactState`."""

    approach: np.ndarray  # last approach (m)
    force: np.ndarray  # last force (N)
    max_approach: np.ndarray  # delta_max, shifted coordinates (m)
    max_force: np.ndarray  # F_max (N)
    residual_approach: np.ndarray  # delta_res, shifted coordinates (m)
    unloading_exponent: np.ndarray
    reloading_exponent: np.ndarray
    branch_value: np.ndarray  # A on unloading, k on reloading
    ratchet_shift: np.ndarray  # s (m)
    pending_ratchet: np.ndarray  # increment this reload adds in the envelope band (m)
    cycles: np.ndarray  # equivalent cycles at this envelope
    work: np.ndarray  # exact work of the force since the start (J)
    branch: np.ndarray  # int8: 0 apart, 1 virgin, 2 unloading, 3 reloading, 4 ratchet

    def as_dict(self) -> dict[str, np.ndarray]:
        return {f.name: getattr(self, f.name) for f in fields(self)}


def core_params(params: LawParams) -> _core.LawParams:
    """The C++ ``LawParams`` of ``params`` (its derived constants computed by the header)."""
    p = _core.LawParams()
    material = _core.Material()
    for name in ("youngs_modulus", "poissons_ratio", "compressive_yield_stress",
                 "friction_angle_deg", "hardening_ratio", "radius"):
        setattr(material, name, getattr(params.material, name))
    p.material = material
    for name in ("yield_approach", "elastic_plastic_exponent", "fully_plastic_approach_ratio",
                 "fully_plastic_exponent", "unloading_power", "reloading_power",
                 "residual_limit", "residual_power", "residual_transition", "residual_log_power",
                 "plastic_work_limit", "plastic_work_power", "plastic_work_transition",
                 "plastic_work_log_power", "deep_plastic_approach_ratio",
                 "deep_plastic_exponent", "calibrated_depth"):
        setattr(p, name, float(getattr(params, name)))
    if params.loading_segments:
        p.set_loading_segments(list(params.loading_segments.depth),
                               list(params.loading_segments.exponent))
    cyclic = _core.CyclicLaw()
    for name in ("enabled", "residual_ratio_coefficient", "residual_ratio_power",
                 "plastic_work_ratio_coefficient", "plastic_work_ratio_power", "tolerance"):
        setattr(cyclic, name, getattr(params.cyclic, name))
    cyclic.shakedown = params.cyclic.form == SHAKEDOWN
    p.cyclic = cyclic
    table = _core.ResidualTable()
    table.depth = list(params.residual_table.depth)
    table.ratio = list(params.residual_table.ratio)
    p.residual_table = table
    radius = _core.RadiusTable()
    for name, values in params.radius_table.to_dict().items():
        setattr(radius, name, values)
    p.radius_table = radius
    p.derive()
    return p


class ContactArrays:
    """State of ``n`` contacts advanced together:
    ``force, stiffness = contacts.step(approach)``.

    ``threads`` (default 1) splits the contacts over that many threads; the results are
    bitwise the same for any number.

    ``radii`` (m, one per contact, optional): grains of any size by similarity (docs/model.md §10).
    Contact
    i is the calibrated law rescaled to spheres of radius ``radii[i]`` (for two grains r1, r2:
    r_eq = 2 r1 r2 / (r1 + r2)), F = s^2 F_R(d / s) with s = radii[i] / R, stiffness s times,
    energies s^3 times; ``state`` then stays in the calibrated spheres' units (approaches / s,
    forces / s^2), the properties below are in the grains' own.

    ``beyond_range``: the first step after which a contact's envelope is beyond the law's
    calibrated depth (``calibrated_range``) ``"warn"``s (a ``BeyondCalibratedRangeWarning``
    with how many contacts and how deep; once, until ``reset``), ``"refuse"``s (a
    ``BeyondCalibratedRangeError`` from that step; the contacts have been advanced) or
    ``"ignore"``s; ``range_excess()`` says it at any time. The check costs the kernel one max
    per contact (of the delta_max it has just written) and the step one comparison."""

    def __init__(self, params: LawParams | None, n: int, *, threads: int = 1,
                 radii=None, beyond_range: str = WARN,
                 _core_contacts: _core.Contacts | None = None):
        if n < 0:
            raise InputError(f"contacts: number of contacts must be >= 0, got {n}")
        _check_threads(threads)
        self.params = params
        self.n = int(n)
        self.beyond_range = calibrated_range.check_policy(beyond_range)
        # delta_max (shifted, calibrated spheres' units) beyond the range; inf: none recorded
        self._range_top = math.inf if params is None else params.calibrated_approach
        self._range_said = False
        self._core = (_core.Contacts(core_params(params), self.n, threads)
                      if _core_contacts is None else _core_contacts)
        self._state = StateArrays(**self._core.state_views())
        self.branch = self._state.branch
        self._scale = None if radii is None else _scales(params, radii, self.n)
        if self._scale is None:
            self.force = self._core.force
            self.stiffness = self._core.stiffness
        else:
            self.force = np.zeros(self.n)
            self.stiffness = np.zeros(self.n)
            self._scaled_approach = np.empty(self.n)

    @classmethod
    def hertz(cls, material: Material, n: int, *, threads: int = 1) -> ContactArrays:
        """Plain elastic Hertz through the same structure (no dissipation)."""
        if n < 0:
            raise InputError(f"contacts: number of contacts must be >= 0, got {n}")
        _check_threads(threads)
        kh = hertz_coefficient(material)
        return cls(None, n, threads=threads, _core_contacts=_core.Contacts.hertz(kh, n, threads))

    @property
    def state(self) -> StateArrays:
        """The state arrays (views of the compiled core's memory), up to date: the step computes
        the envelope of a contact climbing the virgin curve (residual approach, n_u, n_r,
        cycles) only when it leaves the curve, so reading the state brings those of the
        contacts on the curve up to date first (the values the one-contact step would hold,
        bitwise; the step's results do not depend on whether or when the state is read)."""
        self._core.refresh_envelopes()
        return self._state

    @property
    def threads(self) -> int:
        return self._core.threads

    @threads.setter
    def threads(self, value: int) -> None:
        _check_threads(value)
        self._core.threads = value

    def step(self, approach: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Advance every contact to ``approach`` (m, shape (n,)); returns views of the force (N)
        and tangent stiffness (N/m) arrays, overwritten by the next call (without ``radii`` the
        force is the state's ``force`` field, a strided view of the core's per-contact
        records)."""
        approach = np.ascontiguousarray(approach, dtype=np.float64)
        if approach.shape != (self.n,):
            raise InputError(f"approach: expected shape ({self.n},), got {approach.shape}")
        if not np.all(np.isfinite(approach)):
            raise InputError("approach: must be finite numbers of metres (found NaN or inf)")
        return self._step(approach)

    def step_unchecked(self, approach: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``step`` without the finiteness check, for a DEM loop that guarantees finite input
        (a float64 array of shape (n,); other arrays are converted)."""
        return self._step(approach)

    def _step(self, approach: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        if self._scale is None:
            deepest = self._core.step(approach)
        else:
            np.divide(approach, self._scale, out=self._scaled_approach)
            deepest = self._core.step(self._scaled_approach)
            np.multiply(self._core.force, self._scale**2, out=self.force)
            np.multiply(self._core.stiffness, self._scale, out=self.stiffness)
        if deepest > self._range_top and not self._range_said:
            self._range_said = True
            # the warning names the caller of step / step_unchecked
            calibrated_range.report(self.range_excess(), self.beyond_range, stacklevel=4)
        return self.force, self.stiffness

    def range_excess(self) -> calibrated_range.RangeExcess | None:
        """The contacts whose envelope is beyond the law's calibrated depth and the largest
        delta_max/delta_y among them (one pass over the state); None if none is."""
        if math.isinf(self._range_top):
            return None
        depth = self._state.max_approach / self.params.yield_approach  # always current
        beyond = depth > self.params.calibrated_depth
        count = int(np.count_nonzero(beyond))
        return calibrated_range.excess(self.params, float(depth.max()) if count else 0.0,
                                       count, self.n)

    def _length(self, values: np.ndarray) -> np.ndarray:
        return values if self._scale is None else values * self._scale

    def _energy(self, values: np.ndarray) -> np.ndarray:
        return values if self._scale is None else values * self._scale**3

    def contact_radius(self) -> np.ndarray:
        """The contact radius of each contact (m; ``law.contact_radius``: the file's fit to the
        FE, else the unloading stiffness over 2 E*), computed by the compiled law."""
        if self.params is None:
            raise InputError("contact_radius: Hertz contacts have no law state; use "
                             "grain.hertz.contact_radius")
        out = np.empty(self.n)
        self._core.refresh_envelopes()
        self._core.contact_radius(out)
        return self._length(out)

    def reset(self) -> None:
        """Every contact back to untouched (as constructed)."""
        self._core.reset()
        self._range_said = False

    @property
    def max_approach(self) -> np.ndarray:
        s = self.state
        return self._length(s.max_approach + s.ratchet_shift)

    @property
    def residual_approach(self) -> np.ndarray:
        s = self.state
        return self._length(s.residual_approach + s.ratchet_shift)

    @property
    def cycles(self) -> np.ndarray:
        return self.state.cycles

    @property
    def work(self) -> np.ndarray:
        return self._energy(self.state.work)

    @property
    def elastic_energy(self) -> np.ndarray:
        s = self.state
        d = s.approach - s.ratchet_shift
        elastic = s.max_approach <= self._core.params.yield_approach
        base = np.where(elastic, 0.0, s.residual_approach)
        n = np.where(elastic, HERTZ_EXPONENT, s.unloading_exponent)
        return self._energy(np.where(s.force > 0.0, s.force * (d - base) / (n + 1.0), 0.0))

    @property
    def dissipated_energy(self) -> np.ndarray:
        if self._core.hertz_only:
            return np.zeros(self.n)
        return self.work - self.elastic_energy


def _scales(params: LawParams | None, radii, n: int) -> np.ndarray:
    """s = r / R per contact (two grains of radius r: law.hpp's pair_similarity), checked (one
    radius, or one per contact, each > 0)."""
    if params is None:
        raise InputError("radii: the Hertz floor takes no radii (build it for the material)")
    try:
        r = np.broadcast_to(np.asarray(radii, dtype=np.float64), (n,)).copy()
    except ValueError:
        raise InputError(f"radii: expected one radius or {n} (one per contact), got shape "
                         f"{np.shape(radii)}") from None
    if not np.all(np.isfinite(r) & (r > 0.0)):
        raise InputError("radii: every radius must be a finite number of metres > 0")
    scales = np.empty(n)
    _core.pair_similarity_scales(r, r, params.material.radius, scales)  # law.hpp owns the rule
    return scales


def _check_threads(threads) -> None:
    if isinstance(threads, bool) or not isinstance(threads, int) or threads < 1:
        raise InputError(f"threads: must be an integer >= 1, got {threads!r}")
