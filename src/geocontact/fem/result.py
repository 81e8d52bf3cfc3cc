"""What an FE run is and returns: its curve columns, the settings that decide it (load steps per
segment, volumetric treatment, Newton tolerance) and ``FemResult``. Shared by the run
(``fem.run``), its identity (``fem.reuse``) and its checkpoint (``fem.checkpoint``), so that
none of them imports another in a circle."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .solver import ContactSolver
from .state import State

CURVE_COLUMNS = (
    "step", "force_N", "approach_m", "contact_radius_m", "plastic_dissipation_J",
    "elastic_energy_J", "work_J", "peak_pressure_Pa", "plastic_points", "iterations",
    "yielded_contact_fraction", "yielded_core_fraction",
)
# Load steps per monotonic segment of the history, by mesh preset.
STEPS_PER_SEGMENT = {"coarse": 12, "default": 24, "fine": 40}
# Treatment of the volumetric strain of the P2 element (B-bar projection per element).
VOLUMETRIC = {"bbar-p1": (True, 1), "bbar-p0": (True, 0), "full": (False, 0)}
VOLUMETRIC_DEFAULT = "bbar-p1"
KINEMATICS = ("small", "finite")  # fem.solver.ContactSolver / fem.finite_strain
STEP_RULES = ("segment", "decade")  # fem.run.load_schedule
TOLERANCE = 1e-8  # Newton tolerance, relative to the force scale (ContactSolver)


@dataclass
class FemResult:
    curve: dict[str, np.ndarray]
    summary: dict[str, Any]
    states: list[State] = field(default_factory=list, repr=False)  # converged states (opt.)
    solver: ContactSolver | None = field(default=None, repr=False)
