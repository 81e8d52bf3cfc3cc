"""Report section of an FE run (``geocontact fem``): force-approach curve and energies."""

from __future__ import annotations

from html import escape as html_escape
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

from ..fem.roundoff import clean_fe_cycles, fe_summary_resolutions
from ..fem.roundoff import note as resolution_note
from ..figures import Figure
from ..files import (
    read_csv_column,
)
from .common import (
    read_summary,
    relative_dir,
    save_to_figures,
)
from .html import Report, table

# --- FE run --------------------------------------------------------------------------------------


def is_fe_run(directory: Path) -> bool:
    s = read_summary(directory)
    return bool(s) and "cycles" in s and "mesh" in s and (directory / "curve.csv").is_file()


def fe_section(report: Report, directory: Path, root: Path, figures: Path) -> None:
    s = read_summary(directory)
    col = {c: read_csv_column(directory / "curve.csv", c) for c in
           ("force_N", "approach_m", "work_J", "elastic_energy_J", "plastic_dissipation_J",
            "contact_radius_m")}
    tag = relative_dir(directory, root).strip("/").replace("/", "_") or "fe"
    fig, ax = plt.subplots(figsize=(6, 4))
    ax.plot(col["approach_m"] * 1e3, col["force_N"], lw=1.2)
    ax.set_xlabel("ball–ball approach (mm)")
    ax.set_ylabel("force (N)")
    where = relative_dir(directory, root) or "."
    f1 = Figure(f"{tag}_force_approach", f"FE force–approach ({where})",
                f"{len(s['cycles'])} cycle(s), mesh {s['mesh'].get('preset', '?')} "
                f"({s['mesh']['elements']} elements).",
                {"approach_m": col["approach_m"], "force_N": col["force_N"]})
    save_to_figures(fig, figures, f1)
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
    save_to_figures(fig, figures, f2)
    resolutions = fe_summary_resolutions(s)
    cycles = clean_fe_cycles(s["cycles"], resolutions)
    rows = [[i + 1, c["max_force_N"], c["max_approach_m"] * 1e6,
             "-" if c["residual_approach_m"] is None else c["residual_approach_m"] * 1e6,
             c["plastic_work_J"]] for i, c in enumerate(cycles)]
    fy, fp = s.get("first_yield_force_N"), s.get("fully_plastic_force_N")
    report.add(
        f"FE run {relative_dir(directory, root) or '.'}",
        f"<p>First yield {'not reached' if fy is None else f'{fy:.4g} N'}; fully plastic "
        f"{'not reached' if fp is None else f'{fp:.4g} N'}; wall time "
        f"{s['wall_time_s']:.1f} s; version {s.get('version')}.</p>",
        table(["cycle", "Fmax (N)", "δmax (µm)", "δres (µm)", "Wp (J)"], rows),
        f"<p>{html_escape(resolution_note(*resolutions.values()))}</p>", f1, f2)
