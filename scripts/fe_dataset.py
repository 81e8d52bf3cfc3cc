"""The committed FE-run datasets (``datasets/fe-runs/<campaign>/``): what is finished, what is
under way, and whether the runs are still current.

A long FE campaign (the weak grain's finite-strain recalibration: many hours of CPU) outlasts one
working session. Its FE cache is a folder in the repository: every finished run
(``<key>/curve.csv``, ``summary.json`` and the result manifest, ~20 KB) is committed, so the
next session's ``geocontact calibrate --cache datasets/fe-runs/<campaign>`` reuses it and runs
only what is missing. A run under way keeps its checkpoint beside it (``<key>.checkpoint.npz``,
committed at the end of a session), and the next session's run goes on from it.

    PYTHONPATH=src .venv/bin/python scripts/fe_dataset.py [CAMPAIGN_DIR ...] [--json]
    PYTHONPATH=src .venv/bin/python scripts/fe_dataset.py --compare DIR_A DIR_B [--json]
    PYTHONPATH=src .venv/bin/python scripts/fe_dataset.py --law P.json CAMPAIGN_DIR [--json]

For each campaign folder (default: every folder under datasets/fe-runs): the finished runs
(peak force, load-step solves, Newton iterations, wall time) and whether each was computed by
the current FE sources (or older ones whose runs they reproduce bit for bit:
``fem.reuse.REPRODUCED_FE_CODE``) and libraries (``current``) or not (``stale``: a calibration
with this cache would recompute it), and the kernels that made it with how a job at today's
defaults (the compiled kernels with the node contact) reuses it: bit for bit, or a numpy run
within the agreement rule's tolerance (``fem.identity.AGREED_FE_CODE``; ``--kernels numpy``
reuses it bit for bit), its mesh rule and load-step control (``mesh_rule``, ``step_control``:
a run without them in its record was made on the "yield" meshes with fixed steps, the defaults
before issue 36, and is found by a job that asks for them, ``--mesh-rule yield --step-control
fixed``, as the line says; a default job, "auto" and adaptive, runs it anew); the runs under
way (from their checkpoint: steps and solves done of those requested, force reached, FE time and
its cost per solve so far); entries that are neither (reported, never touched). Exit status 0,
or 1 if a run folder is not a complete, self-consistent result (its key is not the hash of its
identity, its manifest or curve is missing).

``--law P.json``: the law file driven along every finished run of the campaign, as the
calibration's acceptance does (``calibrate.acceptance.compare``: force RMS over the path as % of
the peak, residual approach at each return to F = 0): e.g. the shipped weak file, fitted on the
coarse pilot, against the default-mesh campaign's runs it never saw.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "src"))

from geocontact.fem.campaign import describe_progress, run_progress  # noqa: E402
from geocontact.fem.identity import (  # noqa: E402
    agreed_code,
    compiled_code_hash,
    fe_code_hash,
    identity_key,
    library_versions,
    load_result,
    recorded_kernels,
    reproduced_code,
)
from geocontact.fem.settings import chosen_mesh_rule  # noqa: E402
from geocontact.files import RESULT_MANIFEST  # noqa: E402
from geocontact.grain.material import Material  # noqa: E402

DATASETS = ROOT / "datasets" / "fe-runs"


def check_run(folder: Path) -> dict:
    """One finished run folder: its figures, or ``problem`` (why it is not a sound result)."""
    entry: dict = {"key": folder.name}
    if not (folder / RESULT_MANIFEST).is_file():
        return {**entry, "problem": f"no {RESULT_MANIFEST}: not written by geocontact"}
    try:
        result = load_result(folder)
    except Exception as exc:  # noqa: BLE001 - any unreadable result is reported, not raised
        return {**entry, "problem": f"unreadable result: {exc}"}
    summary = result.summary
    identity = summary.get("identity")
    if not isinstance(identity, dict) or identity.get("key") != folder.name:
        return {**entry, "problem": "summary.json identity key differs from the folder name"}
    if identity_key(identity) != folder.name:
        return {**entry, "problem": "identity record does not hash to its key (edited?)"}
    forces = identity["inputs"]["forces_N"]
    current = ((identity.get("fe_code") == fe_code_hash()
                or reproduced_code(identity.get("fe_code"), identity.get("inputs")) is not None)
               and identity.get("libraries") == library_versions())
    control = summary.get("step_control") or {}
    kernels = recorded_kernels(identity)
    # a compiled run is current only under the compiled code that made it (compiled_code)
    current = current and (kernels == "numpy"
                           or identity.get("compiled_code") == compiled_code_hash())
    reuse = "bit for bit"  # the job's kernels: compiled, or numpy with the facet contact
    if kernels == "numpy" and identity["inputs"].get("contact", "node") == "node":
        agreed = agreed_code(identity.get("fe_code"), compiled_code_hash())
        reuse = (f"within {agreed.tolerance:g}" if agreed is not None
                 else "only with --kernels numpy (no agreement entry)")
    return {**entry, "kernels": kernels, "default_reuse": reuse,
            "step_control": identity["inputs"].get("step_control", "fixed"),
            "mesh_rule": identity["inputs"].get("mesh_rule", "yield"),
            # the rule a default job (mesh rule "auto") meshes this run's inputs with
            "auto_mesh_rule": chosen_mesh_rule(Material.from_dict(identity["inputs"]["material"]),
                                               identity["inputs"]["mesh_force_N"])[0],
            "peak_force_N": max(forces), "history_points": len(forces),
            "solves": control.get("solves"), "newton_iterations": summary.get("newton_iterations"),
            "wall_time_s": summary.get("wall_time_s"), "cpu_time_s": summary.get("cpu_time_s"),
            "fe_code": identity.get("fe_code"),
            "state": "current" if current else "stale"}


def check_pending(checkpoint: Path) -> dict:
    """A run under way: how far its checkpoint has come (``fem.campaign.run_progress``)."""
    entry = {"key": checkpoint.name.removesuffix(".checkpoint.npz")}
    try:
        with np.load(checkpoint) as data:
            identity = json.loads(str(data["identity"]))
    except Exception as exc:  # noqa: BLE001 - a checkpoint being rewritten, or a broken one
        return {**entry, "problem": f"unreadable checkpoint: {exc}"}
    if not isinstance(identity, dict) or identity_key(identity) != identity.get("key"):
        return {**entry, "problem": "checkpoint identity record does not hash to its key"}
    try:
        progress = run_progress(checkpoint)
    except Exception as exc:  # noqa: BLE001 - reported, never raised
        return {**entry, "problem": f"unreadable checkpoint: {exc}"}
    forces = identity.get("inputs", {}).get("forces_N", [])
    return {**entry, "peak_force_N": max(forces) if forces else None,
            "steps_done": progress["step"], "steps": progress["steps"],
            "solves_done": progress["solves_done"], "solves": progress["solves"],
            "force_N": progress["force_N"], "wall_time_s": progress["wall_time_s"],
            "progress": describe_progress(progress)}


def campaign_status(folder: Path) -> dict:
    finished, pending, other = [], [], []
    for path in sorted(folder.iterdir()):
        if path.name.startswith("."):
            continue  # a result being written (io.atomic_directory's temporaries)
        if path.is_dir() and (path / "summary.json").exists():
            finished.append(check_run(path))
        elif path.name.endswith(".checkpoint.npz"):
            pending.append(check_pending(path))
        elif not path.name.endswith(".checkpoint.fields") and path.name != "README.md":
            other.append(path.name)
    return {"campaign": folder.name, "finished": finished, "pending": pending, "other": other}


def _asking(run: dict) -> str:
    """What a job at today's defaults must ask for to find ``run``: its mesh rule when "auto"
    would choose another for it, its step control when that is not today's default."""
    from geocontact.fem.settings import FeSettings

    rule, control = run["mesh_rule"], run["step_control"]
    flags = ([f"--mesh-rule {rule}"] if rule != run["auto_mesh_rule"] else []) + (
        [f"--step-control {control}"] if control != FeSettings().step_control else [])
    return f"with {' '.join(flags)} " if flags else ""


def _print(status: dict) -> None:
    finished = status["finished"]
    current = sum(1 for run in finished if run.get("state") == "current")
    print(f"{status['campaign']}: {len(finished)} finished ({current} current), "
          f"{len(status['pending'])} under way")
    for run in sorted(finished, key=lambda r: r.get("peak_force_N") or 0.0):
        if "problem" in run:
            print(f"  {run['key']}  PROBLEM: {run['problem']}")
            continue
        wall = run["wall_time_s"]
        print(f"  {run['key']}  peak {run['peak_force_N']:.4g} N, {run['history_points']} points,"
              f" {run['solves']} solves, {run['newton_iterations']} iterations, "
              f"{wall:.0f} s, {run['state']} ({run['kernels']}, {run['step_control']} steps"
              + (f"; a job {_asking(run)}reuses it {run['default_reuse']})"
                 if run["state"] == "current" else ")"))
    for run in status["pending"]:
        if "problem" in run:
            print(f"  {run['key']}  under way, {run['problem']}")
        else:
            print(f"  {run['key']}  under way: peak {run['peak_force_N']:.4g} N, "
                  f"{run['progress']}")
    for name in status["other"]:
        print(f"  {name}  (not an FE run: left alone)")


def compare_campaigns(first: Path, second: Path, floor: float = 0.05) -> list[dict]:
    """The runs of two campaign folders with the same force history (e.g. one on the coarse
    and one on the default mesh), side by side: per shared history, the peak approach, the
    residual ratio delta_res/delta_max and the elastic recovery 1 - delta_res/delta_max of the
    first cycle (second / first - 1), and the largest gap in approach along the loading branch
    above ``floor`` x the peak (the first run interpolated in ln F - ln delta at the second's
    forces)."""
    from geocontact.fem.staircase import loading_branch

    def runs(folder: Path) -> dict[tuple, object]:
        out = {}
        for summary in sorted(folder.glob("*/summary.json")):
            result = load_result(summary.parent)
            history = tuple(round(f, 9) for f in result.summary["inputs"]["forces_N"])
            out.setdefault(history, result)  # a duplicate (an equivalent run) adds nothing
        return out

    a, b = runs(first), runs(second)
    rows = []
    for history in sorted(set(a) & set(b), key=max):
        ra, rb = a[history], b[history]
        ca, cb = ra.summary["cycles"][0], rb.summary["cycles"][0]
        rho_a = ca["residual_approach_m"] / ca["max_approach_m"]
        rho_b = cb["residual_approach_m"] / cb["max_approach_m"]
        (da, fa), (db, fb) = loading_branch(ra.curve), loading_branch(rb.curve)
        keep = fb > floor * max(history)
        at_b = np.exp(np.interp(np.log(fb[keep]), np.log(fa), np.log(da)))
        rows.append({"peak_force_N": max(history),
                     "peak_approach_relative": cb["max_approach_m"] / ca["max_approach_m"] - 1,
                     "residual_ratio": [rho_a, rho_b],
                     "residual_ratio_relative": rho_b / rho_a - 1 if rho_a > 0 else None,
                     "elastic_recovery_relative": (1 - rho_b) / (1 - rho_a) - 1,
                     "loading_approach_gap_max": float(np.max(np.abs(db[keep] / at_b - 1)))})
    return rows


def law_on_campaign(params_path: Path, folder: Path) -> list[dict]:
    """The law of ``params_path`` along every finished run of ``folder`` (peak order)."""
    from geocontact.calibrate.acceptance import compare
    from geocontact.fem.campaign import FemJob
    from geocontact.law import load_params

    params = load_params(params_path)
    rows = []
    for summary in sorted(folder.glob("*/summary.json")):
        result = load_result(summary.parent)
        inputs = result.summary["identity"]["inputs"]
        job = FemJob.of_inputs(inputs)
        c = compare(params, job, result, name=summary.parent.name, kind="held-out")
        rows.append({"key": summary.parent.name, "forces_N": list(job.forces),
                     "peak_force_N": max(job.forces),
                     "force_rms_percent_of_peak": c.force_rms_percent,
                     "residual_approach_error_percent": c.residual_error_percent})
    return sorted(rows, key=lambda r: (r["peak_force_N"], len(r["forces_N"])))


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("campaigns", nargs="*", type=Path,
                        help="campaign folders (default: every folder in datasets/fe-runs)")
    parser.add_argument("--json", action="store_true", help="print the status as JSON")
    parser.add_argument("--compare", action="store_true",
                        help="compare the runs of two campaign folders with the same histories "
                             "(e.g. two meshes) instead")
    parser.add_argument("--law", type=Path, default=None, metavar="P.json",
                        help="drive this law file along every finished run of the campaign")
    args = parser.parse_args(argv)
    if args.law is not None:
        if len(args.campaigns) != 1 or not args.campaigns[0].is_dir():
            print("error: --law needs one campaign folder", file=sys.stderr)
            return 2
        if not args.law.is_file():
            print(f"error: --law: no file {args.law}", file=sys.stderr)
            return 2
        from geocontact.errors import InputError

        try:
            rows = law_on_campaign(args.law, args.campaigns[0])
        except InputError as exc:
            print(f"error: --law {args.law}: {exc}", file=sys.stderr)
            return 2
        if args.json:
            print(json.dumps(rows, indent=1))
        for row in rows if not args.json else []:
            res = row["residual_approach_error_percent"]
            res = "-" if res is None else f"{res:.2f} %"
            print(f"{row['key']}  peak {row['peak_force_N']:10.4g} N  history of "
                  f"{len(row['forces_N'])} forces  force RMS "
                  f"{row['force_rms_percent_of_peak']:.2f} % of peak  residual approach {res}")
        return 0
    if args.compare:
        if len(args.campaigns) != 2 or not all(p.is_dir() for p in args.campaigns):
            print("error: --compare needs two campaign folders", file=sys.stderr)
            return 2
        rows = compare_campaigns(*args.campaigns)
        if args.json:
            print(json.dumps(rows, indent=1))
        for row in rows if not args.json else []:
            rho_a, rho_b = row["residual_ratio"]
            change = row["residual_ratio_relative"]
            change = "elastic" if change is None else f"{100 * change:+.2f} %"
            print(f"{row['peak_force_N']:10.4g} N  peak approach "
                  f"{100 * row['peak_approach_relative']:+.2f} %  delta_res/delta_max "
                  f"{rho_a:.4f} -> {rho_b:.4f} ({change})  "
                  f"recovery {100 * row['elastic_recovery_relative']:+.2f} %  loading approach "
                  f"gap max {100 * row['loading_approach_gap_max']:.2f} %")
        return 0
    folders = args.campaigns or sorted(p for p in DATASETS.iterdir() if p.is_dir())
    for folder in folders:
        if not folder.is_dir():
            print(f"error: campaign folder {folder} does not exist", file=sys.stderr)
            return 2
    statuses = [campaign_status(folder) for folder in folders]
    if args.json:
        print(json.dumps(statuses, indent=1))
    else:
        for status in statuses:
            _print(status)
    bad = any("problem" in run for status in statuses for run in status["finished"])
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
