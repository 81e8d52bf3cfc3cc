"""Finite strain against small strain (issue 15, fem.finite_strain).

1. Small loads: the reference grain (sigma_c = 10 MPa) 0 -> 10 Fy -> 0, small and finite strain
   on the same mesh and steps: the approach at equal forces on loading, first yield, residual
   approach and plastic work (the finite-strain engine must reproduce the small-strain one
   where strains are small: <= 0.5 %).
2. The paper's histories (docs/cycles.md: repeated, 10 cycles 0 -> 3000 N -> 0; mono-increasing,
   seven cycles rising from 100 to 3000 N; mono-decreasing, 3000, 2500, ..., 500, 100 N) for
   both materials (sigma_c = 10 MPa and 1 MPa), small and finite strain on the same coarse mesh:
   per cycle the peak approach, residual approach and plastic work, and their finite/small
   ratios; the energy balance (work of the force = elastic energy + plastic dissipation) of
   every run.

    PYTHONPATH=src nice -n 5 .venv/bin/python scripts/verify_finite_strain.py   # ~1.5 h
        [--histories repeated mono-increasing mono-decreasing]

Every FE run is a resumable result folder under ``--work`` (``run_history(resume=True)``).
Writes docs/verification/finite_strain.{json,md,png}.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from geocontact.files import atomic_path, provenance, write_json_atomic, write_text_atomic
from geocontact.grain.force_history import preset_history
from geocontact.grain.material import preset

OUT = Path(__file__).resolve().parents[1] / "docs" / "verification"
MATERIALS = {"10MPa": "reference", "1MPa": "reference-weak"}
PEAK = 3000.0


def _run(material, forces, name, args, kinematics, steps):
    from geocontact.fem.run import run_history

    started = time.perf_counter()
    # the "yield" meshes and fixed steps (the defaults before issue 36), on which the committed
    # docs/verification/finite_strain.* were made
    result = run_history(material, forces, mesh=args.mesh, out=args.work / name,
                         steps_per_segment=steps, resume=True, write_fields=False,
                         kinematics=kinematics, progress=True, mesh_rule="yield",
                         step_control="fixed")
    print(f"{name}: {result.summary['steps']} steps, {result.summary['wall_time_s']:.0f} s "
          f"({time.perf_counter() - started:.0f} s now)", flush=True)
    return result


def energy_gap(curve) -> float:
    """max |work - elastic energy - dissipation| / max work along the run."""
    gap = curve["work_J"] - curve["elastic_energy_J"] - curve["plastic_dissipation_J"]
    return float(np.max(np.abs(gap)) / np.max(curve["work_J"]))


def small_loads(args) -> dict:
    from geocontact.grain.hertz import incipient_yield

    material = preset("reference")
    fy = float(incipient_yield(material).force)
    forces = [0.0, 10.0 * fy, 0.0]
    runs = {k: _run(material, forces, f"small-loads-{k}", args, k, args.small_steps)
            for k in ("small", "finite")}
    a, b = runs["small"].curve, runs["finite"].curve
    top_a, top_b = int(np.argmax(a["force_N"])), int(np.argmax(b["force_N"]))
    force = a["force_N"][1:top_a + 1]
    shared = np.isin(force, b["force_N"][:top_b + 1])
    approach_b = np.interp(force, b["force_N"][:top_b + 1], b["approach_m"][:top_b + 1])
    rel = approach_b / a["approach_m"][1:top_a + 1] - 1.0
    cs, cf = runs["small"].summary["cycles"][0], runs["finite"].summary["cycles"][0]
    return {
        "forces_N": forces,
        "approach_max_relative_difference": float(np.max(np.abs(rel[shared]))),
        "first_yield_relative_difference": float(
            runs["finite"].summary["first_yield_force_N"]
            / runs["small"].summary["first_yield_force_N"] - 1.0),
        "residual_approach_relative_difference": float(
            cf["residual_approach_m"] / cs["residual_approach_m"] - 1.0),
        "plastic_work_relative_difference": float(cf["plastic_work_J"] / cs["plastic_work_J"]
                                                  - 1.0),
        "energy_gap": {k: energy_gap(r.curve) for k, r in runs.items()},
    }


HISTORIES = ("repeated", "mono-increasing", "mono-decreasing")


def paper_history(history: str, args) -> tuple[dict, dict]:
    forces = preset_history(history, PEAK)
    out, curves = {}, {}
    for label, name in MATERIALS.items():
        material = preset(name)
        runs = {k: _run(material, forces, f"{history}-{label}-{k}", args, k, args.steps)
                for k in ("small", "finite")}
        per = {}
        for k, r in runs.items():
            cycles = r.summary["cycles"]
            per[k] = {key: [c[key] for c in cycles] for key in
                      ("max_approach_m", "residual_approach_m", "plastic_work_J")}
        ratio = {key: (np.array(per["finite"][key]) / np.array(per["small"][key]) - 1.0).tolist()
                 for key in per["small"]}
        peak = runs["finite"].curve["contact_radius_m"][int(np.argmax(
            runs["finite"].curve["force_N"]))]
        out[label] = {
            "material": name, "per_cycle": per, "finite_over_small_minus_1": ratio,
            "peak_contact_radius_over_R": float(peak / material.radius),
            "energy_gap": {k: energy_gap(r.curve) for k, r in runs.items()},
            "wall_time_s": {k: r.summary["wall_time_s"] for k, r in runs.items()},
            "newton_iterations": {k: r.summary["newton_iterations"] for k, r in runs.items()},
            "steps": runs["small"].summary["steps"],
            "peak_forces_N": [c["max_force_N"] for c in runs["small"].summary["cycles"]],
        }
        curves[label] = {k: r.curve for k, r in runs.items()}
    return out, curves


def _figure(path: Path, curves: dict, record: dict) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    histories = list(record["histories"])
    fig, axes = plt.subplots(len(histories), 3, figsize=(15, 3.8 * len(histories)),
                             squeeze=False)
    for row, history in enumerate(histories):
        for col, label in enumerate(MATERIALS):
            ax = axes[row][col]
            for k, style in (("small", "-"), ("finite", "--")):
                c = curves[history][label][k]
                ax.plot(1e3 * c["approach_m"], c["force_N"], style, lw=1,
                        label=f"{k} strain")
            ax.set_xlabel("approach (mm, ball-ball)")
            ax.set_ylabel("force (N)")
            ax.set_title(f"sigma_c = {label[:-3]} MPa, {history} (peak {PEAK:g} N)",
                         fontsize=9)
            ax.legend(fontsize=8)
            ax.grid(True, alpha=0.3)
        dev = axes[row][2]
        for label, colour in zip(MATERIALS, ("tab:blue", "tab:red"), strict=True):
            ratio = record["histories"][history][label]["finite_over_small_minus_1"]
            n = np.arange(1, len(ratio["max_approach_m"]) + 1)
            for key, marker in (("max_approach_m", "o"), ("residual_approach_m", "s")):
                dev.plot(n, 100 * np.array(ratio[key]), marker + "-", ms=4, color=colour,
                         alpha=1.0 if key == "max_approach_m" else 0.6,
                         label=f"{label}: {key}")
        dev.axhline(0.0, color="0.5", lw=0.8)
        dev.set_xlabel("cycle N")
        dev.set_ylabel("finite / small - 1 (%)")
        dev.set_title(f"{history}: finite against small strain", fontsize=9)
        dev.grid(True, alpha=0.3)
        dev.legend(fontsize=7)
    fig.tight_layout()
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=90, bbox_inches="tight", format="png")
    plt.close(fig)


def _markdown(record: dict) -> str:
    s = record["small_loads"]
    lines = [
        "# Finite strain against small strain (`scripts/verify_finite_strain.py`)", "",
        f"Mesh `{record['inputs']['mesh']}`. Small loads (reference grain, 0 -> 10 Fy -> 0, "
        f"{record['inputs']['small_steps']} steps per segment): approach at equal forces within "
        f"{100 * s['approach_max_relative_difference']:.3f} %, first yield "
        f"{100 * s['first_yield_relative_difference']:+.3f} %, residual approach "
        f"{100 * s['residual_approach_relative_difference']:+.3f} %, plastic work "
        f"{100 * s['plastic_work_relative_difference']:+.3f} %.", "",
        f"The paper's histories (peak {PEAK:g} N), {record['inputs']['steps']} steps per "
        "segment; finite / small - 1 per cycle (%; N = 1, 2, 4 and the last cycle):", "",
        "| history | material | a/R at peak | quantity | N=1 | N=2 | N=4 | last "
        "| energy gap small / finite |",
        "| --- | --- | --- | --- | --- | --- | --- | --- | --- |",
    ]
    for history, by_material in record["histories"].items():
        for label, r in by_material.items():
            for key in ("max_approach_m", "residual_approach_m", "plastic_work_J"):
                v = r["finite_over_small_minus_1"][key]
                cells = " | ".join(f"{100 * v[i]:+.2f}" for i in (0, 1, 3, len(v) - 1))
                gap = r["energy_gap"]
                lines.append(f"| {history} | {label} | {r['peak_contact_radius_over_R']:.3f} | "
                             f"{key} | {cells} | {100 * gap['small']:.2f} % / "
                             f"{100 * gap['finite']:.2f} % |")
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--mesh", default="coarse")
    parser.add_argument("--steps", type=int, default=6, help="paper's histories, per segment")
    parser.add_argument("--histories", nargs="+", choices=HISTORIES, default=list(HISTORIES))
    parser.add_argument("--small-steps", type=int, default=8, help="small loads, per segment")
    parser.add_argument("--work", type=Path, default=Path("out/verify_finite_strain"))
    parser.add_argument("--out", type=Path, default=OUT)
    args = parser.parse_args(argv)
    args.work.mkdir(parents=True, exist_ok=True)
    record = {**provenance("scripts/verify_finite_strain.py", {
        "mesh": args.mesh, "steps": args.steps, "small_steps": args.small_steps,
        "histories": args.histories})}
    record["small_loads"] = small_loads(args)
    record["histories"], curves = {}, {}
    for history in args.histories:
        record["histories"][history], curves[history] = paper_history(history, args)
    args.out.mkdir(parents=True, exist_ok=True)
    write_json_atomic(args.out / "finite_strain.json", record)
    write_text_atomic(args.out / "finite_strain.md", _markdown(record))
    _figure(args.out / "finite_strain.png", curves, record)
    print(_markdown(record))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
