"""Report section of the paper's loading-history study (``geocontact study paper-histories``): its
findings table, and every history's cycles against its first (``cycles.csv``)."""

from __future__ import annotations

import csv
import json
from html import escape as html_escape
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.ticker import MaxNLocator

from ..calibrate.cyclic_fit import ROUND_OFF
from ..errors import InputError
from ..figures import Figure
from .common import save_to_figures
from .html import Report, table

RATIOS = (("residual_increment_ratio", "residual-approach increment / cycle 1"),
          ("plastic_work_ratio", "plastic work / cycle 1"))


def is_paper_histories(directory: Path) -> bool:
    return (directory / "findings.json").is_file()


def paper_histories_section(report: Report, directory: Path, root: Path, figures: Path) -> None:
    """The paper's loading-history findings (``geocontact study paper-histories``) against ours."""
    from ..analyses.paper_histories import format_value as _compact

    try:
        findings = json.loads((directory / "findings.json").read_text())["findings"]
    except (json.JSONDecodeError, KeyError) as exc:
        raise InputError(f"{directory / 'findings.json'}: malformed ({exc})") from None
    evaluated = [f for f in findings if not f.get("missing_runs")
                 and not str(f["our_value"]).startswith("not available")]
    rows = [[f["statement"], f.get("finding") or _compact(f["our_value"]),
             _plain(f.get("paper_value")),
             "undecided" if f["agrees"] is None else ("agrees" if f["agrees"] else "disagrees")]
            for f in evaluated]
    items = ["<p>From <code>geocontact study paper-histories</code> (repeated, monotonically "
             "decreasing and increasing histories to 3000 N for σc = 10 and 1 MPa, and a von "
             "Mises grain). One sentence per statement with the numbers that decide it; the "
             "rule behind each verdict and every number are in <code>findings.json</code> and "
             "<code>findings.csv</code>.</p>",
             table(["paper's statement", "what we find", "paper", "verdict"], rows)]
    left_out = len(findings) - len(evaluated)
    if left_out:
        needed = sorted({run for f in findings if f not in evaluated
                         for run in f.get("missing_runs", f.get("runs", []))})
        items.append(f"<p>{left_out} more of the paper's statements need runs this directory "
                     f"does not hold ({html_escape(', '.join(needed))}): "
                     "<code>geocontact study paper-histories</code> runs the whole study.</p>")
    figure = _ratios_figure(directory, figures, tolerance=_tolerance(directory))
    report.add("The paper's findings on loading histories", *items,
               *([figure] if figure is not None else []))


def _plain(value) -> str:
    """The paper's numbers as words: {"plastic_work": 0.05, "residual": 0.1} -> "plastic work
    0.05, residual 0.1"; a list of numbers -> "2, 3"."""
    from ..analyses.paper_histories import format_value

    if isinstance(value, dict):
        return ", ".join(f"{k.replace('_', ' ')} {_plain(v)}" for k, v in value.items())
    return format_value(value)


def _tolerance(directory: Path) -> float | None:
    try:
        return float(json.loads((directory / "index.json").read_text())["tolerance"])
    except (OSError, ValueError, KeyError, TypeError):
        return None


def _read_cycles(path: Path) -> dict[str, tuple[np.ndarray, dict[str, np.ndarray]]]:
    """Per history of ``cycles.csv`` (mesh checks, ``<run>@<mesh>``, left out): its cycle
    numbers and ratios (NaN where blank); a one-line InputError on a malformed file."""
    rows: dict[str, list[dict[str, str]]] = {}
    try:
        with path.open(newline="") as handle:
            for row in csv.DictReader(handle):
                if "@" not in row["source"]:
                    rows.setdefault(row["source"], []).append(row)
        return {name: (np.array([float(r["cycle"]) for r in runs]),
                       {key: np.array([float(r[key]) if r[key] != "" else np.nan for r in runs])
                        for key, _ in RATIOS})
                for name, runs in rows.items()}
    except (KeyError, TypeError, ValueError, csv.Error, UnicodeDecodeError) as exc:
        raise InputError(f"{path}: malformed ({type(exc).__name__}: {exc})") from None


def _ratios_figure(directory: Path, figures: Path, tolerance: float | None) -> Figure | None:
    """Cycle N over cycle 1 for every history of the study (``cycles.csv``; the mesh checks,
    ``<run>@<mesh>``, left out), on log axes: the repeated runs' ratchet or decay, the
    decreasing runs' shakedown, the increasing runs' growth."""
    path = directory / "cycles.csv"
    if not path.is_file():
        return None
    runs = _read_cycles(path)
    if not runs:
        return None
    fig, axes = plt.subplots(1, 2, figsize=(10, 4.2), sharey=True)
    data: dict[str, np.ndarray] = {}
    for name, (cycle, ratios) in runs.items():
        style = "o-" if name.startswith("repeated") else (
            "s--" if name.startswith("mono-decreasing") else "^:")
        for ax, (key, _) in zip(axes, RATIOS, strict=True):
            shown = (cycle >= 2) & (ratios[key] > ROUND_OFF)
            ax.semilogy(cycle[shown], ratios[key][shown], style, ms=4, lw=0.8, label=name)
            data[f"{name}_{key}_cycle"] = cycle[shown]
            data[f"{name}_{key}"] = ratios[key][shown]
    for ax, (_, title) in zip(axes, RATIOS, strict=True):
        if tolerance is not None:
            ax.axhline(tolerance, color="0.6", ls=":", lw=0.8)
        ax.set_xlabel("cycle N")
        ax.set_title(title, fontsize=9)
        ax.xaxis.set_major_locator(MaxNLocator(integer=True))
    axes[0].set_ylabel("ratio to cycle 1")
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="upper center", bbox_to_anchor=(0.5, 0.0), ncol=3,
               fontsize=8, frameon=False)
    figure = Figure("paper_histories_ratios", "Every history's cycles against its first",
                    "Cycles 2 on of each history (mesh checks left out): circles repeated, "
                    "squares decreasing, triangles increasing loading. Ratios that are zero, "
                    f"negative or below round-off ({ROUND_OFF:g}) are not shown (cycles.csv "
                    "holds them all); dotted: the study's tolerance.", data)
    return save_to_figures(fig, figures, figure)
