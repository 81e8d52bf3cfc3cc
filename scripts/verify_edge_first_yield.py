"""The FE first yield against the analytic one (grain.hertz) over the friction angle, and at the
contact edge (large friction angle) its sensitivity to the mesh.

Above the critical friction angle (49.06 deg for nu = 0.25) the analytic first yield is on the
surface at the contact edge r = a (geocontact.grain.hertz). There the run's
``first_yield_force_N`` is the force at which the largest yield ratio of the elastic solution
(over the quadrature points and on the surface at the contact edge, recovered from outside the
contact: ContactSolver.edge_surface_ratio) reaches 1, located by elastic solves between the last
step below it and the first step at it or plastic (fem.run._Run._locate_first_yield;
``first_yield_bracket_N`` is that pair of steps); below it,
F phi^-3 from the last elastic step. The case is the one of
``tests/test_fem_verification.py::test_first_yield_force_and_location_match_analytic`` (the
reference grain, 0 -> 3 Fy, 12 steps per segment), on the meshes ``run_history`` builds, or
with ``--fractions`` on meshes whose tip size is set by hand, a_min = f x the analytic yield
contact radius, or with ``--edge-grading G`` with a surface band of spacing d / G over the
contact radii 0.8-1.3 a_y (growing by 0.3 per unit depth and distance outside it).

Field check: one elastic solve at the analytic Fy on the run's mesh; its largest yield ratio
(the analytic one is 1 at the contact edge) and, at the quadrature point where it sits, the
analytic ratio of the Hertz field (grain.hertz.stress_field): whether the FE field is right at
its points and how far below the peak those points sample it; and the ratio on the surface at
the contact edge recovered from outside the contact (ContactSolver.edge_surface_ratio; the
analytic one is 1 above the critical angle).

    PYTHONPATH=src .venv/bin/python scripts/verify_edge_first_yield.py   # default mesh; ~2 min
    ... verify_edge_first_yield.py --meshes coarse --betas 55 --edge-grading 40 80 160 --tag _band
    ... verify_edge_first_yield.py --meshes coarse default --betas 55 60 \\
        --fractions 0.3 0.4 0.5 0.6 0.7 --tag _tip

Writes docs/verification/edge_first_yield{TAG}.{md,json}.
"""

from __future__ import annotations

import argparse
import contextlib
import time
from pathlib import Path
from unittest import mock

import numpy as np

from geocontact.fem import mesh as fe_mesh
from geocontact.fem import run
from geocontact.files import provenance, write_json_atomic, write_text_atomic
from geocontact.grain import hertz
from geocontact.grain.material import Material

OUT = Path(__file__).resolve().parents[1] / "docs" / "verification"
EDGE_BAND = (0.8, 1.3)  # contact radii of the --edge-grading band, / a_y


def edge_run(beta: float, mesh: str, fraction: float | None, grading: float | None) -> dict:
    material = Material(10e9, 0.25, 10e6, beta, 0.0, 0.1)
    analytic = hertz.incipient_yield(material)
    started = time.perf_counter()
    with _mesh_rule(analytic, fraction, grading):
        # fixed steps on the "yield" meshes (the defaults before issue 36): the documented
        # table's runs, whose step bracket it reports
        result = run.run_history(material, [0.0, 3.0 * analytic.force], mesh=mesh,
                                 write_fields=False, steps_per_segment=12, mesh_rule="yield",
                                 step_control="fixed")
    s = result.summary
    where = s["first_yield_location_m"]
    return {"beta_deg": beta, "mesh": mesh, "a_min_over_a_y": fraction,
            "edge_grading": grading, "elements": s["mesh"]["elements"],
            "analytic": "contact edge" if analytic.at_surface else "axis",
            "fe_over_analytic": s["first_yield_force_N"] / analytic.force,
            "bracket_over_analytic": [b / analytic.force for b in s["first_yield_bracket_N"]],
            "elastic_solves": s.get("first_yield_search", {}).get("elastic_solves"),
            "r_over_a_y": where["r"] / analytic.contact_radius,
            "z_over_a_y": where["z"] / analytic.contact_radius,
            **field_check(material, analytic, result.solver),
            "wall_time_s": time.perf_counter() - started}


def _mesh_rule(analytic, fraction, grading):
    """The mesh of the run: run_history's, or its tip size set by hand, or with the edge band."""
    stack = contextlib.ExitStack()
    a_y = analytic.contact_radius
    if fraction is not None:
        a_min = fraction * a_y

        def sized_by_hand(material, max_force, mesh="default", min_force=None):
            a_max = max(run.largest_contact_radius_estimate(material, max_force), 2.0 * a_min)
            return fe_mesh.build_mesh(material.radius, a_min, a_max, mesh)

        stack.enter_context(mock.patch.object(run, "history_mesh", sized_by_hand))
    if grading is not None:
        plain = fe_mesh.element_size

        def banded(d, radius, a_min, a_max, preset, *, depth=0.0, band=None):
            outside = np.maximum(np.maximum(EDGE_BAND[0] * a_y - d, d - EDGE_BAND[1] * a_y), 0.0)
            edge = d / grading + fe_mesh.CONTACT_DEPTH_GROWTH * (depth + outside)
            return np.minimum(plain(d, radius, a_min, a_max, preset, depth=depth, band=band),
                              edge)

        stack.enter_context(mock.patch.object(fe_mesh, "element_size", banded))
    return stack


def field_check(material, analytic, solver) -> dict:
    solver.plastic = False
    try:
        state = solver.solve_step(solver.initial_state(), analytic.force)
    finally:
        solver.plastic = True
    ratio = solver.yield_ratio(state)
    k = np.unravel_index(np.argmax(ratio), ratio.shape)
    r, z = float(solver.radius_qp[k]), float(solver.z_qp[k])
    depth = material.radius - float(np.hypot(r, z - material.radius))
    a = analytic.contact_radius
    tan_beta = np.tan(np.radians(material.friction_angle_deg))

    def measure(rho, zeta):
        field = hertz.stress_field(np.array([rho]), np.array([zeta]), material.poissons_ratio)
        return float(hertz.drucker_prager_measure(field, tan_beta)[0])

    peak = measure(analytic.r_over_a, analytic.z_over_a)
    edge, _ = solver.edge_surface_ratio(state)
    return {"fe_ratio_at_fy": float(ratio[k]), "analytic_ratio_there": measure(r / a, depth / a)
            / peak, "check_r_over_a_y": r / a, "check_depth_over_a_y": depth / a,
            "fe_surface_edge_ratio_at_fy": edge}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--meshes", nargs="+", default=["default"])
    parser.add_argument("--betas", nargs="+", type=float,
                        default=[0.0, 30.0, 45.0, 50.0, 55.0, 60.0])
    parser.add_argument("--fractions", nargs="+", type=float, default=[None],
                        help="tip sizes a_min / a_y (default: the mesh run_history builds)")
    parser.add_argument("--edge-grading", nargs="+", type=float, default=[None],
                        help="surface band d / G over 0.8-1.3 a_y (default: none)")
    parser.add_argument("--tag", default="")
    args = parser.parse_args()
    rows = []
    for beta in args.betas:
        for mesh in args.meshes:
            for fraction in args.fractions:
                for grading in args.edge_grading:
                    rows.append(edge_run(beta, mesh, fraction, grading))
                    r = rows[-1]
                    print(f"beta {beta:g} {mesh} a_min {fraction} band {grading}: FE/analytic "
                          f"{r['fe_over_analytic']:.3f} at r = {r['r_over_a_y']:.2f} a_y",
                          flush=True)
    write_text_atomic(OUT / f"edge_first_yield{args.tag}.md", "\n".join(table(rows)) + "\n")
    write_json_atomic(OUT / f"edge_first_yield{args.tag}.json", {
        **provenance("scripts/verify_edge_first_yield.py", vars(args)), "runs": rows})
    print("\n".join(table(rows)))


def table(rows: list[dict]) -> list[str]:
    lines = ["# FE first yield against the analytic one", "",
             "Reference grain at friction angle beta (E = 10 GPa, nu = 0.25, sigma_c = 10 MPa, "
             "R = 0.1 m), 0 -> 3 Fy, 12 steps per segment (`scripts/verify_edge_first_yield.py`). "
             "Analytic: where grain.hertz puts the first yield (the contact edge above 49.06 deg). "
             "FE: `first_yield_force_N`, at the contact edge located by elastic solves inside the "
             "bracket (the last step whose largest yield ratio, over the quadrature points and on "
             "the surface at the edge, is below 1 and the next step), else F phi^-3 from the "
             "last elastic step. f = a_min / a_y: the tip size set by hand; G: the surface band "
             "d / G over 0.8-1.3 a_y (- : the mesh run_history builds). Field check: an elastic "
             "solve at the analytic Fy, its largest yield ratio over the quadrature points "
             "(analytic: 1) and the analytic ratio at that point (r, depth under the surface), "
             "and its ratio on the surface at the contact edge "
             "(ContactSolver.edge_surface_ratio; analytic: 1 above the critical angle).", "",
             "| beta | analytic at | mesh | f | G | elements | FE / analytic Fy | bracket / Fy "
             "| elastic solves | location r / a_y, z / a_y | FE ratio at Fy | analytic there "
             "| at r / a_y, depth / a_y | FE surface ratio at the edge |",
             "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- "
             "| --- |"]
    for r in rows:
        lo, hi = r["bracket_over_analytic"]
        f = "-" if r["a_min_over_a_y"] is None else f"{r['a_min_over_a_y']:g}"
        g = "-" if r["edge_grading"] is None else f"{r['edge_grading']:g}"
        solves = "-" if r["elastic_solves"] is None else str(r["elastic_solves"])
        lines.append(f"| {r['beta_deg']:g}° | {r['analytic']} | {r['mesh']} | {f} | {g} | "
                     f"{r['elements']} | {r['fe_over_analytic']:.3f} | {lo:.3f}–{hi:.3f} | "
                     f"{solves} | {r['r_over_a_y']:.2f}, {r['z_over_a_y']:.3f} | "
                     f"{r['fe_ratio_at_fy']:.3f} | {r['analytic_ratio_there']:.3f} | "
                     f"{r['check_r_over_a_y']:.3f}, {r['check_depth_over_a_y']:.4f} | "
                     f"{r['fe_surface_edge_ratio_at_fy']:.3f} |")
    return lines


if __name__ == "__main__":
    main()
