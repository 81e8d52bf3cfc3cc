"""Sensitivity of the FE first yield at the contact edge (large friction angle) to the tip mesh.

Above the critical friction angle (49.06 deg for nu = 0.25) the analytic first yield is on the
surface at the contact edge r = a (geocontact.grain.hertz). The FE first yield there (the run's
``first_yield_force_N``: F phi^-3 from the last elastic step) depends on where the contact edge
falls between the nodes. This script runs the verification case of
``tests/test_fem_verification.py::test_first_yield_force_and_location_match_analytic`` (the
reference grain at beta = 55 and 60 deg, 0 -> 3 Fy, 12 steps per segment) on meshes whose tip
size is set by hand, a_min = f x the analytic yield contact radius for several f (the mesh is
otherwise ``history_mesh``'s), and reports FE / analytic Fy and the location.

    PYTHONPATH=src .venv/bin/python scripts/verify_edge_first_yield.py   # coarse, default; ~5 min
    ... verify_edge_first_yield.py --meshes fine --betas 60 --fractions 0.3 0.5 0.7 --tag _fine

Writes docs/verification/edge_first_yield{TAG}.{md,json}.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path
from unittest import mock

from geocontact.fem import run
from geocontact.fem.mesh import build_mesh
from geocontact.files import provenance, write_json_atomic, write_text_atomic
from geocontact.grain import hertz
from geocontact.grain.material import Material

OUT = Path(__file__).resolve().parents[1] / "docs" / "verification"


def edge_run(beta: float, mesh: str, fraction: float) -> dict:
    material = Material(10e9, 0.25, 10e6, beta, 0.0, 0.1)
    analytic = hertz.incipient_yield(material)
    a_min = fraction * analytic.contact_radius

    def sized_by_hand(material, max_force, mesh="default", min_force=None):
        a_max = max(run.largest_contact_radius_estimate(material, max_force), 2.0 * a_min)
        return build_mesh(material.radius, a_min, a_max, mesh)

    started = time.perf_counter()
    with mock.patch.object(run, "history_mesh", sized_by_hand):
        result = run.run_history(material, [0.0, 3.0 * analytic.force], mesh=mesh,
                                 write_fields=False, steps_per_segment=12)
    s = result.summary
    where = s["first_yield_location_m"]
    return {"beta_deg": beta, "mesh": mesh, "a_min_over_a_y": fraction,
            "elements": s["mesh"]["elements"],
            "fe_over_analytic": s["first_yield_force_N"] / analytic.force,
            "bracket_over_analytic": [b / analytic.force for b in s["first_yield_bracket_N"]],
            "r_over_a_y": where["r"] / analytic.contact_radius,
            "z_over_a_y": where["z"] / analytic.contact_radius,
            "wall_time_s": time.perf_counter() - started}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--meshes", nargs="+", default=["coarse", "default"])
    parser.add_argument("--betas", nargs="+", type=float, default=[55.0, 60.0])
    parser.add_argument("--fractions", nargs="+", type=float,
                        default=[0.3, 0.4, 0.5, 0.6, 0.7])
    parser.add_argument("--tag", default="")
    args = parser.parse_args()
    rows = []
    for beta in args.betas:
        for mesh in args.meshes:
            for fraction in args.fractions:
                rows.append(edge_run(beta, mesh, fraction))
                r = rows[-1]
                print(f"beta {beta:g} {mesh} a_min {fraction:g} a_y: FE/analytic "
                      f"{r['fe_over_analytic']:.3f} at r = {r['r_over_a_y']:.2f} a_y", flush=True)
    lines = ["# FE first yield at the contact edge against the tip mesh", "",
             "Reference grain at friction angle beta, 0 -> 3 Fy, 12 steps per segment; tip size "
             "a_min / per_tip_radius with a_min = f a_y (`scripts/verify_edge_first_yield.py`).",
             "", "| beta | mesh | f = a_min / a_y | elements | FE / analytic Fy | bracket / Fy "
             "| location r / a_y, z / a_y |", "| --- | --- | --- | --- | --- | --- | --- |"]
    for r in rows:
        lo, hi = r["bracket_over_analytic"]
        lines.append(f"| {r['beta_deg']:g}° | {r['mesh']} | {r['a_min_over_a_y']:g} | "
                     f"{r['elements']} | {r['fe_over_analytic']:.3f} | {lo:.3f}–{hi:.3f} | "
                     f"{r['r_over_a_y']:.2f}, {r['z_over_a_y']:.3f} |")
    OUT.mkdir(parents=True, exist_ok=True)
    write_text_atomic(OUT / f"edge_first_yield{args.tag}.md", "\n".join(lines) + "\n")
    write_json_atomic(OUT / f"edge_first_yield{args.tag}.json", {
        **provenance("scripts/verify_edge_first_yield.py", vars(args)), "runs": rows})
    print("\n".join(lines))


if __name__ == "__main__":
    main()
