"""``geocontact cycles``: FE (and law) on a cyclic force history, shakedown analysis."""

from __future__ import annotations

import sys

from ..errors import InputError
from ..fem.limits import check_resolved_force, check_steps
from ..files import Output, check_file_replaceable, claim
from ..grain.force_history import cycle_windows
from .common import add_fe_model_flags, add_force_flag, fe_model_of, print_json
from .common import load_history_arg as load_history
from .common import load_material_arg as load_material


def register(sub) -> None:
    p = sub.add_parser(
        "cycles",
        help="FE (and law) on a cyclic force history: per-cycle hysteresis, power laws in N, "
             "critical cycle, shakedown state",
        description="Run the FE model on a force history (and the law beside it with --params), "
        "analyse every cycle (residual-approach increment, plastic work, ratios to cycle 1, "
        "power-law fits, critical cycle, elastic/plastic shakedown or ratchetting) and write "
        "DIR/summary.json, DIR/cycles.csv and the FE run in DIR/fe/.",
    )
    p.add_argument("--material", required=True, help="material TOML file or preset name")
    p.add_argument("--history", required=True,
                   help="history TOML: [history] forces = [...] or preset = ... + peak_force; "
                        "must end at zero force")
    p.add_argument("--params", default=None,
                   help="law parameters (geocontact.law/1 JSON) to run the law beside the FE")
    p.add_argument("--mesh", default="default", choices=["coarse", "default", "fine"])
    p.add_argument("--steps", type=int, default=None,
                   help="FE load steps per monotonic segment (default: by mesh preset)")
    p.add_argument("--tolerance", type=float, default=0.01,
                   help="ratio to cycle 1 below which an increment counts as zero (default 0.01)")
    p.add_argument("--out", required=True, help="result directory (written as one unit)")
    add_force_flag(p)
    p.add_argument("--fit-params", default=None, metavar="OUT.json",
                   help="write --params with its cyclic extension fitted to this FE run")
    p.add_argument("--resume", action="store_true",
                   help="reuse a finished FE run in DIR/fe of the same inputs, FE code and "
                        "libraries, or continue from DIR.fe.checkpoint.npz beside DIR")
    p.add_argument("--json", action="store_true", help="print summary.json on stdout")
    add_fe_model_flags(p)
    p.set_defaults(run=run)


def run(args) -> int:
    from ..law import load_params

    material = load_material(args.material)
    forces = load_history(args.history)
    params = load_params(args.params) if args.params else None
    if args.fit_params and params is None:
        raise InputError("--fit-params: needs --params (the law whose cyclic part to fit)")
    outputs = [Output(args.out, "folder", "--out")]
    if args.fit_params:
        check_file_replaceable(args.fit_params, overwrite=args.force, field="--fit-params")
        check_cycles_to_fit(forces)
        outputs.append(Output(args.fit_params, "file", "--fit-params"))
    check_steps(args.steps)
    check_resolved_force(material, max(forces), "history.forces")
    with claim(outputs, "cycles", overwrite=args.force):
        summary = _run(args, material, forces, params)
    if args.json:
        print_json(summary)
        return 0
    print(f"wrote {args.out}: summary.json, cycles.csv, fe/ "
          f"({summary['fe_run']['steps']} FE steps, {summary['fe_run']['wall_time_s']:.1f} s)")
    for name, a in summary["analyses"].items():
        nc = a["critical_cycles"]
        print(f"{name}: {a['state']} after {len(a['cycles'])} cycles (eventually "
              f"{a['eventual_state']}); Nc measured {nc['measured']['elastic_shakedown']}, "
              f"fitted {nc['fitted']['elastic_shakedown']} (tolerance {a['tolerance']:g})")
    if args.fit_params:
        print(f"wrote {args.fit_params} (cyclic extension fitted to the FE)")
    return 0


# with_cyclic fits the ratios of cycles N >= 2 to cycle 1 with a power law in N: cycle 1 and at
# least two more (calibrate.cyclic_fit.fit_ratio_law).
MIN_CYCLES_TO_FIT = 3


def check_cycles_to_fit(forces: list[float]) -> None:
    """--fit-params needs a history of at least ``MIN_CYCLES_TO_FIT`` load-unload cycles: known
    from the history, so refused before the FE run rather than after it."""
    count = len(cycle_windows(forces, list(range(len(forces)))))
    if count < MIN_CYCLES_TO_FIT:
        raise InputError(f"--fit-params: the history has {count} load-unload cycle"
                         f"{'s' if count != 1 else ''}; fitting the cyclic law needs at least "
                         f"{MIN_CYCLES_TO_FIT} (cycle 1 and two after it)")


def _run(args, material, forces, params) -> dict:
    from ..analyses.cycles import run_cycles

    return run_cycles(
        material, forces, args.out, params=params, mesh=args.mesh, steps_per_segment=args.steps,
        tolerance=args.tolerance, resume=args.resume, fit_params=args.fit_params,
        progress=sys.stderr.isatty() or not args.json,
        inputs={"material": str(args.material), "history": str(args.history),
                "params": args.params},
        overwrite=args.force, **fe_model_of(args),
    )
