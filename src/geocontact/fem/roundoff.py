"""The resolution of a run: values below it are round-off, not physics, and are reported as 0.

An energy of a run is a difference of sums over quadrature points (FE) or of cumulative values
(the law's contacts), each of the order of the run's largest work: double precision leaves
round-off of either sign at about 1e-16 of that work (an elastic FE cycle prints a plastic work
of -5.8e-25 J, a contact inside its envelope a dissipation of -2e-16 J). Below ``RELATIVE`` of
the run's energy scale a value is reported as exactly zero, and the report says what the
resolution was. The raw values stay in the run's CSV files (curve.csv, history.csv).

Why a fixed relative floor and not the FE's Newton tolerance (1e-8 of the force scale): the
plastic work of late cycles of a shaking-down history is real and reaches 1e-8 of cycle 1's
(the paper's repeated history); a tolerance-based floor would zero it, while 1e-12 stays four
decades below it and four above round-off.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

RELATIVE = 1e-12


@dataclass(frozen=True)
class Resolution:
    """A run's resolution of one kind of quantity: ``value`` in ``unit``, and how it was made."""

    value: float
    unit: str
    definition: str

    def clean(self, x: float | None) -> float | None:
        """``x``, or 0.0 when it is below the resolution in magnitude (None passes through)."""
        if x is None:
            return None
        return 0.0 if abs(x) < self.value else float(x)

    def format(self, x: float | None, spec: str = ".6g") -> str:
        """``x`` for printing: "0 J (below the resolution 1.2e-15 J)" for round-off."""
        if x is None:
            return "-"
        if abs(x) < self.value:
            return f"0 {self.unit} (below the resolution {self.value:.2g} {self.unit})"
        return f"{x:{spec}} {self.unit}"

    def note(self) -> str:
        """One sentence for a report: what the resolution is and what it does."""
        return note(self)

    def to_dict(self) -> dict[str, Any]:
        return {"value": self.value, "unit": self.unit, "definition": self.definition}

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> Resolution:
        return cls(float(d["value"]), str(d["unit"]), str(d["definition"]))


def note(*resolutions: Resolution) -> str:
    """One sentence for a report: what the run's resolutions are and what they do."""
    each = "; ".join(f"{r.value:.2g} {r.unit}, {r.definition}" for r in resolutions)
    return f"Values below the run's resolution ({each}) are round-off and shown as 0."


def _scale(values) -> float:
    finite = [abs(float(v)) for v in values if v is not None and math.isfinite(float(v))]
    return max(finite, default=0.0)


def fe_energy(max_force: float, max_approach: float) -> Resolution:
    """Energy resolution of an FE run: ``RELATIVE`` x its largest force x its largest
    approach (ball-ball; the pair's energies)."""
    return Resolution(RELATIVE * abs(max_force) * abs(max_approach), "J",
                      f"{RELATIVE:g} x the run's largest force x its largest approach")


def fe_approach(max_approach: float) -> Resolution:
    """Approach resolution of an FE run: ``RELATIVE`` x its largest approach (an elastic
    cycle's residual approach is ~1e-17 of it)."""
    return Resolution(RELATIVE * abs(max_approach), "m",
                      f"{RELATIVE:g} x the run's largest approach")


def fe_resolutions(max_force: float, max_approach: float) -> dict[str, Resolution]:
    """The FE run's resolutions by the kind of quantity they apply to."""
    return {"energy": fe_energy(max_force, max_approach), "approach": fe_approach(max_approach)}


# the per-cycle values of an FE summary and the resolution each is cleaned with
FE_CYCLE_VALUES = {"plastic_work_J": "energy", "loop_work_J": "energy",
                   "residual_elastic_energy_J": "energy", "residual_approach_m": "approach"}


def fe_summary_resolutions(summary: dict[str, Any]) -> dict[str, Resolution]:
    """The resolutions an FE summary records, or (a summary written before they were
    recorded) the same definitions from its cycles."""
    recorded = summary.get("resolution")
    if recorded:
        return {k: Resolution.from_dict(recorded[k]) for k in ("energy", "approach")}
    cycles = summary.get("cycles", [])
    return fe_resolutions(_scale(c["max_force_N"] for c in cycles),
                          _scale(c["max_approach_m"] for c in cycles))


def clean_fe_cycles(cycles: list[dict[str, Any]],
                    resolutions: dict[str, Resolution]) -> list[dict]:
    """Per-cycle values of an FE summary with round-off (below their resolution) set to 0."""
    return [{k: resolutions[FE_CYCLE_VALUES[k]].clean(v) if k in FE_CYCLE_VALUES else v
             for k, v in c.items()} for c in cycles]


def fe_summary_record(resolutions: dict[str, Resolution]) -> dict[str, Any]:
    """The ``resolution`` entry of an FE summary.json."""
    return {**{k: r.to_dict() for k, r in resolutions.items()},
            "applies_to": "per-cycle " + ", ".join(FE_CYCLE_VALUES) + ": 0.0 when below "
                          "(curve.csv keeps the raw values)"}


def seismic_energy(*works: float) -> Resolution:
    """Energy resolution of a seismic run: ``RELATIVE`` x the largest of the work of the base,
    the work of the contact forces and any contact's cumulative dissipation (the values whose
    differences make the per-event dissipations)."""
    return Resolution(RELATIVE * _scale(works), "J",
                      f"{RELATIVE:g} x the largest of the base input work, the work of the "
                      "contact forces and a contact's cumulative dissipation")
