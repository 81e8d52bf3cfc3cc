"""Report section of a seismic DEM run (``geocontact dem seismic``): the record and its base
displacement, settlement and dissipation against the record's time for the geocontact law beside
LAMMPS's granular Hertz-Mindlin, with the time of the PGA and the paper's peak-time rule."""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

from ..figures import Figure
from ..files import read_csv_column
from .common import read_summary, relative_dir, save_to_figures
from .html import Report, table

COLOURS = {"geocontact": "C0", "granular": "C1", "elastic": "C2"}


def _columns(path: Path, names: tuple[str, ...]) -> dict[str, np.ndarray]:
    return {k: read_csv_column(path, k) for k in names}


def _mark_peak(ax, peak_time: float) -> None:
    ax.axvline(peak_time, color="0.5", lw=0.8, ls="--")


def seismic_section(report: Report, directory: Path, root: Path, figures: Path) -> None:
    s = read_summary(directory)
    rel = relative_dir(directory, root)
    tag = "_".join(filter(None, (rel.strip("/").replace("/", "_"), "dem_seismic")))
    rec = s["record"]
    runs = s["runs"]
    peak = rec["peak_time_s"]
    items: list = [table(
        ["record", "duration (s)", "PGA at (s)", "PGA time / length", "paper's rule"],
        [[rec["name"], rec["duration_s"], peak, rec["peak_time_fraction"], rec["paper_rule"]]])]
    rows = []
    for contact, r in runs.items():
        rows.append([contact, r["grains"], r["ranks"], r["steps"], r["runtime_s"],
                     r["timescale"], r["inertia_number"]["max"], r["inertia_number"]["rms"],
                     r["peak_shear_strain"], r["settlement_m"], r["vertical_strain"],
                     r["wall_work_J"], r.get("wall_work_from_wall_forces_J"),
                     r["law_dissipated_J"],
                     r["at_peak_time"]["settlement_fraction"],
                     r["settlement_90_fraction_of_record"]])
    items.append(table(["contact", "grains", "ranks", "steps", "runtime (s)", "time compression",
                        "inertia number (max)", "inertia number (rms)", "peak shear strain",
                        "settlement (m)", "vertical strain", "wall work, virial (J)",
                        "wall work, wall fixes (J)", "law dissipation (J)",
                        "settlement share at the PGA time",
                        "90 % of settlement at (share of record)"], rows))

    # the record: acceleration, and the base displacement it becomes
    acc = _columns(directory / "record.csv", ("time_s", "acceleration_m_s2"))
    base = _columns(directory / "base_motion.csv", ("time_s", "displacement_over_peak"))
    fig, axes = plt.subplots(2, 1, figsize=(7, 4.6), sharex=True)
    axes[0].plot(acc["time_s"], acc["acceleration_m_s2"], lw=0.5, color="0.2")
    axes[0].set_ylabel("ground acceleration (m/s²)")
    axes[1].plot(base["time_s"], base["displacement_over_peak"], lw=0.8, color="C2")
    axes[1].set_ylabel("base displacement / peak")
    axes[1].set_xlabel("record time (s)")
    for ax in axes:
        _mark_peak(ax, peak)
    items.append(save_to_figures(fig, figures, Figure(
        f"{tag}_record", f"The record {rec['name']} and the base displacement",
        f"Baseline {rec['baseline']}; displacement integrated twice, the constant velocity "
        f"{rec['drift_velocity_removed_m_s']:.3g} m/s removed so the ground ends where it "
        f"started; dashed: the PGA at {peak:.3g} s ({rec['peak_time_fraction']:.1%} of the "
        f"record: {rec['paper_rule']} by the paper's rule).",
        {**{f"record_{k}": v for k, v in acc.items()},
         **{f"base_{k}": v for k, v in base.items()}})))

    # settlement and dissipation against the record's time
    fig, axes = plt.subplots(1, 2, figsize=(12, 3.8))
    data: dict[str, np.ndarray] = {}
    for contact in runs:
        t = _columns(directory / contact / "series.csv",
                     ("record_time_s", "settlement_m", "wall_work_J",
                      "wall_work_from_wall_forces_J", "law_dissipated_J"))
        colour = COLOURS[contact]
        axes[0].plot(t["record_time_s"], t["settlement_m"] * 1e6, lw=0.9, label=contact,
                     color=colour)
        axes[1].plot(t["record_time_s"], t["wall_work_J"] * 1e3, lw=0.9,
                     label=f"{contact}: wall work", color=colour)
        if contact == "geocontact":
            axes[1].plot(t["record_time_s"], t["wall_work_from_wall_forces_J"] * 1e3, lw=0.9,
                         ls=":", label="geocontact: wall work (wall fix forces)", color=colour)
            axes[1].plot(t["record_time_s"], t["law_dissipated_J"] * 1e3, lw=0.9, ls="--",
                         label="geocontact: law dissipation", color=colour, alpha=0.7)
        data.update({f"{contact}_{k}": v for k, v in t.items()})
    axes[0].set_ylabel("settlement (µm)")
    axes[1].set_ylabel("energy since the shaking began (mJ)")
    for ax in axes:
        ax.set_xlabel("record time (s)")
        _mark_peak(ax, peak)
        ax.legend(fontsize=7)
    first = next(iter(runs.values()))
    items.append(save_to_figures(fig, figures, Figure(
        f"{tag}_settlement", "Settlement and dissipation under the record",
        f"{first['grains']} grains at {first['stress_at_start_Pa']:.3g} Pa, base displacement "
        f"peak {first['peak_shear_strain']:.2g} of the height; the record's time compressed "
        f"{first['timescale']:.3g}x (largest inertia number {first['inertia_number']['max']:.2g})."
        " Wall work: the work of the base and the top wall on the sample (dissipated by "
        "friction, damping and the law, less the small change of stored energy), from the "
        "virial stresses (both laws) and, dotted, from the wall fixes' own forces (geocontact); "
        "law dissipation: the geocontact normal law's own. Grey dashed: the time of the PGA.",
        data)))
    g = runs.get("geocontact")
    if g and "energy" in g:
        from .dem import ledger_figure

        items.append(ledger_figure(
            {"shaking": g["energy"], "whole run": g["energy_whole_run"]}, figures,
            f"{tag}_energy_ledger",
            "geocontact (pair and walls): where the walls' work went during the shaking and over "
            "the whole run (consolidation included) — the change of kinetic and stored energy "
            "and the energy each channel dissipated, as a share of the walls' own work "
            "(Σ F·v_wall dt); the closure residual of the shaking is "
            f"{100 * g['energy']['closure_residual_fraction']:.2f} % of the work."))
    report.add(f"DEM seismic {rel or '.'}", *items)
