"""``geocontact params``: law parameters for any material in range from the universal law, no
FE run (docs/interfaces.md; docs/universal.md)."""

from __future__ import annotations

import time
from pathlib import Path

from ..errors import InputError
from ..files import Output, check_file_replaceable, claim, provenance
from .common import add_force_flag, print_json
from .common import load_material_arg as load_material


def register(sub) -> None:
    p = sub.add_parser(
        "params",
        help="law parameters (P.json) for any material in range from the universal law, no FE",
        description="Interpolate the shipped FE campaign's normalised data over (friction "
        "angle, Poisson's ratio, hardening ratio, E/sigma_c) at the material, make it "
        "dimensional with the material's first yield and radius, fit the law (the fit of "
        "geocontact calibrate) and write P.json (geocontact.law/1) in under a second. "
        "Range: docs/universal.md.",
    )
    p.add_argument("--material", required=True, metavar="M.toml",
                   help="material TOML file or preset name (radius included)")
    p.add_argument("--out", required=True, metavar="P.json", help="law parameter file to write")
    p.add_argument("--extrapolate", action="store_true",
                   help="accept a material outside the campaign's range (the expected error "
                        "says so)")
    p.add_argument("--dataset", default=None, metavar="DIR",
                   help="universal dataset folder (default: the one shipped with the package)")
    p.add_argument("--design", default="v1", choices=["v1", "record"],
                   help="the dataset's design version: v1 (the shipped one) or record (the "
                        "campaign of record, issue 37: needs --dataset; docs/universal.md)")
    add_force_flag(p, "file")
    p.add_argument("--json", action="store_true", help="print a summary as JSON")
    p.set_defaults(run=run)


def run(args) -> int:

    started = time.perf_counter()
    out = Path(args.out)
    if out.suffix != ".json":
        raise InputError(f"--out: expected a .json file name, got {args.out!r}")
    check_file_replaceable(out, overwrite=args.force, field="--out")
    material = load_material(args.material)
    if args.design == "record" and args.dataset is None:
        raise InputError("--design record: needs --dataset DIR (no dataset of record is shipped "
                         "yet; the pilot's is datasets/universal/record-pilot)")
    if args.dataset is not None and not Path(args.dataset, "points.csv").is_file():
        raise InputError(f"--dataset: no points.csv in {args.dataset}")
    with claim([Output(out, "file", "--out")], "params", overwrite=args.force):
        return _write(args, out, material, started)


def _write(args, out: Path, material, started: float) -> int:
    from ..universal import for_material

    if args.design == "record":
        from ..universal.record_law import record_params

        params = record_params(material, args.dataset, extrapolate=args.extrapolate)
    elif args.dataset is not None:
        from ..universal.interpolate import universal_params

        params = universal_params(material, extrapolate=args.extrapolate,
                                  directory=args.dataset)
    else:
        params = for_material(material, extrapolate=args.extrapolate)

    record = provenance("params", {"material": args.material, "extrapolate": args.extrapolate,
                                   "dataset": args.dataset,
                                   **({"design": args.design} if args.design != "v1" else {})})
    record.pop("geocontact_version")
    from dataclasses import replace

    params = replace(params, provenance={**params.provenance, **record})
    params.save(out)
    wall = time.perf_counter() - started
    u = params.provenance["universal"]
    if args.json:
        print_json({"file": str(out), "wall_time_s": wall, "label": params.label,
                    "yield_force_N": params.yield_force,
                    "yield_approach_m": params.yield_approach,
                    "fully_plastic_force_N": params.fully_plastic_force,
                    "inside_range": u["inside_range"], "outside_range": u["outside_range"],
                    "dataset_points": u["points"], "dataset_sha256": u["dataset_sha256"],
                    "expected_error_loo": u["expected_error_loo"],
                    "calibrated_range": params.calibrated_range,
                    "fit_errors": {k: v for k, v in params.fit_errors.items()
                                   if k != "per_level"}})
        return 0
    e = u["expected_error_loo"]
    print(f"wrote {out} (universal law, {u['points']} FE points, {wall:.2f} s)"
          + ("" if u["inside_range"] else " -- EXTRAPOLATED: " + "; ".join(u["outside_range"])))
    print(f"yield {params.yield_force:.4g} N at {params.yield_approach:.4g} m; expected "
          f"interpolation error (LOO): residual ratio {e['residual_ratio']:.3g}, work ratio "
          f"{e['plastic_work_ratio']:.3g}, log10 approach {e['virgin_log10_approach']:.3g}, "
          f"unloading exponent {e['unloading_exponent']:.3g}")
    top = params.calibrated_range
    print(f"calibrated to delta_max/delta_y = {top['max_depth']:.4g} "
          f"({top['max_force_N']:.4g} N, the campaign's top level here); beyond it the law "
          "extrapolates and geocontact law warns (--strict-range refuses)")
    return 0
