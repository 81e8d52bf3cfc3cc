"""No silent extrapolation: a contact loaded beyond the depth its law was calibrated to.

A law file's ``calibrated_range.max_depth`` is the largest plastic depth x = delta_max/delta_y of
the data the law was fitted to: the deepest FE level (``geocontact calibrate``), the campaign's
top level at the material (``geocontact params``), the record's deepest cycle (``geocontact
fit``). Beyond it every fitted form (the virgin curve's last power law, n_u, n_r, the residual
approach) is extrapolated, and nothing in the law says how well (docs/law.md, "The calibrated
range"). The law's users are told: a warning with how many contacts (or steps) went beyond and
the largest depth reached, or, asked to refuse, a one-line error.

The depth compared is the envelope's, ``ContactState.max_approach / delta_y`` (shifted
coordinates: the depth at which the forms are evaluated). A file without the block has
``calibrated_depth = inf``: nothing is checked, nothing is said.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

from ..errors import InputError

# What to do when a contact goes beyond the calibrated range.
WARN, REFUSE, IGNORE = "warn", "refuse", "ignore"
POLICIES = (WARN, REFUSE, IGNORE)


class BeyondCalibratedRangeWarning(UserWarning):
    """A contact was loaded beyond the depth its law was calibrated to."""


class BeyondCalibratedRangeError(InputError):
    """The same, refused (``beyond_range="refuse"``, ``geocontact law --strict-range``)."""


def check_policy(policy: str) -> str:
    if policy not in POLICIES:
        raise InputError(f"beyond_range: must be one of {', '.join(POLICIES)}, got {policy!r}")
    return policy


@dataclass(frozen=True)
class RangeExcess:
    """Contacts (or steps of one contact) beyond a law's calibrated depth."""

    calibrated_depth: float  # the file's max_depth
    largest_depth: float  # the largest delta_max/delta_y reached
    count: int  # contacts (ContactArrays) or steps (one contact's history) beyond
    total: int  # of how many
    unit: str = "contacts"  # "contacts" | "steps"
    max_force_N: float | None = None  # the file's force at max_depth, when it gives one

    @property
    def over_top(self) -> float:
        """The largest depth reached as a multiple of the calibrated top."""
        return self.largest_depth / self.calibrated_depth

    def message(self, what: str = "the law") -> str:
        verb = "went" if self.unit == "contacts" else "load the contact"
        force = ("" if self.max_force_N is None
                 else f", {self.max_force_N:.4g} N in the calibration")
        return (f"{self.count} of {self.total} {self.unit} {verb} beyond the calibrated range "
                f"of {what}: largest delta_max/delta_y {self.largest_depth:.4g}, "
                f"{self.over_top:.3g} x its calibrated top {self.calibrated_depth:.4g}"
                f"{force}; the law extrapolates there (calibrated_range.max_depth)")

    def to_dict(self) -> dict:
        return {"calibrated_depth": self.calibrated_depth, "largest_depth": self.largest_depth,
                "over_calibrated_top": self.over_top, f"{self.unit}_beyond": self.count,
                self.unit: self.total}


def excess(params, largest_depth: float, count: int, total: int,
           unit: str = "contacts") -> RangeExcess | None:
    """The excess of ``count`` of ``total`` contacts or steps whose deepest is
    ``largest_depth``; None when nothing went beyond (or the file records no range)."""
    if count == 0 or not largest_depth > params.calibrated_depth:
        return None
    force = params.calibrated_range_extra.get("max_force_N")
    return RangeExcess(calibrated_depth=params.calibrated_depth,
                       largest_depth=float(largest_depth), count=int(count), total=int(total),
                       unit=unit, max_force_N=force if isinstance(force, (int, float)) else None)


def report(found: RangeExcess | None, policy: str, what: str = "the law",
           stacklevel: int = 3) -> None:
    """Warn (``WARN``) or raise (``REFUSE``) about ``found``; nothing for None or ``IGNORE``."""
    if found is None or policy == IGNORE:
        return
    text = found.message(what)
    if policy == REFUSE:
        raise BeyondCalibratedRangeError(f"calibrated_range: {text}")
    warnings.warn(text + " (refuse with beyond_range='refuse')", BeyondCalibratedRangeWarning,
                  stacklevel=stacklevel)

