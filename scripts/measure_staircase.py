"""The staircase of the weak grain's FE loading curve (issue 15, part 1).

On sigma_c = 1 MPa (``reference-weak``) loaded 0 -> 6000 N the contact grows to a/R ~ 0.15-0.3
and, with a node-to-flat contact, the contact radius can only move one surface node at a time:
between two engagements the flattened contact sits near its limit load (a plateau in F), then
the next node touches (a riser). Under force control the recorded points lie on the risers; a run
with other load steps samples other risers, so two step counts disagree at the same approach.

Measures (``geocontact.fem.staircase``), on the loading curve above ``--floor`` x Fy:

- ``force_gap_max`` / ``force_gap_rms``: |F_a / F_b - 1| of two runs at the same approach
  (each curve interpolated linearly in ln F - ln delta at the approaches of the other, both
  directions), the issue's "24 vs 48 steps per segment agree within 1 % in force";
- ``slope_jump_max`` and ``slope_total_variation`` of the local log-slope
  s_k = d ln F / d ln delta between consecutive steps: a smooth power-law-like curve has a slowly
  drifting s (total variation ~ the change of the exponent, < 1 over the range), a staircase
  alternates between plateaus (s ~ 0) and risers (s >> 2).

    PYTHONPATH=src nice -n 5 .venv/bin/python scripts/measure_staircase.py --mesh coarse \
        --steps 24 48 --out out/staircase

``--kinematics finite`` measures the finite-strain FE (the weak grain's FE of record, issue 15)::

    PYTHONPATH=src .venv/bin/python scripts/measure_staircase.py --mesh coarse --kinematics finite \
        --mesh-rule contact --steps 24 48 --max-step-ratio 1.01 --out out/staircase

The load-step control (``run_history(max_step_ratio=...)``: every loading step above the
first-yield force solved through geometric sub-steps of at most that force ratio, the requested
steps still the recorded ones) is measured with ``--max-step-ratio``: every cap is run with
every ``--steps``, and all the runs are compared pairwise, so one call gives both the issue's
measure (24 vs 48 steps at one cap) and the control's own convergence (cap r vs sqrt(r) at the
same steps; ``none`` = no cap)::

    PYTHONPATH=src nice -n 10 .venv/bin/python scripts/measure_staircase.py --mesh coarse \
        --mesh-rule contact --steps 24 48 --max-step-ratio 1.02 1.01 --out out/staircase

Each run is a resumable FE result directory under ``--out`` (``run_history(resume=True)``);
the table of measures is printed and written to ``<out>/staircase.json``.
"""

from __future__ import annotations

import argparse
import itertools
import json
import time
from pathlib import Path

import numpy as np

from geocontact.fem.run import load_schedule
from geocontact.fem.staircase import loading_branch, sampling_gap, staircase_measures
from geocontact.files import write_json_atomic
from geocontact.grain.material import load_material

FORCE = 6000.0


def figure(out: Path, names: list[str], path: Path) -> None:
    """F(delta) and the local log-slope of the finished runs ``out/NAME`` (curve.csv)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from geocontact.fem.identity import load_result
    from geocontact.fem.staircase import loading_branch, log_slopes
    from geocontact.files import atomic_path

    fig, (ax, slope) = plt.subplots(1, 2, figsize=(12, 4.5))
    for name in names:
        x, f = loading_branch(load_result(out / name).curve)
        ax.loglog(1e3 * x, f, ".-", ms=3, lw=0.8, label=name)
        slope.semilogx(f[1:], log_slopes(x, f), ".-", ms=3, lw=0.8, label=name)
    ax.set_xlabel("approach (mm)")
    ax.set_ylabel("force (N)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7)
    slope.set_xlabel("force (N)")
    slope.set_ylabel("d ln F / d ln delta between steps")
    slope.set_ylim(0.0, 6.0)
    slope.set_xlim(10.0, None)
    slope.grid(True, which="both", alpha=0.3)
    slope.set_title("sigma_c = 1 MPa, 0 -> 6000 N")
    fig.tight_layout()
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=100, format="png")
    plt.close(fig)


def waypoint_gaps(curves: dict[str, dict], waypoints: int) -> dict:
    """Each run's approach at the history's waypoints (every peak and every return to 0 N: the
    ends of the monotonic segments, recorded by every run whatever its steps), and per pair of
    runs the largest |delta_a / delta_b - 1| there, peaks and residuals apart."""
    ends = {}
    for label, curve in curves.items():
        force, approach = np.asarray(curve["force_N"]), np.asarray(curve["approach_m"])
        turn = np.flatnonzero(np.diff(np.sign(np.diff(force))) != 0) + 1
        ends[label] = approach[np.concatenate([turn, [len(force) - 1]])]
    gaps = {}
    for a, b in itertools.combinations(ends, 2):
        ea, eb = ends[a], ends[b]
        if len(ea) != len(eb) or len(ea) != waypoints - 1:
            continue
        peaks, rests = slice(0, None, 2), slice(1, None, 2)
        gaps[f"{a} vs {b}"] = {
            "peak_approach_gap_max": float(np.max(np.abs(ea[peaks] / eb[peaks] - 1.0))),
            "residual_approach_gap_max": float(np.max(np.abs(ea[rests] / eb[rests] - 1.0)))}
    return {"approach_at_waypoints_m": {k: v.tolist() for k, v in ends.items()}, "pairs": gaps}


def _ratio(text: str) -> float | None:
    return None if text == "none" else float(text)


def main() -> None:
    from geocontact.fem.checkpoint import checkpoint_path, read_checkpoint
    from geocontact.fem.identity import FeRunIdentity, difference, finished_run, load_result
    from geocontact.fem.result import CURVE_COLUMNS
    from geocontact.fem.run import run_history

    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--figure", type=Path, default=None,
                    help="only draw the runs --runs of --out into this PNG")
    ap.add_argument("--runs", nargs="*", default=[])
    ap.add_argument("--material", default="reference-weak")
    ap.add_argument("--mesh", default="coarse")
    ap.add_argument("--mesh-rule", nargs="+", default=["yield"],
                    help="fem mesh rule(s) (run_history); several: every one is run with every "
                         "--contact, --steps and cap, all compared pairwise")
    ap.add_argument("--step-rule", default="segment", help="fem step rule (run_history)")
    ap.add_argument("--contact", nargs="+", default=["node"],
                    help="fem contact(s): node | facet (run_history); every one is run with "
                         "every --steps and cap, and all the runs are compared pairwise")
    ap.add_argument("--kinematics", default="small",
                    help="fem kinematics: small | finite (run_history)")
    ap.add_argument("--steps", type=int, nargs="+", default=[24, 48])
    ap.add_argument("--max-step-ratio", type=_ratio, nargs="+", default=[None],
                    help="cap(s) on the loading force ratio of one solve (run_history "
                         "max_step_ratio); every --steps is run with every cap; none: no cap")
    ap.add_argument("--step-control", nargs="+", default=["fixed"],
                    help="fem step control(s): fixed | adaptive | dissipation (run_history); "
                         "every one is run with every --steps and cap (with adaptive or "
                         "dissipation the cap is its largest step), all compared pairwise")
    ap.add_argument("--kernels", default="numpy", help="fem kernels: numpy | compiled")
    ap.add_argument("--force", type=float, default=FORCE)
    ap.add_argument("--cycles", type=int, default=0,
                    help="run 0 -> F -> 0 this many times instead of 0 -> F (the measures are "
                         "of the first loading; each run's approach at every peak and at every "
                         "return to 0 N is compared too: ``waypoints``)")
    ap.add_argument("--floor", type=float, default=10.0, help="lowest force, x Fy")
    ap.add_argument("--out", required=True)
    ap.add_argument("--progress", action="store_true", help="progress bar of each FE run")
    ap.add_argument("--finished-only", action="store_true",
                    help="measure only the runs already finished in --out (no FE run)")
    ap.add_argument("--under-way", action="store_true",
                    help="as --finished-only, and a run still under way enters with the "
                         "loading its committed checkpoint holds; every run is then cut at the "
                         "lowest force all of them reached (a progress measure, no FE run)")
    ap.add_argument("--json", default=None, help="name of the measures file in --out")
    args = ap.parse_args()
    if args.figure is not None:
        figure(Path(args.out), args.runs, args.figure)
        return

    material = load_material(args.material)
    history = [0.0, args.force] + [0.0, args.force] * (args.cycles - 1) + [0.0] * (args.cycles > 0)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    curves, runs = {}, {}
    fy = None
    under_way = {}
    for rule, contact, control, ratio, n in itertools.product(
            args.mesh_rule, args.contact, args.step_control, args.max_step_ratio, args.steps):
        name = f"{args.mesh}-{rule}-{args.step_rule}-{n}"
        if contact != "node":
            name = f"{args.mesh}-{rule}-{contact}-{args.step_rule}-{n}"
        if args.kinematics != "small":
            name = f"{args.kinematics}-{name}"
        label = f"{n} steps" if len(args.contact) == 1 else f"{contact}, {n} steps"
        if len(args.mesh_rule) > 1:
            label = f"{rule}, {label}"
        if ratio is not None:
            name += f"-cap{ratio:g}"
            label += f", cap {ratio:g}"
        if control != "fixed":
            name += f"-{control}"
            label += f", {control}"
        if args.kernels != "numpy":
            name += f"-{args.kernels}"
        if args.cycles:
            name += f"-{args.cycles}cycles"
        # the step control always named: its default moved from "fixed" to "adaptive" (issue 36)
        model = {"contact": contact, "kinematics": args.kinematics, "step_control": control}
        model.update({"kernels": args.kernels} if args.kernels != "numpy" else {})
        started = time.perf_counter()
        cpu_started = time.process_time()
        if args.finished_only or args.under_way:
            identity = FeRunIdentity.of(
                material, history, args.mesh, steps_per_segment=n,
                mesh_rule=rule, step_rule=args.step_rule, max_step_ratio=ratio, **model)
            result = finished_run(out / name, identity)
            if result is None and (out / name / "summary.json").exists():
                # made by FE code the current one reproduces, or a numpy run the compiled
                # default agrees with (fem.identity.AGREED_FE_CODE)?
                earlier = load_result(out / name)
                if difference(earlier.summary.get("identity"), identity, rounding=True,
                              agreement=True) is None:
                    result = earlier
            ckpt = checkpoint_path(out / name)
            if result is None and args.under_way and ckpt.exists():
                saved = read_checkpoint(ckpt, identity, len(CURVE_COLUMNS))
                if saved is not None:
                    rows = np.asarray(saved.rows, dtype=float)
                    curves[label] = {c: rows[:, i] for i, c in enumerate(CURVE_COLUMNS)}
                    under_way[label] = {"steps_done": saved.done,
                                        "force_N": float(curves[label]["force_N"][-1]),
                                        "wall_time_s": saved.wall_time_s,
                                        "fe_code": json.loads(str(np.load(ckpt)["identity"]))[
                                            "fe_code"]}
                    fy = fy or saved.yield_force
                    continue
            if result is None:
                print(f"{name}: not finished, left out")
                continue
        else:
            result = run_history(material, history, args.mesh, out / name,
                                 steps_per_segment=n, resume=True, write_fields=False,
                                 mesh_rule=rule, step_rule=args.step_rule,
                                 max_step_ratio=ratio, progress=args.progress, **model)
        curves[label] = result.curve
        fy = fy or result.summary["first_yield_force_N"]
        runs[label] = {"elements": result.summary["mesh"]["elements"],
                       "wall_time_s": result.summary["wall_time_s"],
                       "this_call_s": time.perf_counter() - started,
                       "this_call_cpu_s": time.process_time() - cpu_started,
                       "steps": result.summary["steps"],
                       "step_control": result.summary["step_control"],
                       "newton_iterations": result.summary["newton_iterations"],
                       "contact_resolution": result.summary["contact_resolution"],
                       "fe_code": result.summary["identity"]["fe_code"],
                       "steps_per_segment": n,
                       "first_yield_force_predicted_N": result.summary[
                           "first_yield_force_predicted_N"],
                       "version": result.summary["version"]}
    if not curves:
        raise SystemExit("measure_staircase: no run to measure in --out")
    cut = None
    if under_way:  # every run up to the lowest force all of them reached
        cut = min(float(np.max(c["force_N"])) for c in curves.values())
        for label, curve in curves.items():
            above = np.asarray(curve["force_N"]) > cut * (1.0 + 1e-12)
            end = int(np.argmax(above)) if above.any() else len(above)
            curves[label] = {k: np.asarray(v)[:end] for k, v in curve.items()}
    measures = staircase_measures(curves, fy, args.floor)
    for label, r in runs.items():  # a finished run against itself at half its steps' forces
        if r["steps_per_segment"] % 2 == 0:
            x, f = loading_branch(curves[label])
            half = np.array(load_schedule(history, r["steps_per_segment"] // 2,
                                          r["first_yield_force_predicted_N"],
                                          args.step_rule)[0])
            keep = np.array([np.min(np.abs(half / v - 1.0)) < 1e-9 for v in f])
            gmax, grms = sampling_gap((x, f), (x[keep], f[keep]), args.floor * fy)
            measures["runs"][label].update({"sampling_gap_half_max": gmax,
                                            "sampling_gap_half_rms": grms})
    if args.cycles:
        measures["waypoints"] = waypoint_gaps(curves, len(history))
    rules = "-".join(args.mesh_rule)
    measures.update({"material": args.material, "mesh": args.mesh,
                     "mesh_rule": args.mesh_rule[0] if len(args.mesh_rule) == 1 else args.mesh_rule,
                     "step_rule": args.step_rule, "max_step_ratio": args.max_step_ratio,
                     "contact": args.contact, "kinematics": args.kinematics,
                     "force_N": args.force, "first_yield_force_N": fy, "cost": runs,
                     "under_way": under_way, "measured_to_force_N": cut})
    caps = "".join(f"-cap{r:g}" for r in args.max_step_ratio if r is not None)
    contact = "" if args.contact == ["node"] else "-".join(args.contact) + "-"
    kinematics = "" if args.kinematics == "small" else f"{args.kinematics}-"
    default_name = (f"staircase-{kinematics}{args.mesh}-{rules}-{contact}"
                    f"{args.step_rule}{caps}.json")
    write_json_atomic(out / (args.json or default_name), measures)
    print(json.dumps({k: measures[k] for k in ("runs", "pairs")}, indent=1))
    for name, r in runs.items():
        print(f"{name}: {r['elements']} elements, {r['step_control']['solves']} solves, "
              f"{r['wall_time_s']:.0f} s")


if __name__ == "__main__":
    main()
