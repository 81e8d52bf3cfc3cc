"""Does a deep loading need its first contacts resolved? The same run 0 -> F -> 0 on the mesh
``run_history`` builds (graded from 0.7 a_y, every contact from first yield on resolved) and on
meshes whose smallest resolved contact is set later, a_min = f R (the first steps then have one
or two surface elements under the contact), compared where the later meshes resolve the contact.

Why (issue 37, docs/benchmarks.md "What the 64 points cost at this speed"): a hard grain
(E/sigma_c ~ 1e5) has a_y ~ 3e-5 R, so one run to a/R 0.3 resolves four decades of contact size
on one graded mesh, and that is what makes the campaign's hard band cost tens of hours a point.
Below a = 0.02 R the normalised curves do not depend on E/sigma_c (docs/similarity.md), so the
first decades are known; if the loading beyond a few a_min does not depend on how the first
steps were resolved (the early plastic zone is then a small part of the contact's), a hard
grain's run could start its mesh where the sphere's size begins to matter.

    PYTHONPATH=src .venv/bin/python scripts/verify_hard_band_start.py \\
        --material reference-weak --force 1900 --late 1e-3 3e-3 \\
        --json docs/verification/hard-band-start.json
    PYTHONPATH=src .venv/bin/python scripts/verify_hard_band_start.py \\
        --point 2 --force 1000 --late 1e-3 3e-3 \\
        --json docs/verification/hard-band-start-point2.json

``--point N``: the material of the campaign of record's design point N (of its 64; point 2 is a
hard grain, E/sigma_c 1e5, beta 0, nu 0.1, m 0.3) instead of ``--material``.

Measures, against the fully resolved run: the force at the same approach along the loading,
over the steps whose contact radius is at least ``--resolved`` x a_min of the late mesh (the
largest relative difference, and at the peak), the peak and residual approaches, the loop work;
and each run's elements, solves, Newton iterations and CPU time.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from geocontact.errors import ArgumentParser, InputError, run_reporting_errors
from geocontact.fem.limits import check_resolved_force
from geocontact.fem.run import run_history
from geocontact.fem.settings import RESOLVE_FROM_RANGE
from geocontact.files import Output, claim, provenance, write_json_atomic
from geocontact.grain.material import load_material
from geocontact.universal.design import material_at
from geocontact.universal.record import MIN_POINTS_OF_RECORD, design_points


def one_run(material, force: float, mesh: str, late: float | None) -> dict:
    """The run 0 -> force -> 0 (finite strain, the FE's defaults otherwise, backtracked Newton
    updates as the campaign of record's), its smallest resolved contact late * R if given (the
    FE setting ``resolve_from``)."""
    started = time.process_time()
    result = run_history(material, [0.0, force, 0.0], mesh=mesh, write_fields=False,
                         kinematics="finite", newton="backtracking", resolve_from=late)
    s = result.summary
    c = result.curve
    return {"a_min_over_R": late, "elements": s["mesh"]["elements"],
            "solves": s["step_control"].get("solves"),
            "newton_iterations": s["newton_iterations"],
            "cpu_s": time.process_time() - started,
            "approach_m": np.asarray(c["approach_m"]).tolist(),
            "force_N": np.asarray(c["force_N"]).tolist(),
            "contact_radius_m": np.asarray(c["contact_radius_m"]).tolist(),
            "max_approach_m": s["cycles"][0]["max_approach_m"],
            "residual_approach_m": s["cycles"][0]["residual_approach_m"],
            "loop_work_J": s["cycles"][0].get("loop_work_J"),
            "plastic_work_J": s["cycles"][0].get("plastic_work_J")}


PROFILE_MULTIPLES = (2.0, 5.0, 10.0, 20.0, 50.0, 100.0)


def loading(r: dict) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    f = np.asarray(r["force_N"])
    top = int(np.argmax(f))
    return (np.asarray(r["approach_m"])[:top + 1], f[:top + 1],
            np.asarray(r["contact_radius_m"])[:top + 1])


def compare(full: dict, late: dict, radius: float, resolved: float) -> dict:
    d0, f0, _ = loading(full)
    d1, f1, a1 = loading(late)
    keep = a1 >= resolved * late["a_min_over_R"] * radius
    ref = np.interp(d1[keep], d0, f0)
    rel = (f1[keep] - ref) / ref
    # how the difference fades as the contact grows past the late mesh's first resolved one
    profile = []
    for multiple in PROFILE_MULTIPLES:
        beyond = a1[keep] >= multiple * late["a_min_over_R"] * radius
        if beyond.any():
            profile.append({"from_contact_over_a_min": multiple,
                            "largest_force_difference": float(np.max(np.abs(rel[beyond])))})
    return {"a_min_over_R": late["a_min_over_R"], "steps_compared": int(keep.sum()),
            "force_difference_beyond": profile,
            "from_contact_over_R": float(a1[keep][0] / radius) if keep.any() else None,
            "largest_force_difference": float(np.max(np.abs(rel))) if keep.any() else None,
            "force_difference_at_peak": float(rel[-1]) if keep.any() else None,
            "max_approach_ratio": late["max_approach_m"] / full["max_approach_m"],
            "residual_approach_ratio": late["residual_approach_m"] / full["residual_approach_m"],
            "plastic_work_ratio": (late["plastic_work_J"] / full["plastic_work_J"]
                                   if full["plastic_work_J"] else None),
            "cpu_ratio": late["cpu_s"] / full["cpu_s"],
            "solves_ratio": (late["solves"] / full["solves"]
                             if late["solves"] and full["solves"] else None)}


def describe(r: dict) -> str:
    if not r["steps_compared"]:
        return "no loading step with the contact resolved on the late mesh"
    fading = ", ".join(f"{100 * p['largest_force_difference']:.2f} % beyond "
                       f"{p['from_contact_over_a_min']:g} a_min"
                       for p in r["force_difference_beyond"])
    return (f"force from a/R {r['from_contact_over_R']:.3g} on within "
            f"{100 * r['largest_force_difference']:.2f} % ({fading}; peak "
            f"{100 * r['force_difference_at_peak']:+.2f} %)")


def main(argv=None) -> int:
    parser = ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--material", default="reference-weak")
    parser.add_argument("--point", type=int, default=None,
                        help="the campaign of record's design point N's material instead")
    parser.add_argument("--force", type=float, default=1900.0, help="peak force, N")
    parser.add_argument("--mesh", default="coarse", choices=["coarse", "default", "fine"])
    parser.add_argument("--late", type=float, nargs="+", default=[1e-3, 3e-3],
                        help="the later meshes' smallest resolved contact, a_min / R")
    parser.add_argument("--resolved", type=float, default=5.0,
                        help="compare where the contact radius is at least this x a_min")
    parser.add_argument("--json", type=Path, default=None)

    def work() -> int:
        args = parser.parse_args(argv)
        low, high = RESOLVE_FROM_RANGE
        for f in args.late:
            if not low <= f <= high:
                raise InputError(f"--late: each a_min / R must be in [{low:g}, {high:g}], "
                                 f"got {f:g}")
        if not 1.0 <= args.resolved <= 100.0:
            raise InputError(f"--resolved: must be in [1, 100], got {args.resolved:g}")
        if args.point is None:
            material = load_material(args.material)
        else:
            if not 0 <= args.point < MIN_POINTS_OF_RECORD:
                raise InputError(f"--point: must be a design point in [0, "
                                 f"{MIN_POINTS_OF_RECORD - 1}], got {args.point}")
            point = design_points(MIN_POINTS_OF_RECORD)[args.point]
            material = material_at(point.coordinates)
        check_resolved_force(material, args.force, "--force")
        outputs = [Output(args.json, "file", "--json")] if args.json else []
        with claim(outputs, "verify_hard_band_start"):
            runs = [one_run(material, args.force, args.mesh, None)]
            print(f"fully resolved: {runs[0]['elements']} elements, {runs[0]['solves']} solves,"
                  f" {runs[0]['cpu_s']:.0f} s CPU", flush=True)
            rows = []
            for f in args.late:
                runs.append(one_run(material, args.force, args.mesh, f))
                rows.append(compare(runs[0], runs[-1], material.radius, args.resolved))
                r = rows[-1]
                print(f"a_min = {f:g} R: {runs[-1]['elements']} elements, CPU "
                      f"x{r['cpu_ratio']:.2f}; {describe(r)}; residual approach "
                      f"x{r['residual_approach_ratio']:.4f}", flush=True)
            if args.json:
                inputs = {**vars(args), "json": str(args.json)}
                write_json_atomic(args.json, {"material": material.to_dict(),
                                              "runs": runs, "comparison": rows,
                                              "provenance": provenance(
                                                  "verify_hard_band_start", inputs)})
        return 0

    return run_reporting_errors(work)


if __name__ == "__main__":
    raise SystemExit(main())
