"""The bounds of what the FE is asked, checked before any work starts: load steps per segment,
local worker processes, and the largest force whose contact the mesh could resolve."""

from __future__ import annotations

import math

from ..errors import InputError, check_count

# Upper bounds of the counts given on the command line, so a typo fails at once instead of
# running for days or exhausting memory:
# FE load steps per monotonic segment: the presets use 12-40; 10000 is 250x the finest, where
# a segment already takes hours and the curve/checkpoint grow with every step.
MAX_STEPS_PER_SEGMENT = 10000
# local Dask worker processes: each holds an FE model; beyond 256 use a cluster (--scheduler).
MAX_WORKERS = 256


def check_steps(value: int | None) -> None:
    check_count("--steps", value, MAX_STEPS_PER_SEGMENT,
                "FE load steps per monotonic segment; the mesh presets use 12-40")


def check_workers(value: int | None) -> None:
    check_count("--workers", value, MAX_WORKERS, "local processes; use --scheduler beyond")


def check_resolved_force(material, force: float | None, field: str) -> None:
    """A peak force the FE mesh can resolve at all: its Hertz contact radius within the refined
    zone, a <= R/2 (``fem.mesh.CONTACT_RADIUS_LIMIT``; ``fem.mesh.build_mesh`` clips there).
    Hertz's is the smallest contact radius of the grain at that force (a plastic contact is
    wider), so beyond this bound no run could reach the force (and 1e308 N overflowed). Below
    it the run itself stops where the contact it measures passes R/2 (``fem.run.step_loop``),
    so a grain whose plastic contact stays small (a hard, high-friction one) is loaded as deep
    as its contact allows, not as deep as an estimate of it would."""
    if force is None or not (math.isfinite(force) and force > 0):
        return  # the command's own checks name it
    from ..grain.hertz import hertz_force
    from .mesh import CONTACT_RADIUS_LIMIT  # here: the CLI starts without the FE stack

    radius = CONTACT_RADIUS_LIMIT * material.radius
    # Hertz's force at the contact radius a = R/2: its approach is a^2 / R*
    bound = float(hertz_force(material, radius**2 / material.effective_radius))
    if force <= bound:
        return
    raise InputError(f"{field}: must be <= {bound:.4g} N for this material (beyond it even the "
                     f"elastic, Hertz contact radius exceeds {CONTACT_RADIUS_LIMIT:g} R, the FE "
                     f"mesh's refined zone), got {force:g}")
