"""``geocontact seismic``: an acceleration record (and aftershocks) -> contact response."""

from __future__ import annotations

import sys

from ..errors import InputError, check_count
from ..files import Output, check_replaceable, claim
from .common import add_force_flag, print_json


def register(sub) -> None:
    p = sub.add_parser(
        "seismic",
        help="seismic record (+ aftershocks) on a column of spheres: contact response",
        description=(
            "Scale a record (PEER .AT2, two-column text/CSV, or a FEMA P695 name such as "
            "KOBE/NIS000) to a target PGA, shake a column of spheres of the law's material with "
            "it and report contact forces, residual approach, dissipation, settlement and the "
            "loading-history class (rainflow) beside the paper's peak-time rule. Defaults: "
            "geocontact/data/seismic.toml."
        ),
    )
    p.add_argument("record", nargs="?", metavar="RECORD",
                   help="record file (.AT2, .csv, .txt) or FEMA P695 component name")
    p.add_argument("--params", help="law parameters (geocontact.law/1 JSON)")
    p.add_argument("--pga", type=float, default=None,
                   help="target peak ground acceleration, m/s^2 (default 3.0)")
    p.add_argument("--column", type=int, default=None, metavar="N",
                   help="number of spheres in the column (default 5)")
    p.add_argument("--aftershock", nargs="+", action="extend", default=[],
                   metavar="RECORD[@PGA]",
                   help="aftershock record(s), run after the main shock in order; an optional "
                        "@PGA (m/s^2) scales one, else --aftershock-pga")
    p.add_argument("--aftershock-pga", type=float, default=None,
                   help="PGA of aftershocks without @PGA, m/s^2 (default: --pga)")
    p.add_argument("--out", help="output directory (written as one unit)")
    add_force_flag(p)
    p.add_argument("--json", action="store_true", help="print the summary as one JSON document")
    p.add_argument("--unit", default=None, help="record unit if the header lacks it: g, m/s2, "
                   "cm/s2 (overrides the header)")
    p.add_argument("--baseline", default=None, choices=["none", "mean", "linear", "quadratic"],
                   help="baseline correction (eqsig polynomial removal; default linear)")
    p.add_argument("--surcharge", type=float, default=None, help="force on the top sphere, N")
    p.add_argument("--density", type=float, default=None, help="sphere density, kg/m^3")
    p.add_argument("--damping", type=float, default=None, metavar="ZETA",
                   help="viscous normal contact damping ratio (default 0)")
    p.add_argument("--time-step-safety", type=float, default=None,
                   help="dt = safety * sqrt(m / k_max) (default 0.2)")
    p.add_argument("--time-step", type=float, default=None, help="explicit time step, s")
    p.add_argument("--output-interval", type=float, default=None,
                   help="sampling interval of the stored histories, s (default 0.001)")
    p.add_argument("--gap", type=float, default=None,
                   help="quiet time between events, s (default 2.0)")
    p.add_argument("--no-figures", action="store_true", help="skip the PNG figures")
    p.add_argument("--list-records", action="store_true",
                   help="list the FEMA P695 records available offline and exit")
    p.set_defaults(run=run)


def _progress(message: str) -> None:
    print(message, file=sys.stderr, flush=True)


def run(args) -> int:
    from ..analyses.seismic import records

    if args.list_records:
        rows = records.fema_p695_catalogue()
        if args.json:
            print_json({"records": rows})
        else:
            for r in rows:
                print(f"{r['name']:20s} {r['set']:19s} RSN {r['rsn']:5d}  {r['year']}  "
                      f"{r['event']:22s} {r['station']:24s} PGA {r['pga_g']:.2f} g")
        return 0
    if args.record is None:
        raise InputError("RECORD: missing (a file or a FEMA P695 name; see --list-records)")
    if args.params is None:
        raise InputError("--params: missing (law parameters, geocontact.law/1 JSON)")
    if args.out is None:
        raise InputError("--out: missing (output directory)")

    from ..analyses.seismic.analysis import EventSpec, Settings, run_seismic, write_outputs
    from ..analyses.seismic.column import MAX_AFTERSHOCKS, MAX_SPHERES
    from ..law import load_params

    check_replaceable(args.out, "seismic", overwrite=args.force)  # before the run, not after

    if args.pga is not None and not args.pga > 0:
        raise InputError(f"--pga: must be > 0 m/s^2, got {args.pga:g}")
    check_count("--column", args.column, MAX_SPHERES,
                "spheres; the stored histories grow as spheres x samples")
    if len(args.aftershock) > MAX_AFTERSHOCKS:
        raise InputError(f"--aftershock: at most {MAX_AFTERSHOCKS} records (each is a full run "
                         f"of the column after the main shock), got {len(args.aftershock)}")
    settings = Settings.from_defaults(
        target_pga=args.pga, spheres=args.column, unit=args.unit, baseline=args.baseline,
        surcharge=args.surcharge, density=args.density, damping_ratio=args.damping,
        time_step_safety=args.time_step_safety, time_step=args.time_step, gap=args.gap,
        output_interval=args.output_interval,
    )
    if args.unit is not None:
        records.canonical_unit(args.unit, field_name="--unit")
    params = load_params(args.params)
    aftershock_pga = args.aftershock_pga if args.aftershock_pga is not None else settings.target_pga
    main = EventSpec(args.record, settings.target_pga)
    aftershocks = [EventSpec.parse(text, aftershock_pga) for text in args.aftershock]
    with claim([Output(args.out, "folder", "--out")], "seismic", overwrite=args.force):
        result = run_seismic(params, main, aftershocks, settings,
                             params_source=str(args.params), progress=_progress)
        summary = write_outputs(result, args.out, figures=not args.no_figures,
                                overwrite=args.force)
    if args.json:
        print_json(summary)
    else:
        from ..fem.roundoff import Resolution

        energy = Resolution.from_dict(summary["resolution"]["energy"])
        cls = summary["classification"]
        print(f"{result.events[0].record.record.name}: PGA {summary['scaled_pga_m_s2']:.3g} m/s^2, "
              f"peak at {100 * summary['peak_time_fraction']:.1f} % of the record -> paper rule: "
              f"{cls['paper_rule']}")
        for row in summary["contacts"]:
            print(f"  contact {row['contact']}: residual approach "
                  f"+{row['seismic_residual_approach_m']:.4g} m, dissipated "
                  f"{energy.format(row['dissipated_energy_J'], '.4g')}, {row['history_class']}, "
                  f"{row['shakedown_state']}")
        print(f"settlement {summary['settlement_m']:.4g} m; energy resolution "
              f"{energy.value:.2g} J ({energy.definition}); wrote {args.out}")
    return 0
