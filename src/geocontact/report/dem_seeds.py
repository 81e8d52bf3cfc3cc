"""Report section of an oedometer on several samples (``geocontact dem oedometer --seeds K``):
every sample's void ratio against log vertical stress, per contact law, and each cycle's
measures as the mean and spread over the samples (docs/sample-study.md, "The oedometer")."""

from __future__ import annotations

import html
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

from ..analyses.dem_seeds import PAIRED
from ..figures import Figure
from ..files import read_csv_column
from .common import read_summary, relative_dir, save_to_figures
from .dem import COLOURS
from .html import table

SCHEMA = "geocontact.dem-seeds/1"
# (column, measure, scale) of the table: mean ± standard deviation over the samples
COLUMNS = (("e peak", "peak_void_ratio", 1.0), ("e valley", "valley_void_ratio", 1.0),
           ("M reload (MPa)", "reload_modulus_Pa", 1e-6),
           ("M unload (MPa)", "unload_modulus_Pa", 1e-6),
           ("Cc", "compression_index", 1.0), ("Cs", "swelling_index", 1.0),
           ("loop, top wall (J/m³)", "loop_area_top_wall_J_m3", 1.0),
           ("law / walls' work", "law_share", 1.0))


def is_dem_seeds(directory: Path) -> bool:
    s = read_summary(directory)
    return bool(s) and s.get("schema") == SCHEMA


def mean_spread(stats: dict, scale: float = 1.0) -> str:
    if stats["mean"] is None:
        return "—"
    return f"{stats['mean'] * scale:.4g} ± {stats['std'] * scale:.2g}"


def dem_seeds_section(report, directory: Path, root: Path, figures: Path) -> None:
    s = read_summary(directory)
    rel = relative_dir(directory, root)
    tag = "_".join(filter(None, (rel.strip("/").replace("/", "_"), "dem_seeds")))
    fig, ax = plt.subplots(figsize=(6.5, 4))
    data: dict[str, np.ndarray] = {}
    for contact in s["laws"]:
        for k, seed in enumerate(s["seeds"]):
            run = read_summary(directory / f"seed-{seed}")["runs"][contact]
            path = directory / f"seed-{seed}" / contact / "series.csv"
            step, stress = read_csv_column(path, "step"), read_csv_column(path, "stress_Pa")
            e = read_csv_column(path, "void_ratio")
            keep = (step >= run["cycle_start_step"]) & (stress > 0)
            ax.semilogx(stress[keep], e[keep], lw=0.7, color=COLOURS[contact],
                        label=contact if k == 0 else None, alpha=0.8)
            data[f"{contact}_seed{seed}_stress_Pa"] = stress[keep]
            data[f"{contact}_seed{seed}_void_ratio"] = e[keep]
    ax.set_xlabel("vertical stress σ'v (Pa)")
    ax.set_ylabel("void ratio e")
    ax.legend(fontsize=8)
    figure = save_to_figures(fig, figures, Figure(
        f"{tag}_void_ratio", "Void ratio against log vertical stress, every sample",
        f"{len(s['seeds'])} samples (seeds {s['seeds'][0]}–{s['seeds'][-1]}), law "
        f"{s['law_label']}; one line per sample and contact law.", data))
    rows = []
    for contact, law in s["laws"].items():
        for c in law["cycles"]:
            rows.append([contact, c["cycle"], mean_spread(c["peak_stress_Pa"], 1e-3),
                         *(mean_spread(c[m], scale) for _, m, scale in COLUMNS)])
    ranges = [f"<p>{html.escape(contact)}: at most {r['beyond_range_contacts_max']} contacts "
              f"beyond the file's calibrated depth in a sample (deepest "
              f"{r['beyond_range_max_depth']:.4g} δy)</p>"
              for contact, law in s["laws"].items() if (r := law["calibrated_range"])]
    pairs = []
    for pair, cycles in s.get("paired", {}).items():
        pairs.append(f"<p>{html.escape(pair)}, the ratio on the same sample (seed), mean ± "
                     "standard deviation over the samples:</p>")
        pairs.append(table(["cycle", *(c for c, m, _ in COLUMNS if m in PAIRED)],
                           [[c["cycle"], *(mean_spread(c[m]) for _, m, _ in COLUMNS
                                           if m in PAIRED)] for c in cycles]))
    report.add(f"DEM {s['test']}, {len(s['seeds'])} samples {rel or '.'}", figure,
               table(["contact", "cycle", "peak σ'v (kPa)", *(c for c, _, _ in COLUMNS)], rows),
               *pairs, *ranges)
