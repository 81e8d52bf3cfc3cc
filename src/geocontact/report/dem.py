"""Report section of a DEM run (``geocontact dem``): stress-strain loops, residual strain and
work per cycle for the geocontact law beside LAMMPS's granular Hertz-Mindlin, coordination
number, and the distribution of the per-contact residual approach."""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

from ..figures import Figure
from ..files import read_csv_column
from .common import read_summary, relative_dir, save_to_figures
from .html import Report, table

SCHEMA = "geocontact.dem/1"
COLOURS = {"geocontact": "C0", "granular": "C1", "elastic": "C2"}


def is_dem(directory: Path) -> bool:
    s = read_summary(directory)
    return bool(s) and s.get("schema") == SCHEMA


def _series(directory: Path, contact: str) -> dict[str, np.ndarray]:
    path = directory / contact / "series.csv"
    names = ("step", "strain", "stress_Pa", "contacts_per_grain")
    if "void_ratio" in path.read_text().partition("\n")[0].split(","):  # runs since issue 35
        names += ("void_ratio",)
    return {k: read_csv_column(path, k) for k in names}


LEDGER_CHANNELS = (("Δ kinetic", ("change_kinetic_J",)),
                   *((f"Δ stored {k}", ("change_stored_J", k))
                     for k in ("normal", "tangential", "rolling", "twisting")),
                   *((k.replace("_", " "), ("dissipated_J", k))
                     for k in ("law", "sliding", "normal_damping", "tangential_damping",
                               "rolling", "twisting")),
                   ("closure residual", ("closure_residual_J",)))


def _channel(energy: dict, path: tuple[str, ...]) -> float:
    for key in path:
        energy = energy[key]
    return float(energy)


def ledger_figure(ledgers: dict[str, dict], figures: Path, name: str, caption: str):
    """The energy ledger (docs/dem.md "Energy ledger") of each interval in ``ledgers`` (label:
    the ``energy`` object of summary.json): every channel as a share of the interval's boundary
    work, side by side (sliding may be negative: the model's spring gains energy at the slip
    reset where the dashpot's force alone exceeds the Coulomb limit)."""
    labels = list(ledgers)
    fig, ax = plt.subplots(figsize=(max(6.5, 1.2 * len(labels) + 4), 4))
    width = 0.8 / len(LEDGER_CHANNELS)
    data: dict[str, np.ndarray] = {"boundary_work_J": np.array(
        [ledgers[k]["boundary_work_J"] for k in labels])}
    x = np.arange(len(labels))
    for c, (channel, path) in enumerate(LEDGER_CHANNELS):
        values = np.array([_channel(ledgers[k], path) for k in labels])
        share = values / data["boundary_work_J"]
        ax.bar(x + (c - len(LEDGER_CHANNELS) / 2 + 0.5) * width, share * 100, width,
               label=channel, color=f"C{c % 10}", hatch="//" if c >= 10 else None)
        data[f"{'_'.join(path)}"] = values
    ax.axhline(0, color="0.5", lw=0.6)
    ax.set_xticks(x, labels)
    ax.set_ylabel("% of the boundary work")
    ax.legend(fontsize=7, ncol=2)
    caption += (" Sliding is negative where the tangential dashpot's force alone exceeds the "
                "Coulomb limit (the slip reset then stores the spring along the sliding velocity, "
                "as in LAMMPS's granular models): sliding + tangential damping is the tangential "
                "contact's loss (docs/dem.md, \"Energy ledger\").")
    return save_to_figures(fig, figures, Figure(name, "Energy ledger", caption, data))


def _number(value, scale: float = 1.0):
    return "—" if value is None else value * scale


def compressibility_items(directory: Path, runs: dict, tag: str, figures: Path) -> list:
    """The oedometer as geotechnical engineers read it: void ratio against log10 of the vertical
    stress with the unload-reload loops, and a table of each cycle's void ratios, constrained
    moduli, compression and swelling indices and loop area (docs/dem.md)."""
    fig, ax = plt.subplots(figsize=(6.5, 4))
    data: dict[str, np.ndarray] = {}
    rows = []
    for contact, r in runs.items():
        t = _series(directory, contact)
        keep = (t["step"] >= r["cycle_start_step"]) & (t["stress_Pa"] > 0)
        ax.semilogx(t["stress_Pa"][keep], t["void_ratio"][keep], lw=0.8, label=contact,
                    color=COLOURS[contact])
        data[f"{contact}_stress_Pa"] = t["stress_Pa"][keep]
        data[f"{contact}_void_ratio"] = t["void_ratio"][keep]
        for c in r["cycles"]:
            rows.append([contact, c["cycle"], c["peak_stress_Pa"] / 1e3, c["peak_void_ratio"],
                         c["valley_void_ratio"], _number(c["reload_modulus_Pa"], 1e-6),
                         _number(c["unload_modulus_Pa"], 1e-6),
                         _number(c["unload_modulus_initial_Pa"], 1e-6),
                         _number(c["compression_index"]), _number(c["swelling_index"]),
                         c["loop_area_J_m3"]])
    ax.set_xlabel("vertical stress σ'v (Pa)")
    ax.set_ylabel("void ratio e")
    ax.legend(fontsize=8)
    figure = save_to_figures(fig, figures, Figure(
        f"{tag}_void_ratio", "Void ratio against log vertical stress",
        "e = V_voids / V_solid from the top wall's position; the cycles' unload-reload loops "
        "(docs/dem.md, \"Compressibility\").", data))
    return [figure, table(["contact", "cycle", "peak σ'v (kPa)", "e peak", "e valley",
                           "M reload (MPa)", "M unload (MPa)", "M unload initial (MPa)", "Cc",
                           "Cs", "loop area (J/m³)"], rows)]


def dem_section(report: Report, directory: Path, root: Path, figures: Path) -> None:
    s = read_summary(directory)
    if s.get("test") == "seismic":
        from .dem_seismic import seismic_section

        seismic_section(report, directory, root, figures)
        return
    rel = relative_dir(directory, root)
    tag = "_".join(filter(None, (rel.strip("/").replace("/", "_"), "dem")))
    runs = s["runs"]
    rows = []
    for contact, r in runs.items():
        rows.append([contact, r["grains"], r["ranks"], r["steps"], r["runtime_s"],
                     r["timestep_s"], r["packing_fraction"], r["contacts_per_grain_at_stress"],
                     r["inertia_number"]["at_lowest_target"], r["total_residual_strain"]])
    items: list = [table(["contact", "grains", "ranks", "steps", "runtime (s)", "dt (s)",
                          "packing fraction", "contacts/grain at σ0", "inertia number (max)",
                          "residual strain after the cycles"], rows)]

    # stress-strain loops of the cycles
    fig, ax = plt.subplots(figsize=(6.5, 4))
    data: dict[str, np.ndarray] = {}
    for contact, r in runs.items():
        t = _series(directory, contact)
        keep = t["step"] >= r["cycle_start_step"]
        ax.plot(t["strain"][keep] * 1e3, t["stress_Pa"][keep] / 1e3, lw=0.8, label=contact,
                color=COLOURS[contact])
        data[f"{contact}_strain"] = t["strain"][keep]
        data[f"{contact}_stress_Pa"] = t["stress_Pa"][keep]
    ax.set_xlabel("vertical strain (‰, from the height at σ0)")
    ax.set_ylabel("vertical stress (kPa)")
    ax.legend(fontsize=8)
    items.append(save_to_figures(fig, figures, Figure(
        f"{tag}_loops", "Stress–strain loops of the oedometer cycles",
        f"{s['test']} of {next(iter(runs.values()))['grains']} grains, law {s['law_label']}; "
        "stress: contact virial over the sample volume; strain from the top wall's position.",
        data)))

    if all("void_ratio" in _series(directory, c) and "swelling_index" in r["cycles"][0]
           for c, r in runs.items()):
        items += compressibility_items(directory, runs, tag, figures)

    # per cycle: residual strain, work of the top wall, law dissipation, coordination
    fig, axes = plt.subplots(1, 3, figsize=(12, 3.6))
    data = {}
    for contact, r in runs.items():
        n = np.array([c["cycle"] for c in r["cycles"]], dtype=float)
        res = np.array([c["residual_strain"] for c in r["cycles"]])
        work = np.array([c["wall_work_J"] for c in r["cycles"]])
        coord = np.array([c["contacts_per_grain"] for c in r["cycles"]])
        colour = COLOURS[contact]
        axes[0].plot(n, res * 1e3, "o-", ms=4, label=contact, color=colour)
        axes[1].plot(n, work * 1e3, "o-", ms=4, label=f"{contact}: wall work", color=colour)
        if contact == "geocontact":
            law = np.array([c["law_dissipated_J"] for c in r["cycles"]])
            axes[1].plot(n, law * 1e3, "s--", ms=4, label="geocontact: law dissipation",
                         color=colour, alpha=0.6)
            data[f"{contact}_law_dissipated_J"] = law
        axes[2].plot(n, coord, "o-", ms=4, label=contact, color=colour)
        data[f"{contact}_cycle"] = n
        data[f"{contact}_residual_strain"] = res
        data[f"{contact}_wall_work_J"] = work
        data[f"{contact}_contacts_per_grain"] = coord
    axes[0].set_ylabel("residual strain of the cycle (‰)")
    axes[1].set_ylabel("energy per cycle (mJ)")
    axes[2].set_ylabel("contacts per grain (at the valley)")
    for ax in axes:
        ax.set_xlabel("cycle")
        ax.xaxis.get_major_locator().set_params(integer=True)
        ax.axhline(0, color="0.7", lw=0.6)
        ax.legend(fontsize=7)
    items.append(save_to_figures(fig, figures, Figure(
        f"{tag}_cycles", "Residual strain, energy and coordination per cycle",
        "Wall work: ∮ σ dε V, the work of the top wall from valley to valley (in a closed cycle "
        "the energy dissipated by the law, friction and damping); law dissipation: the normal "
        "law's own (pair and walls). Cycles 1–3 repeated, 4–6 increasing, 7–9 decreasing "
        "amplitude (default targets).", data)))

    g = runs.get("geocontact")
    if g and "energy" in g:
        ledgers = {f"cycle {c['cycle']}": c["energy"] for c in g["cycles"]}
        ledgers["all cycles"] = g["energy"]
        items.append(ledger_figure(
            ledgers, figures, f"{tag}_energy_ledger",
            "geocontact (pair and walls): where the walls' work went, per cycle and over the "
            "cycles — the change of kinetic and stored energy and the energy each channel "
            "dissipated, as a share of the walls' own work (Σ F·v_wall dt); the closure "
            f"residual over the cycles is {100 * g['energy']['closure_residual_fraction']:.2f} % "
            "of the work."))
    contacts_csv = directory / "geocontact" / "residual_approach.csv"
    if g and contacts_csv.is_file():
        res = read_csv_column(contacts_csv, "residual_approach_m")
        top = read_csv_column(contacts_csv, "max_approach_m")
        fig, axes = plt.subplots(1, 2, figsize=(10, 3.6))
        axes[0].hist(res * 1e9, bins=40, color="C0")
        axes[0].set_xlabel("residual approach δres (nm)")
        axes[0].set_ylabel("contacts")
        axes[1].hist(res / top, bins=40, range=(0, 1), color="C1")
        axes[1].set_xlabel("δres / δmax")
        ra = g["residual_approach"]
        items.append(save_to_figures(fig, figures, Figure(
            f"{tag}_residual_approach", "Per-contact residual approach at the end",
            f"geocontact, {ra['contacts']} contacts that ever touched ({ra['in_contact']} in "
            f"contact at the end, {ra['plastic']} with δres > 0); median "
            f"{ra['median_m'] * 1e9:.3g} nm. Granular Hertz has none (elastic).",
            {"residual_approach_m": res, "max_approach_m": top})))
    report.add(f"DEM {s['test']} {rel or '.'}", *items)
