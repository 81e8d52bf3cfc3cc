"""The full-size DEM oedometer (docs/dem.md "Measured"): geocontact and granular contacts on 1 and
2 ranks, each a `geocontact dem oedometer` result folder, then one table of runtime, residual
strain and dissipation per cycle (printed, and written as DIR/study.json).

    geocontact study dem-oedometer --grains 5000 --ranks 1 2 --out out/dem-study [--force]

Not part of `make test` (minutes per run); a run that fails is reported and the others go on.
"""

from __future__ import annotations

import sys
from pathlib import Path

from ...analyses.dem import CONTACTS, Settings, run_dem
from ...errors import ArgumentParser, GeocontactError, run_reporting_errors
from ...files import Output, check_replaceable, claim, provenance, write_json_atomic


def main(argv: list[str] | None = None, prog: str = "geocontact study dem-oedometer") -> int:
    parser = ArgumentParser(prog=prog, description=__doc__.splitlines()[0])
    parser.add_argument("--law", default="examples/params-reference.json")
    parser.add_argument("--grains", type=int, default=5000)
    parser.add_argument("--ranks", type=int, nargs="+", default=[1, 2])
    parser.add_argument("--inertia", type=float, default=1e-3)
    parser.add_argument("--out", default="out/dem-study")
    parser.add_argument("--force", action="store_true")
    args = parser.parse_args(argv)

    def run() -> int:
        out = Path(args.out)
        check_replaceable(out, "dem-study", overwrite=args.force)
        with claim([Output(out, "folder", "--out")], "dem-study", overwrite=args.force):
            return _study(args, out)

    return run_reporting_errors(run)


def _study(args, out: Path) -> int:
    out.mkdir(parents=True, exist_ok=True)
    rows = []
    for ranks in args.ranks:
        for contact in CONTACTS:
            folder = out / f"{contact}-{ranks}rank"
            settings = Settings(grains=args.grains, inertia=args.inertia)
            try:
                doc = run_dem("oedometer", args.law, settings, contacts=(contact,),
                              ranks=ranks, out=folder, overwrite=args.force,
                              progress=lambda m, r=ranks: print(f"[{r} rank] {m}",
                                                                file=sys.stderr))
            except GeocontactError as exc:
                print(f"{contact}, {ranks} rank(s): FAILED: {exc}", file=sys.stderr)
                rows.append({"contact": contact, "ranks": ranks, "error": str(exc)})
                continue
            s = doc["runs"][contact]
            rows.append({"contact": contact, "ranks": ranks, "runtime_s": s["runtime_s"],
                         "steps": s["steps"], "packing_fraction": s["packing_fraction"],
                         "contacts_per_grain": s["contacts_per_grain_at_stress"],
                         "inertia_number_max": s["inertia_number"]["at_lowest_target"],
                         "cycles": [{k: c[k] for k in ("cycle", "history", "residual_strain",
                                                       "wall_work_J", "law_dissipated_J")}
                                    for c in s["cycles"]]})
    write_json_atomic(out / "study.json", {"rows": rows, "provenance": provenance(
        "dem-study", vars(args))})
    for r in rows:
        if "error" in r:
            print(f"{r['contact']:10s} {r['ranks']} rank(s): failed: {r['error']}")
            continue
        print(f"{r['contact']:10s} {r['ranks']} rank(s): {r['runtime_s']:.0f} s, "
              f"{r['steps']} steps, phi {r['packing_fraction']:.3f}, "
              f"Z {r['contacts_per_grain']:.2f}, I <= {r['inertia_number_max']:.2g}")
        for c in r["cycles"]:
            print(f"    cycle {c['cycle']} {c['history']:10s} residual strain "
                  f"{c['residual_strain']:+.3e}  wall work {c['wall_work_J']:.3e} J  "
                  f"law dissipation {c['law_dissipated_J']:.3e} J")
    return 0
