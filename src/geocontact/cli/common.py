"""Helpers shared by the sub-commands."""

from __future__ import annotations

import json
import sys
from typing import Any

from ..files import json_safe


def print_json(document: dict[str, Any]) -> None:
    json.dump(json_safe(document), sys.stdout, indent=2)
    sys.stdout.write("\n")


def add_force_flag(parser) -> None:
    """``--force``: replace an output folder that is not a result of this command."""
    parser.add_argument("--force", action="store_true",
                        help="replace the output folder even if it holds files geocontact did "
                             "not write or another command's result (without it: refused)")


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
