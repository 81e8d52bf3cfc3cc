"""The "envelope" load-step control against the "dissipation" control on a repeated history.

A reload of a grain flattened far past first yield re-enters the dent the envelope made: the
contact edge sweeps back over the flattened surface node by node while the plastic flow is a
small fraction of the run's dissipation. The "dissipation" control's edge bound, written for the
plastic front of first loading, cuts such a reload into many small solves; "envelope" measures a
reload below the envelope against itself (fem.run.ENVELOPE_CONTROLS: the edge's advance onto
fresh surface, or its whole advance on the dent's rim, ENVELOPE_RIM_ELEMENTS; the reload's own
dissipation and work). This script runs the same repeated history (0 -> F -> 0, ``--cycles``
times) with:

- ``dissipation``: the control the repeated histories were made with before;
- ``envelope``: the new control;
- ``dissipation-fine``: "dissipation" with its largest step capped at ``--fine-ratio`` (the
  step-convergence reference: every bound of "dissipation" in full, on every reload solve, and
  every solve at most that force ratio; none of the envelope control's own rules in it),

and compares, cycle by cycle from the second on, what a shakedown fit reads: each cycle's
plastic work and residual-approach increment, relative to the fine reference's own value of that
cycle (``per_cycle``), beside the largest difference of the plastic work, residual, peak
approach and loop work relative to the first cycle's value (``to_first_cycle``), with the cost of
each run (solves, Newton iterations, CPU time). The material and F are those of a point of the
campaign of record (``--point``, default 0: E/sigma_c 1732, F = 410 kN on R = 0.1 m, a/R 0.23;
point 1 is E/sigma_c 30), read from the committed dataset (its material and its repeated
history's peak), on the coarse mesh (``--mesh default`` runs the campaign's). Runs are cached in
``--cache`` (fem.campaign); ``--only NAME`` makes one run and compares nothing (two processes
can fill the cache side by side).

    .venv/bin/python scripts/verify_envelope_control.py \\
        --json docs/verification/envelope-control.json
    .venv/bin/python scripts/verify_envelope_control.py --point 1 \\
        --json docs/verification/envelope-control-point1.json

Exit status 0 when "envelope" is within ``--tolerance`` of the fine reference in every cycle's
plastic work and residual increment, or is the very run "dissipation" is (the same solves and
cycles: nothing below the envelope for its rules to change, as on a grain that shakes down in
its first cycle), 1 otherwise. How far "dissipation" itself is from the reference is reported
beside it: a finding about the default control, not a condition here.
"""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "src"))

from geocontact import __version__  # noqa: E402
from geocontact.errors import ArgumentParser, InputError, run_reporting_errors  # noqa: E402
from geocontact.fem.campaign import FemJob, run_campaign  # noqa: E402
from geocontact.fem.identity import compiled_code_hash, fe_code_hash  # noqa: E402
from geocontact.fem.run import ENVELOPE_RIM_ELEMENTS  # noqa: E402
from geocontact.fem.settings import FeSettings  # noqa: E402
from geocontact.files import write_json_atomic  # noqa: E402
from geocontact.grain.material import Material  # noqa: E402
from geocontact.universal.record import fe_settings  # noqa: E402

DATASET = ROOT / "datasets" / "universal" / "record" / "provenance.json"
# name: (step control, capped at --fine-ratio)
VARIANTS = {"dissipation": ("dissipation", False), "envelope": ("envelope", False),
            "dissipation-fine": ("dissipation", True)}
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


def check_range(field: str, value: float, low: float, high: float) -> None:
    """A one-line InputError unless ``low <= value <= high`` (and finite)."""
    if not (math.isfinite(value) and low <= value <= high):
        raise InputError(f"{field}: must be in [{low:g}, {high:g}], got {value}")


def committed_point(index: int) -> tuple[dict, float]:
    """The material and the repeated history's peak force of the campaign of record's point
    ``index`` (its committed provenance); a one-line InputError if it is not there."""
    points = json.loads(DATASET.read_text())["points"]
    if str(index) in points:
        point = points[str(index)]
        return point["material"], max(point["repeated_history_forces_N"])
    raise InputError(f"--point: point {index} is not in {DATASET.relative_to(ROOT)} (points "
                     f"there: {', '.join(sorted(points))})")


def differences(run: dict, reference: dict) -> dict[str, float]:
    """The largest difference of each compared quantity over the cycles, relative to the
    reference's first-cycle value of it."""
    out = {}
    for name in COMPARED:
        scale = abs(reference["cycles"][0][name])
        out[name] = max(abs(a[name] - b[name]) / scale
                        for a, b in zip(run["cycles"], reference["cycles"], strict=True))
    return out


def per_cycle(run: dict, reference: dict) -> dict[str, list[float]]:
    """Cycle by cycle from the second: the plastic work and the increment of the residual
    approach, each relative to the reference's value of that cycle (signed)."""
    mine, theirs = run["cycles"], reference["cycles"]

    def increment(cycles, n):
        return cycles[n]["residual_approach_m"] - cycles[n - 1]["residual_approach_m"]

    return {"plastic_work": [mine[n]["plastic_work_J"] / theirs[n]["plastic_work_J"] - 1.0
                             for n in range(1, len(mine))],
            "residual_increment": [increment(mine, n) / increment(theirs, n) - 1.0
                                   for n in range(1, len(mine))]}


def largest(errors: dict[str, list[float]]) -> float:
    return max(abs(e) for values in errors.values() for e in values)


def main(argv: list[str] | None = None) -> int:
    p = ArgumentParser(prog="verify_envelope_control.py", description=__doc__.split("\n\n")[0])
    p.add_argument("--point", type=int, default=0,
                   help="the campaign of record's point whose material and repeated-history "
                        "force are used (committed in datasets/universal/record)")
    p.add_argument("--force", type=float,
                   help="peak force F (N); default the point's repeated history's")
    p.add_argument("--cycles", type=int, default=10)
    p.add_argument("--mesh", default="coarse", choices=("coarse", "default", "fine"))
    p.add_argument("--fine-ratio", type=float, default=1.05,
                   help="largest force ratio of a solve in the fine reference")
    p.add_argument("--tolerance", type=float, default=0.05,
                   help="allowed difference of a cycle's plastic work and residual increment, "
                        "relative to the fine reference's")
    p.add_argument("--only", choices=tuple(VARIANTS), help="make this run only (into the cache)")
    p.add_argument("--json", type=Path, help="write the comparison here")
    p.add_argument("--cache", type=Path, default=Path("out/cache/envelope-control"),
                   help="FE result cache (runs found there are not made again)")

    def run() -> int:
        args = p.parse_args(argv)
        check_range("--cycles", args.cycles, 2, 100)
        check_range("--fine-ratio", args.fine_ratio, 1.0 + 1e-6, 1.25)
        check_range("--tolerance", args.tolerance, 1e-6, 1.0)
        fields, force = committed_point(args.point)
        if args.force is not None:
            check_range("--force", args.force, 1e-12, 1e12)
            force = args.force
        material = Material(**fields)
        forces = [0.0] + [force, 0.0] * args.cycles
        runs = {}
        for name, (control, capped) in VARIANTS.items():
            if args.only not in (None, name):
                continue
            ratio = args.fine_ratio if capped else None
            print(f"{name}: running", file=sys.stderr, flush=True)
            runs[name] = run_one(material, forces, args.mesh, control, ratio, args.cache)
            r = runs[name]
            print(f"{name}: {r['solves']} solves, {r['newton_iterations']} Newton iterations, "
                  f"CPU {r['cpu_time_s']:.0f} s", file=sys.stderr, flush=True)
        if args.only is not None:
            return 0
        reference = runs["dissipation-fine"]
        compared = {name: differences(runs[name], reference)
                    for name in ("dissipation", "envelope")}
        cycles = {name: per_cycle(runs[name], reference) for name in ("dissipation", "envelope")}
        new, old = runs["envelope"], runs["dissipation"]
        same_run = (new["solves"] == old["solves"] and new["cycles"] == old["cycles"]
                    and new["newton_iterations"] == old["newton_iterations"])
        within = largest(cycles["envelope"]) <= args.tolerance or same_run
        if same_run:
            print("envelope: the same solves and cycles as dissipation (nothing below the "
                  "envelope changed)")
        for name in ("dissipation", "envelope"):
            print(f"{name} vs dissipation-fine, cycles 2-{args.cycles}: plastic work "
                  + " ".join(f"{e:+.3f}" for e in cycles[name]["plastic_work"])
                  + "; residual increment "
                  + " ".join(f"{e:+.3f}" for e in cycles[name]["residual_increment"]))
        print(f"envelope / dissipation: CPU {new['cpu_time_s'] / old['cpu_time_s']:.3f}, "
              f"Newton iterations {new['newton_iterations'] / old['newton_iterations']:.3f}, "
              f"solves {new['solves'] / old['solves']:.3f}")
        if args.json:
            write_json_atomic(args.json, {
                "command": "scripts/verify_envelope_control.py", "version": __version__,
                "fe_code": fe_code_hash(), "compiled_code": compiled_code_hash(),
                "inputs": {"point": args.point, "material": fields, "force_N": force,
                           "cycles": args.cycles, "mesh": args.mesh,
                           "fine_ratio": args.fine_ratio, "tolerance": args.tolerance,
                           "rim_elements": ENVELOPE_RIM_ELEMENTS},
                "runs": runs, "to_first_cycle": compared, "per_cycle": cycles,
                "largest_per_cycle": {name: largest(c) for name, c in cycles.items()},
                "envelope_same_run_as_dissipation": same_run,
                "envelope_within_tolerance": within})
        return 0 if within else 1

    return run_reporting_errors(run)


if __name__ == "__main__":
    sys.exit(main())
