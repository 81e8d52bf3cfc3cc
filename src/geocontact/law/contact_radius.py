"""The law's contact radius (docs/law.md, "The contact radius").

The tangential stiffness (8 G* a), the damping and the outputs of a DEM contact use the contact
radius a. Without a fit, the law takes it from its unloading stiffness S through Sneddon's
S = 2 E* a, exact for an elastic axisymmetric contact (sqrt(R* delta) while Hertz) but 0.75-1.18
times the FE's on the weak grain's committed runs once the contact is plastic: the flattened,
conforming dent keeps a wider contact than its stiffness says near the peak and a narrower one
low on the unloading branch.

A law file can carry the FE's radius instead (the optional block ``contact_radius``, fitted by
``calibrate.contact_radius``). At the plastic depth x = delta_max/delta_y:

    a_max = r(x) sqrt(R* delta_max)                       on the envelope,
    a = a_max (f / (f + c(x) (1 - f)))^q(x),  f = F/F_max  below it (unloading, reloading).

The form reads: at small f, a = a_max (f/c)^q, Hertz's a ~ F^(1/3) from the flattened dent when
q = 1/3; near f = 1 the dent stays in contact (a -> a_max) the more, the smaller c. At x = 1
(elastic) (r, c, q) = (1, 1, 1/3) gives a = sqrt(R* delta), Hertz exactly, so the radius is
continuous at first yield. Between knots the three are linear in ln x (from the Hertz point at
x = 1 to the first knot); beyond the last knot its values hold (``calibrated_range`` says when a
contact is that deep). The C++ header (``RadiusTable``, ``contact_radius`` in
``plugins/lammps/include/geocontact/law.hpp``) is the same, operation for operation.
"""

from __future__ import annotations

from dataclasses import dataclass, fields
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from .kernel import StateArrays
    from .params import LawParams

HERTZ_SHAPE = (1.0, 1.0, 1.0 / 3.0)  # (r, c, q) of an elastic contact


@dataclass(frozen=True)
class RadiusTable:
    """Knots of the fitted contact radius (empty: the law uses its stiffness, Sneddon)."""

    depth: tuple[float, ...] = ()  # x_k = delta_max / delta_y, > 1, increasing
    envelope_ratio: tuple[float, ...] = ()  # r_k = a_max / sqrt(R* delta_max)
    unloading_offset: tuple[float, ...] = ()  # c_k
    unloading_power: tuple[float, ...] = ()  # q_k

    def __post_init__(self) -> None:
        # tuples (hashable, frozen); the entries are checked by LawParams with the schema's
        # messages
        for f in fields(self):
            object.__setattr__(self, f.name, tuple(getattr(self, f.name)))

    def __bool__(self) -> bool:
        return bool(self.depth)

    def shape(self, depth) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(r, c, q) at the plastic depths ``depth`` (vectorised)."""
        x = np.asarray(depth, dtype=float)
        knots = np.array((1.0, *self.depth))
        lx = np.log(np.clip(x, 1.0, knots[-1]))
        columns = zip(HERTZ_SHAPE, (self.envelope_ratio, self.unloading_offset,
                                    self.unloading_power), strict=True)
        return tuple(np.interp(lx, np.log(knots), np.array((h, *k))) for h, k in columns)

    def to_dict(self) -> dict[str, list[float]]:
        return {f.name: list(getattr(self, f.name)) for f in fields(self)}


def radius_below_envelope(max_radius, force_ratio, offset, power):
    """a of the form a_max (f / (f + c (1 - f)))^q (vectorised; f clipped to [0, 1])."""
    f = np.clip(np.asarray(force_ratio, dtype=float), 0.0, 1.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        return max_radius * np.where(f > 0.0, (f / (f + offset * (1.0 - f))) ** power, 0.0)


def contact_radius(params: LawParams, state: StateArrays) -> np.ndarray:
    """The contact radius (m) of contacts in ``state`` under the law ``params``: its fit when the
    file has one, else the unloading stiffness over 2 E* (module docstring)."""
    force = np.asarray(state.force, dtype=float)
    touching = force > 0.0
    if not params.radius_table:
        d = state.approach - state.ratchet_shift
        plastic = state.max_approach > params.yield_approach
        gap = np.where(plastic, d - state.residual_approach, d)
        exponent = np.where(plastic, state.unloading_exponent, 1.5)
        with np.errstate(divide="ignore", invalid="ignore"):
            stiffness = np.where(touching & (gap > 0.0), exponent * force / gap, 0.0)
        return stiffness / (2.0 * params.material.effective_modulus)
    r, c, q = params.radius_table.shape(state.max_approach / params.yield_approach)
    envelope = r * np.sqrt(params.material.effective_radius * state.max_approach)
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(touching, force / state.max_force, 0.0)
    return np.where(touching, radius_below_envelope(envelope, ratio, c, q), 0.0)
