"""Report section of a cyclic simple shear study (``geocontact dem cyclic-shear``): G/Gmax(γ)
and D(γ) per law and mean stress, the mean and spread over the samples, with Darendeli (2001)
and Hardin & Drnevich (1972) for a clean sand at the same mean stress; the stress–strain loops."""

from __future__ import annotations

import csv
import math
import warnings
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

from ..analyses.dem_cyclic import BALANCE_TERMS, BALANCE_TOLERANCE, balance_check
from ..analyses.empirical_curves import darendeli, hardin_drnevich
from ..errors import InputError
from ..figures import Figure
from .common import read_summary, relative_dir, save_to_figures
from .html import Report, table

SCHEMA = "geocontact.dem-cyclic/1"
COLOURS = {"geocontact": "C0", "elastic": "C1", "granular": "C2"}


def is_dem_cyclic(directory: Path) -> bool:
    s = read_summary(directory)
    return bool(s) and s.get("schema") == SCHEMA


def _read(path: Path, text: tuple[str, ...] = ("law", "material")) -> dict[str, np.ndarray]:
    """Every column of a CSV the study wrote: numbers (nan where blank or nan), ``text`` kept
    as strings."""
    if not path.is_file():
        raise InputError(f"report: {path} missing (an incomplete cyclic-shear study?)")
    with path.open(newline="") as handle:
        rows = list(csv.DictReader(handle))
    if not rows:
        raise InputError(f"report: {path} has no rows")

    def number(v: str) -> float:
        try:
            return float(v) if v.strip() else math.nan
        except ValueError:
            raise InputError(f"report: {path}: {v!r} is not a number") from None

    return {k: np.array([r[k] for r in rows]) if k in text
            else np.array([number(r[k]) for r in rows]) for k in rows[0]}


def _curves(directory: Path) -> dict[str, np.ndarray]:
    c = _read(directory / "curves.csv")
    if "quasi_static" not in c:  # a study written before the balance check: check it here
        flags = [balance_check({k: c[k][i] if k in c else math.nan for k in BALANCE_TERMS})
                 ["quasi_static"] for i in range(len(c["law"]))]
        c["quasi_static"] = np.array([math.nan if f is None else float(f) for f in flags])
    return c


def _groups(c: dict[str, np.ndarray]):
    """(law, stress) -> (amplitudes, rows by seed of G/Gmax, of D, of the law's D)."""
    for law in dict.fromkeys(c["law"]):
        for stress in sorted(set(c["consolidation_stress_Pa"][c["law"] == law])):
            mine = (c["law"] == law) & (c["consolidation_stress_Pa"] == stress)
            amps = np.array(sorted(set(c["amplitude"][mine])))
            seeds = sorted(set(c["seed"][mine]))

            def grid(column, mine=mine, amps=amps, seeds=seeds):
                out = np.full((len(seeds), len(amps)), np.nan)
                for i, s in enumerate(seeds):
                    for j, a in enumerate(amps):
                        row = mine & (c["seed"] == s) & (c["amplitude"] == a)
                        out[i, j] = c[column][row][0]
                return out

            # a point whose energy balance does not close is not a quasi-static loop
            # (analyses.dem_cyclic.balance_check): left out of the curves, drawn apart
            dynamic = grid("quasi_static") == 0.0
            yield law, stress, amps, *(np.where(dynamic, np.nan, grid(k)) for k in (
                "G_over_Gmax", "damping_ratio", "damping_ratio_ledger")), dynamic, \
                grid("G_over_Gmax"), grid("damping_ratio")


def dem_cyclic_section(report: Report, directory: Path, root: Path, figures: Path) -> None:
    s = read_summary(directory)
    rel = relative_dir(directory, root)
    tag = "_".join(filter(None, (rel.strip("/").replace("/", "_"), "cyclic_shear")))
    c = _curves(directory)
    rows = [[r["run"], r["grains"], r["packing_fraction"], r["contacts_per_grain"],
             r["consolidated_mean_stress_Pa"], r["Gmax_Pa"], r["steps"], r.get("runtime_s"),
             r.get("beyond_range_contacts"), r.get("beyond_range_max_depth")]
            for r in s["runs"]]
    items: list = [table(["run", "grains", "packing fraction", "contacts/grain",
                          "mean stress (Pa)", "Gmax (Pa)", "steps", "runtime (s)",
                          "contacts beyond the law's calibrated range",
                          f"their largest δmax/δy (calibrated to "
                          f"{s.get('calibrated_max_depth') or 0:.4g})"], rows)]
    groups = list(_groups(c))
    stresses = sorted({g[1] for g in groups})
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.2))
    data: dict[str, np.ndarray] = {}
    styles = ["-", "--", ":", "-."]
    dropped = []
    for law, stress, amps, mod, damp, ledger, dynamic, mod_all, damp_all in groups:
        style = styles[stresses.index(stress) % len(styles)]
        label = f"{law}, {stress / 1e3:.4g} kPa (n = {len(mod)})"
        for ax, values, every in ((axes[0], mod, mod_all), (axes[1], damp, damp_all)):
            mean = _over_samples(np.nanmean, values)
            ax.plot(amps, mean, "o" + style, ms=4, color=COLOURS.get(law, "C2"), label=label)
            if len(values) > 1:
                ax.fill_between(amps, _over_samples(np.nanmin, values),
                                _over_samples(np.nanmax, values),
                                color=COLOURS.get(law, "C2"), alpha=0.2, lw=0)
            if dynamic.any():
                seeds, at = np.nonzero(dynamic)
                ax.plot(amps[at], every[seeds, at], "x", ms=5, color=COLOURS.get(law, "C2"),
                        label=(f"{law}, {stress / 1e3:.4g} kPa: not quasi-static"
                               if ax is axes[0] else None))
        if dynamic.any():
            dropped.append([law, stress, int(dynamic.sum()), dynamic.size,
                            ", ".join(f"{a:.3g}" for a in amps[dynamic.any(axis=0)])])
        key = f"{law}_{stress:g}Pa"
        if np.isfinite(ledger).any():  # pair granular has no ledger
            axes[1].plot(amps, _over_samples(np.nanmean, ledger), "s" + style, ms=4, mfc="none",
                         color=COLOURS.get(law, "C2"), alpha=0.6,
                         label=f"{law}, {stress / 1e3:.4g} kPa: ledger (dissipated)")
            data[f"{key}_damping_ratio_ledger_mean"] = _over_samples(np.nanmean, ledger)
        data[f"{key}_amplitude"] = amps
        data[f"{key}_G_over_Gmax_mean"] = _over_samples(np.nanmean, mod)
        data[f"{key}_damping_ratio_mean"] = _over_samples(np.nanmean, damp)
        data[f"{key}_damping_ratio_min"] = _over_samples(np.nanmin, damp)
        data[f"{key}_damping_ratio_max"] = _over_samples(np.nanmax, damp)
        data[f"{key}_quasi_static_samples"] = np.sum(~dynamic, axis=0).astype(float)
    strains = np.logspace(np.log10(min(c["amplitude"])), np.log10(max(c["amplitude"])), 60)
    for stress in stresses:
        style = styles[stresses.index(stress) % len(styles)]
        dar = darendeli(strains, stress)
        hd = hardin_drnevich(strains, dar["reference_strain"])
        for ax, key in ((axes[0], "G_over_Gmax"), (axes[1], "damping_ratio")):
            ax.plot(strains, dar[key], style, color="k", lw=1,
                    label=f"Darendeli (2001), clean sand, {stress / 1e3:.4g} kPa")
            ax.plot(strains, hd[key], style, color="0.55", lw=1,
                    label="Hardin & Drnevich (1972) hyperbola, same γr")
        data[f"darendeli_{stress:g}Pa_strain"] = strains
        data[f"darendeli_{stress:g}Pa_G_over_Gmax"] = dar["G_over_Gmax"]
        data[f"darendeli_{stress:g}Pa_damping_ratio"] = dar["damping_ratio"]
        data[f"hardin_drnevich_{stress:g}Pa_G_over_Gmax"] = hd["G_over_Gmax"]
        data[f"hardin_drnevich_{stress:g}Pa_damping_ratio"] = hd["damping_ratio"]
    for ax in axes:
        ax.set_xscale("log")
        ax.set_xlabel("shear strain amplitude γa")
        ax.grid(alpha=0.3, which="both")
    axes[0].set_ylabel("G / Gmax")
    axes[1].set_ylabel("damping ratio D")
    axes[0].legend(fontsize=7)
    axes[1].legend(fontsize=6)
    axes[1].set_yscale("symlog", linthresh=1e-3)
    items.append(save_to_figures(fig, figures, Figure(
        f"{tag}_curves", "Modulus reduction and damping against the engineers' curves",
        f"{s['material']}: each amplitude's last cycle; G secant, D = W_loop / (4π W_peak); "
        "markers the mean over the samples, band their range; open squares: the energy the "
        "contacts dissipated over the cycle (the ledger) over 4π W_peak V, which exceeds the "
        "loop's D by the stored energy the sample releases as it relaxes; crosses: a sample's "
        "point whose energy balance does not close (W_loop V ≠ ΔD + ΔU + ΔK beyond "
        f"{BALANCE_TOLERANCE:.0%}: not a quasi-static loop), left out of the mean and band. "
        "Darendeli (2001) through "
        "pystrata for PI = 0, OCR = 1, 1 Hz, 10 cycles; Hardin & Drnevich (1972) the "
        "hyperbola with Darendeli's reference strain and its Masing damping.", data)))

    # the loops of the first sample of each law at the first stress, normalised per amplitude
    fig, axes = plt.subplots(1, len({g[0] for g in groups}), figsize=(11, 4), squeeze=False)
    data = {}
    for ax, law in zip(axes[0], dict.fromkeys(g[0] for g in groups), strict=False):
        run = next(r for r in s["runs"] if r["law"] == law)
        path = directory / "loops" / f"{run['run']}.csv"
        loop = _read(path)
        cycles = loop["cycle"].astype(int)
        for k, a in enumerate(sorted(set(loop["amplitude"]))):
            last = (loop["amplitude"] == a) & (cycles == cycles.max())
            g, t = loop["shear_strain"][last], loop["shear_stress_Pa"][last]
            t = t - 0.5 * (t.max() + t.min())
            ax.plot(g / np.abs(g).max(), t / np.abs(t).max(), lw=0.8, color=f"C{k % 10}",
                    label=f"γa = {a:.2g}")
            data[f"{law}_{a:.3g}_strain"] = g
            data[f"{law}_{a:.3g}_stress_Pa"] = loop["shear_stress_Pa"][last]
        ax.set_title(f"{law}, {run['run']}", fontsize=9)
        ax.set_xlabel("γ / γa")
        ax.set_ylabel("τ / τa (centred)")
        ax.legend(fontsize=6)
    items.append(save_to_figures(fig, figures, Figure(
        f"{tag}_loops", "Stress–strain loops of the last cycle of each amplitude",
        "Each loop scaled by its own amplitudes (so a wider loop is a larger damping ratio); "
        "the data keep the measured strain and stress.", data)))
    if dropped:
        items.insert(1, "<p>Points that are not quasi-static loops (the contact stress's "
                     "loop does not balance the contacts' energy ledger: energy reached the "
                     "grains by the sheared periodic boundary; left out of the curves):</p>")
        items.insert(2, table(["law", "mean stress (Pa)", "points left out", "of",
                               "at amplitudes"], dropped))
    report.add(f"DEM cyclic simple shear {rel or '.'}", *items)


def _over_samples(reduce, values: np.ndarray) -> np.ndarray:
    """np.nanmean / np.nanmin / np.nanmax over the samples of each amplitude; NaN, without a
    warning, where no sample is left (every point left out as not quasi-static)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        return reduce(values, axis=0)
