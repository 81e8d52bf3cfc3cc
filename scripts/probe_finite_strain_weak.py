"""How much of the weak grain's finite- vs small-strain difference is geometric (issue 15).

The coarse comparison along the paper's histories (``verify_finite_strain.py``, 6 uncapped load
steps per segment) gives finite / small - 1 = -12 % in the weak grain's peak approach at
3000 N, while a von Mises sphere of E / sigma_c = 200 at a / R = 0.15 differs by about 1 % from
small strain, in our code and in CalculiX NLGEOM (``verify_finite_strain_ccx.py``). Two
questions, one load 0 -> 3000 N -> 0 on the coarse mesh each:

1. how much of the -12 % is the load-step dependence (docs/fem.md, the staircase): the same runs
   with the load-step cap ``max_step_ratio`` (default 1.02);
2. how much is the Drucker-Prager cone: the same grain with beta = 0 (von Mises at the weak
   grain's E / sigma_c = 1e4).

    PYTHONPATH=src nice -n 5 .venv/bin/python scripts/probe_finite_strain_weak.py   # ~15 min

Every run is a resumable result folder under ``--work``; writes
docs/verification/finite_strain_weak.json and prints the table.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from geocontact.files import provenance, write_json_atomic
from geocontact.grain.material import preset

OUT = Path(__file__).resolve().parents[1] / "docs" / "verification" / "finite_strain_weak.json"
FORCES = [0.0, 3000.0, 0.0]


def main(argv=None) -> int:
    from geocontact.fem.run import run_history

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--work", type=Path, default=Path("out/probe_finite_strain_weak"))
    parser.add_argument("--mesh", default="coarse")
    parser.add_argument("--steps", type=int, default=6)
    parser.add_argument("--max-step-ratio", type=float, default=1.02)
    parser.add_argument("--out", type=Path, default=OUT)
    args = parser.parse_args(argv)
    record = provenance("scripts/probe_finite_strain_weak.py", {
        "material": "reference-weak", "forces_N": FORCES, "mesh": args.mesh,
        "steps": args.steps, "max_step_ratio": args.max_step_ratio})
    rows = []
    for beta in (30.0, 0.0):
        material = preset("reference-weak").with_(friction_angle_deg=beta)
        cycle = {}
        for kinematics in ("small", "finite"):
            result = run_history(material, FORCES, mesh=args.mesh,
                                 out=args.work / f"b{beta:g}-{kinematics}",
                                 steps_per_segment=args.steps, resume=True, write_fields=False,
                                 kinematics=kinematics, max_step_ratio=args.max_step_ratio,
                                 mesh_rule="yield", step_control="fixed")  # as documented
            c = result.summary["cycles"][0]
            peak = int(result.curve["force_N"].argmax())
            cycle[kinematics] = {"max_approach_m": c["max_approach_m"],
                                 "peak_contact_radius_over_R": float(
                                     result.curve["contact_radius_m"][peak] / material.radius),
                                 "residual_approach_m": c["residual_approach_m"],
                                 "wall_time_s": result.summary["wall_time_s"]}
        rows.append({
            "friction_angle_deg": beta, "runs": cycle,
            "finite_over_small_minus_1": {
                k: cycle["finite"][k] / cycle["small"][k] - 1.0
                for k in ("max_approach_m", "residual_approach_m")}})
    record["rows"] = rows
    write_json_atomic(args.out, record)
    print("| beta | a/R at peak (finite) | peak approach small / finite (mm) | finite / small - 1: "
          "peak | residual |")
    print("| --- | --- | --- | --- | --- |")
    for r in rows:
        s, f = r["runs"]["small"], r["runs"]["finite"]
        d = r["finite_over_small_minus_1"]
        print(f"| {r['friction_angle_deg']:g} | {f['peak_contact_radius_over_R']:.3f} | "
              f"{1e3 * s['max_approach_m']:.4f} / "
              f"{1e3 * f['max_approach_m']:.4f} | {100 * d['max_approach_m']:+.1f} % | "
              f"{100 * d['residual_approach_m']:+.1f} % |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
