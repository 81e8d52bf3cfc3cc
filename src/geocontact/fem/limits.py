"""The bounds of what the FE is asked, checked before any work starts: load steps per segment,
local worker processes, and the largest force whose contact the mesh resolves."""

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
    """A peak force the FE mesh resolves: its contact radius estimate (``fem.run``) within the
    refined zone, a <= R/2 (``fem.mesh.build_mesh`` clips there); beyond it the contact would
    outgrow the mesh (and 1e308 N overflowed). The bound is found on that same estimate."""
    if force is None or not (math.isfinite(force) and force > 0):
        return  # the command's own checks name it
    from .run import largest_contact_radius_estimate  # here: the CLI starts without the FE stack
    def resolved(f: float) -> bool:
        return largest_contact_radius_estimate(material, f) <= 0.5 * material.radius

    if resolved(force):
        return
    low, high = 0.0, force
    for _ in range(200):  # bisection in log F: the estimate grows with the force
        mid = math.sqrt(low * high) if low > 0 else high * 1e-12
        low, high = (mid, high) if resolved(mid) else (low, mid)
        if low > 0 and high / low < 1.0 + 1e-6:
            break
    raise InputError(f"{field}: must be <= {low:.4g} N for this material (the largest force "
                     f"whose contact radius the FE mesh resolves, a <= R/2), got {force:g}")
