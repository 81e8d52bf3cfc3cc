"""Where in each cycle of a finished FE run the plastic work is dissipated (no FE work).

For every cycle (0 -> peak -> 0) of the runs given: the plastic work of its loading and of its
unloading, the share of the loading's plastic work dissipated in its last recorded step (the
approach to the peak), and the quadrature points yielding at the peak and at the end of the
unloading (``plastic_points`` of curve.csv: points whose return mapping was plastic in that
step). docs/cycles.md ("Findings with the weak grain's FE of record") reads it: with finite
strain the weak grain re-yields in every reload's approach to the previous peak.

    PYTHONPATH=src .venv/bin/python scripts/cycle_plasticity.py RUN_DIR [RUN_DIR ...] [--json F]

``--twin CACHE`` adds the weak grain's repeated history on the coarse pilot's FE with small
strain, its twin in every other setting (datasets/fe-runs/weak-small-strain-coarse; run, or
resumed from its committed checkpoint, when not finished), beside the pilot's own run.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "src"))

from geocontact import __version__  # noqa: E402
from geocontact.analyses.cycles import fe_cycle_windows  # noqa: E402
from geocontact.errors import run_reporting_errors  # noqa: E402
from geocontact.fem.identity import load_result  # noqa: E402
from geocontact.files import write_json_atomic  # noqa: E402


def cycle_plasticity(run_dir: Path) -> list[dict]:
    """One row per cycle of the finished run in ``run_dir`` (its curve from zero force to a
    peak and back to zero)."""
    result = load_result(run_dir)  # InputError (one line) if it is not a finished run
    curve = result.curve
    force = np.asarray(curve["force_N"], dtype=float)
    work = np.asarray(curve["plastic_dissipation_J"], dtype=float)
    points = np.asarray(curve["plastic_points"], dtype=int)
    rows = []
    for n, (start, end) in enumerate(fe_cycle_windows(curve, result.summary["cycles"]), 1):
        peak = start + int(np.argmax(force[start:end + 1]))
        loading = work[peak] - work[start]
        last = work[peak] - work[peak - 1]
        rows.append({
            "cycle": n, "peak_force_N": float(force[peak]),
            "loading_plastic_work_J": float(loading),
            "unloading_plastic_work_J": float(work[end] - work[peak]),
            "last_step_from_N": float(force[peak - 1]),
            "last_step_share_of_loading": float(last / loading) if loading > 0.0 else None,
            "plastic_points_at_peak": int(points[peak]),
            "plastic_points_at_end": int(points[end]),
        })
    return rows


# The finite-strain run whose small-strain twin --twin runs: the coarse pilot's repeated history
TWIN_OF = ROOT / "datasets" / "fe-runs" / "weak-finite-coarse" / "f4dcbc2b4ecb941f6ab2"


def small_strain_twin(cache: Path) -> Path:
    """The folder of TWIN_OF's small-strain twin in ``cache``, run (or resumed) when needed."""
    from geocontact.fem.campaign import FemJob, run_campaign

    job = FemJob.of_inputs(load_result(TWIN_OF).summary["identity"]["inputs"],
                           kinematics="small", label="repeated-1MPa, small-strain twin")
    run_campaign([job], cache, workers=1)
    return cache / job.key()


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("runs", nargs="*", type=Path, help="finished FE run folders")
    ap.add_argument("--json", type=Path, default=None, help="also write the rows here")
    ap.add_argument("--twin", type=Path, default=None, metavar="CACHE",
                    help="also the small-strain twin of the coarse pilot's repeated run, "
                         "from (or run into) this campaign folder, beside the pilot's run")
    args = ap.parse_args(argv)
    if args.twin is not None:
        args.runs += [TWIN_OF, small_strain_twin(args.twin)]
    if not args.runs:
        ap.error("give finished run folders, or --twin CACHE")
    table = {}
    for run in args.runs:
        rows = table[str(run)] = cycle_plasticity(run)
        print(f"{run}")
        print("  cycle  peak N  loading J  unloading J  last step (from N, share)  "
              "plastic points peak / end")
        for r in rows:
            share = r["last_step_share_of_loading"]
            print(f"  {r['cycle']:5d}  {r['peak_force_N']:6.0f}  "
                  f"{r['loading_plastic_work_J']:9.3g}  "
                  f"{r['unloading_plastic_work_J']:11.3g}  {r['last_step_from_N']:8.0f} N, "
                  f"{'-' if share is None else f'{share:.2f}':>5}        "
                  f"{r['plastic_points_at_peak']:6d} / {r['plastic_points_at_end']:d}")
    if args.json is not None:
        write_json_atomic(args.json, {"version": __version__, "runs": table,
                                      "command": "scripts/cycle_plasticity.py"})
    return 0


if __name__ == "__main__":
    sys.exit(run_reporting_errors(main))
