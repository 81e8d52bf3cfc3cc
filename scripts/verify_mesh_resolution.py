"""How many surface elements must span the contact radius (docs/model.md §5, mesh; issue 16).

Part A, the threshold: an elastic grain (sigma_c = 1e15 Pa, E = 10 GPa, nu = 0.25, R = 0.1 m) on
meshes of every preset sized for contact radii from the Hertz radius at 60 N to the one at 6000 N
(``mesh.build_mesh``), loaded elastically to 120 forces from 0.01 to 6000 N, so that the contact
spans from a fraction of an element (the uniform tip region) to tens of them. At each force: the
surface elements across the Hertz contact radius (``mesh.elements_across``) and the error of the FE
approach and contact radius against Hertz (``geocontact.grain.hertz``). The table bins the largest
errors by the number of elements; it is what ``mesh.MIN_ELEMENTS_ACROSS_CONTACT`` is chosen from.

Part B, the runs: ``run_history`` of that grain on its own mesh (sized by ``history_mesh`` from
the history's smallest load step): 0 -> 6000 N on the default mesh (the issue's new-user case)
and 0 -> 6 -> 60 -> 600 -> 6000 N on the coarse one (the test).

    PYTHONPATH=src .venv/bin/python scripts/verify_mesh_resolution.py      # about 3 min

Writes docs/verification/mesh_resolution.{csv,md,json}.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from geocontact.fem.mesh import MIN_ELEMENTS_ACROSS_CONTACT, PRESETS, build_mesh, elements_across
from geocontact.fem.run import run_history
from geocontact.fem.solver import ContactSolver
from geocontact.files import provenance, write_csv, write_json_atomic, write_text_atomic
from geocontact.grain import hertz
from geocontact.grain.material import Material

OUT = Path(__file__).resolve().parents[1] / "docs" / "verification"
STRONG = Material(10e9, 0.25, 1e15, 30.0, 0.0, 0.1)
MESH_FORCES = (60.0, 6000.0)  # the mesh of part A: uniform tip region below 60 N
FORCES = np.geomspace(0.01, 6000.0, 120)
BINS = (0.0, 1.0, 1.5, 2.0, 2.5, 3.0, 4.0, 5.0, 6.0, 8.0, 12.0, np.inf)
RUNS = {"0-6000 N, default": ([0.0, 6000.0], "default"),
        "0-6-60-600-6000 N, coarse": ([0.0, 6.0, 60.0, 600.0, 6000.0], "coarse")}


def hertz_contact_radius(force):
    return hertz.contact_radius(STRONG, hertz.hertz_approach(STRONG, force))


def elastic_sweep(preset: str) -> list[dict]:
    a_min, a_max = (hertz_contact_radius(f) for f in MESH_FORCES)
    mesh = build_mesh(STRONG.radius, a_min, 1.2 * a_max, preset)
    solver = ContactSolver(STRONG, mesh, plastic=False, force_scale=FORCES[-1],
                           volumetric_order=1)
    state = solver.initial_state()
    rows = []
    for force in FORCES:
        state = solver.solve_step(state, float(force))
        approach = hertz.hertz_approach(STRONG, force)
        a = hertz_contact_radius(force)
        rows.append({"preset": preset, "elements_total": int(mesh.t.shape[1]),
                     "force_N": float(force),
                     "elements_across": elements_across(mesh, STRONG.radius, a),
                     "approach_error": 2.0 * state.top_displacement / approach - 1.0,
                     "contact_radius_error": solver.contact_radius(state) / a - 1.0})
    return rows


def binned(rows: list[dict]) -> list[dict]:
    out = []
    n = np.array([r["elements_across"] for r in rows])
    da = np.abs([r["approach_error"] for r in rows])
    dr = np.abs([r["contact_radius_error"] for r in rows])
    for lo, hi in zip(BINS[:-1], BINS[1:], strict=True):
        inside = (n >= lo) & (n < hi)
        if inside.any():
            out.append({"elements": f"{lo:g}-{hi:g}", "samples": int(inside.sum()),
                        "max_approach_error": float(da[inside].max()),
                        "max_contact_radius_error": float(dr[inside].max())})
    return out


def history_run(forces, mesh) -> dict:
    started = time.perf_counter()
    # the "yield" meshes and fixed steps (the defaults before issue 36), whose resolution the
    # documented table measures
    result = run_history(STRONG, forces, mesh=mesh, write_fields=False, mesh_rule="yield",
                         step_control="fixed")
    wall = time.perf_counter() - started
    c = result.curve
    loaded = c["force_N"] > 0
    force = c["force_N"][loaded]
    approach_error = c["approach_m"][loaded] / hertz.hertz_approach(STRONG, force) - 1.0
    radius_error = c["contact_radius_m"][loaded] / hertz_contact_radius(force) - 1.0
    waypoints = np.isin(force, forces)
    return {"elements": result.summary["mesh"]["elements"], "steps": result.summary["steps"],
            "wall_time_s": wall,
            "max_approach_error_waypoints": float(np.abs(approach_error[waypoints]).max()),
            "max_contact_radius_error_waypoints": float(np.abs(radius_error[waypoints]).max()),
            "max_approach_error_steps": float(np.abs(approach_error).max()),
            "max_contact_radius_error_steps": float(np.abs(radius_error).max()),
            "contact_resolution": result.summary["contact_resolution"],
            "warnings": result.summary["warnings"]}


def main(argv: list[str] | None = None) -> None:
    argparse.ArgumentParser(description=__doc__.splitlines()[0]).parse_args(argv)  # --help
    started = time.perf_counter()
    rows = [row for preset in PRESETS for row in elastic_sweep(preset)]
    tables = {preset: binned([r for r in rows if r["preset"] == preset]) for preset in PRESETS}
    tables["all presets"] = binned(rows)
    runs = {name: history_run(forces, mesh) for name, (forces, mesh) in RUNS.items()}

    OUT.mkdir(parents=True, exist_ok=True)
    write_csv(OUT / "mesh_resolution.csv", {k: [r[k] for r in rows] for k in rows[0]})
    lines = ["# Surface elements across the contact radius against the Hertz error", "",
             "Elastic grain (sigma_c = 1e15 Pa), every preset's mesh sized for the Hertz contact",
             "radii of 60 to 6000 N, 120 elastic loads from 0.01 to 6000 N; largest |error| of",
             "the FE approach and contact radius against Hertz per bin of elements across the",
             "contact radius (`scripts/verify_mesh_resolution.py`).", "",
             "| elements across a | " + " | ".join(tables) + " |",
             "| --- | " + " | ".join("---" for _ in tables) + " |"]
    labels = [b["elements"] for b in tables["all presets"]]
    for label in labels:
        cells = []
        for table in tables.values():
            (b,) = [b for b in table if b["elements"] == label] or [None]
            cells.append("–" if b is None else f"{100 * b['max_approach_error']:.2f} % / "
                         f"{100 * b['max_contact_radius_error']:.2f} % ({b['samples']})")
        lines.append(f"| {label} | " + " | ".join(cells) + " |")
    lines += ["", "(approach / contact radius, samples in the bin.) Warning threshold: "
              f"{MIN_ELEMENTS_ACROSS_CONTACT:g} elements.", "",
              "| run | elements | steps | wall time | max error at the waypoints (approach / a) "
              "| max error over all steps | elements across a: first step / peak |",
              "| --- | --- | --- | --- | --- | --- | --- |"]
    for name, r in runs.items():
        points = r["contact_resolution"]["elements_across_contact_radius"]
        lines.append(
            f"| {name} | {r['elements']} | {r['steps']} | {r['wall_time_s']:.1f} s | "
            f"{100 * r['max_approach_error_waypoints']:.2f} % / "
            f"{100 * r['max_contact_radius_error_waypoints']:.2f} % | "
            f"{100 * r['max_approach_error_steps']:.2f} % / "
            f"{100 * r['max_contact_radius_error_steps']:.2f} % | "
            f"{points['first_loaded_step']['elements']:.2f} / {points['peak']['elements']:.2f} |")
    write_text_atomic(OUT / "mesh_resolution.md", "\n".join(lines) + "\n")
    write_json_atomic(OUT / "mesh_resolution.json", {
        **provenance("scripts/verify_mesh_resolution.py",
                     {"material": STRONG.to_dict(), "mesh_forces_N": list(MESH_FORCES),
                      "forces_N": [float(FORCES[0]), float(FORCES[-1]), len(FORCES)],
                      "runs": {k: {"forces_N": f, "mesh": m} for k, (f, m) in RUNS.items()}}),
        "binned": tables, "runs": runs,
        "threshold_elements": MIN_ELEMENTS_ACROSS_CONTACT,
        "wall_time_s": time.perf_counter() - started})
    print("\n".join(lines))


if __name__ == "__main__":
    main()
