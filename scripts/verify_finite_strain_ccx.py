"""Finite strain at large interference: against CalculiX with NLGEOM and against the published
large-deformation fits (issue 15).

The von Mises sphere on a rigid frictionless flat (preset ``von-mises-large``: E/sigma_c = 200,
nu = 0.3, perfectly plastic, R = 0.1 m) loaded to ``--w-max`` critical interferences (Jackson &
Green normalisation; 100 by default, a/R = 0.15) and unloaded, on one gmsh mesh, four ways:

- ours, small strain and finite strain (``run_history(kinematics=...)``, force control);
- CalculiX 2.20, small strain and NLGEOM (``verification.ccx``, the same nodes and triangles,
  displacement control to the largest approach our finite-strain run reached, then back to
  half of it: past the residual approach, with every increment of the unloading step on the
  branch still in contact).

Our finite-strain run goes to F = the JG load at w_max and reaches the approach d_f; CalculiX
goes to d_f in both kinematics; our small-strain run goes to the force its own loading curve
has at d_f (read off a first small-strain run to F), so that all four unload from the same
largest approach and their residual approaches compare directly.

Compared: the force at equal approach along loading and unloading (each of ours against each
CalculiX run), the residual approach; then all four against Jackson & Green (2005) (loading
force, contact radius) and Etsion, Kligerman & Kadin (2005) / Jackson, Chusoipin & Green (2005)
(residual interference, unloading exponent).

    PYTHONPATH=src nice -n 5 .venv/bin/python scripts/verify_finite_strain_ccx.py   # ~6 min

Another von Mises material (``--material``: a preset name or a material TOML file) and a
largest force in N (``--force``) instead of JG's ``--w-max``, e.g. the weak regime
(E/sigma_c = 1e4; docs/verification.md item 15, "weak regime")::

    PYTHONPATH=src nice -n 5 .venv/bin/python scripts/verify_finite_strain_ccx.py \
        --material docs/verification/finite_strain_ccx_weak_hardening.toml --force 3000 \
        --mesh-rule yield --steps 6 --max-step-ratio 1.02 --penalty 1 --unload-to 0.96 \
        --name finite_strain_ccx_weak_hardening   # ~12 min

Beyond the published fits' range (omega > 110 omega_c) their comparison is left out; the
approach at equal force and the elastic recovery delta_max - delta_res are compared instead
(in every run). A CalculiX run that does not converge ends the script with one line.

Every FE run is a resumable result folder under ``--work`` (``run_history(resume=True)``); each
CalculiX run is kept there as JSON with its inputs and reused when they are the same. Writes
docs/verification/finite_strain_ccx.{json,md,png,csv} (``_default`` etc. for other meshes;
``--name`` another stem).
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

from geocontact.errors import ConvergenceError, InputError
from geocontact.fem.run import history_mesh, run_history, smallest_resolved_force
from geocontact.files import (
    atomic_path,
    provenance,
    write_csv,
    write_json_atomic,
    write_text_atomic,
)
from geocontact.grain.material import load_material
from geocontact.verification import ccx
from geocontact.verification import published_fits as fits

OUT = Path(__file__).resolve().parents[1] / "docs" / "verification"
MATERIAL = "von-mises-large"
PROBES = (0.1, 0.25, 0.5, 0.75, 1.0)  # approach / largest approach of the table
# force / the largest force all four loading branches reach (approach at equal force)
FORCE_PROBES = (0.1, 0.25, 0.5, 0.75, 1.0)
JG_FITTED = 110.0  # the published fits' range in omega/omega_c (JG); beyond it they are skipped
FIT_AT = (2.0, 5.0, 10.0, 20.0, 50.0, 100.0)  # omega/omega_c (JG) of the published-fit table
T_GRID = np.linspace(0.0, 1.0, 101)  # ccx.unloading_shape: (d - d_res)/(d_max - d_res)
# CalculiX unloads to this fraction of the largest approach (the residual approach is 0.7-0.8 of
# it here), so that its increments fall on the unloading branch while in contact
UNLOAD_TO = 0.5
CODES = ("ours_small", "ours_finite", "ccx_small", "ccx_nlgeom")
LABELS = {"ours_small": "geocontact small strain", "ours_finite": "geocontact finite strain",
          "ccx_small": "CalculiX small strain", "ccx_nlgeom": "CalculiX NLGEOM"}


def run_ours(material, forces, name, args, kinematics, mesh_force) -> dict:
    started = time.perf_counter()
    result = run_history(material, forces, mesh=args.mesh, out=args.work / name,
                         steps_per_segment=args.steps, resume=True, write_fields=False,
                         kinematics=kinematics, mesh_force=mesh_force,
                         mesh_rule=args.mesh_rule, max_step_ratio=args.max_step_ratio,
                         step_control="fixed")  # the cap's sub-steps, as documented
    s, c = result.summary, result.curve
    cycle = s["cycles"][0]
    print(f"{name}: {s['steps']} steps, {s['wall_time_s']:.1f} s "
          f"({time.perf_counter() - started:.1f} s now)", flush=True)
    return {"approach": c["approach_m"], "force": c["force_N"],
            "contact_radius": c["contact_radius_m"],
            "max_approach_m": cycle["max_approach_m"],
            "residual_approach_m": cycle["residual_approach_m"],
            "max_force_N": cycle["max_force_N"], "wall_time_s": s["wall_time_s"],
            "steps": s["steps"], "newton_iterations": s.get("newton_iterations"),
            "elements": s["mesh"]["elements"], "nodes": s["mesh"]["nodes"],
            "kinematics": kinematics}


def run_peer(material, fe_mesh, approach, args, nlgeom: bool, mesh_force: float) -> dict:
    """One CalculiX run 0 -> approach -> 0, reused from ``--work`` when its inputs match."""
    name = "ccx_nlgeom" if nlgeom else "ccx_small"
    waypoints = [approach, args.unload_to * approach]
    inputs = {"material": material.to_dict(), "mesh": args.mesh, "mesh_rule": args.mesh_rule,
              "mesh_force_N": mesh_force,
              "approaches_m": waypoints, "increments": [args.increments] * 2,
              "nlgeom": nlgeom, "penalty_factor": args.penalty,
              "nodes": len(fe_mesh.points), "ccx_version": ccx.ccx_version()}
    path = args.work / f"{name}.json"
    if path.exists():
        saved = json.loads(path.read_text())
        if saved.get("inputs") == json.loads(json.dumps(inputs)):
            print(f"{name}: reusing {path}", flush=True)
            if "failed" in saved:
                return _failed_record(saved["failed"], saved["partial"])
            return _peer_record(saved["curve"], saved["summary"])
    try:
        result = ccx.run_ccx(material, fe_mesh, waypoints, [args.increments] * 2,
                             nlgeom=nlgeom, penalty=args.penalty)
    except ConvergenceError as exc:  # e.g. the perfectly plastic grain at E/sigma_c = 1e4
        partial = {k: np.asarray(v).tolist() for k, v in getattr(exc, "partial", {}).items()}
        write_json_atomic(path, {"inputs": inputs, "failed": str(exc), "partial": partial})
        print(f"{name}: {exc}", flush=True)
        return _failed_record(str(exc), partial)
    write_json_atomic(path, {"inputs": inputs, "summary": result.summary,
                             "curve": {k: v.tolist() for k, v in result.curve.items()}})
    print(f"{name}: {result.summary['increments']} increments, "
          f"{result.summary['wall_time_s']:.1f} s", flush=True)
    return _peer_record(result.curve, result.summary)


def _failed_record(message: str, partial: dict) -> dict:
    """A CalculiX run that stopped early: its message and the loading it did converge on."""
    return {"failed": message, "approach": np.asarray(partial.get("approach_m", [0.0])),
            "force": np.asarray(partial.get("force_N", [0.0])),
            "cpu_time_s": partial.get("cpu_time_s"), "wall_time_s": partial.get("wall_time_s")}


def failure_report(args, material, ours: dict, peers: dict) -> dict:
    """What can be compared when a CalculiX run stopped early: our three runs (finite / small
    strain at equal force, residual approach, elastic recovery) and each CalculiX run's
    loading as far as it converged (approach at equal force, where reached)."""
    peak = args.peak
    forces = np.array(FORCE_PROBES) * peak
    loading = {"ours_small": ours["small_to_peak"], "ours_finite": ours["finite"], **peers}
    approach = {k: ccx.loading_approach_at(r, forces) for k, r in loading.items()}
    fin, s2p = ours["finite"], ours["small_to_peak"]
    record = {
        **provenance("scripts/verify_finite_strain_ccx.py", _inputs(args, material)),
        "largest_contact_radius_over_R": float(np.max(fin["contact_radius"]) / material.radius),
        "force_probes": {"force_over_peak": list(FORCE_PROBES), "force_N": forces.tolist(),
                         "approach_m": {k: v.tolist() for k, v in approach.items()}},
        "finite_over_small": {
            "approach_at_force": {
                "ours": (approach["ours_finite"] / approach["ours_small"] - 1.0).tolist(),
                "calculix": (approach["ccx_nlgeom"] / approach["ccx_small"] - 1.0).tolist()},
            "ours_residual_approach": fin["residual_approach_m"] / s2p["residual_approach_m"]
            - 1.0,
            "ours_elastic_recovery": ccx.elastic_recovery(fin) / ccx.elastic_recovery(s2p)
            - 1.0},
        "ours_over_calculix_same_kinematics": {
            "small": (approach["ours_small"] / approach["ccx_small"] - 1.0).tolist(),
            "finite": (approach["ours_finite"] / approach["ccx_nlgeom"] - 1.0).tolist()},
        "ours": {k: {q: v for q, v in r.items() if q not in ("approach", "force", "contact_radius")}
                 for k, r in ours.items()},
        "calculix": {k: {"failed": r.get("failed"),
                         "largest_loading_approach_m": float(np.max(r["approach"])),
                         "largest_force_N": float(np.max(r["force"])),
                         "cpu_time_s": r.get("cpu_time_s")} for k, r in peers.items()},
    }
    return record


def failure_table(record: dict) -> str:
    inputs, fp = record["inputs"], record["force_probes"]
    m = inputs["material"]
    lines = [
        "# Finite strain in the weak regime: CalculiX NLGEOM did not run through",
        "",
        f"Made by `{record['command']}` (geocontact {record['geocontact_version']}, "
        f"{record['created_utc']}); inputs in the .json beside this file.",
        "",
        f"Material `{inputs['preset']}` (E/sigma_c = "
        f"{m['youngs_modulus'] / m['compressive_yield_stress']:g}, nu = {m['poissons_ratio']:g}, "
        f"hardening ratio {m['hardening_ratio']:g}, R = {m['radius']:g} m), mesh "
        f"`{inputs['mesh']}` rule `{inputs['mesh_rule']}`, 0 -> {inputs['peak_force_N']:g} N -> 0"
        f" (ours: {inputs['steps_per_segment']} steps per segment, force-step cap "
        f"{inputs['max_step_ratio']}; largest a/R = "
        f"{record['largest_contact_radius_over_R']:.3f}); CalculiX: "
        f"{inputs['ccx_increments_per_step']} increments per step, contact slope "
        f"{inputs['ccx_penalty_factor']:g} E / smallest edge"
        + ("" if inputs.get("ccx_peer_approach_m") is None
           else f", to {1e3 * inputs['ccx_peer_approach_m']:g} mm") + ".",
        "",
        "| CalculiX run | status | largest loading approach | force there |",
        "| --- | --- | --- | --- |"]
    for k, r in record["calculix"].items():
        lines.append(f"| {LABELS[k]} | {r['failed'] or 'ran through'} | "
                     f"{1e3 * r['largest_loading_approach_m']:.4f} mm | "
                     f"{r['largest_force_N']:.4g} N |")
    lines += ["", "Loading approach at equal force (n/a: not reached):", "",
              "| force (N) | " + " | ".join(f"{f:.4g}" for f in fp["force_N"]) + " |",
              "| --- " * (len(fp["force_N"]) + 1) + "|"]
    for k in CODES:
        lines.append(f"| {LABELS[k]} (mm) | " + " | ".join(
            "n/a" if not np.isfinite(x) else f"{1e3 * x:.4f}" for x in fp["approach_m"][k])
            + " |")
    fs, same = record["finite_over_small"], record["ours_over_calculix_same_kinematics"]
    for label, values in (("finite / small - 1, geocontact", fs["approach_at_force"]["ours"]),
                          ("finite / small - 1, CalculiX", fs["approach_at_force"]["calculix"]),
                          ("geocontact / CalculiX - 1, small strain", same["small"]),
                          ("geocontact / CalculiX - 1, finite strain", same["finite"])):
        lines.append(f"| {label} | " + " | ".join(_pct(x) for x in values) + " |")
    lines += ["", f"Ours, finite / small - 1 at the peak force: residual approach "
              f"{_pct(fs['ours_residual_approach'])}, elastic recovery "
              f"{_pct(fs['ours_elastic_recovery'])}."]
    return "\n".join(lines) + "\n"


def _inputs(args, material) -> dict:
    return {"material": material.to_dict(), "preset": args.material_name, "mesh": args.mesh,
            "mesh_rule": args.mesh_rule,
            "steps_per_segment": args.steps, "ccx_increments_per_step": args.increments,
            "w_max_JG": None if args.force is not None else args.w_max,
            "peak_force_N": args.peak, "max_step_ratio": args.max_step_ratio,
            "ccx_penalty_factor": args.penalty, "ccx_unload_to": args.unload_to,
            "ccx_peer_approach_m": args.peer_approach}


def _peer_record(curve, s) -> dict:
    return {"approach": np.asarray(curve["approach_m"]), "force": np.asarray(curve["force_N"]),
            "max_approach_m": s["max_approach_m"], "residual_approach_m": s["residual_approach_m"],
            "max_force_N": s["max_force_N"], "wall_time_s": s["wall_time_s"],
            "cpu_time_s": s["cpu_time_s"], "steps": s["increments"],
            "elements": s["mesh"]["elements"], "nodes": s["mesh"]["nodes"],
            "kinematics": s.get("kinematics")}


def compare(runs: dict, material, loading: dict) -> dict:
    """``runs``: the four load-unload runs from the same largest approach (unloading, residual
    approach); ``loading``: the runs whose loading branches are compared (ours: the two force
    histories 0 -> F -> 0 with the same load steps, so that small and finite strain differ by
    the kinematics alone)."""
    jg, ke = fits.jackson_green_critical(material), fits.kogut_etsion_critical(material)
    # the largest approach every loading branch reaches (CalculiX's unless --peer-approach)
    d_max = min(float(np.max(r["approach"])) for r in loading.values())
    scale = runs["ccx_nlgeom"]["max_force_N"]
    probes = np.array(PROBES) * d_max
    # the largest force every loading branch reaches: approach at equal force up to it
    common_force = min(float(np.max(r["force"])) for r in loading.values())
    force_probes = np.array(FORCE_PROBES) * common_force
    approach_at = {k: ccx.loading_approach_at(r, force_probes) for k, r in loading.items()}
    recovery = {k: ccx.elastic_recovery(r) for k, r in runs.items()}
    measures = {"force": {k: ccx.loading_force_at(r, probes) for k, r in loading.items()},
                "smoothed_force": {k: ccx.smoothed_force_at(r, probes) for k, r in loading.items()},
                "loading_work": {k: ccx.loading_work_at(r, probes) for k, r in loading.items()}}
    out: dict = {"scale_force_N": scale, "largest_approach_m": d_max, "pairs": {}}
    for ours in ("ours_small", "ours_finite"):
        for peer in ("ccx_small", "ccx_nlgeom"):
            a, b = runs[ours], runs[peer]
            la, lb = loading[ours], loading[peer]
            out["pairs"][f"{ours}-{peer}"] = {
                "max_force_difference": {
                    "loading": ccx.force_difference((la["approach"], la["force"]),
                                                    (lb["approach"], lb["force"]),
                                                    scale)["loading"],
                    "unloading": ccx.force_difference((a["approach"], a["force"]),
                                                      (b["approach"], b["force"]),
                                                      scale)["unloading"]},
                **{f"{q}_relative": (m[ours] / m[peer] - 1.0).tolist()
                   for q, m in measures.items()},
                "approach_at_force_relative": (approach_at[ours] / approach_at[peer]
                                               - 1.0).tolist(),
                "elastic_recovery_relative": recovery[ours] / recovery[peer] - 1.0,
                "residual_ratio_difference": (a["residual_approach_m"] / a["max_approach_m"]
                                              - b["residual_approach_m"] / b["max_approach_m"]),
                "unloading_shape_difference": float(np.max(np.abs(
                    ccx.unloading_shape(a, T_GRID) - ccx.unloading_shape(b, T_GRID)))),
            }
    out["probes"] = {"approach_over_largest": list(PROBES), "approach_m": probes.tolist(),
                     **{q: {k: v.tolist() for k, v in m.items()} for q, m in measures.items()}}
    # small against finite strain, each code on its own: the size of the effect to be resolved
    out["finite_over_small"] = {
        q: {"ours": (m["ours_finite"] / m["ours_small"] - 1.0).tolist(),
            "calculix": (m["ccx_nlgeom"] / m["ccx_small"] - 1.0).tolist()}
        for q, m in {**measures, "approach_at_force": approach_at}.items()}
    out["finite_over_small"]["elastic_recovery"] = {
        "ours": recovery["ours_finite"] / recovery["ours_small"] - 1.0,
        "calculix": recovery["ccx_nlgeom"] / recovery["ccx_small"] - 1.0}
    out["force_probes"] = {"force_over_common": list(FORCE_PROBES),
                           "force_N": force_probes.tolist(),
                           "approach_m": {k: v.tolist() for k, v in approach_at.items()}}
    out["elastic_recovery_m"] = recovery
    if d_max / 2.0 / jg.interference > JG_FITTED:
        return out  # beyond the published fits' range (the weak grain): no comparison

    w_grid = np.array(FIT_AT)
    jg_load = fits.jackson_green_load(material, w_grid) * jg.force
    jg_radius = fits.jackson_green_contact_radius(material, w_grid)
    published: dict = {"w_over_wc_JG": w_grid.tolist(), "load_relative_to_JG": {},
                       "contact_radius_relative_to_JG": {}, "residual": {}}
    for k, r in runs.items():
        published["load_relative_to_JG"][k] = (
            ccx.smoothed_force_at(loading[k], 2.0 * w_grid * jg.interference) / jg_load
            - 1.0).tolist()
        if "contact_radius" in loading[k]:
            k_top = int(np.argmax(loading[k]["force"]))
            omega = loading[k]["approach"][:k_top + 1] / 2.0
            radius = loading[k]["contact_radius"][:k_top + 1]
            a = np.interp(w_grid * jg.interference, omega, radius, right=np.nan)
            published["contact_radius_relative_to_JG"][k] = (a / jg_radius - 1.0).tolist()
        w_ke = r["max_approach_m"] / 2.0 / ke.interference
        w_jg = r["max_approach_m"] / 2.0 / jg.interference
        ratio = r["residual_approach_m"] / r["max_approach_m"]
        ekk, jcg = float(fits.etsion_residual_ratio(w_ke)), float(fits.jackson_residual_ratio(w_jg))
        n, n_ekk = ccx.unloading_exponent(r), float(fits.etsion_unloading_exponent(w_ke))
        published["residual"][k] = {
            "w_max_KE": float(w_ke), "residual_ratio": float(ratio), "EKK": ekk, "JCG": jcg,
            "vs_EKK": float(ratio / ekk - 1.0), "vs_JCG": float(ratio / jcg - 1.0),
            "unloading_exponent": n, "unloading_exponent_EKK": n_ekk,
            "exponent_vs_EKK": n / n_ekk - 1.0}
    out["published"] = published
    return out


def parse_args(argv=None) -> argparse.Namespace:
    """The command line, checked, with ``args.material`` loaded (a preset name or a material
    TOML file), ``args.peak`` the largest force (N) and ``args.work`` this run's folder; bad
    input exits with one line naming the option."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--material", default=MATERIAL,
                        help="preset name or material TOML file (beta = 0: CalculiX's *PLASTIC "
                             "is von Mises)")
    parser.add_argument("--mesh", default="coarse")
    parser.add_argument("--mesh-rule", default="contact",
                        help="fem.mesh rule: 'contact' resolves every contact radius up to the "
                             "largest (no node-by-node staircase), 'yield' the verified meshes")
    parser.add_argument("--steps", type=int, default=24, help="our load steps per segment")
    parser.add_argument("--increments", type=int, default=24,
                        help="CalculiX increments per step (loading, unloading)")
    parser.add_argument("--w-max", type=float, default=100.0,
                        help="largest interference / omega_c (Jackson-Green normalisation)")
    parser.add_argument("--force", type=float, default=None,
                        help="largest force (N) instead of --w-max (a grain beyond the JG fit, "
                             "e.g. E/sigma_c = 1e4)")
    parser.add_argument("--max-step-ratio", type=float, default=None,
                        help="our force-step cap on plastic loading (run_history; None: off)")
    parser.add_argument("--penalty", type=float, default=ccx.PENALTY_DEFAULT,
                        help="CalculiX contact slope / (E / smallest element edge)")
    parser.add_argument("--unload-to", type=float, default=UNLOAD_TO,
                        help="CalculiX unloads to this fraction of the largest approach (just "
                             "below the residual approach ratio)")
    parser.add_argument("--peer-approach", type=float, default=None,
                        help="CalculiX's largest approach (m) instead of our finite-strain run's "
                             "(a path CalculiX converges on); the unloading is then not "
                             "compared")
    parser.add_argument("--name", default=None,
                        help="output stem (default finite_strain_ccx[_MESH])")
    parser.add_argument("--work", type=Path, default=Path("out/finite_strain_ccx"))
    parser.add_argument("--out", type=Path, default=OUT)
    args = parser.parse_args(argv)
    for option, value, low in (("--force", args.force, 0.0), ("--w-max", args.w_max, 1.0),
                               ("--penalty", args.penalty, 0.0),
                               ("--peer-approach", args.peer_approach, 0.0)):
        if value is not None and not (np.isfinite(value) and value > low):
            parser.error(f"{option}: must be > {low:g}, got {value:g}")
    if not 0.0 <= args.unload_to < 1.0:
        parser.error(f"--unload-to: must be in [0, 1), got {args.unload_to:g}")
    if args.max_step_ratio is not None and not args.max_step_ratio > 1.0:
        parser.error(f"--max-step-ratio: must be > 1, got {args.max_step_ratio:g}")
    try:
        args.material_name = args.material
        args.material = load_material(args.material)
    except InputError as exc:
        parser.error(f"--material: {exc}")
    if args.material.friction_angle_deg != 0.0:
        parser.error("--material: CalculiX's *PLASTIC is von Mises, need friction_angle_deg = 0, "
                     f"got {args.material.friction_angle_deg:g}")
    if args.force is None:
        jg = fits.jackson_green_critical(args.material)
        args.peak = float(fits.jackson_green_load(args.material, args.w_max)) * jg.force
        target = f"w{args.w_max:g}"
    else:
        args.peak, target = args.force, f"F{args.force:g}"
    if args.name is None:
        args.name = "finite_strain_ccx" + ("" if args.mesh == "coarse" else f"_{args.mesh}")
    tag = "" if args.material_name == MATERIAL else f"{Path(args.material_name).stem}-"
    extra = "".join(f"-{k}{v:g}" for k, v in (("r", args.max_step_ratio),) if v is not None)
    args.work = args.work / (f"{tag}{args.mesh}-{args.mesh_rule}-{args.steps}-"
                             f"{args.increments}-{target}{extra}")
    return args


def main(argv=None) -> int:
    args = parse_args(argv)
    if ccx.ccx_executable() is None:
        raise SystemExit("verify_finite_strain_ccx: needs CalculiX 'ccx' on PATH (make ccx)")
    material, peak = args.material, args.peak
    jg = fits.jackson_green_critical(material)
    finite = run_ours(material, [0.0, peak, 0.0], "ours_finite", args, "finite", peak)
    small_to_peak = run_ours(material, [0.0, peak, 0.0], "ours_small_to_peak", args, "small",
                             peak)
    d_f = finite["max_approach_m"]
    (d, f), _ = ccx.branches(small_to_peak["approach"], small_to_peak["force"])
    if d[-1] < d_f:
        raise SystemExit("verify_finite_strain_ccx: the small-strain run stopped short of the "
                         "finite-strain run's largest approach")
    small = run_ours(material, [0.0, float(np.interp(d_f, d, f)), 0.0], "ours_small", args,
                     "small", peak)
    sized = [0.0, peak]
    fe_mesh = ccx.AxisymmetricMesh.from_skfem(history_mesh(
        material, peak, args.mesh,
        min_force=smallest_resolved_force(material, sized, args.steps), rule=args.mesh_rule))
    if len(fe_mesh.points) != finite["nodes"] or len(fe_mesh.triangles) != finite["elements"]:
        raise SystemExit("verify_finite_strain_ccx: the CalculiX mesh is not the FE run's")
    peers = {"ccx_small": run_peer(material, fe_mesh, args.peer_approach or d_f, args, False,
                                   peak),
             "ccx_nlgeom": run_peer(material, fe_mesh, args.peer_approach or d_f, args, True,
                                    peak)}
    args.out.mkdir(parents=True, exist_ok=True)
    failed = [k for k, r in peers.items() if "failed" in r]
    if failed:
        report = failure_report(args, material, {"finite": finite, "small_to_peak": small_to_peak,
                                                 "small": small}, peers)
        write_json_atomic(args.out / f"{args.name}.json", report)
        write_text_atomic(args.out / f"{args.name}.md", failure_table(report))
        print(failure_table(report))
        raise SystemExit(f"verify_finite_strain_ccx: CalculiX stopped early ({', '.join(failed)});"
                         f" what compares is in {args.out / args.name}.md")
    runs = {"ours_small": small, "ours_finite": finite, **peers}
    result = compare(runs, material, {**runs, "ours_small": small_to_peak})
    ke = fits.kogut_etsion_critical(material)
    record = {
        **provenance("scripts/verify_finite_strain_ccx.py", _inputs(args, material)),
        "critical_JG": {"interference_m": jg.interference, "force_N": jg.force},
        "critical_KE": {"interference_m": ke.interference, "force_N": ke.force},
        "largest_contact_radius_over_R": float(np.max(finite["contact_radius"])
                                               / material.radius),
        "runs": {k: {q: v for q, v in r.items()
                     if q not in ("approach", "force", "contact_radius")}
                 for k, r in runs.items()},
        **result,
    }
    stem = args.name
    write_csv(args.out / f"{stem}.csv", {
        **{f"{k}_approach_m": r["approach"] for k, r in runs.items()},
        **{f"{k}_force_N": r["force"] for k, r in runs.items()}})
    write_json_atomic(args.out / f"{stem}.json", record)
    write_text_atomic(args.out / f"{stem}.md", table(record, stem))
    figure(args.out / f"{stem}.png", runs, {**runs, "ours_small": small_to_peak}, record,
           material)
    print(table(record))
    return 0


def _pct(x) -> str:
    return "n/a" if x is None or not np.isfinite(x) else f"{100 * x:+.2f} %"


def table(record: dict, stem: str = "finite_strain_ccx") -> str:
    inputs, runs = record["inputs"], record["runs"]
    jg = record["critical_JG"]
    m = inputs["material"]
    hardening = m["hardening_ratio"]
    target = (f"{inputs['w_max_JG']:g} omega_c" if inputs.get("w_max_JG") is not None
              else f"{inputs['peak_force_N']:g} N")
    lines = [
        "# Finite strain at large interference: against CalculiX NLGEOM"
        + (" and the published fits" if "published" in record else ""),
        "",
        f"Made by `{record['command']}` (geocontact {record['geocontact_version']}, "
        f"{record['created_utc']}); curves in {stem}.csv, inputs in {stem}.json.",
        "",
        f"Material `{inputs['preset']}` (E/sigma_c = "
        f"{m['youngs_modulus'] / m['compressive_yield_stress']:g}, "
        f"nu = {m['poissons_ratio']:g}, "
        + ("perfectly plastic" if hardening == 0 else f"hardening ratio {hardening:g}")
        + f", R = {m['radius']:g} m), "
        f"mesh `{inputs['mesh']}` ({runs['ours_finite']['elements']} elements, rule "
        f"`{inputs['mesh_rule']}`, the same in both "
        f"codes), 0 -> {target} (JG: omega_c = "
        f"{jg['interference_m']:.4e} m, P_c = {jg['force_N']:.5g} N) -> 0; largest a/R = "
        f"{record['largest_contact_radius_over_R']:.3f}. Ours: {inputs['steps_per_segment']} "
        "load steps per segment (force control"
        + ("" if inputs.get("max_step_ratio") is None
           else f", plastic force steps capped at x {inputs['max_step_ratio']:g}")
        + "); CalculiX: "
        f"{inputs['ccx_increments_per_step']} increments per step (displacement control to "
        + ("our finite-strain run's largest approach" if _like_for_like(inputs) else
           f"{1e3 * inputs['ccx_peer_approach_m']:g} mm (--peer-approach: our runs' unloading "
           "starts elsewhere, so unloading is compared only within each code)")
        + " and back to "
        f"{inputs.get('ccx_unload_to', UNLOAD_TO):g} of it; contact slope "
        f"{inputs.get('ccx_penalty_factor', ccx.PENALTY_DEFAULT):g} E / smallest edge).",
        "",
        "Loading force at equal approach (power law fitted over +/- 20 % of the approach, "
        "`ccx.smoothed_force_at`), relative to each CalculiX run; then the loading work to the "
        "largest approach, the largest pointwise force differences (of the CalculiX NLGEOM peak "
        "force) and the residual approach ratio:",
        "",
        "| approach / largest | " + " | ".join(f"{p:g}" for p in
                                             record["probes"]["approach_over_largest"])
        + " | loading work | max \\|dF\\|/F loading | max \\|dF\\|/F unloading "
        "| d(delta_res/delta_max) | unloading shape max \\|d(P/P_max)\\| |",
        "| --- " * (len(PROBES) + 6) + "|",
    ]
    like = _like_for_like(inputs)
    for name, pair in record["pairs"].items():
        ours, peer = name.split("-")
        fd = pair["max_force_difference"]
        unloading = (f"{_pct(fd['unloading'])} | {pair['residual_ratio_difference']:+.4f} | "
                     f"{pair['unloading_shape_difference']:.4f}") if like else "- | - | -"
        lines.append(f"| {LABELS[ours]} vs {LABELS[peer]} | "
                     + " | ".join(_pct(x) for x in pair["smoothed_force_relative"])
                     + f" | {_pct(pair['loading_work_relative'][-1])} | {_pct(fd['loading'])} | "
                     f"{unloading} |")
    fs = record["finite_over_small"]
    for who, label in (("ours", "geocontact"), ("calculix", "CalculiX")):
        lines.append(f"| finite / small strain - 1, {label} | "
                     + " | ".join(_pct(x) for x in fs["smoothed_force"][who])
                     + f" | {_pct(fs['loading_work'][who][-1])} | | | | |")
    if "force_probes" in record:
        lines += _equal_force_table(record)
    if "published" not in record:
        return _runs_table(lines, runs)
    lines += [
        "",
        "Against the published large-deformation fits (loading force and contact radius: "
        "Jackson & Green 2005; residual interference: Etsion, Kligerman & Kadin 2005 and Jackson, "
        "Chusoipin & Green 2005; unloading exponent: EKK):",
        "",
        "| run | " + " | ".join(f"P/P_JG - 1 at {w:g} wc" for w in FIT_AT) + " |",
        "| --- " * (len(FIT_AT) + 1) + "|",
    ]
    pub = record["published"]
    for k in CODES:
        lines.append(f"| {LABELS[k]} | "
                     + " | ".join(_pct(x) for x in pub["load_relative_to_JG"][k]) + " |")
    for k, values in pub["contact_radius_relative_to_JG"].items():
        lines.append(f"| {LABELS[k]}: a/a_JG - 1 | " + " | ".join(_pct(x) for x in values)
                     + " |")
    lines += ["", "| run | w_max (KE) | delta_res/delta_max | EKK | vs EKK | JCG | vs JCG | "
              "n unloading | n EKK | vs EKK |", "| --- " * 10 + "|"]
    for k in CODES:
        r = pub["residual"][k]
        lines.append(f"| {LABELS[k]} | {r['w_max_KE']:.1f} | {r['residual_ratio']:.4f} | "
                     f"{r['EKK']:.4f} | {_pct(r['vs_EKK'])} | {r['JCG']:.4f} | "
                     f"{_pct(r['vs_JCG'])} | {r['unloading_exponent']:.3f} | "
                     f"{r['unloading_exponent_EKK']:.3f} | {_pct(r['exponent_vs_EKK'])} |")
    return _runs_table(lines, runs)


def _equal_force_table(record: dict) -> list[str]:
    """Approach at equal force (the loading branches) and elastic recovery, finite / small."""
    fp, fs = record["force_probes"], record["finite_over_small"]
    lines = ["", "Loading approach at equal force (force / the largest force all four loading "
             f"branches reach, {fp['force_N'][-1]:.4g} N; linear on the branch's running maximum, "
             "`ccx.loading_approach_at`) and elastic recovery delta_max - delta_res from the same "
             "largest approach:", "",
             "| force / common largest | " + " | ".join(f"{p:g}" for p in
                                                      fp["force_over_common"])
             + " | elastic recovery |", "| --- " * (len(FORCE_PROBES) + 2) + "|"]
    for k in CODES:
        lines.append(f"| {LABELS[k]}: approach (mm) | "
                     + " | ".join("n/a" if not np.isfinite(x) else f"{1e3 * x:.4f}"
                                  for x in fp["approach_m"][k])
                     + f" | {1e3 * record['elastic_recovery_m'][k]:.4f} mm |")
    for name, pair in record["pairs"].items():
        ours, peer = name.split("-")
        recovery = (_pct(pair["elastic_recovery_relative"]) if _like_for_like(record["inputs"])
                    else "-")
        lines.append(f"| {LABELS[ours]} vs {LABELS[peer]} | "
                     + " | ".join(_pct(x) for x in pair["approach_at_force_relative"])
                     + f" | {recovery} |")
    for who, label in (("ours", "geocontact"), ("calculix", "CalculiX")):
        lines.append(f"| finite / small strain - 1, {label} | "
                     + " | ".join(_pct(x) for x in fs["approach_at_force"][who])
                     + f" | {_pct(fs['elastic_recovery'][who])} |")
    return lines


def _like_for_like(inputs: dict) -> bool:
    """Both codes unload from the same largest approach (no --peer-approach)."""
    return inputs.get("ccx_peer_approach_m") is None


def _runs_table(lines: list[str], runs: dict) -> str:
    lines += ["", "| run | steps | wall time | CPU time | largest force | residual approach |",
              "| --- | --- | --- | --- | --- | --- |"]
    for k in CODES:
        r = runs[k]
        cpu = r.get("cpu_time_s")
        lines.append(f"| {LABELS[k]} | {r['steps']} | {r['wall_time_s']:.1f} s | "
                     f"{'' if cpu is None else f'{cpu:.1f} s'} | {r['max_force_N']:.4g} N | "
                     f"{r['residual_approach_m']:.4e} m |")
    return "\n".join(lines) + "\n"


def figure(path, runs, loading, record, material) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    jg = fits.jackson_green_critical(material)
    styles = {"ours_small": ("tab:blue", "--"), "ours_finite": ("tab:blue", "-"),
              "ccx_small": ("tab:red", "--"), "ccx_nlgeom": ("tab:red", "-")}
    published = "published" in record  # else beyond the fits: approach in mm, force in N
    x_scale, x_label = ((1.0 / (2.0 * jg.interference), r"$\omega/\omega_c$ (JG)") if published
                        else (1e3, "approach (mm)"))
    fig, ((ax, dev), (unl, pub)) = plt.subplots(2, 2, figsize=(12, 9))
    for k in CODES:
        r = runs[k]
        color, ls = styles[k]
        ax.plot(r["approach"] * x_scale, r["force"] / (jg.force if published else 1.0), ls,
                color=color, marker="o" if k.startswith("ours") else None, ms=2.5, lw=1.2,
                label=LABELS[k])
    if published:
        w = np.linspace(1.0, record["inputs"]["w_max_JG"], 200)
        ax.plot(w, fits.jackson_green_load(material, w), ":", color="k",
                label="Jackson & Green 2005")
    ax.set_xlabel(x_label)
    ax.set_ylabel(r"$P/P_c$ (JG)" if published else "force (N)")
    ax.set_title("loading and unloading, E/$\\sigma_c$ = "
                 f"{material.youngs_modulus / material.compressive_yield_stress:g}")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)

    d_max = runs["ccx_nlgeom"]["max_approach_m"]
    grid = np.linspace(0.05, 1.0, 60) * d_max
    reference = ccx.smoothed_force_at(loading["ccx_nlgeom"], grid)
    for k in ("ours_small", "ours_finite", "ccx_small"):
        color, ls = styles[k]
        dev.plot(grid * x_scale,
                 100 * (ccx.smoothed_force_at(loading[k], grid) / reference - 1), ls, color=color,
                 label=LABELS[k])
    dev.axhline(0.0, color="0.5", lw=0.8)
    dev.set_xlabel(x_label)
    dev.set_ylabel("loading force / CalculiX NLGEOM - 1 (%)")
    dev.set_title("loading against CalculiX NLGEOM (+/- 20 % power-law fit)")
    dev.legend(fontsize=8)
    dev.grid(alpha=0.3)

    if published:
        w_grid = np.geomspace(1.0, record["inputs"]["w_max_JG"], 80)
        jg_load = fits.jackson_green_load(material, w_grid) * jg.force
        for k in CODES:
            color, ls = styles[k]
            pub.plot(w_grid, 100 * (ccx.smoothed_force_at(loading[k],
                                                          2.0 * w_grid * jg.interference)
                                    / jg_load - 1), ls, color=color, label=LABELS[k])
    else:
        forces = np.linspace(0.02, 1.0, 80) * record["force_probes"]["force_N"][-1]
        reference = ccx.loading_approach_at(loading["ccx_nlgeom"], forces)
        for k in ("ours_small", "ours_finite", "ccx_small"):
            color, ls = styles[k]
            pub.plot(forces, 100 * (ccx.loading_approach_at(loading[k], forces) / reference - 1),
                     ls, color=color, label=LABELS[k])
    t = T_GRID
    shape_nl = ccx.unloading_shape(runs["ccx_nlgeom"], t)
    for k in ("ours_small", "ours_finite", "ccx_small"):
        color, ls = styles[k]
        unl.plot(t, ccx.unloading_shape(runs[k], t) - shape_nl, ls, color=color, label=LABELS[k])
    unl.axhline(0.0, color="0.5", lw=0.8)
    unl.set_xlabel(r"$(\delta - \delta_{res})/(\delta_{max} - \delta_{res})$")
    unl.set_ylabel(r"$P/P_{max}$ - CalculiX NLGEOM's")
    unl.set_title("unloading shape, against CalculiX NLGEOM")
    unl.legend(fontsize=8)
    unl.grid(alpha=0.3)

    pub.axhline(0.0, color="0.5", lw=0.8)
    pub.set_xscale("log")
    if published:
        pub.set_xlabel(r"$\omega/\omega_c$ (JG)")
        pub.set_ylabel("P / Jackson & Green - 1 (%)")
        pub.set_title("loading, against Jackson & Green (2005)")
    else:
        pub.set_xlabel("force (N)")
        pub.set_ylabel("loading approach / CalculiX NLGEOM - 1 (%)")
        pub.set_title("approach at equal force, against CalculiX NLGEOM")
    pub.legend(fontsize=8)
    pub.grid(alpha=0.3, which="both")
    fig.tight_layout()
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=110)
    plt.close(fig)


if __name__ == "__main__":
    raise SystemExit(main())
