"""The law's contact radius fitted to the FE's (``contact_radius`` of the law file; the form is
in ``law/contact_radius.py`` and docs/law.md, "The contact radius").

Each calibration level is one FE run 0 -> F -> 0 -> F: at its peak the envelope ratio
r = a_max / sqrt(R* delta_max), and from the points of its unloading and reloading branches
(F/F_max in [0.02, 0.98], where the FE's contact is many surface elements wide) the shape
a / a_max = (f / (f + c (1 - f)))^q by least squares on ln a (scipy's ``least_squares``: the FE's
contact radius moves in steps of a surface element, so its relative error is what is even
across the branch). The levels become the knots, at their plastic depths. The errors recorded
are those of the law's radius against every FE point used: on the virgin curves (r interpolated
between the knots) and below the envelopes, and leave-one-out (each inner level predicted from
the table without it), which is what a depth between the levels gets.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares

from ..law.contact_radius import RadiusTable, radius_below_envelope

# branch points used for the shape: away from zero force (a few surface elements) and from the
# peak (the envelope itself)
FORCE_WINDOW = (0.02, 0.98)
START = (0.5, 1.0 / 3.0)  # (c, q); Hertz's is (1, 1/3)
BOUNDS = ((1e-3, 0.02), (100.0, 2.0))  # inside the schema's ranges


@dataclass(frozen=True)
class RadiusLevel:
    """What one FE level says about the contact radius."""

    max_approach: float  # delta_max (m)
    max_force: float  # F_max (N)
    max_radius: float  # the FE's a at the peak (m)
    loading_approach: np.ndarray  # virgin loading, 0 -> peak (m)
    loading_radius: np.ndarray
    branch_force: np.ndarray  # unloading then reloading, below the envelope (N)
    branch_radius: np.ndarray  # (m)

    def branch_points(self) -> tuple[np.ndarray, np.ndarray]:
        """(F/F_max, a/a_max) of the branch points the shape is fitted to."""
        f = self.branch_force / self.max_force
        a = self.branch_radius / self.max_radius
        keep = (f > FORCE_WINDOW[0]) & (f < FORCE_WINDOW[1]) & (a > 0.0)
        return f[keep], a[keep]


def level_from_curve(approach, force, radius, first: slice, second: slice) -> RadiusLevel:
    """The RadiusLevel of an FE run's curve: ``first`` the rows of the first cycle (0 -> F -> 0),
    ``second`` those of the reload (0 -> F)."""
    approach, force, radius = (np.asarray(v, dtype=float) for v in (approach, force, radius))
    peak = first.start + int(np.argmax(force[first]))
    repeak = second.start + int(np.argmax(force[second]))
    below = np.r_[peak + 1:first.stop, second.start:repeak]
    return RadiusLevel(float(approach[peak]), float(force[peak]), float(radius[peak]),
                       approach[first.start:peak + 1], radius[first.start:peak + 1],
                       force[below], radius[below])


def fit_shape(level: RadiusLevel) -> tuple[float, float] | None:
    """(c, q) of the level's branches; None with fewer than 4 points to fit."""
    f, a = level.branch_points()
    if f.size < 4:
        return None

    def residual(theta):
        return np.log(radius_below_envelope(1.0, f, *theta)) - np.log(a)

    return tuple(float(v) for v in least_squares(residual, START, bounds=BOUNDS).x)


def fit_contact_radius(levels: list[RadiusLevel], yield_approach: float,
                       effective_radius: float) -> tuple[RadiusTable, dict]:
    """The law's radius table from the FE levels, and its errors against them (an empty table
    and no errors when no level is plastic enough to have branches to fit)."""
    knots = []
    for level in sorted(levels, key=lambda lv: lv.max_approach):
        depth = level.max_approach / yield_approach
        shape = fit_shape(level) if depth > 1.0 else None
        if shape is None or (knots and depth <= knots[-1][0] * (1.0 + 1e-9)):
            continue
        ratio = level.max_radius / np.sqrt(effective_radius * level.max_approach)
        knots.append((depth, ratio, *shape))
    if not knots:
        return RadiusTable(), {}
    table = RadiusTable(*zip(*knots, strict=True))
    errors = {
        "virgin": _virgin_errors(table, levels, yield_approach, effective_radius),
        "below_envelope": _branch_errors(table, levels, yield_approach, effective_radius),
        "leave_one_out": _leave_one_out(knots, levels, yield_approach, effective_radius),
        "form": "a_max = r sqrt(R* delta_max); a = a_max (f / (f + c (1 - f)))^q, f = F/F_max "
                f"in {list(FORCE_WINDOW)} (law/contact_radius.py)",
    }
    return table, errors


def law_radius_below(table: RadiusTable, level: RadiusLevel, yield_approach: float,
                     effective_radius: float) -> tuple[np.ndarray, np.ndarray]:
    """(law's a, FE's a) at the level's fitted branch points."""
    f, a = level.branch_points()
    r, c, q = table.shape(level.max_approach / yield_approach)
    envelope = r * np.sqrt(effective_radius * level.max_approach)
    return radius_below_envelope(envelope, f, c, q), a * level.max_radius


def law_radius_virgin(table: RadiusTable, level: RadiusLevel, yield_approach: float,
                      effective_radius: float) -> tuple[np.ndarray, np.ndarray]:
    """(law's a, FE's a) on the level's virgin loading, where the FE's contact is past yield
    and past the first tenth of the peak force's radius (a few surface elements)."""
    d, a = level.loading_approach, level.loading_radius
    keep = (d > yield_approach) & (a > 0.1 * level.max_radius)
    r = table.shape(d[keep] / yield_approach)[0]
    return r * np.sqrt(effective_radius * d[keep]), a[keep]


def _summary(law: np.ndarray, fe: np.ndarray) -> dict[str, float]:
    relative = law / fe - 1.0
    return {"rms": float(np.sqrt(np.mean(relative**2))), "max": float(np.max(np.abs(relative))),
            "points": int(relative.size)}


def _virgin_errors(table, levels, yield_approach, effective_radius) -> list[dict]:
    out = []
    for level in levels:
        law, fe = law_radius_virgin(table, level, yield_approach, effective_radius)
        if law.size:
            out.append({"peak_force_N": level.max_force, **_summary(law, fe)})
    return out


def _branch_errors(table, levels, yield_approach, effective_radius) -> list[dict]:
    out = []
    for level in levels:
        if level.max_approach <= yield_approach:
            continue
        law, fe = law_radius_below(table, level, yield_approach, effective_radius)
        if law.size:
            out.append({"peak_force_N": level.max_force, **_summary(law, fe)})
    return out


def _leave_one_out(knots, levels, yield_approach, effective_radius) -> list[dict]:
    by_depth = {lv.max_approach / yield_approach: lv for lv in levels}
    out = []
    for k in range(len(knots) - 1):  # the deepest knot has nothing beyond it to interpolate
        rest = knots[:k] + knots[k + 1:]
        table = RadiusTable(*zip(*rest, strict=True))
        level = by_depth[knots[k][0]]
        law, fe = law_radius_below(table, level, yield_approach, effective_radius)
        out.append({"peak_force_N": level.max_force, **_summary(law, fe)})
    return out
