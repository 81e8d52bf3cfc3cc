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
from geocontact.hertz import incipient_yield
from geocontact.material import preset
from geocontact.verification.ccx import PENALTY_DEFAULT, AxisymmetricMesh, run_ccx

FORCE_OVER_FY = 30.0
INCREMENTS = 24  # CalculiX increments per step (loading, unloading): our default's steps/segment
PROBE = (0.25, 0.5, 0.75, 1.0)  # approaches (/ largest) at which the docs table lists forces


def run_ours(material, force: float, mesh: str) -> dict:
    wall0, cpu0 = time.perf_counter(), time.process_time()
    result = run_history(material, [0.0, force, 0.0], mesh=mesh, write_fields=False)
    wall, cpu = time.perf_counter() - wall0, time.process_time() - cpu0
    cycle = result.summary["cycles"][0]
    return {"approach": result.curve["approach_m"], "force": result.curve["force_N"],
            "max_approach_m": cycle["max_approach_m"],
            "residual_approach_m": cycle["residual_approach_m"],
            "max_force_N": cycle["max_force_N"], "wall_time_s": wall, "cpu_time_s": cpu,
            "steps": result.summary["steps"], "elements": result.summary["mesh"]["elements"],
            "nodes": result.summary["mesh"]["nodes"]}


def run_peer(material, force: float, mesh: str, max_approach: float,
             penalty: float = PENALTY_DEFAULT) -> dict:
    fe_mesh = AxisymmetricMesh.from_skfem(history_mesh(material, force, mesh))
    result = run_ccx(material, fe_mesh, [max_approach, 0.0], [INCREMENTS, INCREMENTS],
                     penalty=penalty)
    s = result.summary
    return {"approach": result.curve["approach_m"], "force": result.curve["force_N"],
            "max_approach_m": s["max_approach_m"], "residual_approach_m": s["residual_approach_m"],
            "max_force_N": s["max_force_N"], "wall_time_s": s["wall_time_s"],
            "cpu_time_s": s["cpu_time_s"], "steps": s["increments"],
            "elements": s["mesh"]["elements"], "nodes": s["mesh"]["nodes"],
            "penalty_slope_Pa_per_m": s["contact"]["penalty_slope_Pa_per_m"]}


def branches(run: dict) -> tuple[tuple[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]]:
    """(approach, force) of the loading branch and of the unloading branch while in contact,
    each sorted by increasing approach."""
    k = int(np.argmax(run["force"]))
    load = (run["approach"][:k + 1], run["force"][:k + 1])
    a, f = run["approach"][k:], run["force"][k:]
    keep = f > 1e-6 * f[0]
    unload = (a[keep][::-1], f[keep][::-1])
    return load, unload


def force_difference(a: dict, b: dict, scale: float) -> dict:
    """Largest |F_a - F_b| at equal approach / scale, per branch, over the approaches both
    branches cover (b interpolated at a's points)."""
    out = {}
    for name, (da, fa), (db, fb) in zip(("loading", "unloading"), branches(a), branches(b),
                                        strict=True):
        lo, hi = max(da[0], db[0]), min(da[-1], db[-1])
        inside = (da >= lo) & (da <= hi)
        diff = np.abs(fa[inside] - np.interp(da[inside], db, fb))
        out[name] = float(np.max(diff) / scale) if diff.size else None
    return out


def forces_at(run: dict, approaches) -> list[float]:
    (d, f), _ = branches(run)
    return [float(np.interp(x, d, f)) for x in approaches]


def discretisation_error(coarse: dict, fine: dict, force: float) -> dict:
    return {"loading_force": force_difference(coarse, fine, force)["loading"],
            "residual_ratio": abs(coarse["residual_approach_m"] / coarse["max_approach_m"]
                                  - fine["residual_approach_m"] / fine["max_approach_m"])}


def _public(run: dict) -> dict:
    return {k: v for k, v in run.items() if k not in ("approach", "force")}


def main(quick: bool = False) -> dict:
    material = preset("von-mises")
    force = FORCE_OVER_FY * float(incipient_yield(material).force)
    meshes = ["coarse"] if quick else ["coarse", "default"]
    load = [os.getloadavg()[0]]
    ours, peer = {}, {}
    for mesh in meshes:
        ours[mesh] = run_ours(material, force, mesh)
        peer[mesh] = run_peer(material, force, mesh, ours[mesh]["max_approach_m"])
        load.append(os.getloadavg()[0])
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
    if not quick:
        levels["coarse"]["discretisation_error"] = {
            "ours": discretisation_error(ours["coarse"], ours["default"], force),
            "calculix": discretisation_error(peer["coarse"], peer["default"], force)}

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
