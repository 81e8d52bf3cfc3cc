"""``geocontact law``: the law along an approach history (docs/interfaces.md)."""

from __future__ import annotations

import sys

import numpy as np

from ..errors import InputError
from ..files import (
    Output,
    check_file_replaceable,
    claim,
    provenance,
    read_csv_column,
    write_csv,
    write_json_atomic,
)
from ..law import BRANCH_NAMES, Contact, load_params
from ..law.calibrated_range import IGNORE
from .common import add_force_flag, print_json


def register(sub) -> None:
    p = sub.add_parser("law", help="run the hysteretic law along an approach history")
    p.add_argument("--params", required=True, help="law parameters (geocontact.law/1 JSON)")
    p.add_argument("--approach", required=True, help="CSV with a column approach_m (m)")
    p.add_argument("--out", required=True, help="output CSV: approach_m, force_N, ...")
    p.add_argument("--radius", type=float, default=None, metavar="R",
                   help="sphere radius in m: the law for two spheres of radius R by similarity "
                        "(F_r(d) = s^2 F(d/s), s = R / the file's radius; docs/model.md §10)")
    p.add_argument("--strict-range", action="store_true",
                   help="refuse (exit 2, nothing written) a history that loads the contact "
                        "beyond the law's calibrated depth (calibrated_range in the file); "
                        "without it such steps are counted and warned about")
    add_force_flag(p, "file")
    p.add_argument("--json", action="store_true", help="print a JSON summary on stdout")
    p.set_defaults(run=run)


def run(args) -> int:
    outputs = [Output(args.out, "file", "--out"), Output(f"{args.out}.meta.json", "file", "--out")]
    for output in outputs:
        check_file_replaceable(output.path, overwrite=args.force, field="--out")
    params = load_params(args.params)
    if args.radius is not None:
        params = params.for_radius(args.radius)
    approaches = read_csv_column(args.approach, "approach_m")
    radius = params.material.radius
    too_deep = np.flatnonzero(approaches > radius)
    if too_deep.size:  # 1e308 gave an infinite force and NaN energies
        i = int(too_deep[0])
        raise InputError(f"approach_m: must be <= the sphere radius {radius:g} m (a ball-ball "
                         f"approach; far beyond any contact law), got {approaches[i]:g} "
                         f"(value {i + 1} of {args.approach})")
    with claim(outputs, "law", overwrite=args.force):
        return _run(args, params, approaches)


def _run(args, params, approaches) -> int:
    contact = Contact(params, beyond_range=IGNORE)  # said once below, with the whole count
    n = approaches.size
    force, stiffness = np.empty(n), np.empty(n)
    residual, dissipated = np.empty(n), np.empty(n)
    branch = []
    for i, a in enumerate(approaches):
        force[i], stiffness[i] = contact.update(float(a))
        s = contact.state
        residual[i] = s.residual_approach + s.ratchet_shift
        dissipated[i] = contact.dissipated_energy
        branch.append(BRANCH_NAMES[s.branch])
    beyond = contact.range_excess()
    if beyond is not None and args.strict_range:
        raise InputError(f"approach_m: {beyond.message(str(args.params))} (--strict-range)")
    write_csv(args.out, {
        "approach_m": approaches,
        "force_N": force,
        "stiffness_N_per_m": stiffness,
        "residual_approach_m": residual,
        "dissipated_energy_J": dissipated,
        "branch": np.array(branch),
    })
    summary = {
        "points": n,
        "max_force_N": float(force.max()),
        "max_approach_m": float(contact.state.max_approach + contact.state.ratchet_shift),
        "residual_approach_m": float(residual[-1]),
        "dissipated_energy_J": float(dissipated[-1]),
        "radius_m": params.material.radius,
        # the file's calibrated range and how far beyond it the history went (null: within)
        "calibrated_range": params.calibrated_range or None,
        "beyond_calibrated_range": None if beyond is None else beyond.to_dict(),
        "provenance": provenance("law", {"params": str(args.params),
                                         "approach": str(args.approach),
                                         "radius_m": args.radius,
                                         "strict_range": args.strict_range}),
    }
    write_json_atomic(f"{args.out}.meta.json", summary)
    if beyond is not None:
        print(f"warning: {beyond.message(str(args.params))} (--strict-range refuses it)",
              file=sys.stderr)
    if args.json:
        print_json(summary)
    else:
        print(f"wrote {args.out} ({n} points); dissipated {dissipated[-1]:.6g} J")
    return 0
