"""Report section of a seismic run (``geocontact seismic``; its own figures embedded)."""

from __future__ import annotations

from html import escape as html_escape
from pathlib import Path

from ..fem.roundoff import Resolution
from ..figures import Figure
from .common import (
    read_summary,
    relative_dir,
)
from .html import Report, table

# --- seismic -------------------------------------------------------------------------------------


def is_seismic(directory: Path) -> bool:
    s = read_summary(directory)
    return bool(s) and bool(s.get("events")) and "record" in s["events"][0]


def seismic_section(report: Report, directory: Path, root: Path, figures: Path) -> None:
    s = read_summary(directory)
    rel = relative_dir(directory, root)
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
