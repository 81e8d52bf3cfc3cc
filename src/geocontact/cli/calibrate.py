"""``geocontact calibrate``: FE campaign + fit -> law parameters (docs/interfaces.md, docs/model.md
§7)."""

from __future__ import annotations

import math
import time
from pathlib import Path

from ..errors import InputError
from ..fem.limits import check_resolved_force, check_steps, check_workers
from ..files import Output, check_output_file, check_output_folder, claim
from .common import add_fe_model_flags, add_force_flag, fe_model_of, print_json
from .common import load_material_arg as load_material


def register(sub) -> None:
    p = sub.add_parser(
        "calibrate",
        help="FE runs at several peak loads + fit -> law parameters (P.json)",
        description="Run the FE calibration campaign (load-unload-reload cycles at peak loads "
        "geometric from ~2 Fy to --max-force; Dask, cached by inputs), fit the law "
        "(docs/law.md forms) and write P.json (geocontact.law/1). With --acceptance, also run "
        "the held-out FE histories and write P.acceptance.json and P.acceptance/ (CSV, PNG). "
        "Defaults: geocontact/data/calibration.toml.",
    )
    p.add_argument("--material", required=True, help="material TOML file or preset name")
    p.add_argument("--out", required=True, help="law parameter file to write (JSON)")
    p.add_argument("--mesh", default="default", choices=["coarse", "default", "fine"])
    p.add_argument("--steps", type=int, default=None,
                   help="FE load steps per monotonic segment (default: by mesh preset)")
    levels = p.add_mutually_exclusive_group()
    levels.add_argument("--levels", type=int, default=None, metavar="N",
                        help="number of peak loads (default 7)")
    levels.add_argument("--peak-forces", default=None, metavar="F1,F2,...",
                        help="explicit peak loads in N (comma-separated)")
    p.add_argument("--max-force", type=float, default=None, metavar="F",
                   help="highest peak load, N (default 6000)")
    p.add_argument("--mesh-force", type=float, default=None, metavar="F",
                   help="the force, N, the campaign's shared mesh is sized for (default: the "
                   "highest peak; at least that): a campaign whose top peak is moved keeps "
                   "the runs it made on that mesh")
    p.add_argument("--residual-form", default="saturating", choices=["saturating", "table"],
                   help="residual approach: the closed saturating form fitted to the levels "
                   "(default), or a table through the levels (monotone cubic in ln ln x, "
                   "logit; needs residual ratios rising with depth; docs/law.md)")
    p.add_argument("--acceptance", action="store_true",
                   help="also compare the law with held-out FE runs (P.acceptance.json)")
    p.add_argument("--scheduler", default=None, metavar="ADDRESS",
                   help="Dask scheduler address (default: a local cluster)")
    p.add_argument("--workers", type=int, default=None, metavar="N",
                   help="local Dask workers (default: one per core)")
    p.add_argument("--cache", default=None, metavar="DIR",
                   help="FE result cache (default out/cache/fem)")
    p.add_argument("--loading-form", default="regimes", choices=["regimes", "segments"],
                   help="form of the virgin curve: two or three power laws (regimes, default) "
                   "or one power law per decade of depth (segments; docs/law.md)")
    add_fe_model_flags(p)
    add_force_flag(p)
    p.add_argument("--json", action="store_true", help="print the parameter file on stdout")
    p.set_defaults(run=run)


def _peak_list(text: str) -> list[float]:
    try:
        return [float(v) for v in text.split(",") if v.strip()]
    except ValueError:
        raise InputError(f"--peak-forces: expected comma-separated numbers (N), got {text!r}"
                         ) from None


def run(args) -> int:
    from ..calibrate.campaign import settings
    from ..calibrate.workflow import calibrate_to_file
    from ..fem.campaign import DEFAULT_CACHE
    from ..fem.settings import DEFAULT_STEP_CONTROL

    started = time.perf_counter()
    check_steps(args.steps)
    check_workers(args.workers)
    if args.scheduler is not None:
        from ..fem.campaign import check_scheduler_address

        check_scheduler_address(args.scheduler)
    out = Path(args.out)
    if out.suffix != ".json":
        raise InputError(f"--out: expected a .json file name, got {args.out!r}")
    check_output_file(out, "--out")
    material = load_material(args.material)
    peaks = _peak_list(args.peak_forces) if args.peak_forces is not None else None
    if peaks:
        check_resolved_force(material, max(peaks), "--peak-forces")
    else:
        default = settings()["campaign"]["max_force_N"]
        check_resolved_force(material, default if args.max_force is None else args.max_force,
                             "--max-force")
    if args.mesh_force is not None:
        top = max(peaks) if peaks else (settings()["campaign"]["max_force_N"]
                                        if args.max_force is None else args.max_force)
        if not (math.isfinite(args.mesh_force) and args.mesh_force >= top):
            raise InputError(f"--mesh-force: must be at least the highest peak, {top:g} N, "
                             f"got {args.mesh_force:g}")
        check_resolved_force(material, args.mesh_force, "--mesh-force")
    cache = check_output_folder(args.cache, "--cache") if args.cache else DEFAULT_CACHE
    inputs = {"material": args.material, "mesh": args.mesh, "steps": args.steps,
              "levels": args.levels, "peak_forces": args.peak_forces,
              "max_force": args.max_force, "cache": str(cache)}
    if args.loading_form != "regimes":  # recorded when not the default (shipped files unchanged)
        inputs["loading_form"] = args.loading_form
    if args.mesh_force is not None:  # recorded when given (shipped files unchanged)
        inputs["mesh_force"] = args.mesh_force
    fe_model = fe_model_of(args)
    inputs.update({k: v for k, v in fe_model.items() if k != "step_control"})
    # the load-step control named where it is not "fixed", its default when it entered the
    # files (as provenance.fe): a file made with fixed steps reads as before, a default one
    # (adaptive, issue 36) says so
    if args.step_control != "fixed":
        inputs["step_control"] = args.step_control
    if args.residual_form != "saturating":  # files of the default form read as before
        inputs["residual_form"] = args.residual_form
    outputs = [Output(out, "file", "--out")]
    if args.acceptance:  # P.acceptance.json and P.acceptance/ beside P.json
        outputs += [Output(out.with_suffix(".acceptance.json"), "file", "--out"),
                    Output(out.with_suffix(".acceptance"), "folder", "--out")]
    with claim(outputs, "calibrate", overwrite=args.force):
        params, runs, table = calibrate_to_file(
            material, out, inputs, peaks=peaks, levels=args.levels, max_force=args.max_force,
            acceptance=args.acceptance, mesh=args.mesh, steps_per_segment=args.steps,
            cache_dir=cache, scheduler=args.scheduler, workers=args.workers,
            progress=not args.json, overwrite=args.force, fe_model=fe_model,
            residual_form=args.residual_form, loading_form=args.loading_form,
            mesh_force=args.mesh_force)
    acceptance_note = _acceptance_lines(table) if table is not None else ""
    wall = time.perf_counter() - started
    if args.json:
        print_json(params.to_dict())
        return 0
    e = params.fit_errors
    model = ("" if args.kinematics == "small" else f", {args.kinematics} strain") + (
        "" if args.mesh_rule == "auto" else f", {args.mesh_rule} mesh rule") + (
        "" if args.step_rule == "segment" else f", {args.step_rule} step rule") + (
        "" if args.max_step_ratio is None else f", load-step ratio <= {args.max_step_ratio:g}") + (
        "" if args.contact == "node" else f", {args.contact} contact") + (
        "" if args.step_control == DEFAULT_STEP_CONTROL else f", {args.step_control} load steps")
    print(f"wrote {out} ({len(runs)} FE levels, {args.mesh} mesh{model}, {wall:.1f} s)")
    print(f"yield: FE {e['yield']['fe_force_N']:.4g} N, analytic "
          f"{e['yield']['analytic_force_N']:.4g} N; FE Fp "
          + ("not reached" if e["fully_plastic"]["fe_force_N"] is None
             else f"{e['fully_plastic']['fe_force_N']:.4g} N"))
    print(f"fit: loading {100 * e['loading_rms_relative']:.2f} % RMS, unloading "
          f"{100 * e['unloading_curve_rms_of_peak']:.2f} % of peak, reloading "
          f"{100 * e['reloading_curve_rms_of_peak']:.2f} % of peak, " + _recovery_text(e))
    if acceptance_note:
        print(acceptance_note, end="")
    return 0


def _recovery_text(e: dict) -> str:
    """How well the residual form holds the elastic recovery: the saturating fit's RMS, or the
    table's leave-one-out maxima (in sample it passes through every level)."""
    if "residual_table_leave_one_out" in e:
        loo = e["residual_table_leave_one_out"]
        return (f"residual table through the levels, leave-one-out max "
                f"{100 * loo['residual_ratio_max_relative']:.2f} % in residual approach, "
                f"{100 * loo['elastic_recovery_max_relative']:.2f} % in elastic recovery")
    return f"elastic recovery {100 * e['elastic_recovery_rms_relative']:.2f} %"


def _acceptance_lines(table: dict) -> str:
    lines = [f"acceptance (goals: force RMS <= {table['goals']['force_rms_percent_of_peak']:g} "
             f"% of peak, residual approach <= "
             f"{table['goals']['residual_approach_error_percent']:g} %):"]
    for r in table["runs"]:
        res = r["residual_approach_error_percent"]
        lines.append(f"  {r['kind']:8s} {r['name']:22s} peak {r['peak_force_N']:9.4g} N  "
                     f"force RMS {r['force_rms_percent_of_peak']:5.2f} %  residual "
                     + ("   -" if res is None else f"{res:5.1f} %"))
    lines.append("held-out goals " + ("met" if table["held_out_all_met"] else "NOT met"))
    return "\n".join(lines) + "\n"
