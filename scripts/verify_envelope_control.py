"""The "envelope" load-step control against the "dissipation" control on a repeated history.

A reload of a grain flattened far past first yield re-enters the dent the envelope made: the
contact edge sweeps back over the flattened surface node by node while the plastic flow is a
small fraction of the dissipation. The "dissipation" control's edge bound, written for the
plastic front of first loading, cuts such a reload into many small solves; "envelope" counts the
edge's advance only onto fresh surface below the largest force reached (fem.run.ENVELOPE_CONTROLS).
This script runs the same repeated history (0 -> F -> 0, ``--cycles`` times) with:

- ``dissipation``: the control the repeated histories were made with before;
- ``envelope``: the new control;
- ``envelope-fine``: the new control with its largest step capped at ``--fine-ratio`` (the
  step-convergence reference: every reload solve at most that force ratio),

and compares, cycle by cycle, the plastic work, the residual and the peak approach and the
loop work, each relative to the first cycle's value of the same quantity (the scale a shakedown
fit reads), with the cost of each run (solves, Newton iterations, CPU time). The material and F
default to point 0 of the campaign of record (E/sigma_c 1732, F = 410 kN on R = 0.1 m: a/R 0.23),
on the coarse mesh (the default mesh is the campaign's; ``--mesh default`` runs it there).

    .venv/bin/python scripts/verify_envelope_control.py \\
        --json docs/verification/envelope-control.json

Exit status 0 when "envelope" is within ``--tolerance`` of the fine reference in every compared
quantity of every cycle, 1 otherwise.
"""

from __future__ import annotations

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "src"))

from geocontact import __version__  # noqa: E402
from geocontact.errors import ArgumentParser, run_reporting_errors  # noqa: E402
from geocontact.fem.campaign import FemJob, run_campaign  # noqa: E402
from geocontact.fem.identity import compiled_code_hash, fe_code_hash  # noqa: E402
from geocontact.fem.settings import FeSettings  # noqa: E402
from geocontact.files import write_json_atomic  # noqa: E402
from geocontact.grain.material import Material  # noqa: E402
from geocontact.universal.record import fe_settings  # noqa: E402

# point 0 of the campaign of record (datasets/universal/record, its repeated history's force)
POINT_0 = {"youngs_modulus": 1.0e10, "poissons_ratio": 0.25,
           "compressive_yield_stress": 5773502.691896256, "friction_angle_deg": 30.0,
           "hardening_ratio": 0.15, "radius": 0.1}
POINT_0_FORCE = 410375.72526837874
COMPARED = ("plastic_work_J", "residual_approach_m", "max_approach_m", "loop_work_J")


def run_one(material: Material, forces: list[float], mesh: str, control: str,
            ratio: float | None, cache: Path) -> dict:
    """One run in the FE cache ``cache`` (a run of FE code the current code reproduces is
    reused: ``fem.campaign.run_campaign``); its CPU time is its own (summary.json)."""
    settings = fe_settings(mesh=mesh, step_control=control, max_step_ratio=ratio)
    job = FemJob(material, tuple(forces), label=f"{control} {ratio}",
                 **{name: getattr(settings, name) for name in FeSettings.names()})
    s = run_campaign([job], cache, workers=1, progress=False)[0].summary
    return {"step_control": control, "max_step_ratio": ratio, "cpu_time_s": s["cpu_time_s"],
            "fe_code": s["identity"]["fe_code"], "newton_iterations": s["newton_iterations"],
            "solves": s["step_control"]["solves"],
            "rejected_solves": s["step_control"]["rejected_solves"],
            "next_step_set_by": s["step_control"]["next_step_set_by"],
            "cycles": [{name: c[name] for name in COMPARED} for c in s["cycles"]]}


def differences(run: dict, reference: dict) -> dict[str, float]:
    """The largest difference of each compared quantity over the cycles, relative to the
    reference's first-cycle value of it."""
    out = {}
    for name in COMPARED:
        scale = abs(reference["cycles"][0][name])
        out[name] = max(abs(a[name] - b[name]) / scale
                        for a, b in zip(run["cycles"], reference["cycles"], strict=True))
    return out


def main(argv: list[str] | None = None) -> int:
    p = ArgumentParser(prog="verify_envelope_control.py", description=__doc__.split("\n\n")[0])
    p.add_argument("--force", type=float, default=POINT_0_FORCE, help="peak force F (N)")
    p.add_argument("--cycles", type=int, default=10)
    p.add_argument("--mesh", default="coarse", choices=("coarse", "default", "fine"))
    p.add_argument("--fine-ratio", type=float, default=1.05,
                   help="largest force ratio of a solve in the fine reference")
    p.add_argument("--tolerance", type=float, default=0.01,
                   help="allowed difference, relative to the first cycle's value")
    p.add_argument("--json", type=Path, help="write the comparison here")
    p.add_argument("--cache", type=Path, default=Path("out/cache/envelope-control"),
                   help="FE result cache (runs found there are not made again)")

    def run() -> int:
        args = p.parse_args(argv)
        material = Material(**POINT_0)
        forces = [0.0] + [args.force, 0.0] * args.cycles
        runs = {}
        for name, control, ratio in (("dissipation", "dissipation", None),
                                     ("envelope", "envelope", None),
                                     ("envelope-fine", "envelope", args.fine_ratio)):
            print(f"{name}: running", file=sys.stderr, flush=True)
            runs[name] = run_one(material, forces, args.mesh, control, ratio, args.cache)
            r = runs[name]
            print(f"{name}: {r['solves']} solves, {r['newton_iterations']} Newton iterations, "
                  f"CPU {r['cpu_time_s']:.0f} s", file=sys.stderr, flush=True)
        reference = runs["envelope-fine"]
        compared = {name: differences(runs[name], reference)
                    for name in ("dissipation", "envelope")}
        within = all(v <= args.tolerance for v in compared["envelope"].values())
        for name, diff in compared.items():
            print(f"{name} vs envelope-fine: " + ", ".join(
                f"{k} {v:.2e}" for k, v in diff.items()))
        new, old = runs["envelope"], runs["dissipation"]
        print(f"envelope / dissipation: CPU {new['cpu_time_s'] / old['cpu_time_s']:.3f}, "
              f"Newton iterations {new['newton_iterations'] / old['newton_iterations']:.3f}")
        if args.json:
            write_json_atomic(args.json, {
                "command": "scripts/verify_envelope_control.py", "version": __version__,
                "fe_code": fe_code_hash(), "compiled_code": compiled_code_hash(),
                "inputs": {"material": POINT_0, "force_N": args.force, "cycles": args.cycles,
                           "mesh": args.mesh, "fine_ratio": args.fine_ratio,
                           "tolerance": args.tolerance},
                "runs": runs, "largest_difference_to_fine": compared,
                "envelope_within_tolerance": within})
        return 0 if within else 1

    return run_reporting_errors(run)


if __name__ == "__main__":
    sys.exit(main())
