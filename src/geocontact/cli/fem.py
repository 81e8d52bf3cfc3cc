"""``geocontact fem``: run a force history on the finite-element model."""

from __future__ import annotations

import sys

from ..fem.limits import check_resolved_force, check_steps
from ..files import Output, claim
from .common import add_fe_model_flags, add_force_flag, print_json
from .common import load_history_arg as load_history
from .common import load_material_arg as load_material


def register(sub) -> None:
    p = sub.add_parser(
        "fem",
        help="FE run of a force history (ball-wall hemisphere, reported as ball-ball)",
        description="Run the axisymmetric FE contact model on a force history and write "
        "DIR/curve.csv, DIR/summary.json and DIR/fields/*.vtu.",
    )
    p.add_argument("--material", required=True, help="material TOML file or preset name")
    p.add_argument("--history", required=True,
                   help="history TOML: [history] forces = [...] or preset = ... + peak_force")
    p.add_argument("--mesh", default="default", choices=["coarse", "default", "fine"])
    p.add_argument("--out", required=True, help="result directory (written atomically)")
    add_force_flag(p)
    p.add_argument("--resume", action="store_true",
                   help="reuse DIR if it is a finished run of the same inputs, FE code and "
                        "libraries, else continue from DIR.checkpoint.npz if it is one of them")
    p.add_argument("--steps", type=int, default=None,
                   help="load steps per monotonic segment (default: by mesh preset)")
    add_fe_model_flags(p)
    p.add_argument("--json", action="store_true", help="print summary.json on stdout")
    p.set_defaults(run=run)


def auto_rule_message(material, summary) -> str:
    """What the mesh rule "auto" chose for the run of ``summary`` and why (its mesh force over
    the analytic first-yield force against fem.settings.AUTO_DENSE_FORCE_RATIO)."""
    from ..fem.settings import auto_rule_reason, chosen_mesh_rule

    return auto_rule_reason(*chosen_mesh_rule(material,
                                              summary["identity"]["inputs"]["mesh_force_N"]))


def run(args) -> int:
    from ..fem.roundoff import fe_summary_resolutions
    from ..fem.run import run_history
    from ..fem.settings import AUTO_MESH_RULE

    material = load_material(args.material)
    forces = load_history(args.history)
    check_steps(args.steps)
    check_resolved_force(material, max(forces), "history.forces")
    with claim([Output(args.out, "folder", "--out")], "fem", overwrite=args.force):
        result = run_history(material, forces, mesh=args.mesh, out=args.out,
                             steps_per_segment=args.steps, resume=args.resume,
                             overwrite=args.force, kinematics=args.kinematics,
                             mesh_rule=args.mesh_rule, step_rule=args.step_rule,
                             max_step_ratio=args.max_step_ratio, contact=args.contact,
                             kernels=args.kernels,
                             step_control=args.step_control, newton=args.newton,
                             resolve_from=args.resolve_from,
                             progress=sys.stderr.isatty() or not args.json)
    s = result.summary
    if args.json:
        print_json(s)
    else:
        fy = s["first_yield_force_N"]
        fp = s["fully_plastic_force_N"]
        print(f"wrote {args.out}: {s['steps']} steps, {s['mesh']['elements']} elements, "
              f"{s['wall_time_s']:.1f} s")
        if args.mesh_rule == AUTO_MESH_RULE:
            print(auto_rule_message(material, s))
        bracket = s.get("first_yield_bracket_N")
        between = (f" (between the steps at {bracket[0]:.6g} and {bracket[1]:.6g} N)"
                   if fy is not None and bracket else "")
        print(f"first yield: {'not reached' if fy is None else f'{fy:.6g} N'}{between}; "
              f"fully plastic: {'not reached' if fp is None else f'{fp:.6g} N'}")
        resolutions = fe_summary_resolutions(s)
        approach, energy = resolutions["approach"], resolutions["energy"]
        for i, c in enumerate(s["cycles"], 1):
            print(f"cycle {i}: Fmax {c['max_force_N']:.6g} N, approach {c['max_approach_m']:.6g} m,"
                  f" residual {approach.format(c['residual_approach_m'])},"
                  f" plastic work {energy.format(c['plastic_work_J'])}")
        for r in (energy, approach):
            print(f"resolution {r.value:.2g} {r.unit}: {r.definition}")
    return 0
