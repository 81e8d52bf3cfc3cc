"""``geocontact demo``: the main job on the built-in reference case, end to end.

1. analytic incipient yield of the reference grains (sigma_c = 10 and 1 MPa);
2. the FE calibration of the law (coarse mesh, a reduced set of peak loads) with its held-out
   acceptance runs -> ``calibration/P.json``;
3. the FE reference cycle 0 -> 6000 N -> 0 on the default mesh (fields for ParaView);
4. the paper's repeated history through the FE and the calibrated law, shakedown analysis, and
   a subset of the paper's loading-history study with its findings table (coarse mesh);
5. the material sweeps of E, beta, sigma_c, m at 6000 N (coarse);
6. the paper's three load histories through the calibrated law;
7. a seismic record (Kobe 1995) with an aftershock through the calibrated law;
8. a small DEM oedometer in LAMMPS (``geocontact dem``: 2000 grains, three repeated cycles, the
   calibrated law beside its grain's elastic law through the same pair style and LAMMPS's
   granular Hertz-Mindlin, all damped to one restitution; needs ``make plugin``);
9. a small cyclic simple shear in LAMMPS (``geocontact dem cyclic-shear``: G/Gmax and D of the
   calibrated law, its cyclic extension off, beside its grain's elastic law, against Darendeli's
   curves; the study of docs/sample-study.md on one small sample);
10. ``geocontact report`` of the whole directory -> ``report.html``.

Every FE run goes through the cached campaign (``fem.campaign``) or, for the reference cycle and
the cyclic history (which keep their ParaView fields), is carried over from the previous demo in
``out`` when its identity (``fem.reuse``) is unchanged, so a second demo is fast.
``quick=True`` is the same job on tiny loads and few steps (the test suite's end-to-end check).
"""

from __future__ import annotations

import json
import shutil
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import matplotlib.pyplot as plt

from ..analyses.force_driven import drive_by_force
from ..fem.campaign import DEFAULT_CACHE
from ..files import (
    Output,
    atomic_directory,
    check_output_folder,
    claim,
    provenance,
    write_json_atomic,
)
from ..grain.force_history import preset_history
from ..grain.hertz import incipient_yield
from ..grain.material import preset
from ..report import Figure, save_figure, table
from .common import add_force_flag, print_json

CASES = (("reference", "σc = 10 MPa"), ("reference-weak", "σc = 1 MPa"))


@dataclass(frozen=True)
class Plan:
    """How much FE work the demo does."""

    calibration_levels: int = 5
    calibration_max_force: float = 6000.0
    calibration_mesh: str = "coarse"
    steps: int | None = None  # FE load steps per segment (None: the mesh preset's)
    reference_force: float = 6000.0
    reference_mesh: str = "default"
    cyclic_peak: float = 3000.0
    cyclic_count: int = 10
    cyclic_mesh: str = "coarse"
    # runs of data/paper-histories.toml for the findings table (sigma_c = 10 MPa and the von
    # Mises grain; the 1 MPa runs are the longest and are left to geocontact study paper-histories)
    paper_runs: tuple[str, ...] = ("repeated-10MPa", "mono-decreasing-10MPa",
                                   "mono-increasing-10MPa", "repeated-von-mises-10MPa")
    sweeps: tuple[str, ...] = ("E", "beta", "sigma_c", "m")
    sweep_force: float | None = None  # None: the sweeps file's (6000 N)
    sweep_mesh: str = "coarse"
    # the DEM oedometer (examples/lammps/in.oedometer): grains, inertia number of the cycles,
    # target stress ratios (peak, valley, ...)
    dem_grains: int = 2000
    dem_inertia: float = 3e-3
    dem_targets: tuple[float, ...] = (1.5, 0.5, 1.5, 0.5, 1.5, 0.5)
    # the cyclic simple shear (examples/lammps/in.cyclicshear): one sample at 100 kPa
    shear_grains: int = 300
    shear_amplitudes: tuple[float, ...] = (1e-6, 1e-5, 1e-4, 1e-3)
    shear_cycles: int = 2


FULL = Plan()
QUICK = Plan(calibration_levels=3, calibration_max_force=300.0, steps=4, reference_force=100.0,
             reference_mesh="coarse", cyclic_peak=100.0, cyclic_count=3, paper_runs=(),
             sweeps=("m",),
             sweep_force=60.0, dem_grains=300, dem_inertia=1e-2, dem_targets=(1.5, 0.5),
             shear_grains=100, shear_amplitudes=(1e-6, 1e-5))


def run_demo(out: str | Path, progress=print, *, quick: bool = False,
             cache_dir: str | Path = DEFAULT_CACHE, overwrite: bool = False) -> Path:
    """Write the demo's run directory atomically (an existing ``out`` only if it is a demo
    result of ours, unless ``overwrite``); returns the report's path."""
    out = Path(out)
    plan = QUICK if quick else FULL
    with atomic_directory(out, "demo", overwrite=overwrite,
                          inputs={"quick": quick, "cache": str(cache_dir)}) as work:
        _write_demo(work, out, plan, Path(cache_dir), progress)
    return out / "report.html"


def _write_demo(work: Path, out: Path, plan: Plan, cache: Path, progress) -> None:
    from ..analyses.cycles import run_cycles
    from ..analyses.sweeps import run_sweeps
    from ..calibrate.workflow import calibrate_to_file
    from ..fem.run import run_history
    from ..report import build_report

    started = time.perf_counter()
    timings: dict[str, float] = {}

    def done(step: str) -> None:
        timings[step] = time.perf_counter() - started - sum(timings.values())
        progress(f"demo: {step} done ({timings[step]:.0f} s)")

    summary: dict = {"plan": plan.__dict__, "cases": {}}
    material = preset("reference")
    rows = []
    for name, label in CASES:
        m = preset(name)
        y = incipient_yield(m)
        summary["cases"][name] = {"material": m.to_dict(), "yield": y.to_dict()}
        rows.append([label, y.force, y.approach * 1e6, y.contact_radius * 1e3,
                     y.peak_pressure / 1e6, y.r_over_a, y.z_over_a])
    preface = [("Incipient yield (analytic)", [table(
        ["case", "Fy (N)", "δy (µm)", "ay (mm)", "p0 (MPa)", "r/a", "z/a"], rows)])]
    done("incipient yield")

    campaign = dict(mesh=plan.calibration_mesh, steps_per_segment=plan.steps, cache_dir=cache,
                    progress=True)
    params, runs, acceptance = calibrate_to_file(
        material, work / "calibration" / "P.json",
        {"material": "reference", "levels": plan.calibration_levels,
         "max_force": plan.calibration_max_force, "mesh": plan.calibration_mesh,
         "steps": plan.steps, "source": "geocontact demo"},
        levels=plan.calibration_levels, max_force=plan.calibration_max_force, acceptance=True,
        **campaign)
    summary["calibration"] = {"levels": len(runs), "fit_errors": params.fit_errors,
                              "held_out_all_met": acceptance["held_out_all_met"]}
    done("calibration")

    _carry_over(out / "fe-reference", work / "fe-reference")
    reference = run_history(material, [0.0, plan.reference_force, 0.0],
                            mesh=plan.reference_mesh, out=work / "fe-reference",
                            steps_per_segment=plan.steps, resume=True,
                            overwrite=True)  # ``work`` is the demo's own new folder
    summary["fe_reference"] = {k: reference.summary[k] for k in
                               ("first_yield_force_N", "fully_plastic_force_N", "cycles",
                                "wall_time_s")}
    done("FE reference cycle")

    preface.append(("The instant route: the universal law beside the FE calibration",
                    _universal_beside_calibration(material, params, reference, plan,
                                                  work / "calibration", summary)))
    done("universal law")

    forces = preset_history("repeated", plan.cyclic_peak)
    forces = forces[: 2 * plan.cyclic_count + 1]
    _carry_over(out / "cycles-repeated", work / "cycles-repeated")
    cyc = run_cycles(material, forces, work / "cycles-repeated", params=params,
                     mesh=plan.cyclic_mesh, steps_per_segment=plan.steps, resume=True,
                     overwrite=True,
                     inputs={"history": "repeated", "peak_force_N": plan.cyclic_peak})
    summary["cycles_repeated"] = {k: v.get("classification") for k, v in
                                  cyc["analyses"].items()}
    done("cyclic history")

    if plan.paper_runs:
        summary["paper_findings"] = _paper_findings(work / "paper-histories", plan, cache)
        done("paper's loading histories")

    run_sweeps(work / "sweeps", list(plan.sweeps), mesh=plan.sweep_mesh,
               peak_force=plan.sweep_force, cache_dir=cache, steps_per_segment=plan.steps)
    done("material sweeps")

    preface.append(("Load histories of the paper through the calibrated law",
                    _law_histories(params, work / "histories", summary)))
    done("law histories")

    summary["seismic"] = _seismic(params, work / "seismic", progress)
    done("seismic")

    _dem(work / "calibration" / "P.json", work / "dem-oedometer", plan, progress)
    done("DEM oedometer")

    summary["dem_cyclic_shear"] = _shear(work / "calibration" / "P.json",
                                         work / "dem-cyclic-shear", plan, progress)
    done("DEM cyclic shear")

    summary["timings_s"] = timings
    write_json_atomic(work / "summary.json", {**summary, "provenance": provenance(
        "demo", {"out": str(out), "quick": plan is QUICK})})
    build_report(work, title="geocontact — reference case",
                 intro=("Two identical sandstone-like spheres (E = 10 GPa, ν = 0.25, σc = 10 "
                        "MPa, β = 30°, m = 0, R = 0.1 m): the FE virtual experiment, the law "
                        "calibrated from it (fit errors and held-out acceptance below), the "
                        "paper's loading histories and shakedown, the material sweeps and a "
                        "seismic record, and a DEM oedometer sample in LAMMPS. Every figure's "
                        "data is a CSV beside the report."
                        + (" <b>Quick mode: tiny loads and few FE steps (a test run), not the "
                           "reference results.</b>" if plan is QUICK else "")),
                 preface=preface)
    done("report")


def _universal_beside_calibration(material, calibrated, reference, plan: Plan,
                                  directory: Path, summary: dict) -> list:
    """``geocontact params`` for the reference grain (no FE run: the shipped campaign's
    universal law, docs/universal.md) written beside the FE calibration's P.json, and both laws
    driven along the FE reference cycle's approach path."""
    from ..calibrate.acceptance import compare
    from ..fem.campaign import FemJob
    from ..universal import for_material

    started = time.perf_counter()
    universal = for_material(material)
    seconds = time.perf_counter() - started
    universal.save(directory / "P-universal.json")
    job = FemJob(material, (0.0, plan.reference_force, 0.0), mesh=plan.reference_mesh,
                 steps_per_segment=plan.steps)
    rows, record = [], {"seconds": seconds,
                        "dataset_points": universal.provenance["universal"]["points"]}
    for name, law in (("FE calibration (calibration/P.json)", calibrated),
                      ("universal law (calibration/P-universal.json)", universal)):
        c = compare(law, job, reference, name=name, kind="held-out")
        residual = c.residual_error_percent
        rows.append([name, law.yield_force, law.fully_plastic_force, c.force_rms_percent,
                     "n/a" if residual is None else residual])
        record[name.split(" (")[0]] = {"force_rms_percent": c.force_rms_percent,
                                       "residual_error_percent": residual}
    summary["universal_law"] = record
    note = (f"The universal law took {seconds:.2f} s and no FE run "
            f"({record['dataset_points']} campaign points shipped with the package); both laws "
            f"along the FE reference cycle 0 → {plan.reference_force:g} N → 0 "
            "(errors in % of the FE peak force and of the FE residual approach).")
    return [f"<p>{note}</p>", table(["law", "Fy (N)", "Fp (N)", "force RMS (%)",
                                     "residual error (%)"], rows)]


def _carry_over(previous: Path, target: Path) -> None:
    """Copy a run of the previous demo into the new one; ``run_history(resume=True)`` (or
    ``run_cycles(resume=True)`` for its FE run) then reuses it if its identity is this run's
    (fem.reuse) and runs it again if not."""
    if (previous / "summary.json").is_file():
        shutil.copytree(previous, target)


def _paper_findings(directory: Path, plan: Plan, cache: Path) -> dict:
    """A subset of the paper's loading-history study and its findings table."""
    from ..analyses.paper_histories import run_paper_histories, write_study

    runs = run_paper_histories(plan.cyclic_mesh, cache, steps_per_segment=plan.steps,
                               only=list(plan.paper_runs))
    findings, _ = write_study(directory, runs, provenance(
        "demo: paper histories", {"runs": list(runs), "mesh": plan.cyclic_mesh}))
    agree = sum(f["agrees"] is True for f in findings)
    judged = sum(f["agrees"] is not None for f in findings)
    return {"runs": list(runs), "agree": agree, "judged": judged, "rows": len(findings)}


def _law_histories(params, directory: Path, summary: dict) -> list:
    """The repeated, decreasing and increasing histories to 3000 N through the law."""
    fig, axes = plt.subplots(1, 3, figsize=(12, 3.6))
    data = {}
    summary["law_histories"] = {}
    for ax, hist in zip(axes, ("repeated", "mono-decreasing", "mono-increasing"), strict=True):
        run = drive_by_force(params, preset_history(hist, 3000.0), points=40)
        ax.plot(run.approach * 1e3, run.force, lw=1)
        ax.set_title(hist, fontsize=10)
        ax.set_xlabel("approach (mm)")
        data[f"{hist}_approach_m"] = run.approach
        data[f"{hist}_force_N"] = run.force
        summary["law_histories"][hist] = run.cycles
    axes[0].set_ylabel("force (N)")
    figure = Figure("law_histories", "The paper's load histories through the calibrated law",
                    "Repeated (10 × 3000 N), monotonically decreasing (3000 → 100 N) and "
                    "increasing (100 → 3000 N); σc = 10 MPa.", data)
    save_figure(fig, directory, figure)
    figure.image = f"{directory.name}/{figure.name}.png"
    figure.data_file = f"{directory.name}/{figure.name}.csv"
    return [figure]


def _seismic(params, directory: Path, progress) -> dict:
    """Kobe 1995 (FEMA P695, shipped offline) scaled to 3 m/s^2 under a column of grains, an
    aftershock after it (``geocontact seismic``)."""
    from ..analyses.seismic.analysis import EventSpec, Settings, run_seismic, write_outputs

    settings = Settings.from_defaults()
    result = run_seismic(params, EventSpec("KOBE/NIS000", settings.target_pga),
                         [EventSpec("KOBE/NIS090", 0.5 * settings.target_pga)], settings,
                         params_source="FE calibration of the demo (calibration/P.json)",
                         progress=lambda m: progress(f"seismic: {m}"))
    summary = write_outputs(result, directory)
    main = summary["events"][0] if "events" in summary else {}
    return {"main_shock": main, "contacts": summary.get("contacts")}


def _dem(law: Path, directory: Path, plan: Plan, progress) -> None:
    """A small oedometer sample in LAMMPS with the calibrated law, its grain's elastic law and
    granular Hertz (``geocontact dem oedometer --contact all``)."""
    from ..analyses.dem import CONTACTS, Settings, run_dem

    settings = Settings(grains=plan.dem_grains, inertia=plan.dem_inertia,
                        targets=plan.dem_targets)
    run_dem("oedometer", law, settings, contacts=CONTACTS, ranks=1, out=directory,
            progress=lambda m: progress(f"dem: {m}"))


def _shear(law: Path, directory: Path, plan: Plan, progress) -> dict:
    """A small cyclic simple shear (``geocontact dem cyclic-shear``) with the calibrated law,
    its cyclic extension off as in the study (docs/sample-study.md), beside its elastic law."""
    from ..analyses.dem_cyclic import CyclicSettings, run_cyclic_shear

    settings = CyclicSettings(grains=plan.shear_grains, amplitudes=plan.shear_amplitudes,
                              cycles=plan.shear_cycles, seeds=1, cyclic_extension="off")
    document = run_cyclic_shear(law, settings, out=directory,
                                progress=lambda m: progress(f"cyclic shear: {m}"))
    return {"runs": [{k: r.get(k) for k in ("run", "law", "Gmax_Pa")}
                     for r in document["runs"]]}


def register(sub) -> None:
    p = sub.add_parser("demo", help="run the main job on the reference case, write a report")
    p.add_argument("--out", default="out/demo", help="output directory (default out/demo)")
    p.add_argument("--quick", action="store_true",
                   help="tiny loads and few FE steps: checks the pipeline in about a minute, "
                   "not the reference results")
    p.add_argument("--cache", default="out/cache/fem", help="FE result cache directory")
    add_force_flag(p)
    p.add_argument("--json", action="store_true",
                   help="print the demo's summary.json (with the report's path) on stdout")
    p.set_defaults(run=run)


def run(args) -> int:
    check_output_folder(args.cache, "--cache")
    with claim([Output(args.out, "folder", "--out")], "demo", overwrite=args.force):
        path = run_demo(args.out, progress=lambda m: print(m, file=sys.stderr),
                        quick=args.quick, cache_dir=args.cache, overwrite=args.force)
    if args.json:
        summary = json.loads((Path(args.out) / "summary.json").read_text())
        print_json({"report": str(path), **summary})
    else:
        print(f"report: {path}")
    return 0
