"""geocontact.fem against CalculiX (ccx) on the same von Mises sphere / rigid-flat problem.

Both codes get the same gmsh mesh (``fem.run.history_mesh``) and the same cycle: our FE is
force-controlled 0 -> F -> 0 (F = 30 Fy); CalculiX is displacement-controlled 0 -> the largest
approach our FE reached on that mesh -> 0 (``verification.ccx``: at F = 0 its penalty contact
leaves the body free, so it cannot be force-controlled). Compared: the force-approach curve
(loading and unloading branches, force difference at equal approach / F), the residual approach,
wall and CPU time.

"Equal accuracy": each code is also run on the next finer mesh preset, and its discretisation
error on the coarser one is measured against its own finer run by the same two numbers (largest
force difference along the loading branch / F, residual approach / largest approach). The cost
ratio is reported on the same mesh, with both errors beside it.
"""

from __future__ import annotations

import os
import time

import numpy as np
from common import record

from geocontact.fem.run import history_mesh, run_history
from geocontact.grain.hertz import incipient_yield
from geocontact.grain.material import preset
from geocontact.verification import ccx
from geocontact.verification import published_fits as fits
from geocontact.verification.ccx import PENALTY_DEFAULT, AxisymmetricMesh, run_ccx

FORCE_OVER_FY = 30.0
INCREMENTS = 24  # CalculiX increments per step (loading, unloading): our default's steps/segment
PROBE = (0.25, 0.5, 0.75, 1.0)  # approaches (/ largest) at which the docs table lists forces
W_NLGEOM = 100.0  # interference / omega_c (Jackson-Green) of the finite-strain comparison


def run_ours(material, force: float, mesh: str, kinematics: str = "small") -> dict:
    wall0, cpu0 = time.perf_counter(), time.process_time()
    # the "yield" mesh CalculiX is given (run_peer: history_mesh's rule) and fixed steps, as
    # many as its increments: the two codes on the same discretisation
    result = run_history(material, [0.0, force, 0.0], mesh=mesh, write_fields=False,
                         kinematics=kinematics, mesh_rule="yield", step_control="fixed")
    wall, cpu = time.perf_counter() - wall0, time.process_time() - cpu0
    cycle = result.summary["cycles"][0]
    return {"approach": result.curve["approach_m"], "force": result.curve["force_N"],
            "max_approach_m": cycle["max_approach_m"],
            "residual_approach_m": cycle["residual_approach_m"],
            "max_force_N": cycle["max_force_N"], "wall_time_s": wall, "cpu_time_s": cpu,
            "steps": result.summary["steps"], "elements": result.summary["mesh"]["elements"],
            "nodes": result.summary["mesh"]["nodes"]}


def run_peer(material, force: float, mesh: str, max_approach: float,
             penalty: float = PENALTY_DEFAULT, nlgeom: bool = False,
             unload_to: float = 0.0) -> dict:
    """CalculiX 0 -> max_approach -> unload_to x max_approach (past the residual approach)."""
    fe_mesh = AxisymmetricMesh.from_skfem(history_mesh(material, force, mesh))
    result = run_ccx(material, fe_mesh, [max_approach, unload_to * max_approach],
                     [INCREMENTS, INCREMENTS], penalty=penalty, nlgeom=nlgeom)
    s = result.summary
    return {"approach": result.curve["approach_m"], "force": result.curve["force_N"],
            "max_approach_m": s["max_approach_m"], "residual_approach_m": s["residual_approach_m"],
            "max_force_N": s["max_force_N"], "wall_time_s": s["wall_time_s"],
            "cpu_time_s": s["cpu_time_s"], "steps": s["increments"],
            "elements": s["mesh"]["elements"], "nodes": s["mesh"]["nodes"],
            "penalty_slope_Pa_per_m": s["contact"]["penalty_slope_Pa_per_m"]}


def branches(run: dict):
    return ccx.branches(run["approach"], run["force"])


def force_difference(a: dict, b: dict, scale: float) -> dict:
    """Largest |F_a - F_b| at equal approach / scale, per branch (``ccx.force_difference``)."""
    return ccx.force_difference((a["approach"], a["force"]), (b["approach"], b["force"]), scale)


def forces_at(run: dict, approaches) -> list[float]:
    (d, f), _ = branches(run)
    return [float(np.interp(x, d, f)) for x in approaches]


def discretisation_error(coarse: dict, fine: dict, force: float) -> dict:
    return {"loading_force": force_difference(coarse, fine, force)["loading"],
            "residual_ratio": abs(coarse["residual_approach_m"] / coarse["max_approach_m"]
                                  - fine["residual_approach_m"] / fine["max_approach_m"])}


def _public(run: dict) -> dict:
    return {k: v for k, v in run.items() if k not in ("approach", "force")}


def compare_codes(material, force: float, meshes: list[str], kinematics: str = "small",
                  unload_to: float = 0.0) -> tuple[dict, dict, dict, list[float]]:
    """Ours (``kinematics``) and CalculiX (NLGEOM for "finite") on each mesh, the same cycle
    0 -> force -> 0; their agreement mesh for mesh and, with two meshes, each code's error on
    the first against its own run on the second ("equal accuracy")."""
    load = [os.getloadavg()[0]]
    ours, peer = {}, {}
    for mesh in meshes:
        ours[mesh] = run_ours(material, force, mesh, kinematics)
        peer[mesh] = run_peer(material, force, mesh, ours[mesh]["max_approach_m"],
                              nlgeom=kinematics == "finite", unload_to=unload_to)
        load.append(os.getloadavg()[0])
    levels = {}
    for mesh in meshes:
        o, p = ours[mesh], peer[mesh]
        levels[mesh] = {
            "ours": _public(o), "calculix": _public(p),
            "agreement": {
                "force_difference": force_difference(p, o, force),
                "residual_approach_difference": (p["residual_approach_m"]
                                                 - o["residual_approach_m"])
                / o["residual_approach_m"],
                "peak_force_difference": (p["max_force_N"] - o["max_force_N"]) / force,
            },
            "forces_at_approach": {
                "approach_m": [x * o["max_approach_m"] for x in PROBE],
                "ours_N": forces_at(o, [x * o["max_approach_m"] for x in PROBE]),
                "calculix_N": forces_at(p, [x * o["max_approach_m"] for x in PROBE]),
            },
            "wall_time_ratio": o["wall_time_s"] / p["wall_time_s"],
            "cpu_time_ratio": o["cpu_time_s"] / p["cpu_time_s"],
        }
    if len(meshes) > 1:
        levels[meshes[0]]["discretisation_error"] = {
            "ours": discretisation_error(ours[meshes[0]], ours[meshes[1]], force),
            "calculix": discretisation_error(peer[meshes[0]], peer[meshes[1]], force)}
    return ours, peer, levels, load


def main(quick: bool = False) -> dict:
    material = preset("von-mises")
    force = FORCE_OVER_FY * float(incipient_yield(material).force)
    meshes = ["coarse"] if quick else ["coarse", "default"]
    ours, peer, levels, load = compare_codes(material, force, meshes)
    penalty_check = None
    if not quick:  # the penalty's own error: the coarse run again with a 10x stiffer penalty
        stiff = run_peer(material, force, "coarse", ours["coarse"]["max_approach_m"],
                         penalty=10 * PENALTY_DEFAULT)
        penalty_check = {"penalty_factor": 10 * PENALTY_DEFAULT,
                         "force_difference": force_difference(peer["coarse"], stiff, force),
                         "residual_ratio": discretisation_error(peer["coarse"], stiff,
                                                                force)["residual_ratio"],
                         "wall_time_s": stiff["wall_time_s"], "cpu_time_s": stiff["cpu_time_s"]}
        load.append(os.getloadavg()[0])

    top = meshes[-1]
    o, p = ours[top], peer[top]
    agreement = levels[top]["agreement"]
    note = (f"{top} mesh ({o['elements']} P2 / CAX6 elements), 0 -> {FORCE_OVER_FY:g} Fy -> 0; "
            f"force difference <= {100 * max(agreement['force_difference'].values()):.2g} % F, "
            f"residual approach {100 * agreement['residual_approach_difference']:+.2g} %; "
            f"CPU ratio {levels[top]['cpu_time_ratio']:.2f}")
    return record(
        "fem_vs_calculix", o["wall_time_s"], "s",
        "CalculiX 2.20 ccx (CAX6, penalty contact, 1 thread)", p["wall_time_s"],
        ratio=o["wall_time_s"] / p["wall_time_s"],
        material="von-mises", force_N=force, force_over_first_yield=FORCE_OVER_FY,
        mesh=top, elements_ours=o["elements"], elements_calculix=p["elements"],
        max_force_difference=max(agreement["force_difference"].values()),
        residual_approach_difference=agreement["residual_approach_difference"],
        cpu_time_ratio=levels[top]["cpu_time_ratio"], levels=levels,
        penalty_check=penalty_check, load_average_1min=load,
        goal="our wall time / ccx wall time <= 1 at equal accuracy",
        note=note,
    )


def main_nlgeom(quick: bool = False) -> dict:
    """Finite strain at large interference: our ``kinematics="finite"`` against CalculiX NLGEOM
    on preset ``von-mises-large`` (E/sigma_c = 200), 0 -> the Jackson-Green load at
    ``W_NLGEOM`` critical interferences (a/R = 0.15) -> 0, coarse and default mesh."""
    material = preset("von-mises-large")
    jg = fits.jackson_green_critical(material)
    force = float(fits.jackson_green_load(material, W_NLGEOM)) * jg.force
    meshes = ["coarse"] if quick else ["coarse", "default"]
    # CalculiX unloads to half the largest approach (the residual approach is ~0.75 of it):
    # its 24 unloading increments then fall on the branch still in contact
    ours, peer, levels, load = compare_codes(material, force, meshes, "finite", unload_to=0.5)
    top = meshes[-1]
    o, p = ours[top], peer[top]
    agreement = levels[top]["agreement"]
    return record(
        "fem_finite_vs_calculix_nlgeom", o["wall_time_s"], "s",
        "CalculiX 2.20 ccx NLGEOM (CAX6, penalty contact, 1 thread)", p["wall_time_s"],
        ratio=o["wall_time_s"] / p["wall_time_s"],
        material="von-mises-large", force_N=force, w_max_jackson_green=W_NLGEOM, mesh=top,
        elements_ours=o["elements"], elements_calculix=p["elements"],
        max_force_difference=max(agreement["force_difference"].values()),
        residual_approach_difference=agreement["residual_approach_difference"],
        cpu_time_ratio=levels[top]["cpu_time_ratio"], levels=levels, load_average_1min=load,
        goal="our finite-strain wall time / ccx NLGEOM wall time <= 1 at equal accuracy",
        note=(f"{top} mesh ({o['elements']} elements), finite strain, 0 -> {W_NLGEOM:g} wc -> "
              f"0 (a/R 0.15); force difference <= "
              f"{100 * max(agreement['force_difference'].values()):.2g} % F, residual approach "
              f"{100 * agreement['residual_approach_difference']:+.2g} %; CPU ratio "
              f"{levels[top]['cpu_time_ratio']:.2f}"),
    )
