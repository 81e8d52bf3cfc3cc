"""Run committed FE runs again with the current FE code and compare them bit for bit.

The evidence behind an entry of ``fem.identity.REPRODUCED_FE_CODE`` (older FE sources whose
finished runs the current sources reproduce): a change that only acts where the older code gave
up must leave every run that finished under it as it was. This script takes finished runs of a
committed campaign folder (``datasets/fe-runs/<campaign>``; the cheapest first, or the ones
named), runs each again from its recorded inputs with the current code into ``--out``, and
compares the new result with the committed one: curve.csv value for value (exactly) and
summary.json field for field, except what must differ (``identity``: the FE code hash and key;
``wall_time_s``, ``cpu_time_s``); a committed run made before summary.json recorded ``choice``
(the mesh rule and step control and why) is compared with the one its inputs give.

    PYTHONPATH=src .venv/bin/python scripts/reproduce_fe_runs.py \\
        datasets/fe-runs/weak-finite-coarse --runs 2 --out out/reproduce \\
        --json docs/verification/fe-reproduction.json

Exit status 0 if every run compared equal, 1 otherwise. A run already in ``--out`` of the
current code is compared without running it again (the runs resume from their checkpoints).

``--kernels compiled``: the runs made again on the compiled kernels (``fem.compiled``) instead
of the kernels they were made with, which agree with the numpy path within the Newton tolerance,
not bit for bit: each row then also gives the largest difference of every curve column and of
every number of summary.json, relative to the largest magnitude of that column or field
(``largest_differences``, the largest of all ``largest_difference``), the CPU time of both
runs and their Newton iterations, and whether it is within the agreement rule's tolerance
(``agrees``: ``fem.identity.AGREEMENT_TOLERANCE``, every curve column and summary number there);
the evidence goes to its own file (docs/verification/fe-kernels-agreement.json), the evidence of
an ``fem.identity.AGREED_FE_CODE`` entry; exit status 0 if every run agrees:

    PYTHONPATH=src .venv/bin/python scripts/reproduce_fe_runs.py \
        datasets/fe-runs/weak-finite-coarse --runs 1 --kernels compiled \
        --out out/reproduce-compiled --json docs/verification/fe-kernels-agreement.json
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "src"))

from geocontact import __version__  # noqa: E402
from geocontact.fem.identity import (  # noqa: E402
    AGREEMENT_TOLERANCE,
    compiled_code_hash,
    fe_code_hash,
    load_result,
    recorded_kernels,
)
from geocontact.fem.run import run_history  # noqa: E402
from geocontact.fem.settings import recorded_choice  # noqa: E402
from geocontact.grain.material import Material  # noqa: E402

# summary.json fields that differ between two runs of the same arithmetic
EXPECTED_TO_DIFFER = ("identity", "wall_time_s", "cpu_time_s")


def committed_runs(campaign: Path) -> list[Path]:
    """The finished run folders of ``campaign``, cheapest (recorded wall time) first."""
    folders = [p.parent for p in campaign.glob("*/summary.json")]
    return sorted(folders, key=lambda p: (load_result(p).summary.get("wall_time_s") or 0.0,
                                          p.name))


def rerun(folder: Path, out: Path, kernels: str | None = None):
    """The run of ``folder`` made again from its recorded inputs into ``out/<key>`` (with
    ``kernels``: on those kernels instead of the recorded ones)."""
    identity = load_result(folder).summary["identity"]
    inputs = {**identity["inputs"], "kernels": kernels or recorded_kernels(identity)}
    return run_history(
        Material.from_dict(inputs["material"]), inputs["forces_N"], mesh=inputs["mesh"],
        out=out / folder.name, steps_per_segment=inputs["steps_per_segment"],
        tolerance=inputs["tolerance"], volumetric=inputs["volumetric"],
        mesh_force=inputs["mesh_force_N"], mesh_rule=inputs.get("mesh_rule", "yield"),
        kinematics=inputs.get("kinematics", "small"),
        step_rule=inputs.get("step_rule", "segment"),
        max_step_ratio=inputs.get("max_step_ratio"), contact=inputs.get("contact", "node"),
        kernels=inputs["kernels"],
        # a record without it was made with fixed steps (the default before issue 36)
        step_control=inputs.get("step_control", "fixed"),
        resume=True, write_fields=False,
        overwrite=True, progress=True)


def compare(committed: Path, again) -> dict:
    """Where the run made again differs from the committed one (empty lists: nowhere)."""
    old = load_result(committed)
    curve_differs = [name for name in old.curve
                     if name not in again.curve
                     or not np.array_equal(old.curve[name], again.curve[name])]
    curve_differs += [name for name in again.curve if name not in old.curve]
    fields = set(old.summary) | set(again.summary)
    summary_differs = sorted(name for name in fields if name not in EXPECTED_TO_DIFFER
                             and _engine_free(old.summary, name)
                             != _engine_free(again.summary, name))
    return {"key": committed.name, "peak_force_N": max(old.summary["inputs"]["forces_N"]),
            "made_by": old.summary["identity"]["fe_code"],
            "rows": len(old.curve["force_N"]), "curve_columns_differing": curve_differs,
            "summary_fields_differing": summary_differs,
            "wall_time_s": {"committed": old.summary.get("wall_time_s"),
                            "again": again.summary.get("wall_time_s")},
            "cpu_time_s_again": again.summary.get("cpu_time_s"),
            "equal": not curve_differs and not summary_differs}


def _engine_free(summary: dict, name: str):
    """A field of summary.json, its inputs without ``kernels`` when the kernels are those of the
    run's identity (recorded or not as they are its contact's default or not: the same
    inputs). The identity's kernels themselves are compared by the caller's row."""
    if name == "choice":
        # the run's mesh rule and step control and why (issue 36's switch of the defaults): a
        # run made before it has none, and the one its inputs give (recorded_choice) must be
        # the rerun's
        return recorded_choice(summary)
    value = summary.get(name)
    if name == "inputs" and isinstance(value, dict):
        kernels = recorded_kernels(summary["identity"])
        return {**{k: v for k, v in value.items() if k != "kernels"}, "kernels": kernels}
    return value


def _numbers(value, path=()):
    """The numeric leaves of a JSON-like value, as {path: float}."""
    if isinstance(value, dict):
        return {k: v for key, item in value.items()
                for k, v in _numbers(item, (*path, key)).items()}
    if isinstance(value, list):
        return {k: v for i, item in enumerate(value)
                for k, v in _numbers(item, (*path, i)).items()}
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        return {path: float(value)}
    return {}


def agreement(old, again) -> dict:
    """How far the run ``again`` (a FemResult) made on other kernels is from ``old``: the
    largest difference of each curve column relative to the column's largest magnitude, and of
    each number of summary.json (but its identity, wall and CPU time) relative to its magnitude
    (the 8 largest); the Newton iterations of both (old, again)."""
    columns = {}
    for name, values in old.curve.items():
        if name in again.curve and len(again.curve[name]) == len(values):
            scale = float(np.max(np.abs(values))) or 1.0
            columns[name] = float(np.max(np.abs(again.curve[name] - values))) / scale
    before = _numbers({k: v for k, v in old.summary.items() if k not in EXPECTED_TO_DIFFER})
    after = _numbers({k: v for k, v in again.summary.items() if k not in EXPECTED_TO_DIFFER})
    summary = {}
    for key, value in before.items():
        if key in after and math.isfinite(value):
            scale = abs(value) or 1.0
            summary[".".join(map(str, key))] = abs(after[key] - value) / scale
    largest = sorted(summary.items(), key=lambda kv: -kv[1])[:8]
    iterations = [int(np.sum(old.curve["iterations"])), int(np.sum(again.curve["iterations"]))]
    worst = max([*columns.values(), *summary.values()], default=0.0)
    return {"largest_differences": {"curve": columns, "summary_largest": dict(largest)},
            "newton_iterations": iterations, "largest_difference": worst,
            "tolerance": AGREEMENT_TOLERANCE,
            "agrees": (worst <= AGREEMENT_TOLERANCE and set(columns) == set(old.curve)
                       and iterations[0] == iterations[1] and set(before) <= set(after))}


def _row_code(row: dict) -> tuple:
    """What a row of the evidence file is of: the run, and the code it was made again by."""
    return row["campaign"], row["key"], row.get("fe_code"), row.get("compiled_code")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("campaign", type=Path, help="a committed campaign folder")
    parser.add_argument("--runs", type=int, default=1,
                        help="how many of its finished runs, the cheapest first (default 1)")
    parser.add_argument("--keys", nargs="*", default=None, help="these runs instead")
    parser.add_argument("--out", type=Path, default=Path("out/reproduce"))
    parser.add_argument("--kernels", choices=["numpy", "compiled"], default=None,
                        help="make the runs again on these kernels (default: the recorded "
                             "ones); other than the recorded: compared within tolerance")
    parser.add_argument("--json", type=Path, default=None,
                        help="write the comparison here (merged with an earlier file's runs: "
                             "one row per run and FE code)")
    args = parser.parse_args(argv)
    if args.runs < 1:
        parser.error(f"--runs: must be >= 1, got {args.runs}")
    folders = committed_runs(args.campaign)
    if args.keys:
        known = {p.name: p for p in folders}
        missing = [k for k in args.keys if k not in known]
        if missing:
            parser.error(f"--keys: not finished runs of {args.campaign}: {', '.join(missing)}")
        folders = [known[k] for k in args.keys]
    else:
        folders = folders[:args.runs]
    args.out.mkdir(parents=True, exist_ok=True)
    rows = []
    for folder in folders:
        print(f"reproduce: {folder}", file=sys.stderr)
        cpu = time.process_time()
        again = rerun(folder, args.out, args.kernels)
        row = {"campaign": args.campaign.name, **compare(folder, again)}
        if args.kernels is not None:
            row.update(kernels=args.kernels, cpu_s_again=time.process_time() - cpu,
                       **agreement(load_result(folder), again))
        verdict = ("equal" if row["equal"] else
                   f"within {AGREEMENT_TOLERANCE:g}" if row.get("agrees") else "DIFFERENT")
        print(f"reproduce: {folder.name}: {verdict} "
              f"({row['rows']} curve rows; differing: "
              f"{row['curve_columns_differing'] + row['summary_fields_differing'] or 'none'})",
              file=sys.stderr)
        rows.append(row)
    if args.json is not None:
        earlier = (json.loads(args.json.read_text()).get("runs", [])
                   if args.json.exists() else [])
        # a run compared again under the same FE code (and compiled code) replaces its row
        rows = [{**r, "fe_code": fe_code_hash(),
                 **({"compiled_code": compiled_code_hash()}
                    if r.get("kernels") == "compiled" else {})} for r in rows]
        done = {_row_code(r) for r in rows}
        kept = [r for r in earlier if _row_code(r) not in done]
        record = {"version": __version__, "command": "scripts/reproduce_fe_runs.py",
                  "runs": kept + rows}
        args.json.write_text(json.dumps(record, indent=1) + "\n")
    return 0 if all(r["equal"] or r.get("agrees") for r in rows) else 1


if __name__ == "__main__":
    sys.exit(main())
