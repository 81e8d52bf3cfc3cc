"""Helpers shared by the sub-commands."""

from __future__ import annotations

import json
import math
import sys
from typing import Any

from ..errors import InputError
from ..io import json_safe

# Upper bounds of the counts given on the command line, so a typo fails at once instead of
# running for days or exhausting memory:
# FE load steps per monotonic segment: the presets use 12-40; 10000 is 250x the finest, where
# a segment already takes hours and the curve/checkpoint grow with every step.
MAX_STEPS_PER_SEGMENT = 10000
# local Dask worker processes: each holds an FE model; beyond 256 use a cluster (--scheduler).
MAX_WORKERS = 256


def print_json(document: dict[str, Any]) -> None:
    json.dump(json_safe(document), sys.stdout, indent=2)
    sys.stdout.write("\n")


def add_force_flag(parser) -> None:
    """``--force``: replace an output folder that is not a result of this command."""
    parser.add_argument("--force", action="store_true",
                        help="replace the output folder even if it holds files geocontact did "
                             "not write or another command's result (without it: refused)")


def check_count(field: str, value: int | None, high: int, why: str = "") -> None:
    """An optional integer argument in [1, high]; ``why`` says where the bound comes from."""
    if value is not None and not 1 <= value <= high:
        raise InputError(f"{field}: must be in [1, {high}]{' (' + why + ')' if why else ''}, "
                         f"got {value}")


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
    from ..fem.run import largest_contact_radius_estimate

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


# The attributes add_fe_model_flags adds (the FemJob / run_history keywords of the FE model).
FE_MODEL = ("kinematics", "mesh_rule", "step_rule", "max_step_ratio")


def fe_model_of(args) -> dict:
    """The FE model the flags of ``add_fe_model_flags`` chose, as FemJob keywords (``contact``
    only when not the default, so the records of default runs are unchanged)."""
    model = {key: getattr(args, key) for key in FE_MODEL}
    if args.contact != "node":
        model["contact"] = args.contact
    return model


def add_fe_model_flags(p) -> None:
    """--kinematics, --mesh-rule, --step-rule, --max-step-ratio and --contact of the FE engine
    (docs/fem.md)."""
    from ..fem.mesh import MESH_RULES

    p.add_argument("--kinematics", default="small", choices=["small", "finite"],
                   help="FE kinematics: small strain (default) or finite strain (logarithmic "
                        "elastic strain, exponential map, F-bar)")
    p.add_argument("--mesh-rule", default="yield", choices=list(MESH_RULES),
                   help="FE mesh rule: 'yield' (default, the verified meshes), 'contact' "
                        "(small surface elements over the plastic range of contact radii: the "
                        "contact edge of a weak grain moves in steps of ~1 %% of the radius) or "
                        "'contact-dense' (twice as many surface elements there)")
    p.add_argument("--step-rule", default="segment", choices=["segment", "decade"],
                   help="FE load steps: 'segment' (default, --steps per monotonic segment) or "
                        "'decade' (also at least --steps/2 geometric loading steps per decade "
                        "of force: for histories spanning many decades of F/Fy)")
    p.add_argument("--max-step-ratio", type=float, default=None, metavar="R",
                   help="FE load-step control: solve each loading step above the first-yield "
                        "force through geometric sub-steps of at most R in force (e.g. 1.01; "
                        "the requested steps are still the recorded ones): a weak grain's "
                        "perfectly plastic flattening is step dependent (docs/fem.md)")
    p.add_argument("--contact", default="node", choices=["node", "facet"],
                   help="FE contact with the flat: 'node' (default, exact node-to-flat "
                        "constraint) or 'facet' (penalty integrated over the surface facets, "
                        "the contact edge moving inside an element: no kink in the loading "
                        "curve as a node engages)")
