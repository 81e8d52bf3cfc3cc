"""The FE first yield against the analytic one (grain.hertz) over the friction angle, and at the
contact edge (large friction angle) its sensitivity to the tip mesh.

Above the critical friction angle (49.06 deg for nu = 0.25) the analytic first yield is on the
surface at the contact edge r = a (geocontact.grain.hertz). There the run's
``first_yield_force_N`` is the force at which the largest yield ratio of the elastic solution
reaches 1, located by elastic solves between the last elastic and the first plastic step
(fem.run._Run._locate_first_yield; ``first_yield_bracket_N`` is that pair of steps); below it,
F phi^-3 from the last elastic step. The case is the one of
``tests/test_fem_verification.py::test_first_yield_force_and_location_match_analytic`` (the
reference grain, 0 -> 3 Fy, 12 steps per segment), on the meshes ``run_history`` builds, or with
``--fractions`` on meshes whose tip size is set by hand, a_min = f x the analytic yield contact
radius (the mesh is otherwise ``history_mesh``'s).

    PYTHONPATH=src .venv/bin/python scripts/verify_edge_first_yield.py   # default mesh; ~2 min
    ... verify_edge_first_yield.py --meshes coarse default --betas 55 60 \
        --fractions 0.3 0.4 0.5 0.6 0.7 --tag _tip

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


def edge_run(beta: float, mesh: str, fraction: float | None) -> dict:
    material = Material(10e9, 0.25, 10e6, beta, 0.0, 0.1)
    analytic = hertz.incipient_yield(material)
    started = time.perf_counter()
    result = _run(material, analytic, mesh, fraction)
    s = result.summary
    where = s["first_yield_location_m"]
    return {"beta_deg": beta, "mesh": mesh, "a_min_over_a_y": fraction,
            "elements": s["mesh"]["elements"],
            "analytic": "contact edge" if analytic.at_surface else "axis",
            "fe_over_analytic": s["first_yield_force_N"] / analytic.force,
            "bracket_over_analytic": [b / analytic.force for b in s["first_yield_bracket_N"]],
            "elastic_solves": s.get("first_yield_search", {}).get("elastic_solves"),
            "r_over_a_y": where["r"] / analytic.contact_radius,
            "z_over_a_y": where["z"] / analytic.contact_radius,
            "wall_time_s": time.perf_counter() - started}


def _run(material, analytic, mesh, fraction):
    history = [0.0, 3.0 * analytic.force]
    if fraction is None:
        return run.run_history(material, history, mesh=mesh, write_fields=False,
                               steps_per_segment=12)
    a_min = fraction * analytic.contact_radius

    def sized_by_hand(material, max_force, mesh="default", min_force=None):
        a_max = max(run.largest_contact_radius_estimate(material, max_force), 2.0 * a_min)
        return build_mesh(material.radius, a_min, a_max, mesh)

    with mock.patch.object(run, "history_mesh", sized_by_hand):
        return run.run_history(material, history, mesh=mesh, write_fields=False,
                               steps_per_segment=12)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--meshes", nargs="+", default=["default"])
    parser.add_argument("--betas", nargs="+", type=float,
                        default=[0.0, 30.0, 45.0, 50.0, 55.0, 60.0])
    parser.add_argument("--fractions", nargs="+", type=float, default=[None],
                        help="tip sizes a_min / a_y (default: the mesh run_history builds)")
    parser.add_argument("--tag", default="")
    args = parser.parse_args()
    rows = []
    for beta in args.betas:
        for mesh in args.meshes:
            for fraction in args.fractions:
                rows.append(edge_run(beta, mesh, fraction))
                r = rows[-1]
                print(f"beta {beta:g} {mesh} a_min {fraction} a_y: FE/analytic "
                      f"{r['fe_over_analytic']:.3f} at r = {r['r_over_a_y']:.2f} a_y", flush=True)
    lines = ["# FE first yield against the analytic one", "",
             "Reference grain at friction angle beta (E = 10 GPa, nu = 0.25, sigma_c = 10 MPa, "
             "R = 0.1 m), 0 -> 3 Fy, 12 steps per segment (`scripts/verify_edge_first_yield.py`). "
             "Analytic: where grain.hertz puts the first yield (the contact edge above 49.06 deg). "
             "FE: `first_yield_force_N`, at the contact edge located by elastic solves inside the "
             "bracket (the last elastic and the first plastic step), else F phi^-3 from the last "
             "elastic step. f = a_min / a_y: the tip size set by hand (- : the mesh run_history "
             "builds).", "",
             "| beta | analytic at | mesh | f | elements | FE / analytic Fy | bracket / Fy "
             "| elastic solves | location r / a_y, z / a_y |",
             "| --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
    for r in rows:
        lo, hi = r["bracket_over_analytic"]
        f = "-" if r["a_min_over_a_y"] is None else f"{r['a_min_over_a_y']:g}"
        solves = "-" if r["elastic_solves"] is None else str(r["elastic_solves"])
        lines.append(f"| {r['beta_deg']:g}° | {r['analytic']} | {r['mesh']} | {f} | "
                     f"{r['elements']} | {r['fe_over_analytic']:.3f} | {lo:.3f}–{hi:.3f} | "
                     f"{solves} | {r['r_over_a_y']:.2f}, {r['z_over_a_y']:.3f} |")
    OUT.mkdir(parents=True, exist_ok=True)
    write_text_atomic(OUT / f"edge_first_yield{args.tag}.md", "\n".join(lines) + "\n")
    write_json_atomic(OUT / f"edge_first_yield{args.tag}.json", {
        **provenance("scripts/verify_edge_first_yield.py", vars(args)), "runs": rows})
    print("\n".join(lines))


if __name__ == "__main__":
    main()
