"""Mesh convergence of the FE engine on the reference cycle (docs/model.md §5 verification).

The reference material (E = 10 GPa, nu = 0.25, sigma_c = 10 MPa, beta = 30 deg, m = 0,
R = 0.1 m), force history 0 -> 6000 N -> 0, on the coarse, default and fine meshes, each with
its preset number of load steps per segment (what ``geocontact fem --mesh M`` runs). Reported per
mesh: the loading force at fixed approaches (25, 50, 100 % of the smallest peak approach of the
three runs), the peak and residual approach, the plastic work, the first-yield force Fy, the
fully plastic onset Fp (geocontact.fem.run.fully_plastic_onset) and the wall time; and the
relative difference of each mesh from the fine one. Fp is also evaluated for other sizes of the
contact core over which the yielded fraction is measured (the criterion's sensitivity).

    PYTHONPATH=src .venv/bin/python scripts/verify_mesh_convergence.py     # about 10 min
    ... verify_mesh_convergence.py --steps preset --tag _preset_steps   # each mesh's own steps

The same number of load steps on every mesh (default 24 per segment) isolates the mesh; with
``--steps preset`` each mesh runs its own preset (what ``geocontact fem --mesh M`` does), which
mixes in the load-step dependence. Writes docs/verification/mesh_convergence{TAG}.{csv,md,json}
and fp_fractions{TAG}.csv.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from geocontact.fem.result import STEPS_PER_SEGMENT
from geocontact.fem.run import (
    FULLY_PLASTIC_CORE,
    FULLY_PLASTIC_FRACTION,
    fully_plastic_onset,
    run_history,
)
from geocontact.files import provenance, write_csv, write_json_atomic, write_text_atomic
from geocontact.grain.material import preset

OUT = Path(__file__).resolve().parents[1] / "docs" / "verification"
FORCES = [0.0, 6000.0, 0.0]
MESHES = ("coarse", "default", "fine")
APPROACH_FRACTIONS = (0.25, 0.5, 1.0)
CORE_EXTENTS = (0.5, 0.6, 0.7, 0.8, 0.9, 1.0)


def _run(material, mesh: str, steps: int | None) -> dict:
    started = time.perf_counter()
    # the "yield" meshes and fixed steps (the defaults before issue 36): the presets' meshes,
    # whose convergence the documented table measures
    result = run_history(material, FORCES, mesh=mesh, write_fields=False, keep_states=True,
                         steps_per_segment=steps, mesh_rule="yield", step_control="fixed")
    wall = time.perf_counter() - started
    c, s, solver = result.curve, result.summary, result.solver
    (cycle,) = s["cycles"]
    peak = int(np.argmax(c["force_N"]))
    loading = slice(0, peak + 1)
    fractions = {e: np.array([solver.yielded_contact_fraction(st, e)
                              for st in result.states[: peak + 1]]) for e in CORE_EXTENTS}
    onsets = {e: fully_plastic_onset(c["force_N"][loading], c["approach_m"][loading], f)
              for e, f in fractions.items()}
    return {
        "mesh": mesh, "elements": s["mesh"]["elements"], "nodes": s["mesh"]["nodes"],
        "steps": s["steps"], "steps_per_segment": s["inputs"]["steps_per_segment"],
        "wall_time_s": wall,
        "loading_force_N": c["force_N"][loading], "loading_approach_m": c["approach_m"][loading],
        "max_approach_m": cycle["max_approach_m"],
        "residual_approach_m": cycle["residual_approach_m"],
        "plastic_work_J": cycle["plastic_work_J"],
        "first_yield_force_N": s["first_yield_force_N"],
        "fully_plastic_force_N": s["fully_plastic_force_N"],
        "fully_plastic_by_core": {str(e): (o["force_N"] if o else None)
                                  for e, o in onsets.items()},
        "fractions": fractions,
    }


def _force_at(run: dict, approach: float) -> float:
    """Loading force at ``approach``: linear in log-log between steps (F ~ delta^n locally)."""
    d, f = run["loading_approach_m"], run["loading_force_N"]
    keep = (d > 0) & (f > 0)
    return float(np.exp(np.interp(np.log(approach), np.log(d[keep]), np.log(f[keep]))))


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--meshes", nargs="+", default=list(MESHES), choices=MESHES)
    parser.add_argument("--steps", default="24",
                        help="load steps per segment for every mesh (default 24, the default "
                        "mesh's), or 'preset' for each mesh's own (coarse 12, default 24, fine 40)")
    parser.add_argument("--tag", default="", help="suffix of the output file names")
    parser.add_argument("--out", type=Path, default=OUT)
    args = parser.parse_args(argv)
    steps = None if args.steps == "preset" else int(args.steps)
    material = preset("reference")
    runs = [_run(material, m, steps) for m in args.meshes]
    reference_approach = min(r["max_approach_m"] for r in runs)

    quantities = [(f"force at {int(100 * q)} % approach (N)", lambda r, q=q:
                   _force_at(r, q * reference_approach)) for q in APPROACH_FRACTIONS]
    quantities += [
        ("peak approach (m)", lambda r: r["max_approach_m"]),
        ("residual approach (m)", lambda r: r["residual_approach_m"]),
        ("plastic work (J)", lambda r: r["plastic_work_J"]),
        ("first yield Fy (N)", lambda r: r["first_yield_force_N"]),
        ("fully plastic Fp (N)", lambda r: r["fully_plastic_force_N"]),
    ]
    table = {name: [fn(r) for r in runs] for name, fn in quantities}
    last = len(runs) - 1
    columns = {"quantity": list(table)}
    for i, r in enumerate(runs):
        columns[r["mesh"]] = [v[i] for v in table.values()]
    for i, r in enumerate(runs[:last]):
        columns[f"{r['mesh']}_vs_{runs[last]['mesh']}"] = [
            (v[i] / v[last] - 1.0) if v[i] is not None and v[last] else None
            for v in table.values()]
    args.out.mkdir(parents=True, exist_ok=True)
    write_csv(args.out / f"mesh_convergence{args.tag}.csv",
              {k: [("" if x is None else x) for x in v] for k, v in columns.items()})
    long = {"mesh": [], "step": [], "force_N": [], "approach_m": []}
    long.update({f"yielded_fraction_core_{e}": [] for e in CORE_EXTENTS})
    for r in runs:
        n = len(r["loading_force_N"])
        long["mesh"] += [r["mesh"]] * n
        long["step"] += list(range(n))
        long["force_N"] += list(r["loading_force_N"])
        long["approach_m"] += list(r["loading_approach_m"])
        for e in CORE_EXTENTS:
            long[f"yielded_fraction_core_{e}"] += list(r["fractions"][e])
    write_csv(args.out / f"fp_fractions{args.tag}.csv", long)
    record = {
        **provenance("scripts/verify_mesh_convergence.py", {
            "material": material.to_dict(), "forces_N": FORCES, "meshes": args.meshes,
            "steps_per_segment": {m: steps or STEPS_PER_SEGMENT[m] for m in args.meshes},
            "reference_approach_m": reference_approach,
            "fully_plastic_criterion": {"fraction": FULLY_PLASTIC_FRACTION,
                                        "core": FULLY_PLASTIC_CORE}}),
        "table": table,
        "runs": [{k: v for k, v in r.items() if k not in ("loading_force_N",
                                                          "loading_approach_m", "fractions")}
                 for r in runs],
    }
    write_json_atomic(args.out / f"mesh_convergence{args.tag}.json", record)
    text = _markdown(record, runs, args.tag)
    write_text_atomic(args.out / f"mesh_convergence{args.tag}.md", text)
    print(text)
    return 0


def _markdown(record: dict, runs: list[dict], tag: str) -> str:
    names = [r["mesh"] for r in runs]
    last = names[-1]
    head = "| quantity | " + " | ".join(names) + " | " + " | ".join(
        f"{n} vs {last}" for n in names[:-1]) + " |"
    lines = [
        "# Mesh convergence on the reference cycle (0 -> 6000 N -> 0)",
        "",
        "Load steps per segment: " + ", ".join(f"{r['mesh']} {r['steps_per_segment']}"
                                               for r in runs) + ".",
        "",
        f"Made by `{record['command']}` (geocontact {record['geocontact_version']}, "
        f"{record['created_utc']}); inputs and raw numbers in mesh_convergence{tag}.json, the "
        f"yielded fractions per step in fp_fractions{tag}.csv. Fixed approaches are fractions of "
        f"{record['inputs']['reference_approach_m']:.5e} m (the smallest peak approach of the "
        "runs). Fp: yielded fraction of the contact core r < "
        f"{record['inputs']['fully_plastic_criterion']['core']} a reaching "
        f"{record['inputs']['fully_plastic_criterion']['fraction']}.",
        "",
        head,
        "| --- " * (1 + 2 * len(names) - 1) + "|",
    ]
    for name, values in record["table"].items():
        cells = [("–" if v is None else f"{v:.5g}") for v in values]
        rel = [("–" if (v is None or not values[-1]) else f"{100 * (v / values[-1] - 1):+.2f} %")
               for v in values[:-1]]
        lines.append(f"| {name} | " + " | ".join(cells) + " | " + " | ".join(rel) + " |")
    lines += ["", "| mesh | elements | nodes | steps (per segment) | wall time |",
              "| --- | --- | --- | --- | --- |"]
    for r in runs:
        lines.append(f"| {r['mesh']} | {r['elements']} | {r['nodes']} | {r['steps']} "
                     f"({r['steps_per_segment']}) | {r['wall_time_s']:.1f} s |")
    lines += ["", "Fp (N) against the core radius over which the yielded fraction is measured "
              f"(threshold {FULLY_PLASTIC_FRACTION}):", "",
              "| core r/a | " + " | ".join(names) + " |", "| --- " * (1 + len(names)) + "|"]
    for e in CORE_EXTENTS:
        cells = [r["fully_plastic_by_core"][str(e)] for r in runs]
        lines.append(f"| {e} | " + " | ".join("–" if c is None else f"{c:.0f}" for c in cells)
                     + " |")
    lines += ["", "(Wall times on the shared 2-core machine; they vary with its load.)", ""]
    return "\n".join(lines)


if __name__ == "__main__":
    raise SystemExit(main())
