"""Make the synthetic single-grain laboratory tests of examples/tests/ from FE runs.

No measured single-grain test ships with any package, so the example tests of
``geocontact fit`` are made here from this project's FE engine (``geocontact.fem``, coarse mesh)
for two materials that no calibration of the project uses, and then dirtied the way a
displacement-controlled press dirties a curve:

* the set-up: ``platens`` (one grain between two rigid platens: platen displacement 2w = the
  pair approach delta at the same force, docs/model.md §10) or ``flat`` (one grain on a rigid flat:
  displacement w = delta / 2);
* platen (machine) compliance: the measured displacement adds F / k_machine;
* an unknown contact point: the record starts with the platen short of the grain (a
  pre-contact segment of zero force), and the machine's zero is wherever the run started;
* after each unloading the press backs off past the residual approach (the grain lifts off,
  force zero) and comes back (re-contact);
* uneven sampling (a logger with jittered intervals at a constant platen speed);
* load-cell noise (Gaussian) with a small tare offset, and displacement-transducer noise;
* the units a lab writes (mm and N, or um and kN);
* the shapes of ``SHAPES`` (issue 37): cycles of increasing amplitude whose first peak is 6 %
  of the largest, a long approach before contact, a sparse first loading; 0.4 % load-cell
  noise.

Seeded: the same command writes the same files. The FE runs are cached in out/cache/fem.

    nice -n 5 .venv/bin/python scripts/make_synthetic_lab_tests.py          # examples/tests/
    nice -n 5 .venv/bin/python scripts/make_synthetic_lab_tests.py --only ramp-quartzite \
        approach-quartzite sparse-quartzite                                 # the SHAPES only
    nice -n 5 .venv/bin/python scripts/make_synthetic_lab_tests.py --refresh-masters \
        --only platens-quartzite flat-sandstone   # the committed master curves, with a
    nice -n 5 .venv/bin/python scripts/make_synthetic_lab_tests.py --check-curves \
        --only platens-quartzite flat-sandstone   # their check histories' FE runs
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

from geocontact.errors import run_reporting_errors
from geocontact.fem.campaign import DEFAULT_CACHE, FemJob, run_campaign
from geocontact.files import write_json_atomic, write_text_atomic
from geocontact.grain.hertz import incipient_yield
from geocontact.grain.material import Material

OUT = Path("examples/tests")
MASTERS = Path("tests/data/labtest")  # the FE master curves the tests' identifications end on

# Two grains no calibration of the project uses (docs/model.md §9 ranges); radii of lab grains.
TESTS = {
    "platens-quartzite": {
        "material": dict(youngs_modulus=30e9, poissons_ratio=0.2,
                         compressive_yield_stress=25e6, friction_angle_deg=20.0,
                         hardening_ratio=0.0, radius=4e-3),
        "setup": "platens",
        "peaks_over_yield": [4.0, 15.0, 50.0, 150.0],   # the test's load-unload cycles
        "machine_stiffness_N_per_m": 3.0e6,
        "units": ("mm", "N"),
        "seed": 11,
        # the different history the fitted law must predict (scripts/verify_lab_fit.py):
        # repeated cycles, a partial unload-reload, a new higher peak
        "check_history_over_yield": [0.0, 30.0, 0.0, 30.0, 0.0, 30.0, 9.0, 30.0, 0.0,
                                     100.0, 0.0],
    },
    "flat-sandstone": {
        "material": dict(youngs_modulus=8e9, poissons_ratio=0.3,
                         compressive_yield_stress=6e6, friction_angle_deg=35.0,
                         hardening_ratio=0.0, radius=10e-3),
        "setup": "flat",
        "peaks_over_yield": [5.0, 20.0, 80.0],
        "machine_stiffness_N_per_m": 5.0e6,
        "units": ("um", "kN"),
        "seed": 23,
        "check_history_over_yield": [0.0, 40.0, 0.0, 40.0, 12.0, 40.0, 0.0, 40.0, 0.0,
                                     70.0, 0.0],
    },
}

# Records a lab engineer brings that the first-loading contact fit could not take (issue 37):
# the quartzite grain above (its committed master curve serves the fast tests), one FE run of
# cycles of increasing amplitude whose first peak is 6 % of the largest, load-cell noise 0.4 %
# of the peak, each dirtied in its own way. Every entry of TESTS takes these keys too
# (defaults: the constants below).
QUARTZITE = TESTS["platens-quartzite"]
RAMP = [8.0, 20.0, 50.0, 130.0]  # Fy: the first cycle is 8 / 130 = 6.2 % of the peak
# the check history is the quartzite test's own FE run (its mesh sized for 150 Fy)
QUARTZITE = {**QUARTZITE, "check_mesh_over_yield": max(QUARTZITE["peaks_over_yield"])}
SHAPES = {
    # (a) cycles of increasing amplitude, the first at 6 % of the largest
    "ramp-quartzite": {**QUARTZITE, "peaks_over_yield": RAMP, "force_noise": 4e-3,
                       "seed": 31},
    # (b) a long approach: the platen travels 3 x the test's travel at zero force first
    "approach-quartzite": {**QUARTZITE, "peaks_over_yield": RAMP, "force_noise": 4e-3,
                           "gap": 3.0, "setup": "flat", "units": ("um", "N"), "seed": 32},
    # (c) a sparse first loading: the press loads fast to the first peak (about 12 points)
    "sparse-quartzite": {**QUARTZITE, "peaks_over_yield": RAMP, "force_noise": 4e-3,
                         "first_loading_points": 12, "seed": 33},
}
TESTS.update(SHAPES)

LENGTH = {"m": 1.0, "mm": 1e-3, "um": 1e-6}
FORCE = {"N": 1.0, "kN": 1e3}
# FE load steps per monotonic segment: a lab logger samples far more densely than the FE's
# coarse preset (12), and the record interpolates linearly between the FE's steps
FE_STEPS = 40
# the FE settings the committed records were made with: the "yield" meshes and fixed steps (the
# defaults before issue 36), so that the records regenerate from this script
COMMITTED_FE = {"mesh_rule": "yield", "step_control": "fixed"}
SAMPLES = 3000           # points of the record (about)
FORCE_NOISE = 3e-4       # load-cell noise, standard deviation as a fraction of the peak force
FORCE_TARE = 1e-3        # load-cell offset left after zeroing, fraction of the peak force
DISPLACEMENT_NOISE = 3e-4  # transducer noise, fraction of the peak displacement
GAP = 0.15               # pre-contact travel, fraction of the peak displacement
BACK_OFF = 0.04          # travel past the residual approach after each unloading, same
SEATING_SPEED = 0.1      # platen speed up to the first peak, share of the test speed
DURATION = 1200.0        # s, the whole record at a constant platen speed


def material_of(spec) -> Material:
    return Material(**spec["material"])


def test_job(spec, *, mesh: str = "coarse") -> FemJob:
    material = material_of(spec)
    fy = incipient_yield(material).force
    forces = [0.0]
    for k in spec["peaks_over_yield"]:
        forces += [k * fy, 0.0]
    return FemJob(material, tuple(forces), mesh=mesh, steps_per_segment=FE_STEPS,
                  label="lab test", **COMMITTED_FE)


def check_job(spec, *, mesh: str = "coarse") -> FemJob:
    """The FE run of the other history, which the law fitted to the test must predict."""
    material = material_of(spec)
    fy = incipient_yield(material).force
    mesh_peak = spec.get("check_mesh_over_yield", max(spec["peaks_over_yield"]))
    return FemJob(material, tuple(k * fy for k in spec["check_history_over_yield"]),
                  mesh=mesh, mesh_force=mesh_peak * fy,
                  steps_per_segment=FE_STEPS, label="check history", **COMMITTED_FE)


def displacement_of(approach, setup: str):
    """What the press measures of the pair approach delta (docs/model.md §10)."""
    return approach / 2.0 if setup == "flat" else approach


def clean_record(approach, force, setup: str, machine_stiffness: float | None, *,
                 gap: float = GAP):
    """The test as a noise-free machine would record it: pre-contact travel (``gap`` of the
    test's travel), the FE path, a back-off past the residual approach after each unloading,
    compliance added. Returns the machine displacement (m, zero at contact) and force (N)
    along the path."""
    u = displacement_of(np.asarray(approach, float), setup)
    f = np.asarray(force, float)
    span = float(u.max())
    path_u, path_f = [np.array([-gap * span])], [np.array([0.0])]
    zero = np.flatnonzero(f == 0.0)
    start = 0
    for z in list(zero[1:]) + [len(f) - 1]:
        path_u.append(u[start:z + 1])
        path_f.append(f[start:z + 1])
        back = u[z] - BACK_OFF * span
        path_u.append(np.array([back, u[z]]) if z < len(f) - 1 else np.array([back]))
        path_f.append(np.zeros(2 if z < len(f) - 1 else 1))
        start = z + 1
    path_u, path_f = np.concatenate(path_u), np.concatenate(path_f)
    if machine_stiffness:
        path_u = path_u + path_f / machine_stiffness
    return path_u, path_f


def lab_record(u, f, rng, *, samples: int = SAMPLES, noisy: bool = True,
               force_noise: float = FORCE_NOISE, first_loading_points: int | None = None):
    """Resample a path at a constant platen speed with jittered logger intervals and add the
    noises. Returns time (s), machine displacement (m, zero = start of the record), force (N)
    and the true contact point (the machine displacement where the path touches the grain).
    ``first_loading_points``: the press runs from contact to the first peak so fast that the
    logger takes about this many points there (a sparse first loading) instead of seating
    slowly."""
    s = np.concatenate([[0.0], np.cumsum(np.abs(np.diff(u)))])
    seat = float(s[int(np.argmax(np.diff(u) < 0))])  # the first reversal
    if first_loading_points is None:
        # the press seats the grain slowly: up to the first peak at SEATING_SPEED of the speed
        # of the rest, so the logger (constant rate) takes more points there
        clock = np.where(s <= seat, s / SEATING_SPEED, seat / SEATING_SPEED + (s - seat))
    else:
        # the approach at the test's speed, then contact -> first peak in first_loading_points
        # logger intervals, then the test's speed again
        touch = float(s[int(np.argmax(f > 0.0))])
        rest = s[-1] - seat + touch
        fast = first_loading_points * rest / (samples - first_loading_points)
        clock = np.where(s <= touch, s, np.where(
            s <= seat, touch + (s - touch) * fast / (seat - touch), touch + fast + (s - seat)))
    step = clock[-1] / samples
    gaps = step * (rng.uniform(0.3, 1.7, size=int(1.3 * samples)) if noisy
                   else np.ones(int(1.3 * samples)))
    at = np.concatenate([[0.0], np.cumsum(gaps)])
    at = at[at <= clock[-1]]
    keep = np.concatenate([[True], np.diff(s) > 0])
    disp = np.interp(at, clock[keep], u[keep])
    force = np.interp(at, clock[keep], f[keep])
    time = at / clock[-1] * DURATION
    peak, span = float(f.max()), float(u.max() - u.min())
    if noisy:
        force = force + FORCE_TARE * peak + rng.normal(0.0, force_noise * peak, force.size)
        disp = disp + rng.normal(0.0, DISPLACEMENT_NOISE * span, disp.size)
    return time, disp - disp[0], force, -float(disp[0])


def write_test(path: Path, time, disp, force, units) -> None:
    lu, fu = units
    lines = ["# synthetic test made by scripts/make_synthetic_lab_tests.py from a geocontact "
             "FE run (not a measurement); see examples/tests/README.md",
             f"time_s,displacement_{lu},force_{fu}"]
    lines += [f"{t:.3f},{d / LENGTH[lu]:.6g},{x / FORCE[fu]:.6g}"
              for t, d, x in zip(time, disp, force, strict=True)]
    write_text_atomic(path, "\n".join(lines) + "\n")


def make(names, mesh: str, cache: Path, out: Path) -> dict:
    """The records of ``names`` from their FE runs (tests sharing a history share the run);
    the check histories are named in the truth files and run by scripts/verify_lab_fit.py."""
    specs = {n: TESTS[n] for n in names}
    jobs = [test_job(s, mesh=mesh) for s in specs.values()]
    checks = [check_job(s, mesh=mesh) for s in specs.values()]
    unique = list({job.key(): job for job in jobs}.values())
    by_key = dict(zip((job.key() for job in unique),
                      run_campaign(unique, cache, workers=1, progress=True), strict=True))
    made = {}
    for i, (name, spec) in enumerate(specs.items()):
        result = by_key[jobs[i].key()]
        c = result.curve
        gap = spec.get("gap", GAP)
        noise = spec.get("force_noise", FORCE_NOISE)
        u, f = clean_record(c["approach_m"], c["force_N"], spec["setup"],
                            spec["machine_stiffness_N_per_m"], gap=gap)
        rng = np.random.default_rng(spec["seed"])
        sparse = spec.get("first_loading_points")
        t, d, x, touch = lab_record(u, f, rng, force_noise=noise, first_loading_points=sparse)
        write_test(out / f"{name}.csv", t, d, x, spec["units"])
        t0, d0, x0, touch0 = lab_record(u, f, rng, noisy=False, first_loading_points=sparse)
        write_test(out / f"{name}.clean.csv", t0, d0, x0, spec["units"])
        material = material_of(spec)
        truth = {
            "note": "synthetic: the FE run this test was made from, and how it was dirtied",
            "material": material.to_dict(),
            "setup": spec["setup"],
            "radius_m": material.radius,
            "machine_stiffness_N_per_m": spec["machine_stiffness_N_per_m"],
            "analytic_yield": incipient_yield(material).to_dict(),
            "fe_first_yield_force_N": result.summary.get("first_yield_force_N"),
            "fe_first_yield_approach_m": result.summary.get("first_yield_approach_m"),
            "fe_cycles": [{k: cy[k] for k in ("max_force_N", "max_approach_m",
                                              "residual_approach_m")}
                          for cy in result.summary["cycles"]],
            "fe_history_N": list(jobs[i].forces),
            "fe_mesh": mesh,
            "fe_cache_key": jobs[i].key(),
            "check_history_N": list(checks[i].forces),
            "check_cache_key": checks[i].key(),
            "noise": {"force_sd_of_peak": noise, "force_tare_of_peak": FORCE_TARE,
                      "displacement_sd_of_span": DISPLACEMENT_NOISE,
                      "pre_contact_travel_of_span": gap, "back_off_of_span": BACK_OFF,
                      "samples": SAMPLES, "first_loading_points": sparse,
                      "seed": spec["seed"]},
            # where the grain is touched, in the record's machine displacement after the
            # machine compliance F / k is subtracted (the noisy record's zero carries the
            # transducer noise of its first point)
            "contact_displacement_m": touch,
            "clean_contact_displacement_m": touch0,
            "units": list(spec["units"]),
            "check_history_over_yield": spec["check_history_over_yield"],
            "peaks_over_yield": spec["peaks_over_yield"],
        }
        write_json_atomic(out / f"{name}.truth.json", truth)
        made[name] = truth
    return made


def write_masters(names, cache: Path, tests: Path, masters: Path) -> None:
    """The FE master curve each noise-free test's identification ends on (``geocontact fit``,
    coarse mesh), for the fast tests of tests/test_labtest.py."""
    from geocontact.labtest import fit_test, read_test

    for name in (n for n in names if n not in SHAPES):  # SHAPES use the quartzite's curve
        truth = json.loads((tests / f"{name}.truth.json").read_text())
        m = truth["material"]
        fit = fit_test(read_test(tests / f"{name}.clean.csv"), truth["setup"], m["radius"],
                       machine_stiffness=truth["machine_stiffness_N_per_m"],
                       poissons_ratio=m["poissons_ratio"],
                       friction_angle=m["friction_angle_deg"], bootstrap_samples=0,
                       cache_dir=cache)
        master = {**fit.master, "material": fit.master["material"].to_dict(),
                  "note": f"FE master curve of the identification of {name}.clean.csv "
                          "(scripts/make_synthetic_lab_tests.py)"}
        write_json_atomic(masters / f"{name}.master.json", master)


def refresh_masters(names, cache: Path, masters: Path) -> None:
    """Rerun the FE run of each committed master curve (its material, force and mesh; no new
    identification) and write it again with what the current ``identify.master_curve`` keeps
    (the contact radius ``a`` for the unloading stiffness's E*): the curve's x and g must come
    out as committed (to 1e-9), else it stops."""
    from geocontact.labtest.identify import master_curve, read_master

    for name in (n for n in names if n not in SHAPES):
        path = masters / f"{name}.master.json"
        old = read_master(path)
        new = master_curve(old["material"], old["max_force_N"], mesh=old["mesh"],
                           cache_dir=cache)
        for key in ("x", "g"):
            if old[key].shape != new[key].shape or not np.allclose(new[key], old[key],
                                                                    rtol=1e-9, atol=0):
                raise SystemExit(f"{name}: the FE run no longer reproduces the committed "
                                 f"master curve's {key}; rerun without --refresh-masters")
        write_json_atomic(path, {**new, "material": new["material"].to_dict(),
                                 "note": old["note"] + "; contact radius added by "
                                 "--refresh-masters (the same FE run)"})


CHECK_CURVES = {"platens-quartzite": MASTERS / "quartzite-check.json",
                "flat-sandstone": MASTERS / "sandstone-check.json"}
CHECK_CURVE = CHECK_CURVES["platens-quartzite"]  # the records of SHAPES are the quartzite's


def write_check_curve(cache: Path, path: Path = CHECK_CURVE,
                      name: str = "platens-quartzite") -> None:
    """The FE run of a grain's check history (what the law fitted to its records must
    predict, docs/fit.md acceptance), for the fast tests of tests/test_labtest_shapes.py and
    tests/test_labtest.py: its approach path, forces, steps and cycles."""
    job = check_job(TESTS[name])
    result = run_campaign([job], cache, workers=1, progress=True)[0]
    keep = ("residual_approach_m", "max_force_N", "steps")
    write_json_atomic(path, {
        "note": f"FE run of the {name.split('-')[1]} grain's check history "
                "(scripts/make_synthetic_lab_tests.py write_check_curve)",
        "forces_N": list(job.forces), "cache_key": job.key(),
        "curve": {k: [float(v) for v in result.curve[k]] for k in ("approach_m", "force_N")}
        | {"step": [int(v) for v in result.curve["step"]]},
        "summary": {"cycles": [{k: cy[k] for k in keep} for cy in result.summary["cycles"]],
                    "identity": {"key": job.key()}}})


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--mesh", default="coarse", choices=["coarse", "default", "fine"])
    parser.add_argument("--only", nargs="*", default=list(TESTS), choices=list(TESTS))
    parser.add_argument("--cache", default=str(DEFAULT_CACHE))
    parser.add_argument("--out", default=str(OUT))
    parser.add_argument("--refresh-masters", action="store_true",
                        help="only rerun the committed master curves' FE runs and rewrite them "
                             "with the contact radius (no new identification)")
    parser.add_argument("--check-curves", action="store_true",
                        help="only write the check histories' FE runs of the two tests to "
                             "tests/data/labtest (run or taken from the cache)")
    args = parser.parse_args(argv)

    def run():
        if args.refresh_masters:
            refresh_masters(args.only, Path(args.cache), MASTERS)
            return
        if args.check_curves:
            for name in (n for n in args.only if n in CHECK_CURVES):
                write_check_curve(Path(args.cache), CHECK_CURVES[name], name)
            return
        made = make(args.only, args.mesh, Path(args.cache), Path(args.out))
        write_masters(args.only, Path(args.cache), Path(args.out), MASTERS)
        if set(args.only) & set(SHAPES):
            write_check_curve(Path(args.cache))
        print(json.dumps({n: t["fe_cycles"] for n, t in made.items()}, indent=1))

    return run_reporting_errors(run)


if __name__ == "__main__":
    sys.exit(main())
