"""Figures and tables of the universal law's dataset (docs/universal.md): the normalised data of
every campaign point, the leave-one-out errors of the surfaces, and the depth range the FE
covers at each E/sigma_c (contact radius and approach over R at the top level, from the FE
runs in the cache).

    PYTHONPATH=src .venv/bin/python scripts/universal_report.py --out docs/universal \
        --cache out/cache/universal
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np

from geocontact.errors import ArgumentParser, run_reporting_errors
from geocontact.files import write_json_atomic, write_text_atomic
from geocontact.universal.dataset import LEVEL_FIELDS, read_points, read_provenance
from geocontact.universal.design import LEVELS, force_levels
from geocontact.universal.interpolate import surfaces


def depth_range(data, record, cache: Path) -> list[dict]:
    rows = []
    for i, index in enumerate(data["index"].astype(int)):
        point = record["points"].get(str(index))
        if point is None:
            continue
        top = cache / point["cache_keys"][-1] / "summary.json"
        if not top.exists():
            continue
        summary = json.loads(top.read_text())
        peak = summary["contact_resolution"]["elements_across_contact_radius"]["peak"]
        radius = point["material"]["radius"]
        cycles = summary["cycles"][0]
        rows.append({"index": int(index), "s": float(data["log10_modulus_over_strength"][i]),
                     "beta": float(data["friction_angle_deg"][i]),
                     "top_force_over_yield": float(force_levels(
                         data["log10_modulus_over_strength"][i])[-1]),
                     "top_depth_x": float(10 ** data[f"logx_{LEVELS - 1}"][i]),
                     "contact_radius_over_R": peak["contact_radius_m"] / radius,
                     "approach_over_R": cycles["max_approach_m"] / radius
                     if "max_approach_m" in cycles else None,
                     "elements": summary["mesh"]["elements"],
                     "point_wall_time_s": sum(point["run_wall_time_s"])})
    return rows


def main(argv=None) -> int:
    parser = ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", required=True)
    parser.add_argument("--dataset", default=None)
    parser.add_argument("--cache", default="out/cache/universal")

    def run() -> int:
        args = parser.parse_args(argv)  # a bad flag is one line, not a traceback
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        out = Path(args.out)
        out.mkdir(parents=True, exist_ok=True)
        data = read_points(args.dataset)
        record = read_provenance(args.dataset)
        n = data["index"].size
        table = surfaces(args.dataset)
        loo = table.loo_summary()
        ranges = depth_range(data, record, Path(args.cache))
        write_json_atomic(out / "dataset-summary.json", {
            "points": n, "dataset_sha256": table.dataset_sha256, "loo": loo,
            "depth_range": ranges})
        lines = ["| quantity | LOO RMS | LOO max | kernel(s) |", "|---|---|---|---|"]
        for group, e in loo.items():
            lines.append(f"| {group} | {e['rms']:.3g} | {e['max']:.3g} | "
                         f"{', '.join(e['kernels'])} |")
        write_text_atomic(out / "loo.md", "\n".join(lines) + "\n")
        lines = ["| E/σc | top F/Fy | top x = δmax/δy | a/R at top | δmax/R at top | "
                 "elements | FE wall time of the point (s) |", "|---|---|---|---|---|---|---|"]
        for r in sorted(ranges, key=lambda r: (r["s"], r["index"])):
            dr = "–" if r["approach_over_R"] is None else f"{r['approach_over_R']:.3g}"
            lines.append(f"| {10 ** r['s']:.0f} | {r['top_force_over_yield']:.0f} | "
                         f"{r['top_depth_x']:.0f} | {r['contact_radius_over_R']:.3f} | {dr} | "
                         f"{r['elements']} | {r['point_wall_time_s']:.0f} |")
        write_text_atomic(out / "depth-range.md", "\n".join(lines) + "\n")

        fig, axes = plt.subplots(1, 3, figsize=(13, 3.8))
        cmap = plt.get_cmap("viridis")
        for i in range(n):
            colour = cmap(data["friction_angle_deg"][i] / 55.0)
            x = 10 ** np.array([data[f"logx_{k}"][i] for k in range(LEVELS)])
            for ax, name in zip(axes[:2], ("residual", "work"), strict=True):
                ax.plot(x, [data[f"{name}_{k}"][i] for k in range(LEVELS)], "o-", ms=3,
                        lw=0.8, color=colour)
            axes[2].plot(x, [data[f"unloading_exponent_{k}"][i] for k in range(LEVELS)],
                         "o-", ms=3, lw=0.8, color=colour)
        for ax, label in zip(axes, ("δres/δmax", "Wp/Wtotal", "unloading exponent n_u"),
                             strict=True):
            ax.set_xscale("log")
            ax.set_xlabel("x = δmax/δy (analytic δy)")
            ax.set_ylabel(label)
            ax.grid(alpha=0.3)
        sm = plt.cm.ScalarMappable(cmap=cmap, norm=plt.Normalize(0, 55))
        fig.colorbar(sm, ax=axes, label="friction angle β (deg)")
        fig.suptitle(f"Universal law dataset: {n} campaign points, coarse-mesh FE, "
                     "7 levels each", fontsize=10)
        fig.savefig(out / "dataset.png", dpi=110)
        plt.close(fig)
        assert set(LEVEL_FIELDS) >= {"residual", "work"}
        print(json.dumps({"points": n, "loo": loo}, indent=2))
        return 0

    return run_reporting_errors(run)


if __name__ == "__main__":
    sys.exit(main())
