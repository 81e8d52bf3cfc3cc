"""Report section of the material sweeps (``geocontact sweep``)."""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt

from ..figures import Figure
from ..files import (
    read_csv_column,
)
from .common import (
    positive,
    read_summary,
    readable_log_ticks,
    save_to_figures,
)
from .html import Report, table

# --- material sweeps -----------------------------------------------------------------------------


def is_sweeps(directory: Path) -> bool:
    s = read_summary(directory)
    return bool(s) and s.get("schema") == "geocontact.sweeps/1"


def sweeps_section(report: Report, directory: Path, root: Path, figures: Path) -> None:
    s = read_summary(directory)
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
        save_to_figures(fig, figures, fig_item)
        items.append(fig_item)
        for st in entry["statements"]:
            rows.append([name, st["statement"], st["quantity"],
                         ", ".join(f"{x:.3g}" for x in st["values"]), st["expected"],
                         st["found"], "agrees" if st["agrees"] else "disagrees"])
    items.append(table(["sweep", "paper's statement", "quantity", "our values (sweep order)",
                        "paper", "ours", "verdict"], rows))
    report.add("Influence of material properties", *items)
