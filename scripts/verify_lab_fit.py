"""Acceptance of ``geocontact fit`` (issue 13) on the synthetic tests of examples/tests/.

For each test (a grain no calibration of the project uses):

1. the law is fitted to the noisy test (what a lab would have: noise, offset, unknown contact
   point, uneven sampling, machine compliance), with nu and beta given;
2. the fitted law is driven along a *different* FE history of the same grain (repeated cycles,
   a partial unload-reload, a new higher peak; ``make_synthetic_lab_tests.check_job``) and
   compared with ``calibrate.acceptance.compare``: force RMS over the path, % of the peak
   (goal <= 5 %), residual approach at each return to zero force (goal <= 10 %);
3. the fit of the noise-free version of the same test identifies sigma_c (goal within 5 %) and
   E;
4. the bootstrap's standard errors against the scatter over independent noise realizations of
   the noise-free record (the generator's noise model), all with the same master curve.

    nice -n 5 .venv/bin/python scripts/verify_lab_fit.py [--bootstrap 30] [--out out/verify_lab_fit]
    nice -n 5 .venv/bin/python scripts/verify_lab_fit.py --shapes   # the records of issue 37
    nice -n 5 .venv/bin/python scripts/verify_lab_fit.py --committed [--shapes] [--channels]

``--committed``: no FE run at all: the committed master curves and check-history runs
(tests/data/labtest) instead of the identification's and the cache's (items 1-3; the
realizations with the committed master, their bias and scatter, no bootstrap); ``--channels``
adds the realizations with the noise on one channel at a time (load cell, displacement
transducer), which tells which one makes a bias.

FE runs (the tests, the check histories and the identification's master curves) come from
the cache out/cache/fem when there (make_synthetic_lab_tests.py fills it), else run (coarse).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))

from make_synthetic_lab_tests import OUT, SHAPES, TESTS, check_job  # noqa: E402

from geocontact.calibrate.acceptance import compare  # noqa: E402
from geocontact.errors import run_reporting_errors  # noqa: E402
from geocontact.fem.campaign import DEFAULT_CACHE, run_campaign  # noqa: E402
from geocontact.files import write_json_atomic  # noqa: E402
from geocontact.labtest import fit_test, read_test  # noqa: E402

GOALS = {"force_rms_percent_of_peak": 5.0, "residual_approach_error_percent": 10.0,
         "sigma_c_error_percent_noise_free": 5.0}


def fit(path: Path, truth: dict, bootstrap: int, cache: Path, identify: str = "fe"):
    m = truth["material"]
    return fit_test(read_test(path), truth["setup"], truth["radius_m"],
                    machine_stiffness=truth["machine_stiffness_N_per_m"],
                    poissons_ratio=m["poissons_ratio"], friction_angle=m["friction_angle_deg"],
                    bootstrap_samples=bootstrap, cache_dir=cache, identify=identify)


def realizations(path: Path, truth: dict, clean, *, samples: int,
                 channels: str = "force,displacement", boot: bool = True) -> dict:
    """Does the bootstrap's standard error describe the scatter over the noise? The noise-free
    record re-noised ``samples`` times with the generator's noise model (independent
    realizations), each fitted with the noise-free fit's master curve (or, in the universal
    mode, identified again with the universal law); beside it, the bootstrap standard error of
    one realization."""
    from make_synthetic_lab_tests import DISPLACEMENT_NOISE, FORCE_NOISE, FORCE_TARE

    from geocontact.labtest.curve import Record
    from geocontact.labtest.fit import bootstrap, refit

    m = truth["material"]
    rec = read_test(path)
    peak, span = float(rec.force.max()), float(np.ptp(rec.displacement))
    rng = np.random.default_rng(2024)
    options = dict(machine_stiffness=truth["machine_stiffness_N_per_m"],
                   poissons_ratio=m["poissons_ratio"], friction_angle=m["friction_angle_deg"])
    rows, first = [], None
    for _ in range(samples):
        # both draws always, so each channel's noise is the same whichever channels are on
        dn = rng.normal(0, DISPLACEMENT_NOISE * span, rec.force.size)
        fn = rng.normal(0, FORCE_NOISE * peak, rec.force.size)
        noisy = Record(rec.displacement + (dn if "displacement" in channels else 0.0),
                       rec.force + FORCE_TARE * peak + (fn if "force" in channels else 0.0),
                       rec.time, "realization", {})
        fit = refit(noisy, clean, truth["setup"], truth["radius_m"], None, **options)
        first = first or (noisy, fit)
        rows.append((fit.params.material.compressive_yield_stress,
                     fit.params.material.youngs_modulus, fit.params.yield_force))
    sig, mod, fy = (np.array(v) for v in zip(*rows, strict=True))
    boot = bootstrap(first[0], first[1], truth["setup"], truth["radius_m"], samples=samples,
                     seed=7, **options)["relative_standard_errors"] if boot else None
    if boot is None:
        return {"samples": samples, "noise_on": channels,
                "scatter_relative": {"compressive_yield_stress": float(np.std(sig)
                                                                       / np.mean(sig)),
                                     "youngs_modulus": float(np.std(mod) / np.mean(mod))},
                "bias_percent": {"compressive_yield_stress": float(
                    100 * (np.mean(sig) / m["compressive_yield_stress"] - 1)),
                    "youngs_modulus": float(100 * (np.mean(mod) / m["youngs_modulus"] - 1))}}
    return {"samples": samples,
            "scatter_relative": {"compressive_yield_stress": float(np.std(sig) / np.mean(sig)),
                                 "youngs_modulus": float(np.std(mod) / np.mean(mod)),
                                 "yield_force": float(np.std(fy) / np.mean(fy))},
            "bias_percent": {"compressive_yield_stress": float(
                100 * (np.mean(sig) / m["compressive_yield_stress"] - 1)),
                "youngs_modulus": float(100 * (np.mean(mod) / m["youngs_modulus"] - 1))},
            "bootstrap_relative_of_one": {
                "compressive_yield_stress": boot["compressive_yield_stress_Pa"],
                "youngs_modulus": boot["youngs_modulus_Pa"],
                "yield_force": boot["yield_force_N"]}}


def verify(name: str, bootstrap: int, cache: Path, tests: Path,
           realization_count: int = 12, identify: str = "fe") -> dict:
    truth = json.loads((tests / f"{name}.truth.json").read_text())
    started = time.perf_counter()
    noisy = fit(tests / f"{name}.csv", truth, bootstrap, cache, identify)
    job = check_job(TESTS[name])
    result = run_campaign([job], cache, workers=1, progress=False)[0]
    c = compare(noisy.params, job, result, name=f"{name}-check", kind="held-out",
                description="a different FE history of the same grain")
    clean = fit(tests / f"{name}.clean.csv", truth, 0, cache, identify)
    m = truth["material"]
    se = noisy.bootstrap.get("standard_errors", {}) if noisy.bootstrap else {}

    def err(value, true):
        return 100.0 * (value / true - 1.0)

    row = {
        "test": name,
        "identify": identify,
        "setup": truth["setup"],
        "true_material": m,
        "check_history_N": list(job.forces),
        "force_rms_percent_of_peak": c.force_rms_percent,
        "force_max_percent_of_peak": c.force_max_percent,
        "residual_approach_error_percent": c.residual_error_percent,
        "residuals": c.residuals,
        "noisy": {
            "youngs_modulus_error_percent": err(noisy.params.material.youngs_modulus,
                                                m["youngs_modulus"]),
            "sigma_c_error_percent": err(noisy.params.material.compressive_yield_stress,
                                         m["compressive_yield_stress"]),
            "yield_force_over_fe": noisy.params.yield_force / truth["fe_first_yield_force_N"],
            "standard_errors": se,
            "sigma_c_range_over_true": [
                v / m["compressive_yield_stress"] for v in noisy.identification.get(
                    "sigma_c_modulus_valley", {}).get("sigma_c_range_Pa", [])],
            "bootstrap_samples": bootstrap,
        },
        "noise_free": {
            "youngs_modulus_error_percent": err(clean.params.material.youngs_modulus,
                                                m["youngs_modulus"]),
            "sigma_c_error_percent": err(clean.params.material.compressive_yield_stress,
                                         m["compressive_yield_stress"]),
            "yield_force_over_fe": clean.params.yield_force / truth["fe_first_yield_force_N"],
            "first_estimate_sigma_c_error_percent": err(
                clean.identification["first_estimate"]["compressive_yield_stress_Pa"],
                m["compressive_yield_stress"]),
        },
        "wall_time_s": time.perf_counter() - started,
    }
    row["noise_realizations"] = realizations(tests / f"{name}.clean.csv", truth, clean,
                                             samples=realization_count)
    row["meets"] = {
        "force": row["force_rms_percent_of_peak"] <= GOALS["force_rms_percent_of_peak"],
        "residual": (row["residual_approach_error_percent"] or 0.0)
        <= GOALS["residual_approach_error_percent"],
        "sigma_c_noise_free": abs(row["noise_free"]["sigma_c_error_percent"])
        <= GOALS["sigma_c_error_percent_noise_free"],
    }
    return row


def _committed_master(name: str) -> dict:
    """The FE master curve a test's identification ended on (tests/data/labtest)."""
    from make_synthetic_lab_tests import MASTERS

    from geocontact.labtest.identify import read_master

    return read_master(MASTERS / f"{name}.master.json")


def _committed_check(name: str):
    """The grain's check-history FE run committed in tests/data/labtest, as
    calibrate.acceptance.compare reads a job and its run."""
    from types import SimpleNamespace

    from make_synthetic_lab_tests import CHECK_CURVES

    data = json.loads(CHECK_CURVES[name].read_text())
    return (SimpleNamespace(forces=tuple(data["forces_N"]), identity=lambda: None),
            SimpleNamespace(curve=data["curve"], summary=data["summary"]))


def verify_committed(name: str, tests: Path, realization_count: int,
                     channels: bool) -> dict:
    """Items 1-3 of the module docstring with the committed master curve and check-history
    run (no FE run, no bootstrap): the noisy fit along the check history, the noise-free E and
    sigma_c, and the realizations' bias and scatter (with --channels, also with the noise on one
    channel at a time)."""
    from geocontact.labtest.fit import fit_once

    truth = json.loads((tests / f"{name}.truth.json").read_text())
    m = truth["material"]
    grain = "platens-quartzite" if name in SHAPES else name  # SHAPES: the quartzite's
    master = _committed_master(grain)

    def fit_of(record):
        return fit_once(read_test(tests / f"{record}.csv"), truth["setup"], m["radius"],
                        machine_stiffness=truth["machine_stiffness_N_per_m"],
                        poissons_ratio=m["poissons_ratio"],
                        friction_angle=m["friction_angle_deg"], master=master)

    def errors(fit):
        return {"youngs_modulus_error_percent": 100.0 * (
            fit.params.material.youngs_modulus / m["youngs_modulus"] - 1.0),
            "sigma_c_error_percent": 100.0 * (fit.params.material.compressive_yield_stress
                                              / m["compressive_yield_stress"] - 1.0),
            "contact_choice": fit.contact.get("choice", {}).get("chosen", "only one")}

    noisy, clean = fit_of(name), fit_of(f"{name}.clean")
    job, run = _committed_check(grain)
    c = compare(noisy.params, job, run, name=f"{name}-check", kind="held-out",
                description="a different FE history of the same grain")
    row = {"test": name, "master": "committed (tests/data/labtest)",
           "force_rms_percent_of_peak": c.force_rms_percent,
           "force_max_percent_of_peak": c.force_max_percent,
           "residual_approach_error_percent": c.residual_error_percent,
           "noisy": errors(noisy), "noise_free": errors(clean)}
    dy, pair = truth["fe_first_yield_approach_m"], 2.0 if truth["setup"] == "flat" else 1.0
    for key, fit, at in (("noisy", noisy, "contact_displacement_m"),
                         ("noise_free", clean, "clean_contact_displacement_m")):
        if at in truth:
            row[key]["contact_error_over_yield_approach"] = pair * (
                fit.contact["contact_displacement_m"] - truth[at]) / dy
    sets = ["force,displacement"] + (["force", "displacement"] if channels else [])
    row["noise_realizations"] = [
        realizations(tests / f"{name}.clean.csv", truth, clean, samples=realization_count,
                     channels=on, boot=False) for on in sets]
    row["meets"] = {
        "force": row["force_rms_percent_of_peak"] <= GOALS["force_rms_percent_of_peak"],
        "residual": (row["residual_approach_error_percent"] or 0.0)
        <= GOALS["residual_approach_error_percent"],
        "sigma_c_noise_free": abs(row["noise_free"]["sigma_c_error_percent"])
        <= GOALS["sigma_c_error_percent_noise_free"]}
    return row


def write_acceptance(rows: list[dict], out) -> dict:
    """The acceptance document of ``rows`` (each with its goals' ``meets``), written to ``out``."""
    document = {"goals": GOALS, "tests": rows,
                "all_met": all(all(r["meets"].values()) for r in rows)}
    write_json_atomic(out, document)
    return document


def verdict(document: dict, out) -> int:
    """The last line, and the exit code: 0 when every goal of every test is met."""
    print("all goals met" if document["all_met"] else "goals NOT all met", f"({out})")
    return 0 if document["all_met"] else 1


def committed(args) -> int:
    names = list(SHAPES) if args.shapes else [n for n in TESTS if n not in SHAPES]
    rows = [verify_committed(n, Path(args.tests), args.realizations, args.channels)
            for n in names]
    document = write_acceptance(rows, args.out)
    for r in rows:
        print(f"{r['test']:20s} check history: force RMS {r['force_rms_percent_of_peak']:.2f} % "
              f"(max {r['force_max_percent_of_peak']:.1f} %), residual "
              f"{r['residual_approach_error_percent']:.1f} %; noisy: E "
              f"{r['noisy']['youngs_modulus_error_percent']:+.1f} %, sigma_c "
              f"{r['noisy']['sigma_c_error_percent']:+.1f} %; noise-free: E "
              f"{r['noise_free']['youngs_modulus_error_percent']:+.1f} %, sigma_c "
              f"{r['noise_free']['sigma_c_error_percent']:+.1f} %")
        for z in r["noise_realizations"]:
            print(f"{'':20s} {z['samples']} realizations, noise on {z['noise_on']}: sigma_c "
                  f"{z['bias_percent']['compressive_yield_stress']:+.1f} % (scatter "
                  f"{100 * z['scatter_relative']['compressive_yield_stress']:.1f} %), E "
                  f"{z['bias_percent']['youngs_modulus']:+.1f} % (scatter "
                  f"{100 * z['scatter_relative']['youngs_modulus']:.1f} %)")
    return verdict(document, args.out)


def verify_shape(name: str, cache: Path, tests: Path) -> dict:
    """A record of SHAPES (issue 37): the contact point against the generator's, the fit with
    the quartzite test's committed master curve (no identification run), the law along the
    record and along the check history (the acceptance of docs/fit.md)."""
    from geocontact.cli.fit_output import law_along, path_rms_percent
    from geocontact.labtest.fit import fit_once

    truth = json.loads((tests / f"{name}.truth.json").read_text())
    m = truth["material"]
    started = time.perf_counter()
    fit = fit_once(read_test(tests / f"{name}.csv"), truth["setup"], m["radius"],
                   machine_stiffness=truth["machine_stiffness_N_per_m"],
                   poissons_ratio=m["poissons_ratio"], friction_angle=m["friction_angle_deg"],
                   master=_committed_master("platens-quartzite"))
    seconds = time.perf_counter() - started
    test = fit.test
    pair = 2.0 if truth["setup"] == "flat" else 1.0  # approach of the set-up's displacement
    contact = test.contact
    error = pair * (contact["contact_displacement_m"] - truth["contact_displacement_m"])
    smooth, law = law_along(fit.params, test.approach)
    job = check_job(TESTS[name])
    result = run_campaign([job], cache, workers=1, progress=False)[0]
    c = compare(fit.params, job, result, name=f"{name}-check", kind="held-out",
                description="a different FE history of the same grain")
    dy = truth["fe_first_yield_approach_m"]
    row = {
        "test": name, "setup": truth["setup"], "fit_seconds": seconds,
        "contact_error_m": error, "contact_error_over_yield_approach": error / dy,
        "contact_standard_error_over_yield_approach": pair * contact[
            "contact_displacement_se_m"] / dy,
        "first_peak_approach_over_yield_approach": truth["fe_cycles"][0]["max_approach_m"] / dy,
        "cycles_found": len(fit.levels), "cycles": len(truth["peaks_over_yield"]),
        "record_force_rms_percent_of_peak": path_rms_percent(smooth, law - test.force,
                                                             test.peak_force),
        "force_rms_percent_of_peak": c.force_rms_percent,
        "force_max_percent_of_peak": c.force_max_percent,
        "residual_approach_error_percent": c.residual_error_percent,
        "youngs_modulus_error_percent": 100.0 * (fit.params.material.youngs_modulus
                                                 / m["youngs_modulus"] - 1.0),
        "sigma_c_error_percent": 100.0 * (fit.params.material.compressive_yield_stress
                                          / m["compressive_yield_stress"] - 1.0),
    }
    row["meets"] = {
        "force": row["force_rms_percent_of_peak"] <= GOALS["force_rms_percent_of_peak"],
        "residual": (row["residual_approach_error_percent"] or 0.0)
        <= GOALS["residual_approach_error_percent"],
        "cycles": row["cycles_found"] == row["cycles"]}
    return row


def shapes(args) -> int:
    from make_synthetic_lab_tests import SHAPES

    rows = [verify_shape(n, Path(args.cache), Path(args.tests)) for n in SHAPES]
    document = write_acceptance(rows, args.out)
    for r in rows:
        print(f"{r['test']:20s} contact {r['contact_error_over_yield_approach']:+.2f} dy (se "
              f"{r['contact_standard_error_over_yield_approach']:.2f} dy), "
              f"{r['cycles_found']}/{r['cycles']} cycles, record RMS "
              f"{r['record_force_rms_percent_of_peak']:.2f} %; check history: force RMS "
              f"{r['force_rms_percent_of_peak']:.2f} % (max {r['force_max_percent_of_peak']:.1f}"
              f" %), residual {r['residual_approach_error_percent']:.1f} %; E "
              f"{r['youngs_modulus_error_percent']:+.1f} %, sigma_c "
              f"{r['sigma_c_error_percent']:+.1f} % ({r['fit_seconds']:.0f} s)")
    return verdict(document, args.out)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--bootstrap", type=int, default=30)
    parser.add_argument("--cache", default=str(DEFAULT_CACHE))
    parser.add_argument("--tests", default=str(OUT))
    parser.add_argument("--out", default=None,
                        help="default out/verify_lab_fit.json (out/verify_lab_fit-universal"
                             ".json with --identify universal)")
    parser.add_argument("--identify", choices=("fe", "universal"), default="fe",
                        help="the identification to verify (geocontact fit --identify)")
    parser.add_argument("--realizations", type=int, default=12,
                        help="independent noise realizations of each test (bootstrap check)")
    parser.add_argument("--shapes", action="store_true",
                        help="the records of SHAPES (issue 37: small first cycle, long "
                             "approach, sparse first loading) with the committed master curve")
    parser.add_argument("--committed", action="store_true",
                        help="no FE run: the committed master curves and check-history runs "
                             "(tests/data/labtest), realizations without the bootstrap")
    parser.add_argument("--channels", action="store_true",
                        help="with --committed: realizations with the noise on one channel "
                             "at a time too")
    args = parser.parse_args(argv)
    if args.committed:
        args.out = args.out or ("out/verify_lab_fit-committed"
                                + ("-shapes" if args.shapes else "") + ".json")
        return run_reporting_errors(lambda: committed(args))
    args.out = args.out or ("out/verify_lab_fit-shapes.json" if args.shapes else
                            "out/verify_lab_fit.json" if args.identify == "fe"
                            else f"out/verify_lab_fit-{args.identify}.json")
    if args.shapes:
        return run_reporting_errors(lambda: shapes(args))

    def run():
        rows = [verify(n, args.bootstrap, Path(args.cache), Path(args.tests), args.realizations,
                       args.identify) for n in TESTS if n not in SHAPES]
        document = write_acceptance(rows, args.out)
        for r in rows:
            print(f"{r['test']:20s} check history: force RMS {r['force_rms_percent_of_peak']:.2f}"
                  f" % of peak, residual {r['residual_approach_error_percent']:.1f} %; noisy: "
                  f"E {r['noisy']['youngs_modulus_error_percent']:+.1f} %, sigma_c "
                  f"{r['noisy']['sigma_c_error_percent']:+.1f} %; noise-free: E "
                  f"{r['noise_free']['youngs_modulus_error_percent']:+.1f} %, sigma_c "
                  f"{r['noise_free']['sigma_c_error_percent']:+.1f} %")
            z = r["noise_realizations"]
            print(f"{'':20s} over {z['samples']} noise realizations: sigma_c scatter "
                  f"{100 * z['scatter_relative']['compressive_yield_stress']:.1f} % (bootstrap "
                  f"of one: {100 * z['bootstrap_relative_of_one']['compressive_yield_stress']:.1f}"
                  f" %), E scatter {100 * z['scatter_relative']['youngs_modulus']:.1f} % "
                  f"(bootstrap {100 * z['bootstrap_relative_of_one']['youngs_modulus']:.1f} %), "
                  f"sigma_c bias {z['bias_percent']['compressive_yield_stress']:+.1f} %")
        return verdict(document, args.out)

    return run_reporting_errors(run)


if __name__ == "__main__":
    sys.exit(main())
