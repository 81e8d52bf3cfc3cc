"""``geocontact fit``: the law (and the material) fitted to a measured single-grain
force-displacement test (docs/interfaces.md; docs/fit.md)."""

from __future__ import annotations

import sys
import time

from ..errors import InputError
from .common import add_force_flag, print_json

MAX_BOOTSTRAP = 1000


def register(sub) -> None:
    p = sub.add_parser(
        "fit",
        help="fit the law (and identify the material) from a measured force-displacement test",
        description="Read a single-grain test (CSV with unit-suffixed columns displacement_mm|"
        "_um|_m, force_N|_kN, optional time_s), remove the machine compliance, find the contact "
        "point, segment the load-unload cycles, fit the law through the same fits as "
        "geocontact calibrate, identify sigma_c with an FE master curve, bootstrap standard "
        "errors, and write P.json (geocontact.law/1) and the folder P.fit/ (fit.json, "
        "curve.csv, figures; geocontact report P.fit). docs/fit.md.",
    )
    p.add_argument("curve", metavar="CURVE.csv", help="the test record")
    p.add_argument("--setup", required=True, choices=["pair", "platens", "flat"],
                   help="pair: grain on grain, displacement = approach; platens: one grain "
                        "between two platens, displacement = approach of the pair; flat: one "
                        "grain on a flat, approach = 2 x displacement")
    p.add_argument("--radius", required=True, type=float, metavar="R",
                   help="grain radius, m")
    p.add_argument("--out", required=True, metavar="P.json", help="law parameter file")
    p.add_argument("--poissons-ratio", type=float, default=None, metavar="NU",
                   help="Poisson's ratio (default 0.25, recorded as assumed)")
    p.add_argument("--friction-angle", type=float, default=None, metavar="DEG",
                   help="Drucker-Prager friction angle beta (default 30, recorded as "
                        "assumed; sigma_c against beta is reported)")
    p.add_argument("--hardening-ratio", type=float, default=None, metavar="M",
                   help="hardening ratio m = E_t/E (default 0, recorded as assumed)")
    p.add_argument("--machine-stiffness", type=float, default=None, metavar="K",
                   help="stiffness of the machine (platens, load cell, frame), N/m, "
                        "subtracted in series (default: none)")
    p.add_argument("--columns", default=None, metavar="KIND=NAME:UNIT,...",
                   help="name the columns, e.g. displacement=Stroke:mm,force=Load:kN,time=t:s")
    p.add_argument("--identify", default="fe", choices=["fe", "universal", "departure"],
                   help="sigma_c and the yield: fe = FE master curve (a few coarse FE runs, "
                        "cached; default), universal = the universal law's virgin loading (no "
                        "FE run; its interpolation error applies), departure = where the record "
                        "leaves Hertz, no FE (biased: a first estimate)")
    p.add_argument("--mesh", default="coarse", choices=["coarse", "default", "fine"],
                   help="FE mesh of the identification runs")
    p.add_argument("--cache", default=None, metavar="DIR",
                   help="FE result cache (default out/cache/fem)")
    p.add_argument("--bootstrap", type=int, default=30, metavar="N",
                   help="bootstrap samples for the standard errors (0: none; default 30)")
    p.add_argument("--seed", type=int, default=0, help="bootstrap seed (default 0)")
    p.add_argument("--strict-range", action="store_true",
                   help="with --identify universal: refuse (one line, nothing written) a record "
                        "deeper than the universal law's calibrated depth instead of warning")
    add_force_flag(p)
    p.add_argument("--json", action="store_true", help="print one JSON document (fit.json)")
    p.set_defaults(run=run)


def run(args) -> int:
    from ..files import Output, check_output_folder, claim
    from ..labtest import read_test
    from .fit_output import check_outputs

    started = time.perf_counter()
    if not 0 <= args.bootstrap <= MAX_BOOTSTRAP:
        raise InputError(f"--bootstrap: must be in [0, {MAX_BOOTSTRAP}], got {args.bootstrap}")
    out, folder = check_outputs(args.out, args.force)
    if args.cache:
        check_output_folder(args.cache, "--cache")
    record = read_test(args.curve, args.columns)
    with claim([Output(out, "file", "--out"), Output(folder, "folder", "--out")], "fit",
               overwrite=args.force):
        return _fit(args, record, started)


def _fit(args, record, started: float) -> int:
    from pathlib import Path

    from ..labtest import fit_test
    from .fit_output import write_fit

    def progress(k, n):
        print(f"\rbootstrap {k}/{n}", end="" if k < n else "\n", file=sys.stderr, flush=True)

    result = fit_test(record, args.setup, args.radius, machine_stiffness=args.machine_stiffness,
                      poissons_ratio=args.poissons_ratio, friction_angle=args.friction_angle,
                      hardening_ratio=args.hardening_ratio, bootstrap_samples=args.bootstrap,
                      seed=args.seed, identify=args.identify, mesh=args.mesh,
                      cache_dir=Path(args.cache) if args.cache else None,
                      progress=None if args.json else progress,
                      strict_range=args.strict_range)
    inputs = {"curve": args.curve, "curve_sha256": record.sha256, "setup": args.setup,
              "radius": args.radius, "poissons_ratio": args.poissons_ratio,
              "friction_angle": args.friction_angle, "hardening_ratio": args.hardening_ratio,
              "machine_stiffness": args.machine_stiffness, "columns": args.columns,
              "identify": args.identify, "mesh": args.mesh, "bootstrap": args.bootstrap,
              "seed": args.seed}
    document = write_fit(result, args.out, overwrite=args.force, inputs=inputs)
    if args.json:
        print_json(document)
        return 0
    fitted = document["fitted"]

    def line(name, key, scale, unit):
        v, se = fitted[key]["value"], fitted[key]["standard_error"]
        return (f"  {name:28s} {v / scale:12.5g}" + (f" ± {se / scale:.2g}" if se else "")
                + f" {unit}")

    m = result.params.material
    print(f"wrote {args.out} and {Path(args.out).with_suffix('.fit')} "
          f"({time.perf_counter() - started:.1f} s)")
    where = ("refined on the Hertz onset" if "whole_record" in result.contact
             else "from the whole record")
    if "choice" in result.contact:
        where += f"; chosen by the {result.contact['choice']['by']}"
    print(f"contact point at displacement {result.contact['contact_displacement_m']:.4g} ± "
          f"{result.contact['contact_displacement_se_m']:.2g} m ({where}), "
          f"load-cell offset {result.contact['offset_N']:.3g} N, noise "
          f"{result.contact['noise_N']:.2g} N; {len(result.levels)} cycles")
    k = result.test.machine_stiffness
    print(f"machine compliance: F / k subtracted, k = {k:.4g} N/m" if k else
          "machine compliance: none subtracted (--machine-stiffness not given; a press's own "
          "compliance left in the record lowers E and sigma_c)")
    route = result.modulus_route
    print(line("Young's modulus E", "youngs_modulus_Pa", 1e9, "GPa") + "  (" + (
        "unloading stiffness S = 2 beta E* a: the record does not resolve its Hertz part"
        if route["route"] == "unloading_stiffness" else "Hertz part") + ")")
    if route.get("unloading_stiffness_Pa") and route["route"] != "unloading_stiffness":
        se = route.get("unloading_stiffness_standard_error_Pa")
        print(f"  {'':28s} the unloading stiffness gives "
              f"{route['unloading_stiffness_Pa'] / 1e9:.4g}"
              + (f" ± {se / 1e9:.2g}" if se else "") + " GPa")
    source = ("FE master curve" if result.master is not None else "universal law"
              if result.universal is not None else "departure from Hertz: a first estimate")
    print(line("yield stress sigma_c", "compressive_yield_stress_Pa", 1e6, "MPa")
          + f"  ({source})")
    for row in result.identification.get("beta_profile", []):
        print(f"  {'':28s} beta {row['friction_angle_deg']:4.0f} deg: sigma_c "
              f"{row['compressive_yield_stress_Pa'] / 1e6:.4g} MPa, misfit {row['misfit']:.3g}")
    beyond = (result.identification.get("calibrated_range") or {}).get("warning")
    if beyond:
        print(f"warning: {beyond}", file=sys.stderr)
    print(line("first-yield force Fy", "yield_force_N", 1.0, "N"))
    for key in ("poissons_ratio", "friction_angle_deg", "hardening_ratio"):
        state = "assumed" if key in result.assumed else "given"
        print(f"  {key:28s} {getattr(m, key):12.5g} ({state})")
    print(f"law along the record: RMS "
          f"{document['law_along_record']['force_rms_percent_of_peak']:.2f} % of the peak "
          f"force")
    return 0
