"""The law's forms side by side on a committed FE campaign: which forms meet the calibration's
goals, in sample and on levels the fit did not see.

For each combination of the residual form (``saturating`` | ``table``) and the virgin curve's
form (``regimes`` | ``segments``), the law is fitted to the campaign's finished calibration runs
(``geocontact calibrate``'s fit, no FE work: the runs are read from the dataset folder, computed
by ``make calibrate-weak-finite`` or its coarse pilot) and measured:

- in sample (the fit's own errors): loading RMS, residual approach max relative error and
  elastic recovery RMS; a table goes through its knots, so its in-sample residual errors are
  zero by construction and its leave-one-out errors are reported instead;
- leave one level out: every interior level's run is held out, the law is fitted to the other
  runs (their virgin curve, their levels) and driven along the held-out run's approach path
  (``calibrate.acceptance.compare``, as the acceptance does): force RMS over the path as % of
  the peak, and the residual approach at each return to zero force, % of the FE's. This spaces
  the levels twice as far apart as the calibration does, so it is a conservative stand-in for
  the held-out acceptance runs until the campaign's own acceptance runs exist.

    PYTHONPATH=src .venv/bin/python scripts/compare_law_forms.py \\
        --dataset datasets/fe-runs/weak-finite-coarse --material reference-weak \\
        --mesh coarse --levels 13 --kinematics finite --mesh-rule contact \\
        --max-step-ratio 1.02 --step-control fixed [--out out/forms/weak-finite-coarse.json]

Only finished runs are used (the missing levels are listed); nothing is written into the
dataset. The JSON output records the inputs, the version and every number printed.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "src"))

from geocontact import __version__  # noqa: E402
from geocontact.calibrate.acceptance import compare  # noqa: E402
from geocontact.calibrate.campaign import (  # noqa: E402
    calibration_jobs,
    extract_run,
    fit_runs,
    peak_forces,
)
from geocontact.calibrate.fit import LOADING_FORMS, RESIDUAL_FORMS  # noqa: E402
from geocontact.cli.common import add_fe_model_flags, fe_model_of  # noqa: E402
from geocontact.errors import InputError, run_reporting_errors  # noqa: E402
from geocontact.fem.identity import cached_run  # noqa: E402
from geocontact.files import write_json_atomic  # noqa: E402
from geocontact.grain.material import load_material  # noqa: E402


def finished_runs(dataset: Path, jobs) -> tuple[list, list[float]]:
    """The calibration runs of ``jobs`` finished in ``dataset`` (extracted), and the peak
    forces of those not (yet) there."""
    runs, missing = [], []
    for job in jobs:
        result = cached_run(dataset, job.identity())
        if result is None:
            missing.append(max(job.forces))
        else:
            runs.append(extract_run(job, result))
    return runs, missing


def in_sample(params) -> dict:
    e = params.fit_errors
    out = {"loading_rms_relative": e["loading_rms_relative"]}
    if params.residual_tabulated:
        loo = e["residual_table_leave_one_out"]
        out.update(residual_ratio_max_relative=loo["residual_ratio_max_relative"],
                   elastic_recovery_max_relative=loo["elastic_recovery_max_relative"],
                   residual_errors="leave-one-out of the table (in sample: zero by "
                                   "construction)")
    else:
        out.update(residual_ratio_max_relative=e["residual_ratio_max_relative"],
                   elastic_recovery_rms_relative=e["elastic_recovery_rms_relative"],
                   residual_errors="in sample")
    return out


def held_out(material, runs, forms: dict) -> list[dict]:
    """Each interior level held out: the law of the other runs along its FE path."""
    rows = []
    for i in range(1, len(runs) - 1):
        others = runs[:i] + runs[i + 1:]
        params = fit_runs(material, others, **forms)
        run = runs[i]
        c = compare(params, run.job, run.result, name=f"held-out-level-{i + 1}",
                    kind="held-out")
        rows.append({"level": i + 1, "peak_force_N": run.level.max_force,
                     "force_rms_percent_of_peak": c.force_rms_percent,
                     "residual_approach_error_percent": c.residual_error_percent})
    return rows


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="compare_law_forms.py", description=__doc__.split("\n")[0])
    p.add_argument("--dataset", required=True, help="committed FE campaign folder")
    p.add_argument("--material", required=True, help="material TOML file or preset name")
    p.add_argument("--mesh", default="default", choices=["coarse", "default", "fine"])
    p.add_argument("--levels", type=int, default=13)
    p.add_argument("--steps", type=int, default=None)
    p.add_argument("--out", default=None, help="JSON file to write (optional)")
    add_fe_model_flags(p)
    args = p.parse_args(argv)
    dataset = Path(args.dataset)
    if not dataset.is_dir():
        raise InputError(f"--dataset: {dataset} is not a folder")
    material = load_material(args.material)
    peaks = peak_forces(material, args.levels)
    jobs = calibration_jobs(material, peaks, args.mesh, args.steps, fe_model_of(args))
    runs, missing = finished_runs(dataset, jobs)
    if len(runs) < 4:
        raise InputError(f"--dataset: {len(runs)} finished calibration runs of these inputs in "
                         f"{dataset}; the comparison needs at least 4")
    print(f"{len(runs)} of {len(jobs)} levels finished"
          + (f"; missing peaks {', '.join(f'{f:.4g}' for f in missing)} N" if missing else ""))
    results = []
    for residual_form in RESIDUAL_FORMS:
        for loading_form in LOADING_FORMS:
            forms = {"residual_form": residual_form, "loading_form": loading_form}
            params = fit_runs(material, runs, **forms)
            rows = held_out(material, runs, forms)
            result = {**forms, "in_sample": in_sample(params),
                      "held_out_levels": rows,
                      "held_out_max_force_rms_percent": max(
                          r["force_rms_percent_of_peak"] for r in rows),
                      "held_out_max_residual_error_percent": max(
                          r["residual_approach_error_percent"] for r in rows)}
            results.append(result)
            s = result["in_sample"]
            print(f"{residual_form:>10} + {loading_form:<8}: loading "
                  f"{100 * s['loading_rms_relative']:.2f} %, residual "
                  f"{100 * s['residual_ratio_max_relative']:.1f} % ({s['residual_errors']}); "
                  f"levels held out: force RMS <= {result['held_out_max_force_rms_percent']:.2f}"
                  f" % of peak, residual approach <= "
                  f"{result['held_out_max_residual_error_percent']:.1f} %")
    if args.out:
        write_json_atomic(Path(args.out), {
            "generator": "scripts/compare_law_forms.py", "geocontact_version": __version__,
            "inputs": {"dataset": str(dataset), "material": args.material, "mesh": args.mesh,
                       "levels": args.levels, "steps": args.steps, **fe_model_of(args)},
            "finished_levels": len(runs), "missing_peaks_N": missing,
            "forms": results})
        print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(run_reporting_errors(lambda: main()))
