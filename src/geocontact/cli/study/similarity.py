"""The similarity study of material space (issue 12, docs/model.md §10; docs/similarity.md).

FE load-unload-reload runs of the reference grain (nu, beta, m) = (0.25, 30 deg, 0) at
E / sigma_c = 10^2 ... 10^4 (sigma_c varied at fixed E and R), each to the same peaks in units
of its own first-yield force on a mesh sized from its own contact radii (data/similarity.toml),
then: the normalised numbers of every run (x, F / Fy, delta_res / delta_max, Wp / Wt, n_u, n_r),
their collapse, and the finite-size deviation from the half-space curve with its fitted form.

    # FE runs (cached in --cache by their inputs and the FE code: a rerun resumes) + analysis
    nice -n 5 geocontact study similarity --out out/similarity
    # ... and publish the dataset (src/geocontact/data/similarity-*) and figures (docs/similarity)
    nice -n 5 geocontact study similarity --out out/similarity \
        --publish
    # figures and fits again from the committed dataset alone, no FE
    geocontact study similarity --from-data --out out/sim-data
"""

from __future__ import annotations

import json
import math
import shutil
import sys
import time
from pathlib import Path

import numpy as np

from ...calibrate import similarity as sim
from ...errors import ArgumentParser, InputError
from ...fem.campaign import DEFAULT_CACHE, run_campaign
from ...fem.identity import fe_code_hash
from ...files import Output, atomic_directory, atomic_path, claim, provenance, write_csv

DATA = Path(__file__).resolve().parents[2] / "data"  # the package data --publish updates
DOCS = Path("docs") / "similarity"  # of the checkout the study runs in
COMMAND = "geocontact study similarity"
ROW_KEYS = ("modulus_ratio", "poissons_ratio", "friction_angle_deg", "mesh", "peak_over_yield",
            "depth", "approach_over_radius", "contact_radius_over_radius",
            "yield_contact_radius_over_radius", "force_over_limit", "residual_ratio",
            "plastic_work_ratio", "dissipation_ratio", "unloading_exponent",
            "reloading_exponent", "unloading_fit_rms", "reloading_fit_rms",
            "fe_yield_over_analytic", "elements_across_contact_at_peak",
            "elements_across_contact_at_yield", "mesh_elements", "steps", "newton_iterations",
            "wall_time_s", "cache_key")
CURVE_KEYS = ("modulus_ratio", "peak_over_yield", "depth", "force_over_yield",
              "contact_radius_over_radius")


# --- FE -> rows ---------------------------------------------------------------------------------
def run_study(cache: Path) -> tuple[list[dict], list[dict], list]:
    runs = sim.study_jobs()
    # cheapest first (the smallest peaks), so an interrupted study has the most points cached
    order = sorted(range(len(runs)), key=lambda i: (runs[i].peak_over_yield,
                                                     runs[i].modulus_ratio_exponent))
    print(f"similarity: {len(runs)} FE runs (cache {cache})", file=sys.stderr)
    results = run_campaign([runs[i].job for i in order], cache, workers=1)
    by_index = dict(zip(order, results, strict=True))
    rows, curves = [], []
    for i, run in enumerate(runs):
        result = by_index[i]
        row = sim.measure(run.job, result)
        row["design_depth"] = run.design_depth if run.design_depth is not None else math.nan
        rows.append(row)
        if sim.on_ratio_axis(row):
            curve = sim.loading_curve(run.job, result)
            for k in range(len(curve["depth"])):
                curves.append({"modulus_ratio": row["modulus_ratio"],
                               "peak_over_yield": row["peak_over_yield"],
                               **{key: float(curve[key][k]) for key in CURVE_KEYS[2:]}})
    return rows, stitch(curves), runs


def stitch(curves: list[dict]) -> list[dict]:
    """Per grain, the virgin curve from the run with the smallest peak above each force (the
    best-resolved one there, as calibrate.campaign.virgin_curve): run k's points between the
    peaks of runs k-1 and k."""
    out = []
    for ratio in sorted({c["modulus_ratio"] for c in curves}):
        mine = [c for c in curves if c["modulus_ratio"] == ratio]
        below = 0.0
        for peak in sorted({c["peak_over_yield"] for c in mine}):
            out += [c for c in mine if c["peak_over_yield"] == peak
                    and c["force_over_yield"] > below and c["force_over_yield"] > 0.0]
            below = peak
    return out


def columns(rows: list[dict], keys) -> dict[str, np.ndarray]:
    return {key: np.array([row[key] for row in rows]) for key in keys}


# --- fits ---------------------------------------------------------------------------------------
def fits(rows: list[dict], curves: list[dict]) -> tuple[dict, dict]:
    out, data = {}, {}
    for quantity in sim.FITTED:
        data[quantity] = sim.deviations(rows, quantity, sim.HALF_SPACE_BELOW, curves)
        fit = sim.fit_finite_size(data[quantity], quantity, sim.FIT_MAX_APPROACH).to_dict()
        out[quantity] = {**fit, "fe_scatter_small_contacts": data[quantity]["floor"],
                         "fe_scatter_points": data[quantity]["floor_points"]}
    return {"half_space_below_contact_radius_over_radius": sim.HALF_SPACE_BELOW,
            "fit_max_approach_over_radius": sim.FIT_MAX_APPROACH, "fits": out}, data


def collapse_spread(rows: list[dict], max_contact: float) -> dict:
    """Largest difference between grains at the same design peak, over the runs whose contact
    stays below ``max_contact`` x R: how well E / sigma_c drops out there."""
    coarse = [r for r in rows if sim.on_ratio_axis(r)]
    spread = {}
    for key in ("depth", "residual_ratio", "plastic_work_ratio", "unloading_exponent",
                "reloading_exponent", "fe_yield_over_analytic"):
        worst = 0.0
        for peak in sorted({r["peak_over_yield"] for r in coarse}):
            values = [r[key] for r in coarse if r["peak_over_yield"] == peak
                      and r["contact_radius_over_radius"] < max_contact]
            if len(values) > 1:
                worst = max(worst, (max(values) - min(values))
                            / (abs(np.mean(values)) if key in ("depth",) else 1.0))
        spread[key] = worst
    return spread


# --- figures ------------------------------------------------------------------------------------
def figures(rows: list[dict], curves: list[dict], fit: dict, data: dict, folder: Path) -> list:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    coarse = [r for r in rows if sim.on_ratio_axis(r)]
    ratios = sorted({r["modulus_ratio"] for r in coarse})
    colours = plt.cm.viridis(np.linspace(0.0, 0.9, len(ratios)))
    names = []

    fig, axes = plt.subplots(2, 2, figsize=(10, 8))
    panels = [("force", "F / Fy"), ("residual_ratio", r"$\delta_{res}/\delta_{max}$"),
              ("plastic_work_ratio", r"$W_p / W_t$"), ("unloading_exponent", r"$n_u$")]
    for ax, (key, label) in zip(axes.flat, panels, strict=True):
        for ratio, colour in zip(ratios, colours, strict=True):
            tag = f"E/σc = 10^{math.log10(ratio):.1f}"
            if key == "force":
                mine = [c for c in curves if c["modulus_ratio"] == ratio and c["depth"] > 0]
                ax.loglog([c["depth"] for c in mine], [c["force_over_yield"] for c in mine],
                          "-", color=colour, lw=1.2, label=tag)
                continue
            mine = sorted((r for r in coarse if r["modulus_ratio"] == ratio),
                          key=lambda r: r["depth"])
            x = [r["depth"] for r in mine]
            y = [r[key] for r in mine]
            ax.semilogx(x, y, "-", color=colour, lw=1.0, label=tag)
            big = [r["contact_radius_over_radius"] > 0.1 for r in mine]
            ax.scatter(x, y, s=22, color=colour, zorder=3,
                       facecolors=["none" if b else colour for b in big])
        check = [r for r in rows if r["mesh"] != sim.settings()["study"]["mesh"]]
        if key != "force" and check:
            ax.scatter([r["depth"] for r in check], [r[key] for r in check], marker="x",
                       s=50, color="red", zorder=4, label=f"{check[0]['mesh']} mesh")
        ax.set_xlabel(r"$x = \delta_{max}/\delta_y$")
        ax.set_ylabel(label)
        ax.grid(True, which="both", alpha=0.3)
    axes.flat[0].legend(fontsize=8)
    axes.flat[1].legend(fontsize=7, loc="lower right")
    fig.suptitle("Collapse over E/σc, (ν, β, m) = (0.25, 30°, 0); open symbols: a > 0.1 R")
    fig.tight_layout()
    names.append(save(fig, folder, "similarity-collapse.png"))

    fig, grid = plt.subplots(2, 3, figsize=(15, 8.5))
    axes = list(grid.flat[:len(sim.FITTED)])
    grid.flat[-1].axis("off")
    titles = {"force": r"$F/F_{hs} - 1$ at the same x (loading curves)",
              "residual_ratio": r"$\delta_{res}/\delta_{max}$ minus half-space",
              "plastic_work_ratio": r"$W_p/W_t$ minus half-space",
              "unloading_exponent": r"$n_u$ minus half-space",
              "reloading_exponent": r"$n_r$ minus half-space"}
    norm = matplotlib.colors.LogNorm(vmin=0.5, vmax=1000.0)
    for ax, quantity in zip(axes, sim.FITTED, strict=True):
        d = data[quantity]
        points = ax.scatter(d["approach_over_radius"], d["deviation"], c=d["depth"], norm=norm,
                            cmap="plasma", s=9 if quantity == "force" else 28, zorder=3)
        f = fit["fits"][quantity]
        theta = [f["parameters"][n] for n in sim.PARAMETERS]
        for depth in (3.0, 30.0, 300.0):
            # where the study has grains: delta / R up to x delta_y / R of E / sigma_c = 10^2
            top = min(sim.FIT_MAX_APPROACH, depth * f["yield_approach_over_radius_max"])
            s_line = np.geomspace(1e-7, top, 200)
            ax.plot(s_line, sim.finite_size_model(theta, s_line, depth), "-",
                    color=plt.cm.plasma(norm(depth)), lw=1.4, label=f"fit, x = {depth:g}")
        ax.axvline(sim.FIT_MAX_APPROACH, color="grey", ls=":", lw=1)
        ax.axhline(0.0, color="k", lw=0.5)
        ax.set_xscale("log")
        ax.set_xlim(1e-5, 1.0)
        ax.set_xlabel(r"$\delta/R$" + (" (peak)" if quantity != "force" else ""))
        ax.set_title(titles[quantity], fontsize=10)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7, loc="lower left" if quantity == "force" else "upper left")
        if quantity == "force":
            ax.set_ylim(-0.4, 0.1)
    legend = grid.flat[-1]
    fig.colorbar(points, cax=legend.inset_axes([0.05, 0.1, 0.06, 0.8]),
                 label=r"$x = \delta/\delta_y$")
    legend.text(0.3, 0.5, "deviation = e √s + p s^k x^q,\ns = δ/R, x = δ/δy;\nhalf-space: "
                f"a < {sim.HALF_SPACE_BELOW:g} R\n(force: E/σc = 10^4)", transform=legend.transAxes,
                va="center", fontsize=9)
    fig.suptitle("Finite size: the deviation from the half-space curve and its fit up to "
                 f"δ/R = {sim.FIT_MAX_APPROACH:g} (dotted)", fontsize=10)
    fig.tight_layout()
    names.append(save(fig, folder, "similarity-finite-size.png"))

    axes_config = sim.settings().get("axes")
    if axes_config:
        ratio = 10.0 ** axes_config["modulus_ratio_exponent"]
        mesh = sim.settings()["study"]["mesh"]
        same = [r for r in rows if r["mesh"] == mesh and math.isclose(r["modulus_ratio"], ratio)]
        variants = sorted({(r["poissons_ratio"], r["friction_angle_deg"]) for r in same})
        fig, axes = plt.subplots(1, 4, figsize=(16, 4))
        for nu, beta in variants:
            mine = sorted((r for r in same if (r["poissons_ratio"], r["friction_angle_deg"])
                           == (nu, beta)), key=lambda r: r["depth"])
            style = "k-o" if (nu, beta) == (0.25, 30.0) else ("-s" if nu != 0.25 else "-^")
            for ax, key in zip(axes, ("peak_over_yield", "residual_ratio",
                                      "plastic_work_ratio", "unloading_exponent"), strict=True):
                ax.plot([r["depth"] for r in mine], [r[key] for r in mine], style, ms=4,
                        label=f"ν = {nu:g}, β = {beta:g}°")
        for ax, label in zip(axes, ("F / Fy", r"$\delta_{res}/\delta_{max}$", r"$W_p/W_t$",
                                    r"$n_u$"), strict=True):
            ax.set_xscale("log")
            ax.set_xlabel(r"$x = \delta_{max}/\delta_y$")
            ax.set_ylabel(label)
            ax.grid(True, which="both", alpha=0.3)
        axes[0].set_yscale("log")
        axes[1].legend(fontsize=7)
        fig.suptitle(f"The axes that stay: ν and β at E/σc = 10^{math.log10(ratio):.1f}, m = 0")
        fig.tight_layout()
        names.append(save(fig, folder, "similarity-axes.png"))
    return names


def save(fig, folder: Path, name: str) -> str:
    import matplotlib.pyplot as plt

    fig.savefig(folder / name, dpi=110)
    plt.close(fig)
    return name


# --- the whole study ----------------------------------------------------------------------------
def table(rows: list[dict]) -> str:
    lines = ["| E/σc | ν | β | F/Fy | x | δ/R | a/R | δres/δmax | Wp/Wt | n_u | n_r | elements "
             "across a (peak) | wall s |", "|" + "---|" * 13]
    for r in sorted(rows, key=lambda r: (not sim.on_ratio_axis(r), r["mesh"] != "coarse",
                                         r["friction_angle_deg"], r["poissons_ratio"],
                                         r["peak_over_yield"], r["modulus_ratio"])):
        mesh = "" if r["mesh"] == "coarse" else f" ({r['mesh']} mesh)"
        lines.append(
            f"| 10^{math.log10(r['modulus_ratio']):.1f}{mesh} | {r['poissons_ratio']:g} | "
            f"{r['friction_angle_deg']:g}° | {r['peak_over_yield']:.4g} | "
            f"{r['depth']:.4g} | {r['approach_over_radius']:.3g} | "
            f"{r['contact_radius_over_radius']:.3g} | {r['residual_ratio']:.4f} | "
            f"{r['plastic_work_ratio']:.4f} | {r['unloading_exponent']:.4f} | "
            f"{r['reloading_exponent']:.4f} | {r['elements_across_contact_at_peak']:.1f} | "
            f"{r['wall_time_s']:.0f} |")
    return "\n".join(lines) + "\n"


def correction_table(fit: dict) -> str:
    """The fitted deviation on a grid of E / sigma_c and x: F / F_hs - 1 (%) and the shift of
    delta_res / delta_max and of n_u; "-" outside the fit's domain."""
    depths = (2.0, 10.0, 30.0, 100.0, 300.0, 900.0)
    lines = ["| E/σc | " + " | ".join(f"x = {x:g}" for x in depths) + " |",
             "|---|" + "---|" * len(depths)]
    for exponent in sim.settings()["study"]["modulus_ratio_exponents"]:
        yield_approach = sim._yield_approach_over_radius(10.0 ** exponent)
        cells = []
        for x in depths:
            try:
                force = sim.finite_size_factor(x, x * yield_approach, fits=fit) - 1.0
                residual = sim.finite_size_factor(x, x * yield_approach,
                                                  quantity="residual_ratio", fits=fit)
                n_u = sim.finite_size_factor(x, x * yield_approach,
                                             quantity="unloading_exponent", fits=fit)
            except InputError:
                cells.append("–")
                continue
            cells.append(f"{100 * force:+.1f} % / {residual:+.3f} / {n_u:+.3f}")
        lines.append(f"| 10^{exponent:g} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def mesh_check_table(rows: list[dict]) -> str:
    """Each default-mesh run beside the coarse run of the same grain and peak."""
    lines = ["| E/σc | F/Fy | a/R | x coarse / default | δres/δmax | Wp/Wt | n_u |",
             "|---|---|---|---|---|---|---|"]
    study_mesh = sim.settings()["study"]["mesh"]
    for check in sorted((r for r in rows if r["mesh"] != study_mesh),
                        key=lambda r: (r["peak_over_yield"], r["modulus_ratio"])):
        coarse = [r for r in rows if sim.on_ratio_axis(r)
                  and math.isclose(r["modulus_ratio"], check["modulus_ratio"])
                  and math.isclose(r["peak_over_yield"], check["peak_over_yield"], rel_tol=1e-6)]
        if not coarse:
            continue
        c = coarse[0]
        lines.append(
            f"| 10^{math.log10(c['modulus_ratio']):.1f} | {c['peak_over_yield']:.4g} | "
            f"{check['contact_radius_over_radius']:.3f} | {c['depth']:.4g} / {check['depth']:.4g} "
            f"({100 * (c['depth'] / check['depth'] - 1):+.1f} %) | "
            + " | ".join(f"{c[k]:.4f} / {check[k]:.4f}" for k in (
                "residual_ratio", "plastic_work_ratio", "unloading_exponent")) + " |")
    return "\n".join(lines) + "\n"


def deep_check_table(rows: list[dict], curves: list[dict], fit: dict) -> str:
    """The fitted force correction against the deviation each mesh measures at the peaks with a
    default-mesh twin: F / F_hs - 1 at the grain's x, from its x and the half-space grain's
    (largest E / sigma_c) x at the same peak force on the same mesh, F_hs ~ x^n with n the local
    slope of the half-space loading curve."""
    reference = max(r["modulus_ratio"] for r in rows)
    ref_curve = [c for c in curves if math.isclose(c["modulus_ratio"], reference)]
    slope = sim.half_space_interpolant(
        [c["depth"] for c in ref_curve], [c["force_over_yield"] for c in ref_curve])
    top = max(c["depth"] for c in ref_curve)
    study_mesh = sim.settings()["study"]["mesh"]

    def twin(mesh, ratio, peak):
        return next((r for r in rows if r["mesh"] == mesh and sim.on_ratio_axis(
            {**r, "mesh": study_mesh}) and math.isclose(r["modulus_ratio"], ratio)
            and math.isclose(r["peak_over_yield"], peak, rel_tol=1e-6)), None)

    lines = ["| E/σc | F/Fy | δ/R | x (default) | F/F_hs − 1, coarse | default | fit |",
             "|---|---|---|---|---|---|---|"]
    checks = sorted((r for r in rows if r["mesh"] != study_mesh
                     and not math.isclose(r["modulus_ratio"], reference)),
                    key=lambda r: (r["peak_over_yield"], r["modulus_ratio"]))
    for check in checks:
        cells = []
        for mesh in (study_mesh, check["mesh"]):
            grain = twin(mesh, check["modulus_ratio"], check["peak_over_yield"])
            half = twin(mesh, reference, check["peak_over_yield"])
            if grain is None or half is None:
                cells.append(None)
                continue
            x, x_hs = grain["depth"], half["depth"]
            at = min(x_hs, top / 1.06)  # the local slope between the two, inside the curve
            n = math.log(slope(1.05 * at) / slope(at / 1.05)) / math.log(1.05 ** 2)
            cells.append((x_hs / x) ** n - 1.0)
        if cells[1] is None:
            continue
        try:
            predicted = sim.finite_size_factor(check["depth"], check["approach_over_radius"],
                                               fits=fit) - 1.0
            predicted_text = f"{100 * predicted:+.1f} %"
        except InputError:
            predicted_text = "outside the fit"
        coarse_text = "–" if cells[0] is None else f"{100 * cells[0]:+.1f} %"
        lines.append(f"| 10^{math.log10(check['modulus_ratio']):.1f} | "
                     f"{check['peak_over_yield']:.4g} | {check['approach_over_radius']:.3g} | "
                     f"{check['depth']:.4g} | {coarse_text} | {100 * cells[1]:+.1f} % | "
                     f"{predicted_text} |")
    return "\n".join(lines) + "\n"


def analyse(rows, curves, folder: Path, inputs: dict) -> dict:
    fit, data = fits(rows, curves)
    document = {**provenance(COMMAND, inputs), "settings": sim.settings(),
                "finite_size": fit,
                "collapse_spread_below_a_over_R_0.05": collapse_spread(rows, 0.05),
                "total_fe_wall_time_s": float(sum(r["wall_time_s"] for r in rows)),
                "runs": len(rows)}
    write_csv(folder / sim.DATASET, columns(rows, ROW_KEYS))
    write_csv(folder / sim.CURVES, columns(curves, CURVE_KEYS))
    (folder / sim.PROVENANCE).write_text(json.dumps(document, indent=2) + "\n")
    (folder / "table.md").write_text(table(rows))
    (folder / "correction-table.md").write_text(correction_table(fit))
    (folder / "mesh-check.md").write_text(mesh_check_table(rows))
    (folder / "deep-check.md").write_text(deep_check_table(rows, curves, fit))
    figures(rows, curves, fit, data, folder)
    return document


def main(argv: list[str] | None = None, prog: str = "geocontact study similarity") -> int:
    parser = ArgumentParser(prog=prog, description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", default="out/similarity", help="result folder")
    parser.add_argument("--cache", default=str(DEFAULT_CACHE), help="FE result cache")
    parser.add_argument("--overwrite", action="store_true")
    parser.add_argument("--from-data", action="store_true",
                        help="no FE: the fits and figures from the committed dataset")
    parser.add_argument("--publish", action="store_true",
                        help="copy the dataset into src/geocontact/data and the figures into "
                             "docs/similarity")
    args = parser.parse_args(argv)
    with claim([Output(args.out, "folder", "--out")], COMMAND, overwrite=args.overwrite):
        return _study(args)


def _study(args) -> int:
    start = time.time()
    if args.from_data:
        rows = sim.read_rows(DATA / sim.DATASET)
        curves = sim.read_rows(DATA / sim.CURVES)
        inputs = {"from_data": str(DATA / sim.DATASET)}
    else:
        rows, curves, runs = run_study(Path(args.cache))
        inputs = {"fe_code_hash": fe_code_hash(),
                  "runs": [r.job.inputs() for r in runs]}
    with atomic_directory(args.out, COMMAND, overwrite=args.overwrite,
                          inputs={"from_data": args.from_data}) as folder:
        document = analyse(rows, curves, folder, inputs)
        if args.publish:
            publish(folder, data=not args.from_data)
    print(json.dumps(document["finite_size"], indent=1))
    print(f"similarity: {len(rows)} runs, FE wall {document['total_fe_wall_time_s']:.0f} s, "
          f"this command {time.time() - start:.0f} s; result in {args.out}", file=sys.stderr)
    return 0


def publish(folder: Path, data: bool = True) -> None:
    """The dataset into the package's data (the finite-size factor reads it; not when it came
    from there, ``data`` False) and the figures and tables into the docs; each file written
    atomically."""
    DOCS.mkdir(parents=True, exist_ok=True)
    targets = [(name, DATA) for name in (sim.DATASET, sim.CURVES, sim.PROVENANCE)] if data \
        else []
    targets += [(p.name, DOCS) for p in sorted(folder.glob("*.png"))]
    targets += [(name, DOCS) for name in ("table.md", "correction-table.md", "mesh-check.md",
                                           "deep-check.md")]
    for name, where in targets:
        with atomic_path(where / name) as tmp:
            shutil.copyfile(folder / name, tmp)

