"""``geocontact demo``: the main job on the built-in reference case.

What exists so far runs end to end: analytic incipient yield of the reference grains
(sigma_c = 10 and 1 MPa), the hysteretic law with the illustrative parameters (clearly labelled:
not yet an FE calibration) — loading/unloading/reloading curves, residual approach and plastic
work against plastic depth — and the paper's three force histories driven through the law.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

from .hertz import incipient_yield
from .histories import drive_by_force, preset_history
from .io import atomic_directory, provenance, write_json_atomic
from .law import Contact
from .law.illustrative import illustrative_params
from .material import preset
from .report import Figure, Report, save_figure, table, write_html

CASES = (("reference", "σc = 10 MPa"), ("reference-weak", "σc = 1 MPa"))


def _law_cycles(params, depths):
    """Load to each depth (in delta_y), unload to apart, reload past the peak."""
    dy = params.yield_approach
    curves = []
    for depth in depths:
        c = Contact(params)
        dmax = depth * dy
        up = np.linspace(0, dmax, 200)
        fu = [c.update(d)[0] for d in up]
        dres = c.state.residual_approach
        down = np.linspace(dmax, dres, 200)
        fd = [c.update(d)[0] for d in down]
        again = np.linspace(dres, 1.2 * dmax, 200)
        fr = [c.update(d)[0] for d in again]
        curves.append((depth, up, fu, down, fd, again, fr))
    return curves


def _seismic_section(report: Report, params, work: Path, progress) -> dict:
    """Kobe 1995 (FEMA P695, shipped offline) scaled to 3 m/s^2 under a column of 5 grains,
    an aftershock after it: the paper's three kinds of figures, with the contact response."""
    from .seismic.analysis import EventSpec, Settings, run_seismic, write_outputs

    settings = Settings.from_defaults()
    result = run_seismic(params, EventSpec("KOBE/NIS000", settings.target_pga),
                         [EventSpec("KOBE/NIS090", 0.5 * settings.target_pga)], settings,
                         params_source="illustrative (reference case)",
                         progress=lambda m: progress(f"seismic: {m}"))
    summary = write_outputs(result, work / "seismic")
    main = summary["events"][0] if "events" in summary else {}
    report.add(
        "Seismic loading: Kobe 1995 and an aftershock",
        "<p>Record KOBE/NIS000 (Nishi-Akashi) scaled to a peak of 3 m/s², then KOBE/NIS090 at "
        "1.5 m/s² as an aftershock, shaking the base of a column of identical grains "
        "(<code>geocontact seismic</code>; data in <code>seismic/</code>).</p>",
        Figure("record", "The scaled records", "Dashed: time of the peak (the paper's rule).",
               image="seismic/record.png", data_file="seismic/records.csv"),
        Figure("force_history", "Contact forces", "Every contact of the column.",
               image="seismic/force_history.png", data_file="seismic/history.csv"),
        Figure("loops", "Force–approach loops", "From the static state through both events.",
               image="seismic/loops.png", data_file="seismic/history.csv"),
    )
    return {"main_shock": main, "contacts": summary.get("contacts")}


def run_demo(out: str | Path, progress=print) -> Path:
    """Write the demo's run directory atomically; returns the report's path."""
    out = Path(out)
    with atomic_directory(out) as work:
        _write_demo(work, out, progress)
    return out / "report.html"


def _write_demo(work: Path, out: Path, progress) -> None:
    summary: dict = {"cases": {}}
    report = Report(
        title="geocontact — reference case",
        intro=("Two identical sandstone-like spheres (E = 10 GPa, ν = 0.25, β = 30°, m = 0, "
               "R = 0.1 m). Incipient yield is analytic (Hertz field + Drucker–Prager). The law "
               "uses <b>illustrative parameters</b> (published forms, plausible values) until "
               "the FE calibration lands; curves are the law's, not FE results."),
        provenance=provenance("demo", {"out": str(out)}),
    )
    rows = []
    for name, label in CASES:
        material = preset(name)
        y = incipient_yield(material)
        summary["cases"][name] = {"material": material.to_dict(), "yield": y.to_dict()}
        rows.append([label, y.force, y.approach * 1e6, y.contact_radius * 1e3,
                     y.peak_pressure / 1e6, y.r_over_a, y.z_over_a])
    progress("incipient yield: done")
    report.add("Incipient yield (analytic)", table(
        ["case", "Fy (N)", "δy (µm)", "ay (mm)", "p0 (MPa)", "r/a", "z/a"], rows))

    params = illustrative_params(preset("reference"))
    dy, fy = params.yield_approach, params.yield_force
    curves = _law_cycles(params, [1.0, 5.0, 20.0, 80.0, 200.0])
    fig, ax = plt.subplots(figsize=(6, 4.2))
    data = {}
    for depth, up, fu, down, fd, again, fr in curves:
        line, = ax.plot(up / dy, np.array(fu) / fy, lw=1.4, label=f"δmax = {depth:g} δy")
        ax.plot(down / dy, np.array(fd) / fy, "--", color=line.get_color(), lw=1)
        ax.plot(again / dy, np.array(fr) / fy, ":", color=line.get_color(), lw=1)
        data[f"approach_over_dy_{depth:g}"] = np.concatenate([up, down, again]) / dy
        data[f"force_over_fy_{depth:g}"] = np.concatenate([fu, fd, fr]) / fy
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlim(0.1, 300)
    ax.set_ylim(1e-2, None)
    ax.set_xlabel("δ / δy")
    ax.set_ylabel("F / Fy")
    ax.legend(fontsize=8)
    fig1 = Figure("law_cycles", "Loading (solid), unloading (dashed), reloading (dotted)",
                  "The law from several peak depths; reloading rejoins the virgin curve.", data)
    save_figure(fig, work, fig1)

    x = np.geomspace(1, 1000, 200)
    dmax = x * dy
    law_wp = params.envelope_plastic_work(dmax) / params.virgin_work(dmax)
    fig, ax = plt.subplots(figsize=(6, 4))
    ax.semilogx(x, params.residual_ratio(x), label="δres / δmax")
    ax.semilogx(x, law_wp, label="Wp / Wtotal (law's loop area)")
    ax.semilogx(x, params.plastic_work_ratio(x), "--", label="Wp / Wtotal (fitted form)")
    ax.set_xlabel("δmax / δy")
    ax.legend()
    fig2 = Figure("residual_and_work", "Residual approach and plastic work against depth",
                  "The law's own loop area beside the plastic-work form (SPEC §6).",
                  {"depth": x, "residual_ratio": params.residual_ratio(x),
                   "plastic_work_ratio_law": law_wp,
                   "plastic_work_ratio_form": params.plastic_work_ratio(x)})
    save_figure(fig, work, fig2)
    progress("law curves: done")

    hist_figs = []
    summary["histories"] = {}
    for name, label in CASES:
        p = illustrative_params(preset(name))
        fig, axes = plt.subplots(1, 3, figsize=(12, 3.6))
        data = {}
        for ax, hist in zip(axes, ("repeated", "mono-decreasing", "mono-increasing"),
                            strict=True):
            run = drive_by_force(p, preset_history(hist, 3000.0), points=40)
            ax.plot(run.approach * 1e3, run.force, lw=1)
            ax.set_title(hist, fontsize=10)
            ax.set_xlabel("approach (mm)")
            data[f"{hist}_approach_m"] = run.approach
            data[f"{hist}_force_N"] = run.force
            summary["histories"][f"{name}/{hist}"] = run.cycles
        axes[0].set_ylabel("force (N)")
        f = Figure(f"histories_{name}", f"The paper's load histories through the law, {label}",
                   "Repeated (10 × 3000 N), monotonically decreasing (3000 → 100 N) and "
                   "increasing (100 → 3000 N). Without the cyclic extension repeated cycles "
                   "are closed loops after the first.", data)
        save_figure(fig, work, f)
        hist_figs.append(f)
        progress(f"histories {label}: done")
    report.add("The hysteretic law (illustrative parameters)", fig1, fig2)
    report.add("Load histories of the paper", *hist_figs)
    summary["seismic"] = _seismic_section(report, params, work, progress)
    write_json_atomic(work / "summary.json", {**summary, "provenance": report.provenance})
    write_html(report, work)
