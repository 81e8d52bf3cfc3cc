"""Law parameters: the versioned JSON document ``geocontact.law/1`` (docs/interfaces.md,
docs/model.md §6).

Dimensionless plastic depth ``x = max(delta_max / delta_y, 1)``. Fitted forms (docs/law.md):

* virgin loading (docs/model.md §6): ``F = Kh d^1.5`` (d <= dy), ``Fy (d/dy)^n1`` (dy < d <= dp),
  ``Fp (d/dp)^n2`` (d > dp), with ``dp = (fully_plastic_approach_ratio) * dy``;
* unloading exponent ``n_u(x) = 1.5 x^pu`` (tends to 3/2 as x -> 1, Etsion et al. 2005 form);
* reloading exponent ``n_r(x) = min(1.5 x^pr, n_u(x))`` (a reload curve never lies below the
  unload curve, so a closed reload-unload loop cannot create energy);
* residual approach ``d_res / d_max = rho_inf (1 - (1 + (x - 1)/x0)^-s)`` (zero at yield,
  below 1 everywhere; x0 = 1 is the original ``rho_inf (1 - x^-s)``, a larger transition depth
  x0 gives the slow start and log-like rise the FE shows), or tabulated: a monotone cubic
  through knots in (ln ln x, logit rho) (``residual_table.ResidualTable``);
* plastic work ratio ``Wp / W_total = w_inf (1 - (1 + (x - 1)/x0w)^-e)`` (the FE's; reported
  beside the law's own loop area, which follows from the curves above);
* cyclic extension: residual-approach increment of cycle N over the first cycle's residual
  approach ``c N^-p`` (N >= 2, so c may exceed 1 as long as the cycle-2 ratio ``c 2^-p <= 1``);
  critical cycle number where it falls below ``tolerance``.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .. import schema
from .._version import __version__
from ..errors import InputError
from ..files import read_text_input, write_text_atomic
from ..grain.hertz import hertz_coefficient
from ..grain.material import Material
from ..schema import finite_number
from . import _core
from .contact_radius import RadiusTable
from .residual_table import ResidualTable

SCHEMA = schema.law_schema()["schema"]
HERTZ_EXPONENT = 1.5
# Grid of plastic depths on which a parameter set is checked for energy consistency.
# 1e7 covers the deepest calibrations (sigma_c = 1 MPa at 6000 N reaches x ~ 2e5).
_CHECK_DEPTHS = np.geomspace(1.0, 1.0e7, 3001)


def saturating_ratio(depth, limit: float, power: float, transition: float = 1.0,
                     log_power: float = 1.0):
    """``limit (1 - exp(-power L^b))`` with ``L = log(1 + (x - 1)/transition)`` and
    ``b = log_power``: zero at x = 1, rising to ``limit``.

    With b = 1 it is ``limit (1 - (1 + (x - 1)/transition)^-power)``, and with transition = 1
    too exactly the original ``limit (1 - x^-power)`` (log x, as before). b > 1 stretches the
    rise over more decades of depth (the recovery of a weak sphere keeps shrinking from x ~ 10
    to 10^5). Written with expm1/log1p so it is accurate just above yield, where it is tiny."""
    x = np.maximum(depth, 1.0)
    lx = np.log(x) if transition == 1.0 else np.log1p((x - 1.0) / transition)
    if log_power != 1.0:
        lx = lx**log_power
    return -limit * np.expm1(-power * lx)


def power_law_critical_cycle(coefficient: float, power: float, tolerance: float) -> int | None:
    """First cycle N >= 2 from which the ratio c N^-p stays below ``tolerance``; None if it
    never does (p < 0: the ratio grows, so it leaves any tolerance; p = 0 above it) or only
    beyond 1e15 cycles. (A law file's powers are positive; the analyses' fits of FE cycles can
    rise, e.g. over a ratchet's onset.)"""
    if power < 0.0:
        return None
    if coefficient <= tolerance:
        return 2
    if power == 0.0:
        return None
    log_n = math.log(coefficient / tolerance) / power
    if log_n > math.log(1e15):
        return None
    return max(2, math.ceil(math.exp(log_n)))


# Forms of the cyclic extension (docs/law.md, "Repeated cycles"). TRUNCATED, the original (files
# without ``cyclic.form``): increments c N^-p, zero once below the tolerance; every closed cycle
# loops along the fitted n_r(x). SHAKEDOWN: increments c N^-p in every cycle (their sum
# converges for p > 1), and the dissipation of closed cycle N is the plastic-work ratio law
# c_w N^-p_w times cycle 1's, through the main reloading exponent (it tends to n_u: the loop
# closes, elastic shakedown as in the FE).
TRUNCATED, SHAKEDOWN = "truncated", "shakedown"


@dataclass(frozen=True)
class CyclicLaw:
    """Optional ratchetting and shakedown extension (docs/model.md §6): per-cycle residual-approach
    increments and, in the shakedown form, per-cycle loop dissipation."""

    enabled: bool = False
    residual_ratio_coefficient: float = 0.0
    residual_ratio_power: float = 1.0
    plastic_work_ratio_coefficient: float = 0.0
    plastic_work_ratio_power: float = 1.0
    tolerance: float = 0.01
    form: str = TRUNCATED

    @property
    def shakedown(self) -> bool:
        return self.enabled and self.form == SHAKEDOWN

    def residual_ratio(self, cycle: float) -> float:
        """Increment of residual approach in cycle N (N >= 2) over the first cycle's residual."""
        if cycle < 2.0:
            return 0.0
        ratio = self.residual_ratio_coefficient * cycle ** (-self.residual_ratio_power)
        return ratio if self.form == SHAKEDOWN or ratio >= self.tolerance else 0.0

    def plastic_work_ratio(self, cycle: float) -> float:
        """Dissipation of closed cycle N (N >= 2) over cycle 1's (the shakedown form's loops)."""
        if cycle < 2.0:
            return 1.0
        return self.plastic_work_ratio_coefficient * cycle ** (-self.plastic_work_ratio_power)

    def critical_cycle(self) -> int | None:
        """First cycle whose residual-approach increment ratio is below the tolerance."""
        return power_law_critical_cycle(self.residual_ratio_coefficient,
                                        self.residual_ratio_power, self.tolerance)

    def plastic_work_critical_cycle(self) -> int | None:
        """First cycle whose plastic-work ratio is below the tolerance."""
        return power_law_critical_cycle(self.plastic_work_ratio_coefficient,
                                        self.plastic_work_ratio_power, self.tolerance)

    def to_dict(self) -> dict[str, Any]:
        return {
            "enabled": self.enabled,
            "residual_ratio": {"coefficient": self.residual_ratio_coefficient,
                               "power": self.residual_ratio_power},
            "plastic_work_ratio": {"coefficient": self.plastic_work_ratio_coefficient,
                                   "power": self.plastic_work_ratio_power},
            "tolerance": self.tolerance,
            # optional key, written when not the default (files without it are truncated)
            **({"form": self.form} if self.form != TRUNCATED else {}),
        }

    def check_second_cycle(self) -> None:
        """The ratios c N^-p apply from cycle 2 on: c may exceed 1 only while c 2^-p <= 1."""
        for key in ("residual_ratio", "plastic_work_ratio"):
            second = (getattr(self, f"{key}_coefficient")
                      * 2.0 ** (-getattr(self, f"{key}_power")))
            if second > 1.0:
                raise InputError(f"cyclic.{key}: the cycle-2 ratio coefficient * 2^-power must "
                                 f"be in [0, 1], got {second:g}")


# Powers of the scale s = r / R of a quantity, by the unit suffix of its key (docs/model.md §10).
_SIMILARITY_POWERS = {"_N": 2, "_m": 1, "_J": 3, "_N_per_m": 1}


def _scale_by_unit(value: Any, s: float, power: int = 0) -> Any:
    """A copy of a JSON-like record with every number scaled by s^power, power from the unit
    suffix of the key it stands under (nested under a key without one: unchanged)."""
    if isinstance(value, dict):
        out = {}
        for key, item in value.items():
            suffix = max((u for u in _SIMILARITY_POWERS if str(key).endswith(u)), key=len,
                         default=None)
            out[key] = _scale_by_unit(item, s, _SIMILARITY_POWERS[suffix] if suffix else power)
        return out
    if isinstance(value, list):
        return [_scale_by_unit(v, s, power) for v in value]
    if isinstance(value, (int, float)) and not isinstance(value, bool) and power:
        return value * s**power
    return value


# At most this many virgin-curve segments (the schema's; the C++ header's
# LawParams::kMaxSegments holds them, params.hpp checks the two agree).
MAX_SEGMENTS = int(schema.field("loading.segments.depth")["maxItems"])


def _check_segments(depth, exponent) -> tuple[tuple[float, ...], tuple[float, ...]]:
    """``loading.segments`` held to the file's rules (the schema's messages, as a document
    read by either reader gets them), plus the rule between its entries: the first segment
    starts at yield."""
    depth = schema.check_array("loading.segments.depth", depth,
                               schema.field("loading.segments.depth"))
    exponent = schema.check_array("loading.segments.exponent", exponent,
                                  schema.field("loading.segments.exponent"),
                                  {"loading.segments.depth": depth})
    if depth[0] != 1.0:
        raise InputError(f"loading.segments.depth[0]: the first segment starts at yield, "
                         f"must be 1, got {depth[0]:g}")
    return depth, exponent


@dataclass(frozen=True)
class LoadingSegments:
    """The virgin curve as power-law segments (``loading.segments``): segment k starts at the
    plastic depth ``depth[k]`` (``depth[0]`` = 1, yield) with exponent ``exponent[k]``
    (empty: the law uses the regimes)."""

    depth: tuple[float, ...] = ()
    exponent: tuple[float, ...] = ()

    def __post_init__(self) -> None:
        object.__setattr__(self, "depth", tuple(float(v) for v in self.depth))
        object.__setattr__(self, "exponent", tuple(float(v) for v in self.exponent))

    def __bool__(self) -> bool:
        return bool(self.depth)


@dataclass(frozen=True)
class _Segments:
    """Starts of the virgin curve's power-law segments: approach x_k delta_y, force F_k
    (F_0 = Fy, F_k+1 = F_k (x_k+1/x_k)^n_k), exact virgin work W_k there (a power law's work
    is (F d - F_start d_start) / (n + 1)); the C++ header's
    LawParams::derive_segments, the same operations."""

    approach: np.ndarray
    exponent: np.ndarray
    force: np.ndarray
    work: np.ndarray

    @classmethod
    def of(cls, depth, exponent, yield_approach: float, yield_force: float) -> _Segments:
        force, work = [yield_force], [yield_force * yield_approach / (HERTZ_EXPONENT + 1.0)]
        for k in range(1, len(depth)):
            ratio, n = depth[k] / depth[k - 1], exponent[k - 1]
            force.append(force[-1] * ratio**n)
            work.append(work[-1] + (force[-1] * depth[k] - force[-2] * depth[k - 1])
                        * yield_approach / (n + 1.0))
        return cls(approach=np.asarray(depth, dtype=float) * yield_approach,
                   exponent=np.asarray(exponent, dtype=float),
                   force=np.asarray(force), work=np.asarray(work))

    def index(self, approach):
        """Segment k of each approach: x_k delta_y < d <= x_k+1 delta_y (0 at or below yield)."""
        return np.maximum(np.searchsorted(self.approach, approach, side="left") - 1, 0)


@dataclass(frozen=True)
class LawParams:
    """Every parameter of the law, with the material and incipient yield it belongs to."""

    material: Material
    yield_approach: float
    elastic_plastic_exponent: float
    fully_plastic_approach_ratio: float
    fully_plastic_exponent: float
    unloading_power: float
    reloading_power: float
    # the closed residual form (limit, power, transition, log power; the defaults stand for the
    # unused values beside a table, as in the file)
    residual_limit: float = 0.0
    residual_power: float = 1.0
    plastic_work_limit: float = 0.0
    plastic_work_power: float = 1.0
    residual_transition: float = 1.0
    plastic_work_transition: float = 1.0
    residual_log_power: float = 1.0
    plastic_work_log_power: float = 1.0
    # optional third loading regime beyond delta_q = deep_ratio delta_y: F = Fq (d/dq)^n3
    deep_plastic_approach_ratio: float = math.inf
    deep_plastic_exponent: float = 1.0
    # optional: the virgin curve as power-law segments (``loading.segments``; empty: the
    # regimes above); with them the regime fields mirror its first three segments
    loading_segments: LoadingSegments = field(default_factory=LoadingSegments)
    cyclic: CyclicLaw = field(default_factory=CyclicLaw)
    # the tabulated residual form instead of the closed one (empty: the closed form)
    residual_table: ResidualTable = field(default_factory=ResidualTable)
    # the contact radius fitted to the FE (``contact_radius``; empty: a from the unloading
    # stiffness, Sneddon; law/contact_radius.py)
    radius_table: RadiusTable = field(default_factory=RadiusTable)
    yield_extra: dict[str, Any] = field(default_factory=dict)
    # how deep the law was calibrated (``calibrated_range``, docs/law.md): the largest
    # delta_max/delta_y of its data, beyond which the fitted forms extrapolate (inf: not
    # recorded, nothing is checked), and the file's other keys there (max_force_N, ...)
    calibrated_depth: float = math.inf
    calibrated_range_extra: dict[str, Any] = field(default_factory=dict)
    provenance: dict[str, Any] = field(default_factory=dict)
    fit_errors: dict[str, Any] = field(default_factory=dict)
    label: str = ""

    def __post_init__(self) -> None:
        if not math.isinf(self.calibrated_depth):  # a range set in code: the file's rule
            schema.check_number("calibrated_range.max_depth", self.calibrated_depth,
                                schema.field("calibrated_range.max_depth"))
        if self.loading_segments:
            depth, exponent = _check_segments(self.loading_segments.depth,
                                              self.loading_segments.exponent)
            mirror = {"elastic_plastic_exponent": exponent[0],
                      "fully_plastic_approach_ratio": depth[1],
                      "fully_plastic_exponent": exponent[1],
                      "deep_plastic_approach_ratio": depth[2] if len(depth) > 2 else math.inf,
                      "deep_plastic_exponent": exponent[2] if len(depth) > 2 else 1.0}
            for name, value in mirror.items():
                object.__setattr__(self, name, value)
        if self.residual_table:
            # a table built in code is held to the file's rules (schema messages)
            table = self.residual_table
            depth = schema.check_array("residual_approach.table.depth", table.depth,
                                       schema.field("residual_approach.table.depth"))
            schema.check_array("residual_approach.table.ratio", table.ratio,
                               schema.field("residual_approach.table.ratio"),
                               {"residual_approach.table.depth": depth})
            # beside a table the closed form's fields hold their (unused) defaults, as a file
            # read with one does: a law is one set of values, whichever way it was made
            for key in ("limit", "power", "transition_depth", "log_power"):
                spec = schema.field(f"residual_approach.{key}")
                object.__setattr__(self, spec["name"], schema.default(spec))
        if self.radius_table:  # a table built in code is held to the file's rules
            knots = {"contact_radius.depth": schema.check_array(
                "contact_radius.depth", self.radius_table.depth,
                schema.field("contact_radius.depth"))}
            for name in ("envelope_ratio", "unloading_offset", "unloading_power"):
                path = f"contact_radius.{name}"
                schema.check_array(path, getattr(self.radius_table, name), schema.field(path),
                                   knots)
        self._check_energy()

    @property
    def residual_tabulated(self) -> bool:
        """Whether the residual ratio is the table (else the closed saturating form)."""
        return bool(self.residual_table)

    def residual_closed_form(self, needed_by: str) -> tuple[float, float, float, float]:
        """(limit, power, transition, log power) of the closed residual form, for code that
        works on those parameters (``needed_by`` says which); a tabulated law has none: a
        one-line InputError."""
        if self.residual_table:
            raise InputError(f"residual_approach: {needed_by} needs the closed form (limit, "
                             "power, transition_depth, log_power); this law tabulates it "
                             "(residual_approach.table)")
        return (self.residual_limit, self.residual_power, self.residual_transition,
                self.residual_log_power)

    @property
    def calibrated_range(self) -> dict[str, Any]:
        """The file's ``calibrated_range`` block (empty when not recorded)."""
        if math.isinf(self.calibrated_depth):
            return {}
        return {"max_depth": self.calibrated_depth, **self.calibrated_range_extra}

    @property
    def calibrated_approach(self) -> float:
        """delta_max of the deepest calibrated level, max_depth delta_y (m; inf: not recorded)."""
        return self.calibrated_depth * self.yield_approach

    # --- derived constants ---------------------------------------------------------------
    @property
    def hertz_coefficient(self) -> float:
        """Kh of F = Kh delta^1.5 for two identical spheres (docs/model.md §4)."""
        return hertz_coefficient(self.material)

    @property
    def yield_force(self) -> float:
        # Fy from the same Hertz formula, so the virgin curve is continuous at delta_y exactly.
        return self.hertz_coefficient * self.yield_approach**HERTZ_EXPONENT

    @property
    def fully_plastic_approach(self) -> float:
        return self.fully_plastic_approach_ratio * self.yield_approach

    @property
    def fully_plastic_force(self) -> float:
        return self.yield_force * self.fully_plastic_approach_ratio**self.elastic_plastic_exponent

    # --- similarity (docs/model.md §10) -----------------------------------------------------------
    def for_radius(self, radius: float) -> LawParams:
        """The law of two identical spheres of radius ``radius`` of the same material.

        The rate-independent continuum problem has no length scale: with s = r / R the
        spheres of radius r are those of radius R scaled by s, so F_r(delta) = s^2 F_R(delta / s),
        energies scale by s^3 and every approach by s. The law's only length is delta_y (its
        other parameters are functions of delta / delta_y), so scaling delta_y and the radius
        is the whole rescaling; the recorded yield values and fit errors scale with their units
        (``_N`` s^2, ``_m`` s, ``_J`` s^3). Exact for any history (tests/test_law_similarity.py;
        the FE itself: tests/test_fem_similarity.py)."""
        from dataclasses import replace

        radius = finite_number("radius", radius)
        material = self.material.with_(radius=radius)  # the material's own radius range
        # two grains of radius r: law.hpp's similarity rule, its one owner (the binding)
        s = _core.pair_similarity(radius, radius, self.material.radius).scale
        similarity = {"from_radius_m": self.material.radius, "scale": s,
                      "rule": "F_r(d) = s^2 F_R(d / s), s = r / R (docs/model.md §10)"}
        return replace(self, material=material, yield_approach=s * self.yield_approach,
                       yield_extra=_scale_by_unit(self.yield_extra, s),
                       calibrated_range_extra=_scale_by_unit(self.calibrated_range_extra, s),
                       fit_errors=_scale_by_unit(self.fit_errors, s),
                       provenance={**self.provenance, "similarity": similarity})

    # --- the fitted functions of the plastic depth x = delta_max / delta_y ----------------
    def unloading_exponent(self, depth):
        x = np.maximum(depth, 1.0)
        return HERTZ_EXPONENT * x**self.unloading_power

    def reloading_exponent(self, depth):
        x = np.maximum(depth, 1.0)
        return np.minimum(HERTZ_EXPONENT * x**self.reloading_power, self.unloading_exponent(x))

    def residual_ratio(self, depth):
        if self.residual_table:
            return self.residual_table(depth)
        return saturating_ratio(depth, self.residual_limit, self.residual_power,
                                self.residual_transition, self.residual_log_power)

    def plastic_work_ratio(self, depth):
        """The FE's Wp/W_total fitted as a function of depth (diagnostic, docs/model.md §6)."""
        return saturating_ratio(depth, self.plastic_work_limit, self.plastic_work_power,
                                self.plastic_work_transition, self.plastic_work_log_power)

    @property
    def deep_plastic_approach(self) -> float:
        """delta_q, start of the optional third loading regime (inf without one)."""
        return self.deep_plastic_approach_ratio * self.yield_approach

    @property
    def deep_plastic_force(self) -> float:
        """F at delta_q (inf without a third regime)."""
        if math.isinf(self.deep_plastic_approach_ratio):
            return math.inf
        return self.fully_plastic_force * (
            self.deep_plastic_approach_ratio / self.fully_plastic_approach_ratio
        ) ** self.fully_plastic_exponent

    @property
    def segments(self) -> _Segments:
        """The virgin curve's power-law segments beyond delta_y (from ``loading_segments`` or
        the regimes: (1, n1), (r_p, n2)[, (r_q, n3)])."""
        cached = self.__dict__.get("_segments")
        if cached is None:
            if self.loading_segments:
                depth, exponent = self.loading_segments.depth, self.loading_segments.exponent
            else:
                depth, exponent = [1.0, self.fully_plastic_approach_ratio], [
                    self.elastic_plastic_exponent, self.fully_plastic_exponent]
                if math.isfinite(self.deep_plastic_approach_ratio):
                    depth.append(self.deep_plastic_approach_ratio)
                    exponent.append(self.deep_plastic_exponent)
            cached = _Segments.of(depth, exponent, self.yield_approach, self.yield_force)
            object.__setattr__(self, "_segments", cached)
        return cached

    def virgin_force(self, approach):
        """Virgin loading curve F(delta): Hertz, then the power-law segments, continuous at
        delta_y and at every segment's start."""
        d = np.maximum(np.asarray(approach, dtype=float), 0.0)
        seg = self.segments
        k = seg.index(d)
        with np.errstate(invalid="ignore", over="ignore", divide="ignore"):
            return np.where(d <= self.yield_approach,
                            self.hertz_coefficient * d**HERTZ_EXPONENT,
                            seg.force[k] * (d / seg.approach[k]) ** seg.exponent[k])

    def virgin_work(self, approach):
        """Work of the force along the virgin curve from 0 to delta (exact integral)."""
        d = np.maximum(np.asarray(approach, dtype=float), 0.0)
        seg = self.segments
        k = seg.index(d)
        n = seg.exponent[k]
        with np.errstate(invalid="ignore", over="ignore", divide="ignore"):
            return np.where(
                d <= self.yield_approach,
                self.hertz_coefficient * d ** (HERTZ_EXPONENT + 1.0) / (HERTZ_EXPONENT + 1.0),
                seg.work[k] + seg.force[k] * seg.approach[k] / (n + 1.0)
                * ((d / seg.approach[k]) ** (n + 1.0) - 1.0))

    def virgin_exponent(self, approach: float) -> float:
        """Local log-slope d ln F / d ln delta of the virgin curve at ``approach``."""
        d = float(approach)
        if d <= self.yield_approach:
            return HERTZ_EXPONENT
        seg = self.segments
        return float(seg.exponent[seg.index(d)])

    def virgin_approach(self, force: float) -> float:
        """Inverse of the virgin loading curve: the approach at which it carries ``force``."""
        f = float(force)
        if f <= 0.0:
            return 0.0
        if f <= self.yield_force:
            return (f / self.hertz_coefficient) ** (1.0 / HERTZ_EXPONENT)
        seg = self.segments
        k = int(np.searchsorted(seg.force, f, side="left")) - 1
        return float(seg.approach[k] * (f / seg.force[k]) ** (1.0 / seg.exponent[k]))

    def envelope_plastic_work(self, max_approach):
        """Plastic work of a full load-unload cycle to delta_max, as the law computes it:
        the virgin work minus what the unloading curve gives back, Fmax (dmax - dres)/(n_u + 1)."""
        dmax = np.asarray(max_approach, dtype=float)
        x = dmax / self.yield_approach
        returned = (self.virgin_force(dmax) * dmax * (1.0 - self.residual_ratio(x))
                    / (self.unloading_exponent(x) + 1.0))
        return self.virgin_work(dmax) - returned

    def _check_energy(self) -> None:
        """Reject parameter sets whose full-cycle plastic work is negative or shrinks with depth:
        such a law would give back more energy than it took (docs/model.md §6, dissipation >= 0)."""
        dmax = _CHECK_DEPTHS * self.yield_approach
        wp = self.envelope_plastic_work(dmax) / (self.yield_force * self.yield_approach)
        bad = np.flatnonzero((wp < -1e-9) | (np.diff(wp, prepend=wp[0]) < -1e-9))
        if bad.size:
            x = _CHECK_DEPTHS[bad[0]]
            what = ("the ratios of residual_approach.table" if self.residual_table
                    else "residual_approach.limit")
            raise InputError(
                "unloading/residual_approach: this parameter set creates energy (the cycle's "
                f"plastic work decreases) at delta_max/delta_y = {x:.4g}; "
                f"raise {what} or lower loading.elastic_plastic_exponent"
            )

    # --- JSON ----------------------------------------------------------------------------
    def to_dict(self) -> dict[str, Any]:

        ydict = {
            **self.yield_extra,
            "approach_m": self.yield_approach,
            "force_N": self.yield_force,
        }
        return {
            "schema": SCHEMA,
            "label": self.label,
            "material": self.material.to_dict(),
            "yield": ydict,
            "loading": {"segments": {
                "depth": list(self.loading_segments.depth),
                "exponent": list(self.loading_segments.exponent)}}
            if self.loading_segments else {
                "elastic_plastic_exponent": self.elastic_plastic_exponent,
                "fully_plastic_approach_ratio": self.fully_plastic_approach_ratio,
                "fully_plastic_exponent": self.fully_plastic_exponent,
                "fully_plastic_approach_m": self.fully_plastic_approach,
                "fully_plastic_force_N": self.fully_plastic_force,
                **({} if math.isinf(self.deep_plastic_approach_ratio) else {
                    "deep_plastic_approach_ratio": self.deep_plastic_approach_ratio,
                    "deep_plastic_exponent": self.deep_plastic_exponent,
                    "deep_plastic_approach_m": self.deep_plastic_approach,
                    "deep_plastic_force_N": self.deep_plastic_force}),
            },
            "unloading": {"exponent_power": self.unloading_power},
            "reloading": {"exponent_power": self.reloading_power},
            "residual_approach": ({"table": self.residual_table.to_dict()}
                                  if self.residual_table else
                                  _saturating_dict(self.residual_limit, self.residual_power,
                                                   self.residual_transition,
                                                   self.residual_log_power)),
            "plastic_work": _saturating_dict(self.plastic_work_limit, self.plastic_work_power,
                                             self.plastic_work_transition,
                                             self.plastic_work_log_power),
            "cyclic": {**self.cyclic.to_dict(), "critical_cycle": self.cyclic.critical_cycle()},
            # optional blocks, written when recorded (files without them read as before)
            **({"contact_radius": self.radius_table.to_dict()} if self.radius_table else {}),
            **({"calibrated_range": self.calibrated_range} if self.calibrated_range else {}),
            "provenance": {"geocontact_version": __version__, **self.provenance},
            "fit_errors": self.fit_errors,
        }

    def to_json(self) -> str:
        """The parameter file's text (what ``save`` writes)."""
        return json.dumps(self.to_dict(), indent=2) + "\n"

    def save(self, path: str | Path) -> None:
        """Write atomically (temporary file, then rename)."""
        write_text_atomic(path, self.to_json())

    @classmethod
    def from_dict(cls, data: dict[str, Any], *, source: str = "parameters") -> LawParams:
        """From a parsed ``geocontact.law/1`` document: every field checked against the schema
        (``geocontact.schema``, the same table and messages as the C++ reader), then the rules
        between fields. ``source`` is kept for callers; messages name the fields."""
        values = schema.validate(data)
        groups: dict[str, dict[str, Any]] = {"material": {}, "cyclic": {}, "residual_table": {},
                                             "loading_segments": {}, "radius_table": {}}
        top: dict[str, Any] = {}
        for name, value in schema.named_values(values).items():
            group, _, attribute = name.rpartition(".")
            (groups[group] if group else top)[attribute] = value
        segments = LoadingSegments(**groups["loading_segments"])
        if segments:  # the regime fields are left out: they mirror the first segments
            top.update(elastic_plastic_exponent=segments.exponent[0],
                       fully_plastic_approach_ratio=segments.depth[1],
                       fully_plastic_exponent=segments.exponent[1])
        ratio_p = top["fully_plastic_approach_ratio"]
        if top["deep_plastic_approach_ratio"] <= ratio_p:
            raise InputError(
                "loading.deep_plastic_approach_ratio: must be above "
                f"loading.fully_plastic_approach_ratio ({ratio_p:g}), got "
                f"{top['deep_plastic_approach_ratio']:g}")
        cyclic = CyclicLaw(**groups["cyclic"])
        cyclic.check_second_cycle()
        params = cls(material=Material(**groups["material"]), cyclic=cyclic,
                     residual_table=ResidualTable(**groups["residual_table"]),
                     radius_table=RadiusTable(**groups["radius_table"]),
                     loading_segments=segments,
                     yield_extra=values["yield.*"],
                     calibrated_range_extra=values.get("calibrated_range.*", {}), **top)
        if "yield.force_N" in values:
            given = values["yield.force_N"]
            if abs(given - params.yield_force) > 1e-6 * params.yield_force:
                raise InputError(
                    f"yield.force_N: {given:.6g} N disagrees with Hertz at yield.approach_m "
                    f"({params.yield_force:.6g} N); the two must describe the same point"
                )
        return params


def _saturating_dict(limit: float, power: float, transition: float,
                     log_power: float = 1.0) -> dict[str, float]:
    # transition_depth = 1 and log_power = 1 (the original form) are left out: such files
    # read as before
    out = {"limit": limit, "power": power}
    if transition != 1.0:
        out["transition_depth"] = transition
    if log_power != 1.0:
        out["log_power"] = log_power
    return out


NON_FINITE_LITERALS = ("-Infinity", "Infinity", "NaN")


def non_finite_literal(text: str, source: str) -> None:
    """JSON has no NaN or infinity, but ``json.loads`` reads the literals NaN, Infinity and
    -Infinity: refuse them first, in one line with their place, the message the C++ reader
    gives (params.hpp, reject_non_finite_literals), so the two readers never disagree."""
    in_string, line, line_start, i = False, 1, 0, 0
    while i < len(text):
        c = text[i]
        if c == "\n":
            line, line_start = line + 1, i + 1
        elif in_string:
            if c == "\\":
                i += 1
            elif c == '"':
                in_string = False
        elif c == '"':
            in_string = True
        else:
            for literal in NON_FINITE_LITERALS:
                if text.startswith(literal, i):
                    raise InputError(f"params: malformed JSON in {source}: {literal} at line "
                                     f"{line} column {i - line_start + 1} (JSON has no NaN or "
                                     "infinity; give a finite number)")
        i += 1


def load_params(path: str | Path) -> LawParams:
    """Read and validate a ``geocontact.law/1`` parameter file."""
    text = read_text_input(path, "params")
    non_finite_literal(text, str(path))
    try:
        data = json.loads(text)
    except json.JSONDecodeError as exc:
        raise InputError(
            f"params: malformed JSON in {path}: {exc.msg} at line {exc.lineno}"
        ) from None
    except RecursionError:
        raise InputError(f"params: malformed JSON in {path}: nested too deeply") from None
    return LawParams.from_dict(data, source="params")
