"""Shakedown of the law against the FE, cycle by cycle (issue 17; docs/cycles.md "The law's
shakedown form").

For each material and mesh: the FE run of 10 cycles 0 -> 3000 N -> 0 (``geocontact cycles``,
reused from ``--work`` when its inputs and FE code are unchanged), and beside it the law,
driven by the same force history, with

* ``shipped``: the shipped calibration as it is (``examples/params-reference*.json``; its cyclic
  laws were fitted to the calibration's own repeated run), and
* ``refit``: the same file with its cyclic laws fitted to this FE run (``--fit-params``), in the
  shakedown form,

and prints, per cycle N >= 2, the law's residual-approach increment and dissipation over the
FE's (a factor; 1 is exact). Then a long history for each refit law: 1000 cycles of
100 % -> 80 % -> 100 % of 3000 N (a contact of a seismic column), the cumulative residual
approach and dissipation after 10, 100, 500 and 1000 cycles.

    geocontact study shakedown --mesh coarse default \
        --work out/shakedown
"""

from __future__ import annotations

import json
from pathlib import Path

from ...analyses.cycles import run_cycles
from ...analyses.force_driven import drive_by_force
from ...calibrate.cyclic_fit import analyse, with_cyclic
from ...errors import ArgumentParser, InputError, run_reporting_errors
from ...files import Output, claim, write_text_atomic
from ...grain.material import preset
from ...law import load_params

FILES = {"reference": Path("examples") / "params-reference.json",
         "reference-weak": Path("examples") / "params-reference-weak.json"}
PEAK = 3000.0
CYCLES = 10


def law_rows(params, forces):
    return drive_by_force(params, forces, points=60).cycles


def factors(law, fe, key):
    out = []
    for n in range(1, len(fe)):
        if key == "residual":
            a = law[n]["residual_approach_m"] - law[n - 1]["residual_approach_m"]
            b = fe[n]["residual_approach_increment_m"]
        else:
            a, b = law[n]["plastic_work_J"], fe[n]["plastic_work_J"]
        out.append(a / b if b > 0.0 else float("nan"))
    return out


def long_history(params):
    forces = [0.0, PEAK]
    marks = (10, 100, 500, 1000)
    rows = []
    for m in marks:
        run = drive_by_force(params, forces + [0.8 * PEAK, PEAK] * m + [0.0], points=3)
        last = run.cycles[-1]
        rows.append({"cycles": m, "residual_approach_m": last["residual_approach_m"],
                     "dissipation_J": last["plastic_work_J"]})
    return rows


def calibration_run(params, mesh: str, cache: Path, forces) -> Path | None:
    """The FE summary of the calibration's repeated run, if it is this history on this mesh and
    still in the FE cache."""
    info = params.provenance.get("cyclic", {})
    if info.get("mesh") != mesh or info.get("history_forces_N") != forces:
        return None
    path = cache / str(info.get("cache_key")) / "summary.json"
    return path if path.exists() else None


def compare(fe, shipped, refit, forces) -> dict:
    entry = {"fe": fe, "laws": {}}
    print("  FE residual increment / cycle-1 residual: "
          + " ".join(f"{c['residual_increment_ratio']:.3g}" for c in fe[1:]))
    print("  FE plastic work / cycle 1's:              "
          + " ".join(f"{c['plastic_work_ratio']:.3g}" for c in fe[1:]))
    for label, law in (("shipped", shipped), ("refit", refit)):
        if law is None:
            continue
        rows = law_rows(law, forces)
        res, work = factors(rows, fe, "residual"), factors(rows, fe, "work")
        entry["laws"][label] = {"form": law.cyclic.form, "enabled": law.cyclic.enabled,
                                "residual_factor": res, "work_factor": work}
        state = law.cyclic.form if law.cyclic.enabled else "off"
        print(f"  law ({label}, {state}) / FE, residual increment N=2..10: "
              + " ".join(f"{f:.2f}" for f in res))
        print(f"  law ({label}) / FE, dissipation N=2..10:         "
              + " ".join(f"{f:.2f}" for f in work))
    if refit is not None:
        entry["long_history"] = long_history(refit)
        print("  refit law, 1000 cycles 100-80-100 %: "
              + "; ".join(f"N={r['cycles']}: dres {r['residual_approach_m']:.6g} m, "
                          f"D {r['dissipation_J']:.6g} J" for r in entry["long_history"]))
    return entry


def main(argv: list[str] | None = None, prog: str = "geocontact study shakedown") -> int:
    parser = ArgumentParser(prog=prog, description=__doc__.splitlines()[0])
    parser.add_argument("--mesh", nargs="+", default=["coarse"],
                        choices=["coarse", "default", "fine"])
    parser.add_argument("--material", nargs="+", default=list(FILES), choices=list(FILES))
    parser.add_argument("--work", default="out/shakedown", help="FE runs (reused) go here")
    parser.add_argument("--cache", default="out/cache/fem",
                        help="FE cache: the calibration's own repeated run is taken from it "
                             "when it is this history on this mesh (default: %(default)s)")
    parser.add_argument("--json", help="also write every number to this JSON file")
    parser.add_argument("--force", action="store_true",
                        help="replace --json even if geocontact did not write it")

    def run() -> int:
        args = parser.parse_args(argv)
        outputs = [Output(args.json, "file", "--json")] if args.json else []
        with claim(outputs, "study shakedown", overwrite=args.force):  # before the FE work
            return _study(args)

    return run_reporting_errors(run)


def _study(args) -> int:
    forces = [0.0] + [PEAK, 0.0] * CYCLES
    report = {}
    for name in args.material:
        shipped = load_params(FILES[name])
        for mesh in args.mesh:
            out = Path(args.work) / f"{name}-{mesh}"
            refit_path = Path(args.work) / f"{name}-{mesh}.refit.json"
            print(f"{name} / {mesh}: FE 10 x {PEAK:g} N ...", flush=True)
            cached = calibration_run(shipped, mesh, Path(args.cache), forces)
            if cached is not None:  # the calibration's own repeated run: no FE rerun
                print(f"  FE from the calibration's repeated run ({cached})")
                analysis = analyse(json.loads(cached.read_text())["cycles"])
                try:
                    refit = with_cyclic(shipped, analysis)
                except InputError as error:
                    print(f"  no cyclic refit: {error}")
                    refit = None
                report[f"{name}/{mesh}"] = compare(analysis.cycles, shipped, refit, forces)
                continue
            try:
                summary = run_cycles(preset(name), forces, out, params=shipped, mesh=mesh,
                                     resume=True, fit_params=refit_path, progress=False)
                refit = load_params(refit_path)
            except InputError as error:  # e.g. the FE shakes down at once: nothing to fit
                print(f"  no cyclic refit: {error}")
                summary = run_cycles(preset(name), forces, out, params=shipped, mesh=mesh,
                                     resume=True, progress=False)
                refit = None
            fe = summary["analyses"]["fe"]["cycles"]
            entry = compare(fe, shipped, refit, forces)
            report[f"{name}/{mesh}"] = entry
    if args.json:
        write_text_atomic(args.json, json.dumps(report, indent=1) + "\n")
    return 0
