"""``geocontact report DIR``: recognise the results in a run directory and turn each into a
report section (figures from the results' own data, each figure's data as CSV beside it).

Recognised, in DIR itself and in its immediate sub-directories:

* an FE run (``curve.csv`` + ``summary.json`` with ``cycles``): force-approach curve, energies;
* law parameters (``*.json`` with ``"schema": "geocontact.law/1"``): the law's curves, residual
  approach and plastic work against depth with the FE points it was fitted to;
* material sweeps (``summary.json`` with ``"schema": "geocontact.sweeps/1"``);
* a seismic run (``summary.json`` with ``events``; its own figures are embedded);
* a cyclic-history run (``geocontact cycles``: ``summary.json`` with ``analyses``): the ratios of
  cycle N to cycle 1 with their power laws, the shakedown states and critical cycles.

Sections for other result kinds register themselves in ``SECTIONS`` (first match wins).
"""

from __future__ import annotations

import json
from collections.abc import Callable
from html import escape as html_escape
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.ticker import FormatStrFormatter, LogLocator, NullFormatter, ScalarFormatter

from .analyses.cycles import ROUND_OFF
from .errors import InputError
from .io import (
    add_to_manifest,
    atomic_directory,
    provenance,
    read_csv_column,
    write_text_atomic,
)
from .report import Figure, Report, is_our_report, render_html, save_figure, table
from .resolution import Resolution, clean_fe_cycles, fe_summary_resolutions
from .resolution import note as resolution_note

FIGURES = "figures"
REPORT_HTML = "report.html"


def _summary(directory: Path) -> dict | None:
    path = directory / "summary.json"
    if not path.is_file():
        return None
    try:
        return json.loads(path.read_text())
    except json.JSONDecodeError as exc:
        raise InputError(f"{path}: malformed JSON: {exc}") from None


def _save(fig, figures: Path, figure: Figure) -> Figure:
    """Save into DIR/figures/ and point the figure at it (paths relative to DIR)."""
    save_figure(fig, figures, figure)
    figure.image = f"{FIGURES}/{figure.name}.png"
    if figure.data:
        figure.data_file = f"{FIGURES}/{figure.name}.csv"
    return figure


def _rel(directory: Path, root: Path) -> str:
    rel = directory.relative_to(root).as_posix()
    return "" if rel == "." else rel + "/"


# --- FE run --------------------------------------------------------------------------------------


def is_fe_run(directory: Path) -> bool:
    s = _summary(directory)
    return bool(s) and "cycles" in s and "mesh" in s and (directory / "curve.csv").is_file()


def fe_section(report: Report, directory: Path, root: Path, figures: Path) -> None:
    s = _summary(directory)
    col = {c: read_csv_column(directory / "curve.csv", c) for c in
           ("force_N", "approach_m", "work_J", "elastic_energy_J", "plastic_dissipation_J",
            "contact_radius_m")}
    tag = _rel(directory, root).strip("/").replace("/", "_") or "fe"
    fig, ax = plt.subplots(figsize=(6, 4))
    ax.plot(col["approach_m"] * 1e3, col["force_N"], lw=1.2)
    ax.set_xlabel("ball–ball approach (mm)")
    ax.set_ylabel("force (N)")
    f1 = Figure(f"{tag}_force_approach", f"FE force–approach ({_rel(directory, root) or '.'})",
                f"{len(s['cycles'])} cycle(s), mesh {s['mesh'].get('preset', '?')} "
                f"({s['mesh']['elements']} elements).",
                {"approach_m": col["approach_m"], "force_N": col["force_N"]})
    _save(fig, figures, f1)
    fig, ax = plt.subplots(figsize=(6, 4))
    step = np.arange(len(col["work_J"]))
    balance = col["elastic_energy_J"] + col["plastic_dissipation_J"]
    ax.plot(step, col["work_J"], label="work of the force")
    ax.plot(step, balance, "--", label="elastic energy + plastic dissipation")
    ax.plot(step, col["plastic_dissipation_J"], label="plastic dissipation")
    ax.set_xlabel("step")
    ax.set_ylabel("energy (J, pair)")
    ax.legend(fontsize=8)
    f2 = Figure(f"{tag}_energy", "Energy balance of the FE run",
                "The work of the force against stored plus dissipated energy, step by step.",
                {"step": step, "work_J": col["work_J"], "elastic_J": col["elastic_energy_J"],
                 "plastic_J": col["plastic_dissipation_J"]})
    _save(fig, figures, f2)
    resolutions = fe_summary_resolutions(s)
    cycles = clean_fe_cycles(s["cycles"], resolutions)
    rows = [[i + 1, c["max_force_N"], c["max_approach_m"] * 1e6,
             "-" if c["residual_approach_m"] is None else c["residual_approach_m"] * 1e6,
             c["plastic_work_J"]] for i, c in enumerate(cycles)]
    fy, fp = s.get("first_yield_force_N"), s.get("fully_plastic_force_N")
    report.add(
        f"FE run {_rel(directory, root) or '.'}",
        f"<p>First yield {'not reached' if fy is None else f'{fy:.4g} N'}; fully plastic "
        f"{'not reached' if fp is None else f'{fp:.4g} N'}; wall time "
        f"{s['wall_time_s']:.1f} s; version {s.get('version')}.</p>",
        table(["cycle", "Fmax (N)", "δmax (µm)", "δres (µm)", "Wp (J)"], rows),
        f"<p>{html_escape(resolution_note(*resolutions.values()))}</p>", f1, f2)


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
LOG_FLOOR = 1e-3
LOG_POINTS = 300


def positive(x, y) -> tuple[np.ndarray, np.ndarray]:
    """The points of a curve that a log-log axis can show (x > 0 and y > 0, finite): a line is
    never drawn through zero on a log axis."""
    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    keep = np.isfinite(x) & np.isfinite(y) & (x > 0) & (y > 0)
    return x[keep], y[keep]


def readable_log_ticks(ax) -> None:
    """Tick labels of a log axis that spans little more than a decade: matplotlib labels every
    minor tick there (2, 3, ..., 9 x 10^n, overlapping); label 1, 2 and 5 x 10^n instead."""
    for axis, (lo, hi) in ((ax.xaxis, ax.get_xlim()), (ax.yaxis, ax.get_ylim())):
        if axis.get_scale() != "log" or not 0 < lo < hi:
            continue
        if hi / lo <= 300.0:
            axis.set_major_locator(LogLocator(subs=(1.0,)))
            axis.set_minor_locator(LogLocator(subs=(2.0, 5.0)))
            axis.set_major_formatter(FormatStrFormatter("%g"))
            axis.set_minor_formatter(FormatStrFormatter("%g"))
        else:
            axis.set_minor_formatter(NullFormatter())


def _toward(start: float, end: float, points: int, floor: float) -> np.ndarray:
    """From ``start`` to ``end``, dense on a log scale of the distance to ``end``
    (down to ``floor`` of the span): an unloading branch that vanishes at the residual
    approach as a power of the distance is then resolved to its end."""
    span = start - end
    return end + span * np.geomspace(1.0, floor, points)


def law_curves(params, depths) -> list[tuple]:
    """Load to each depth (in delta_y), unload until apart, reload past the peak: every branch
    on a log grid (loading from ``LOG_FLOOR`` delta_y, unloading and reloading dense near the
    residual approach), so the curves are fit for log axes."""
    from .law import Contact

    dy = params.yield_approach
    curves = []
    for depth in depths:
        c = Contact(params)
        dmax = depth * dy
        up = np.geomspace(LOG_FLOOR * dy, dmax, LOG_POINTS)
        fu = np.array([c.update(d)[0] for d in up])
        dres = c.state.residual_approach
        floor = min(1e-4, LOG_FLOOR * dy / dmax)
        down = _toward(dmax, dres, LOG_POINTS, floor)
        fd = np.array([c.update(d)[0] for d in down])
        c.update(dres)
        again = np.concatenate([_toward(dmax, dres, LOG_POINTS, floor)[::-1],
                                np.geomspace(dmax, 1.2 * dmax, 40)[1:]])
        fr = np.array([c.update(d)[0] for d in again])
        curves.append((depth, up, fu, down, fd, again, fr))
    return curves


def law_section(report: Report, path: Path, root: Path, figures: Path) -> None:
    from .law import load_params

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
    _save(fig, figures, f1)

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
    _save(fig, figures, f2)
    rows = [[k, v] for k, v in (
        ("label", params.label), ("Fy (N)", fy), ("δy (µm)", dy * 1e6),
        ("n1", params.elastic_plastic_exponent), ("δp/δy", params.fully_plastic_approach_ratio),
        ("n2", params.fully_plastic_exponent), ("p_u", params.unloading_power),
        ("p_r", params.reloading_power), ("ρ∞", params.residual_limit),
        ("s", params.residual_power), ("w∞", params.plastic_work_limit),
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
        from .calibrate.workflow import check_acceptance

        problems = check_acceptance(path.parent / t.get("params", ""))
        if problems:
            items.insert(0, "<p><b>Warning: this table and the parameter file were not written "
                            "together</b> (" + html_escape("; ".join(problems)) + "): rerun the "
                            "calibration.</p>")
    report.add(f"Calibration acceptance ({t.get('params', path.name)})", *items)


# --- material sweeps -----------------------------------------------------------------------------


def is_sweeps(directory: Path) -> bool:
    s = _summary(directory)
    return bool(s) and s.get("schema") == "geocontact.sweeps/1"


def sweeps_section(report: Report, directory: Path, root: Path, figures: Path) -> None:
    s = _summary(directory)
    items: list = [f"<p>One FE run 0 → {s['peak_force_N']:g} N → 0 per point, mesh "
                   f"<code>{s['mesh']}</code>, base material <code>{s['base']}</code>.</p>"]
    rows = []
    for name, entry in s["sweeps"].items():
        curves = directory / f"curves_{name}.csv"
        fig, axes = plt.subplots(1, 2, figsize=(11, 4))
        data = {}
        for point in entry["points"]:
            v = point["value"]
            label = f"{entry['label']} = {v * entry['scale']:g}"
            cols = {c: read_csv_column(curves, f"{c}@{v:g}", ragged=True) for c in
                    ("approach_over_max", "force_over_max", "approach_over_yield",
                     "force_over_yield")}
            axes[0].plot(cols["approach_over_max"], cols["force_over_max"], lw=1, label=label)
            # the log-log panel: only the FE points a log axis can show (not the start at
            # zero nor the end of unloading at zero force), joined by straight segments
            x, y = positive(cols["approach_over_yield"], cols["force_over_yield"])
            axes[1].loglog(x, y, lw=1, label=label)
            data.update({f"{k}@{v:g}": a for k, a in cols.items()
                         if k in ("approach_over_max", "force_over_max")})
            data.update({f"approach_over_yield@{v:g}": x, f"force_over_yield@{v:g}": y})
        axes[0].set_xlabel("δ / δmax")
        axes[0].set_ylabel("F / Fmax")
        axes[1].set_xlabel("δ / δy")
        axes[1].set_ylabel("F / Fy")
        axes[0].legend(fontsize=7)
        readable_log_ticks(axes[1])
        fig_item = Figure(f"sweep_{name}", f"Influence of {entry['label']}",
                          "Loading and unloading at the same peak force, normalised by the peak "
                          "(left) and by incipient yield (right, log axes: the FE points with "
                          "δ > 0 and F > 0, so not the start of loading nor the end of "
                          "unloading).", data)
        _save(fig, figures, fig_item)
        items.append(fig_item)
        for st in entry["statements"]:
            rows.append([name, st["statement"], st["quantity"],
                         ", ".join(f"{x:.3g}" for x in st["values"]), st["expected"],
                         st["found"], "agrees" if st["agrees"] else "disagrees"])
    items.append(table(["sweep", "paper's statement", "quantity", "our values (sweep order)",
                        "paper", "ours", "verdict"], rows))
    report.add("Influence of material properties", *items)


# --- seismic -------------------------------------------------------------------------------------


def is_seismic(directory: Path) -> bool:
    s = _summary(directory)
    return bool(s) and bool(s.get("events")) and "record" in s["events"][0]


def seismic_section(report: Report, directory: Path, root: Path, figures: Path) -> None:
    s = _summary(directory)
    rel = _rel(directory, root)
    items: list = []
    energy = (Resolution.from_dict(s["resolution"]["energy"]) if "resolution" in s
              else None)  # (a summary written before resolutions were recorded)
    clean = energy.clean if energy else (lambda x: x)
    rows = [[e["label"], e["record"].get("name", ""),
             e["paper_rule"]["peak_time_fraction"], e["paper_rule"]["history_class"],
             e["settlement_m"] * 1e6,
             clean(sum(c["dissipated_energy_J"] for c in e["contacts"]))] for e in s["events"]]
    items.append(table(["event", "record", "peak-time fraction", "paper's rule",
                        "settlement (µm)", "dissipated by the contacts (J)"], rows))
    if energy:
        items.append(f"<p>{html_escape(energy.note())}</p>")
    for name in s.get("figures", []):
        stem = Path(name).stem
        csv = {"record": "records.csv"}.get(stem, "history.csv")
        items.append(Figure(f"seismic_{stem}", stem.replace("_", " ").capitalize(),
                            "From the seismic run.", image=f"{rel}{name}",
                            data_file=f"{rel}{csv}"))
    report.add(f"Seismic run {rel or '.'}", *items)


# --- cyclic histories (geocontact cycles) --------------------------------------------------------


def is_cycles(directory: Path) -> bool:
    s = _summary(directory)
    return bool(s) and isinstance(s.get("analyses"), dict) and "fe" in s["analyses"]


def cycles_section(report: Report, directory: Path, root: Path, figures: Path) -> None:
    """Ratios of cycle N to cycle 1 on log axes with the fitted power laws, and the states."""
    s = _summary(directory)
    tag = (_rel(directory, root).strip("/").replace("/", "_") or "cycles") + "_cycles"
    fig, axes = plt.subplots(1, 2, figsize=(10, 4), sharey=True)
    data: dict[str, np.ndarray] = {}
    rows = []
    for name, a in s["analyses"].items():
        n = np.array([c["cycle"] for c in a["cycles"]], dtype=float)
        for ax, key in zip(axes, ("residual_increment_ratio", "plastic_work_ratio"), strict=True):
            r = np.array([np.nan if c[key] is None else c[key] for c in a["cycles"]], dtype=float)
            shown = (n >= 2) & (r > ROUND_OFF)
            line, = ax.loglog(n[shown], r[shown], "o", label=name)
            fit = a["fits"].get(key)
            if fit:
                ax.loglog(n[n >= 2], fit["coefficient"] * n[n >= 2] ** -fit["power"], "-",
                          color=line.get_color(), lw=0.8)
                data[f"{name}_{key}_fit"] = fit["coefficient"] * n[n >= 2] ** -fit["power"]
            # what the log axes show (every ratio, round-off included, is in summary.json)
            data[f"{name}_{key}_cycle"] = n[shown]
            data[f"{name}_{key}"] = r[shown]
        data[f"{name}_fit_cycle"] = n[n >= 2]
        nc = a["critical_cycles"]
        rows.append([name, len(a["cycles"]), a["state"], a["eventual_state"],
                     str(nc["measured"]["elastic_shakedown"]),
                     str(nc["fitted"]["elastic_shakedown"]), a["tolerance"]])
    for ax, label in zip(axes, ("residual-approach increment / cycle 1",
                                "plastic work / cycle 1"), strict=True):
        ax.axhline(s["analyses"]["fe"]["tolerance"], color="0.6", ls=":", lw=0.8)
        ax.set_xlabel("cycle N")
        ax.set_title(label, fontsize=9)
        cycles = sorted({int(k) for k in n if k >= 2})
        if 0 < len(cycles) <= 12:
            ax.set_xticks(cycles)
        ax.xaxis.set_major_formatter(ScalarFormatter())
        ax.xaxis.set_minor_formatter(NullFormatter())
    axes[0].set_ylabel("ratio to cycle 1")
    axes[0].legend(fontsize=7)
    figure = Figure(f"{tag}_ratios", "Cycle N over cycle 1",
                    "Markers: measured (ratios below round-off, 1e-10, not shown); lines: "
                    "fitted power laws c N^-p; dotted: the tolerance.", data)
    _save(fig, figures, figure)
    report.add(f"Cyclic history {_rel(directory, root) or '.'}",
               table(["source", "cycles", "state", "eventual state", "Nc measured",
                      "Nc fitted", "tolerance"], rows), figure)


def is_paper_histories(directory: Path) -> bool:
    return (directory / "findings.json").is_file()


def paper_histories_section(report: Report, directory: Path, root: Path, figures: Path) -> None:
    """The paper's loading-history findings (scripts/paper_histories.py) against our numbers."""
    from .analyses.paper_histories import format_value as _compact

    try:
        findings = json.loads((directory / "findings.json").read_text())["findings"]
    except (json.JSONDecodeError, KeyError) as exc:
        raise InputError(f"{directory / 'findings.json'}: malformed ({exc})") from None
    evaluated = [f for f in findings if not f.get("missing_runs")
                 and not str(f["our_value"]).startswith("not available")]
    rows = [[f["statement"], f["quantity"], _compact(f["our_value"]),
             _compact(f.get("paper_value")),
             "undecided" if f["agrees"] is None else ("agrees" if f["agrees"] else "disagrees")]
            for f in evaluated]
    items = ["<p>From <code>scripts/paper_histories.py</code> (repeated, monotonically "
             "decreasing and increasing histories to 3000 N for σc = 10 and 1 MPa, and a von "
             "Mises grain); the rule behind each verdict is in <code>findings.json</code>.</p>",
             table(["paper's statement", "quantity", "ours", "paper", "verdict"], rows)]
    left_out = len(findings) - len(evaluated)
    if left_out:
        needed = sorted({run for f in findings if f not in evaluated
                         for run in f.get("missing_runs", f.get("runs", []))})
        items.append(f"<p>{left_out} more of the paper's statements need runs this directory "
                     f"does not hold ({html_escape(', '.join(needed))}): "
                     "<code>python scripts/paper_histories.py</code> runs the whole study.</p>")
    report.add("The paper's findings on loading histories", *items)


SECTIONS: list[tuple[Callable[[Path], bool], Callable]] = [
    (is_paper_histories, paper_histories_section),
    (is_sweeps, sweeps_section),
    (is_seismic, seismic_section),
    (is_cycles, cycles_section),
    (is_fe_run, fe_section),
]


def build_report(directory: str | Path, title: str | None = None, intro: str = "",
                 preface: list[tuple[str, list]] | None = None, *,
                 overwrite: bool = False) -> Path:
    """Write DIR/report.html (and DIR/figures/) from every result found in DIR; ``preface``:
    (heading, items) sections placed first (the demo's own tables and figures).

    ``figures/`` is written as one unit (no stale figure of an earlier report survives) and
    then ``report.html``; either is replaced only if an earlier report wrote it (unless
    ``overwrite``), and both join DIR's result manifest when DIR is a result of ours."""
    root = Path(directory)
    if not root.is_dir():
        raise InputError(f"report: not a directory: {directory}")
    html_path = root / REPORT_HTML
    if html_path.exists() and not overwrite and not is_our_report(html_path):
        raise InputError(f"report: {html_path} exists and was not written by geocontact; "
                         "refusing to replace it: move it or pass overwrite=True")
    report = Report(title=title or f"geocontact — {root.name}", intro=intro,
                    provenance=provenance("report", {"directory": str(root)}))
    for heading, items in preface or []:
        report.add(heading, *items)
    found = len(preface or [])
    with atomic_directory(root / FIGURES, "report", overwrite=overwrite) as figures:
        subs = sorted(p for p in root.iterdir()
                      if p.is_dir() and p.name != FIGURES and not p.name.startswith("."))
        for sub in [root] + subs:
            for path in law_files(sub):
                law_section(report, path, root, figures)
                found += 1
            for test, section in SECTIONS:
                if test(sub):
                    section(report, sub, root, figures)
                    found += 1
                    break
        if not found:
            raise InputError(f"report: no geocontact results found in {directory} (looked for "
                             "FE runs, law parameter files, sweeps, seismic runs, cyclic "
                             "histories)")
        text = render_html(report, root, figures)
    write_text_atomic(html_path, text)
    add_to_manifest(root, [REPORT_HTML])
    return html_path
