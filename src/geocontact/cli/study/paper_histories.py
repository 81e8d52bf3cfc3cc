"""The paper's loading histories on our FE engine (docs/model.md §8; docs/cycles.md).

Runs repeated (10 x 3000 N), monotonically decreasing (3000 -> 100 N) and monotonically
increasing (100 -> 3000 N) histories for sigma_c = 10 MPa (preset ``reference``) and 1 MPa
(``reference-weak``), and the repeated history for a von Mises grain of the same strength
(``reference-von-mises``), as one FE campaign cached in ``out/cache/fem``; analyses every run
with ``geocontact.analyses.cycles``; writes to ``out/paper-histories/``:

* ``<run>.json`` - the run's inputs, FE summary and cycle analysis; ``cycles.csv`` - every cycle
  of every run;
* ``findings.json`` / ``findings.csv`` - the paper's statements with our numbers;
  ``tables.md`` - both as the Markdown tables of docs/cycles.md;
* ``params-cyclic-<run>.json`` - the law parameters given with ``--params`` (default: the shipped
  calibrated ones for the material, examples/params-reference*.json) with ``cyclic`` fitted to
  the repeated runs;
* ``index.json`` - settings, wall time, file list.

    geocontact study paper-histories [--mesh coarse] [--steps N] [--workers 2]
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

from ...analyses.paper_histories import format_value as fmt
from ...analyses.paper_histories import run_paper_histories, write_study
from ...calibrate.cyclic_fit import with_cyclic
from ...errors import ArgumentParser, InputError
from ...files import (
    Output,
    atomic_directory,
    claim,
    provenance,
    write_json_atomic,
    write_text_atomic,
)
from ...law import load_params
from ..common import add_fe_model_flags, fe_model_of

CALIBRATED = {"reference": Path("examples") / "params-reference.json",
                "reference-weak": Path("examples") / "params-reference-weak.json"}


def _model(inputs: dict) -> str:
    """The mesh of a run, and its kinematics when not small strain."""
    kinematics = inputs.get("kinematics", "small")
    return inputs["mesh"] + ("" if kinematics == "small" else f", {kinematics} strain")


def markdown(runs, findings) -> str:
    """The tables of docs/cycles.md: per run, then the paper's statements."""
    lines = ["| run | mesh | cycles | FE steps | FE wall s | cycle 2 residual / plastic-work "
             "ratio | last cycle | power law residual c, p (rms log10) | power law Wp c, p "
             "(rms log10) | geometric factor residual / Wp | Nc fitted (res, Wp) | "
             "Nc measured (res, Wp) | state | eventual |",
             "|" + " --- |" * 14]
    for name, run in runs.items():
        a, c = run.analysis, run.analysis.cycles
        rf, wf = a.residual_fit, a.plastic_work_fit
        g = a.geometric_fits
        geo = " / ".join(fmt(g[k]["factor"]) if g.get(k) else "-"
                         for k in ("residual_increment_ratio", "plastic_work_ratio"))
        fit = [f"{f.coefficient:.3g}, {f.power:.3g} ({f.rms_log10_error:.2g})" if f else "-"
               for f in (rf, wf)]
        ncf, ncm = a.critical_cycles["fitted"], a.critical_cycles["measured"]
        lines.append(
            f"| {name} | {_model(run.summary['inputs'])} | {len(c)} | {run.summary['steps']} | "
            f"{run.summary['wall_time_s']:.0f} | {fmt(c[1]['residual_increment_ratio'])} / "
            f"{fmt(c[1]['plastic_work_ratio'])} | {fmt(c[-1]['residual_increment_ratio'])} / "
            f"{fmt(c[-1]['plastic_work_ratio'])} | {fit[0]} | {fit[1]} | {geo} | "
            f"{ncf['residual_increment']}, {ncf['plastic_work']} | "
            f"{ncm['residual_increment']}, {ncm['plastic_work']} | {a.state} | "
            f"{a.eventual_state} |")
    lines += ["", "| statement | quantity | ours | paper | agrees |", "|" + " --- |" * 5]
    for f in findings:
        verdict = {True: "yes", False: "**no**", None: "n/a"}[f["agrees"]]
        paper = "-" if f["paper_value"] is None else fmt(f["paper_value"])
        ours = f.get("finding") or fmt(f["our_value"])
        lines.append(f"| {f['statement']} | {f['quantity']} | {ours} | {paper} | {verdict} |")
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None, prog: str = "geocontact study paper-histories") -> int:
    from ...fem.settings import MESH_RULE_CHOICES

    ap = ArgumentParser(prog=prog, description=__doc__.splitlines()[0])
    ap.add_argument("--mesh", default="coarse", choices=["coarse", "default", "fine"])
    ap.add_argument("--steps", type=int, default=None, help="FE steps per monotonic segment")
    ap.add_argument("--tolerance", type=float, default=0.01)
    ap.add_argument("--workers", type=int, default=None, help="Dask workers (default: cores)")
    ap.add_argument("--cache", default="out/cache/fem")
    ap.add_argument("--out", default="out/paper-histories")
    ap.add_argument("--only", nargs="*", default=None, help="run names (default: all)")
    ap.add_argument("--check-mesh", default=None, choices=["coarse", "default", "fine"],
                    help="also run repeated-10MPa on this mesh (mesh sensitivity of the "
                         "cyclic quantities)")
    ap.add_argument("--force", action="store_true",
                    help="replace --out even if it holds files geocontact did not write")
    add_fe_model_flags(ap)
    ap.add_argument("--fe-model-materials", nargs="+", default=None, metavar="PRESET",
                    help="apply the FE model flags above only to the runs of these material "
                         "presets; the others run with the FE defaults (small strain), e.g. "
                         "finite strain only for reference-weak (default: every run); "
                         "--step-control reaches every run")
    ap.add_argument("--others-mesh-rule", default=None,
                    choices=list(MESH_RULE_CHOICES),
                    help="with --fe-model-materials: the mesh rule of the other runs (default: "
                         "the FE default, 'auto'); 'yield' is the rule the committed study's "
                         "other runs were meshed with (make paper-histories-finite)")
    args = ap.parse_args(argv)
    if args.others_mesh_rule is not None and args.fe_model_materials is None:
        raise InputError("--others-mesh-rule: only with --fe-model-materials (without it the "
                         "FE model flags reach every run)")
    out = Path(args.out)
    # before the FE runs: ours to replace, writable, no other run on it
    with claim([Output(out, "folder", "--out")], "paper-histories", overwrite=args.force):
        return _study(args, out)


def _study(args, out: Path) -> int:
    started = time.perf_counter()
    runs = run_paper_histories(args.mesh, args.cache, steps_per_segment=args.steps,
                               tolerance=args.tolerance, workers=args.workers, only=args.only,
                               mesh_checks=({"repeated-10MPa": args.check_mesh}
                                            if args.check_mesh else None),
                               fe_model=fe_model_of(args),
                               fe_model_materials=args.fe_model_materials,
                               others_fe_model=({"mesh_rule": args.others_mesh_rule}
                                                if args.others_mesh_rule else None))
    # the whole study lands as one folder: an interrupted rerun never mixes old and new files
    with atomic_directory(out, "paper-histories", overwrite=args.force,
                          inputs=vars(args)) as tmp:
        record = provenance("geocontact study paper-histories", vars(args))
        findings, files = write_study(tmp, runs, record)
        write_text_atomic(tmp / "tables.md", markdown(runs, findings))
        files.append("tables.md")
        for name, run in runs.items():
            if (run.history != "repeated" or run.material_name not in CALIBRATED
                    or "@" in name):
                continue
            params = load_params(CALIBRATED[run.material_name])
            try:
                fitted = with_cyclic(params, run.analysis, provenance={
                    "fe_run": name, "fe_inputs": run.summary.get("inputs"),
                    "base_params": str(CALIBRATED[run.material_name]),
                    "command": "geocontact study paper-histories"})
            except InputError as exc:  # a ratchetting run has no cyclic law: say so, keep going
                print(f"{name}: no cyclic law fitted ({exc})", file=sys.stderr)
                continue
            fitted.save(tmp / f"params-cyclic-{name}.json")
            files.append(f"params-cyclic-{name}.json")
        mesh_check = {}
        for name in (n for n in runs if "@" in n):
            base = runs[name.split("@")[0]]
            mesh_check[name] = {
                run.name: {"mesh": run.summary["inputs"]["mesh"],
                           "elements": run.summary["mesh"]["elements"],
                           "residual_increment_ratio": [c["residual_increment_ratio"]
                                                        for c in run.analysis.cycles],
                           "plastic_work_ratio": [c["plastic_work_ratio"]
                                                  for c in run.analysis.cycles],
                           "critical_cycles": run.analysis.critical_cycles,
                           "state": run.analysis.state}
                for run in (base, runs[name])}
        wall = time.perf_counter() - started
        write_json_atomic(tmp / "index.json", {
            "wall_time_s": wall, "mesh": args.mesh, "steps_per_segment": args.steps,
            "fe_model": fe_model_of(args),
            "tolerance": args.tolerance, "files": files, "mesh_check": mesh_check,
            "fe_wall_time_s": {n: r.summary.get("wall_time_s") for n, r in runs.items()},
            "provenance": record,
        })
    for f in findings:
        verdict = {True: "agrees", False: "DISAGREES", None: "n/a"}[f["agrees"]]
        print(f"[{verdict}] {f['statement']}")
    print(f"wrote {out} in {wall:.0f} s", file=sys.stderr)
    return 0

