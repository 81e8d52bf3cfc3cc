"""Report section of a laboratory-test fit (``geocontact fit``: the ``P.fit/`` folder): the
record against the fitted law with the residuals, the contact point and yield, the identified
material with its bootstrap standard errors and what was given or assumed."""

from __future__ import annotations

import json
from html import escape as html_escape
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

from ..figures import Figure, save_figure
from ..files import read_csv_column
from .common import relative_dir, save_to_figures
from .html import Report, table

SCHEMA = "geocontact.labfit/1"


def read_fit(directory: Path) -> dict | None:
    path = directory / "fit.json"
    if not path.is_file():
        return None
    try:
        document = json.loads(path.read_text())
    except (json.JSONDecodeError, UnicodeDecodeError):
        return None
    return document if isinstance(document, dict) and document.get("schema") == SCHEMA else None


def is_labfit(directory: Path) -> bool:
    return read_fit(directory) is not None and (directory / "curve.csv").is_file()


def _curve(directory: Path) -> dict[str, np.ndarray]:
    return {c: read_csv_column(directory / "curve.csv", c)
            for c in ("approach_m", "force_N", "law_approach_m", "law_force_N", "branch")}


def _figures(directory: Path, tag: str) -> list[tuple]:
    """(matplotlib figure, Figure record) of the fit and of the contact/yield zoom."""
    doc = read_fit(directory)
    c = _curve(directory)
    d, f, law, branch = c["approach_m"], c["force_N"], c["law_force_N"], c["branch"]
    dl = c["law_approach_m"]  # the smoothed approach the law was driven along
    peak = float(f.max())
    rms = doc["law_along_record"]["force_rms_percent_of_peak"]
    fig, (ax, ax2) = plt.subplots(2, 1, figsize=(6.2, 5.6), sharex=False,
                                  gridspec_kw={"height_ratios": [3, 1.3]})
    names = doc.get("branches", {})
    colours = {"1": "0.2", "2": "tab:blue", "3": "tab:green", "4": "0.7", "0": "0.85"}
    for code in ("0", "1", "2", "3", "4"):
        on = branch == int(code)
        if on.any():
            ax.plot(d[on] * 1e6, f[on], ".", ms=1.6, color=colours[code],
                    label=names.get(code, code))
    ax.plot(dl * 1e6, law, "-", lw=1.0, color="tab:red", label="fitted law")
    ax.set_xlabel("pair approach δ (µm, from the contact point)")
    ax.set_ylabel("force F (N)")
    ax.legend(fontsize=7, loc="upper left", markerscale=4)
    ax.grid(alpha=0.3)
    ax.set_title(f"law along the record: RMS {rms:.2f} % of the peak force", fontsize=9)
    index = np.arange(d.size)
    ax2.plot(index, 100.0 * (f - law) / peak, ".", ms=1.2, color="0.3")
    ax2.axhline(0.0, color="tab:red", lw=0.8)
    ax2.set_xlabel("record point")
    ax2.set_ylabel("data − law (% peak)")
    ax2.grid(alpha=0.3)
    fig.tight_layout()
    test = doc["test"]
    one = Figure(f"{tag}fit", "Fitted law against the test",
                 f"{html_escape(Path(test['curve']).name)}, set-up {test['setup']}, R = "
                 f"{test['radius_m']:.4g} m: the conditioned record (machine compliance "
                 "removed, from the fitted contact point, pair approach) by branch, the law "
                 "driven along it, and the residual.",
                 {"approach_m": d, "force_N": f, "law_approach_m": dl, "law_force_N": law,
                  "branch": branch})
    # contact and yield: the first loading on log axes with Hertz and the yield point
    material = doc["material"]["values"]
    y = doc["yield"]
    virgin = (branch == 1) & (d > 0) & (f > 0)
    fig2, bx = plt.subplots(figsize=(5.6, 4.0))
    bx.loglog(d[virgin] * 1e6, f[virgin], ".", ms=2, color="0.3", label="virgin loading")
    grid = np.geomspace(max(d[virgin].min(), 1e-3 * d.max()), d.max(), 200)
    kh = y["force_N"] / y["approach_m"] ** 1.5
    bx.loglog(grid * 1e6, kh * grid**1.5, "--", color="tab:blue", lw=1,
              label=f"Hertz, E = {material['youngs_modulus'] / 1e9:.4g} GPa")
    on = virgin & (dl > 0) & (law > 0)
    order = np.argsort(dl[on])
    bx.loglog(dl[on][order] * 1e6, law[on][order], "-", color="tab:red", lw=1.2,
              label="fitted law")
    bx.plot([y["approach_m"] * 1e6], [y["force_N"]], "o", color="tab:red", mfc="none",
            label=f"yield Fy = {y['force_N']:.3g} N")
    dep = doc.get("departure_from_hertz") or {}
    if dep:
        bx.plot([dep["approach_m"] * 1e6], [dep["force_N"]], "s", color="tab:orange",
                mfc="none", label="leaves Hertz by 3 %")
    bx.set_xlabel("pair approach δ (µm)")
    bx.set_ylabel("force F (N)")
    bx.legend(fontsize=7)
    bx.grid(alpha=0.3, which="both")
    two = Figure(f"{tag}yield", "Contact point, Hertz part and yield",
                 "The virgin loading on log axes: Hertz with the fitted E*, the law, its yield "
                 "point (the FE first yield of the identified material when identified) and "
                 "where the record leaves Hertz by 3 %.",
                 {"approach_m": d[virgin], "force_N": f[virgin],
                  "law_approach_m": dl[virgin], "law_force_N": law[virgin]})
    return [(fig, one), (fig2, two)]


def draw_fit_figures(directory: Path, into: Path) -> list[Figure]:
    """The fit's figures as PNG + CSV in ``into`` (the fit folder itself)."""
    out = []
    for fig, record in _figures(directory, ""):
        save_figure(fig, into, record)
        out.append(record)
    return out


def _pm(value, se, scale=1.0, digits=4):
    if value is None:
        return "-"
    text = f"{value / scale:.{digits}g}"
    return text + (f" ± {se / scale:.2g}" if se else "")


def labfit_section(report: Report, directory: Path, root: Path, figures: Path) -> None:
    doc = read_fit(directory)
    where = relative_dir(directory, root) or "."
    tag = where.strip("/").replace("/", "_").replace(".", "_") + "_" if where != "." else "fit_"
    items = []
    for fig, record in _figures(directory, tag):
        items.append(save_to_figures(fig, figures, record))
    fitted = doc["fitted"]
    m = doc["material"]["values"]
    rows = [
        ["E (GPa)", _pm(fitted["youngs_modulus_Pa"]["value"],
                        fitted["youngs_modulus_Pa"]["standard_error"], 1e9),
         "fitted (E* of the virgin loading with the FE master curve)"
         if doc["identification"].get("rounds") else "fitted (E* of the Hertz part)"],
        ["σc (MPa)", _pm(fitted["compressive_yield_stress_Pa"]["value"],
                         fitted["compressive_yield_stress_Pa"]["standard_error"], 1e6),
         html_escape(doc["yield"].get("source", ""))],
        ["ν", f"{m['poissons_ratio']:g}",
         "assumed" if "poissons_ratio" in doc["assumed"] else "given"],
        ["β (deg)", f"{m['friction_angle_deg']:g}",
         "assumed" if "friction_angle_deg" in doc["assumed"] else "given"],
        ["m", f"{m['hardening_ratio']:g}",
         "assumed" if "hardening_ratio" in doc["assumed"] else "given"],
        ["Fy (N)", _pm(fitted["yield_force_N"]["value"],
                       fitted["yield_force_N"]["standard_error"]), "fitted"],
        ["machine stiffness (N/m)", f"{k:.4g}" if (k := doc["test"].get(
            "machine_stiffness_N_per_m")) else "none subtracted",
         "given: F / k removed from the displacement" if k else
         "not given: a press's own compliance left in the record lowers E and σc"],
    ]
    for key in ("elastic_plastic_exponent", "fully_plastic_exponent", "unloading_power",
                "reloading_power", "residual_limit"):
        rows.append([key, _pm(fitted[key]["value"], fitted[key]["standard_error"]), "fitted"])
    cycles = [[c["cycle"], c["max_force_N"], c["max_approach_m"] * 1e6,
               c["residual_approach_m"] * 1e6, c["plastic_work_J"]] for c in doc["cycles"]]
    boot = doc.get("bootstrap") or {}
    notes = (f"<p>Standard errors: {html_escape(boot.get('method', 'none (no bootstrap)'))}"
             + (f"; {boot.get('succeeded')} of {boot.get('samples')} samples, seed "
                f"{boot.get('seed')}." if boot else ".") + "</p>")
    beta = ", ".join(f"β = {r['friction_angle_deg']:g}°: "
                     f"{r['compressive_yield_stress_Pa'] / 1e6:.3g}"
                     for r in doc["sigma_c_of_beta"])
    report.add(
        f"Laboratory-test fit {directory.resolve().name if where == '.' else where}",
        f"<p>Law file <code>{html_escape(doc['params_file'])}</code>, fitted to "
        f"<code>{html_escape(doc['test']['curve'])}</code> ({doc['test']['points']} points, "
        f"set-up {doc['test']['setup']}). Law along the record: RMS "
        f"{doc['law_along_record']['force_rms_percent_of_peak']:.2f} % of the peak force.</p>",
        table(["value", "fit", "source"], rows), notes,
        table(["cycle", "Fmax (N)", "δmax (µm)", "δres (µm)", "Wp (J)"], cycles),
        f"<p>What one test cannot separate: σc (MPa) against β at the fitted yield force "
        f"(analytic incipient yield): {html_escape(beta)}.</p>",
        *items)
