"""Report section of a cyclic-history run (``geocontact cycles``): ratios of cycle N to cycle 1
with their power laws, shakedown states, critical cycles."""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.ticker import NullFormatter, ScalarFormatter

from ..calibrate.cyclic_fit import ROUND_OFF
from ..figures import Figure
from .common import (
    read_summary,
    relative_dir,
    save_to_figures,
)
from .html import Report, table

# --- cyclic histories (geocontact cycles) --------------------------------------------------------


def is_cycles(directory: Path) -> bool:
    s = read_summary(directory)
    return bool(s) and isinstance(s.get("analyses"), dict) and "fe" in s["analyses"]


def cycles_section(report: Report, directory: Path, root: Path, figures: Path) -> None:
    """Ratios of cycle N to cycle 1 on log axes with the fitted power laws, and the states."""
    s = read_summary(directory)
    tag = (relative_dir(directory, root).strip("/").replace("/", "_") or "cycles") + "_cycles"
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
    save_to_figures(fig, figures, figure)
    report.add(f"Cyclic history {relative_dir(directory, root) or '.'}",
               table(["source", "cycles", "state", "eventual state", "Nc measured",
                      "Nc fitted", "tolerance"], rows), figure)
