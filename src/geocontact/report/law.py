"""Report section of a law parameter file: the law's curves, residual approach and plastic work
against depth with the FE points it was fitted to, and a calibration's acceptance."""

from __future__ import annotations

import json
from html import escape as html_escape
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

from ..errors import InputError
from ..figures import Figure
from .common import (
    LOG_FLOOR,
    LOG_POINTS,
    positive,
    save_to_figures,
    toward,
)
from .html import Report, table

# --- law parameters ------------------------------------------------------------------------------


def law_files(directory: Path) -> list[Path]:
    found = []
    for path in sorted(directory.glob("*.json")):
        try:
            if json.loads(path.read_text()).get("schema") == "geocontact.law/1":
                found.append(path)
        except (json.JSONDecodeError, AttributeError, UnicodeDecodeError):
            continue
    return found


# Log-axis figures start their curves this far below delta_y (the law is Hertz there) and
# sample every branch on a log grid, so slopes read off the figure are the law's own.


def law_curves(params, depths) -> list[tuple]:
    """Load to each depth (in delta_y), unload until apart, reload past the peak: every branch
    on a log grid (loading from ``LOG_FLOOR`` delta_y, unloading and reloading dense near the
    residual approach), so the curves are fit for log axes."""
    from ..law import Contact

    dy = params.yield_approach
    curves = []
    for depth in depths:
        c = Contact(params, beyond_range="ignore")  # figures of the curves, to any depth asked
        dmax = depth * dy
        up = np.geomspace(LOG_FLOOR * dy, dmax, LOG_POINTS)
        fu = np.array([c.update(d)[0] for d in up])
        dres = c.state.residual_approach
        floor = min(1e-4, LOG_FLOOR * dy / dmax)
        down = toward(dmax, dres, LOG_POINTS, floor)
        fd = np.array([c.update(d)[0] for d in down])
        c.update(dres)
        again = np.concatenate([toward(dmax, dres, LOG_POINTS, floor)[::-1],
                                np.geomspace(dmax, 1.2 * dmax, 40)[1:]])
        fr = np.array([c.update(d)[0] for d in again])
        curves.append((depth, up, fu, down, fd, again, fr))
    return curves


def law_section(report: Report, path: Path, root: Path, figures: Path) -> None:
    from ..law import load_params

    params = load_params(path)
    dy, fy = params.yield_approach, params.yield_force
    tag = path.relative_to(root).with_suffix("").as_posix().replace("/", "_")
    per_level = (params.fit_errors or {}).get("per_level", [])
    depth_max = max([lv["depth"] for lv in per_level], default=200.0)
    depths = [d for d in (1.0, 5.0, 20.0, 80.0, 200.0, 800.0) if d <= 1.05 * depth_max] or [5.0]
    fig, ax = plt.subplots(figsize=(6, 4.2))
    data = {}
    for depth, up, fu, down, fd, again, fr in law_curves(params, depths):
        color = None
        for branch, d, f, style in (("loading", up, fu, "-"), ("unloading", down, fd, "--"),
                                    ("reloading", again, fr, ":")):
            x, y = positive(d / dy, f / fy)
            line, = ax.plot(x, y, style, color=color, lw=1.4 if branch == "loading" else 1,
                            label=f"δmax = {depth:g} δy" if branch == "loading" else None)
            color = line.get_color()
            data[f"{branch}_approach_over_dy_{depth:g}"] = x
            data[f"{branch}_force_over_fy_{depth:g}"] = y
    ax.set_xscale("log")
    ax.set_yscale("log")
    # two decades of Hertz below yield (slope 3/2) under the elastic-plastic branches
    ax.set_xlim(1e-2, 1.5 * max(depths))
    ax.set_ylim(1e-3, None)
    ax.set_xlabel("δ / δy")
    ax.set_ylabel("F / Fy")
    ax.legend(fontsize=8)
    f1 = Figure(f"{tag}_cycles", "The law: loading (solid), unloading (dashed), reloading "
                "(dotted)", "From several peak depths; reloading rejoins the virgin curve. "
                "Every branch sampled on a log grid (loading from 0.001 δy: Hertz, slope 3/2, "
                "below yield); points at zero force are not drawn on the log axes.", data)
    save_to_figures(fig, figures, f1)

    x = np.geomspace(1, max(1000.0, 1.5 * depth_max), 200)
    law_wp = params.envelope_plastic_work(x * dy) / params.virgin_work(x * dy)
    fig, ax = plt.subplots(figsize=(6, 4))
    ax.semilogx(x, params.residual_ratio(x), label="δres / δmax (law)")
    ax.semilogx(x, law_wp, label="Wp / Wtotal (law's loop area)")
    ax.semilogx(x, params.plastic_work_ratio(x), "--", label="Wp / Wtotal (fitted form)")
    data = {"depth": x, "residual_ratio": params.residual_ratio(x),
            "plastic_work_ratio_law": law_wp,
            "plastic_work_ratio_form": params.plastic_work_ratio(x)}
    if per_level:
        d = np.array([lv["depth"] for lv in per_level])
        ax.semilogx(d, [lv["residual_ratio"] for lv in per_level], "o", label="δres / δmax (FE)")
        ax.semilogx(d, [lv["plastic_work_ratio"] for lv in per_level], "s",
                    label="Wp / Wtotal (FE)")
        data["fe_depth"] = d
        data["fe_residual_ratio"] = np.array([lv["residual_ratio"] for lv in per_level])
        data["fe_plastic_work_ratio"] = np.array([lv["plastic_work_ratio"] for lv in per_level])
    ax.set_xlabel("δmax / δy")
    ax.legend(fontsize=8)
    f2 = Figure(f"{tag}_residual_work", "Residual approach and plastic work against depth",
                "The law's forms" + (" against the FE levels they were fitted to." if per_level
                                     else " (no FE levels recorded in this file)."), data)
    save_to_figures(fig, figures, f2)
    table_knots = params.residual_table
    residual = ((("δres/δmax", f"table of {len(table_knots.depth)} knots, δmax/δy "
                  f"{table_knots.depth[0]:.4g} to {table_knots.depth[-1]:.4g}"),)
                if table_knots else (("ρ∞", params.residual_limit), ("s", params.residual_power)))
    segments = params.loading_segments
    loading = ((("loading segments", ", ".join(
        f"n = {n:.4g} from δ/δy = {x:.4g}" for x, n in zip(segments.depth, segments.exponent,
                                                          strict=True))),)
               if segments else (("n1", params.elastic_plastic_exponent),
                                 ("δp/δy", params.fully_plastic_approach_ratio),
                                 ("n2", params.fully_plastic_exponent)))
    rows = [[k, v] for k, v in (
        ("label", params.label), ("Fy (N)", fy), ("δy (µm)", dy * 1e6),
        *loading, ("p_u", params.unloading_power),
        ("p_r", params.reloading_power), *residual, ("w∞", params.plastic_work_limit),
        ("e", params.plastic_work_power))]
    errors = {k: v for k, v in (params.fit_errors or {}).items() if isinstance(v, float)}
    report.add(f"Law parameters {path.relative_to(root).as_posix()}",
               table(["parameter", "value"], rows),
               table(["fit error", "value"], [[k, v] for k, v in errors.items()])
               if errors else "<p>No fit errors recorded (not an FE calibration).</p>", f1, f2)
    acceptance = path.with_suffix(".acceptance.json")
    if acceptance.is_file():
        acceptance_section(report, acceptance, root)


def acceptance_section(report: Report, path: Path, root: Path) -> None:
    """The calibration's acceptance table and its FE-vs-law figures (written by calibrate)."""
    try:
        t = json.loads(path.read_text())
    except json.JSONDecodeError as exc:
        raise InputError(f"{path}: malformed JSON: {exc}") from None
    folder = path.parent / t.get("figures", path.with_suffix("").stem)
    rel = folder.relative_to(root).as_posix()
    rows = [[r["kind"], r["name"], r["description"], r["peak_force_N"],
             r["force_rms_percent_of_peak"],
             "-" if r["residual_approach_error_percent"] is None
             else r["residual_approach_error_percent"],
             "yes" if r["meets_force_goal"] and r["meets_residual_goal"] is not False else "no"]
            for r in t["runs"]]
    goals = t["goals"]
    items: list = [
        f"<p>The law driven along each FE run's approach path ({html_escape(t['definition'])})."
        f" Goals on held-out runs: force RMS ≤ {goals['force_rms_percent_of_peak']:g} % of "
        f"the peak, residual approach within {goals['residual_approach_error_percent']:g} %. "
        f"Held-out goals {'met' if t['held_out_all_met'] else '<b>not met</b>'}.</p>",
        table(["kind", "run", "history", "peak (N)", "force RMS (% of peak)",
               "residual error (%)", "meets goals"], rows)]
    for r in t["runs"]:
        if (folder / f"{r['name']}.png").is_file():
            items.append(Figure(f"acceptance_{r['name']}", f"FE vs law: {r['name']}",
                                f"{r['description']}; forces "
                                f"{', '.join(f'{f:.4g}' for f in r['forces_N'])} N.",
                                image=f"{rel}/{r['name']}.png",
                                data_file=f"{rel}/{r['name']}.csv"))
    if "params_sha256" in t:  # written with hash links (older tables have none)
        from ..calibrate.workflow import check_acceptance

        problems = check_acceptance(path.parent / t.get("params", ""))
        if problems:
            items.insert(0, "<p><b>Warning: this table and the parameter file were not written "
                            "together</b> (" + html_escape("; ".join(problems)) + "): rerun the "
                            "calibration.</p>")
    report.add(f"Calibration acceptance ({t.get('params', path.name)})", *items)
