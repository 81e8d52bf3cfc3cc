"""Partial unloading: how much does a cycle that unloads only part of the way ratchet, in the FE
and in the law's cyclic extension?

The law counts a reversal of depth d = 1 - Fmin/Fmax as the fraction d of a cycle (Miner;
docs/law.md, "Repeated cycles") and ratchets by the fitted cycle law once those fractions add up. A
DEM contact under a shaken or sheared sample sees mostly such partial cycles, many of them tiny
(docs/sample-study.md, "Under micro-cycles the ratchet extension keeps the grains moving"), so
whether the FE's ratchet scales with d is what decides how micro-cycles should count. This drives
the reference grain (sigma_c = 10 MPa, beta = 30 deg) through 0 -> F -> (1 - d) F -> F -> ... (10
peaks, 9 partial unloadings) -> 0 at F = 3000 N, for d = 0.002, 0.01, 0.05, 0.2, 0.5 and 1 (the last
is the paper's repeated history), small strain, on the coarse and the default mesh, and the shipped
calibration (examples/params-reference.json, fitted to the default mesh's full cycles) through the
same forces.

Measured per run: the approach at each valley (the force minimum of each partial unloading)
and at each peak; the valley's rise over the nine reloads (the ratchet seen at the valleys)
and its share of the full cycle's on the same mesh, against Miner's d.

FE runs go through the cached campaign into the committed dataset
``datasets/fe-runs/partial-unloading`` (resumable run by run; the default mesh's full cycle is
the committed paper-histories run), so a rerun with the same FE code is no FE work:

    PYTHONPATH=src nice -n 5 .venv/bin/python scripts/verify_partial_unloading.py \\
        [--mesh coarse default] [--json docs/verification/partial_unloading.json]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "src"))

from geocontact import __version__  # noqa: E402
from geocontact.analyses.force_driven import drive_by_force  # noqa: E402
from geocontact.fem.campaign import FemJob, run_campaign  # noqa: E402
from geocontact.files import write_json_atomic  # noqa: E402
from geocontact.grain.material import preset  # noqa: E402
from geocontact.law import load_params  # noqa: E402

DATASETS = ROOT / "datasets" / "fe-runs"
CACHE = DATASETS / "partial-unloading"
# the paper's repeated history on the default mesh is committed with the paper's runs
PAPER_CACHE = DATASETS / "paper-histories-finite"
PEAK_N = 3000.0
PEAKS = 10
DEPTHS = (0.002, 0.01, 0.05, 0.2, 0.5, 1.0)
LAW = ROOT / "examples" / "params-reference.json"


def history(depth: float) -> tuple[float, ...]:
    """0 -> F, then PEAKS - 1 times (1 - depth) F -> F, then -> 0."""
    low = (1.0 - depth) * PEAK_N
    return (0.0, PEAK_N, *([low, PEAK_N] * (PEAKS - 1)), 0.0)


def turning_points(force: np.ndarray, approach: np.ndarray) -> tuple[list[float], list[float]]:
    """The approach at each peak (force maxima at the top) and each valley (interior minima)."""
    top = force.max()
    peaks, valleys = [], []
    for i in range(1, len(force) - 1):
        if force[i] >= force[i - 1] and force[i] >= force[i + 1] and force[i] > 0.999 * top:
            peaks.append(float(approach[i]))
        elif force[i] < force[i - 1] and force[i] <= force[i + 1]:
            valleys.append(float(approach[i]))
    return peaks, valleys


def measures(force, approach) -> dict:
    peaks, valleys = turning_points(np.asarray(force), np.asarray(approach))
    if len(peaks) != PEAKS or len(valleys) != PEAKS - 1:
        raise RuntimeError(f"expected {PEAKS} peaks and {PEAKS - 1} valleys, got "
                           f"{len(peaks)} and {len(valleys)}")
    return {"peak_approach_m": peaks, "valley_approach_m": valleys,
            "valley_rise_m": valleys[-1] - valleys[0],
            "peak_change_m": peaks[-1] - peaks[0],
            "second_valley_rise_m": valleys[1] - valleys[0]}


def fe_runs(mesh: str, depths=DEPTHS) -> dict[float, dict]:
    material = preset("reference")
    # the "yield" meshes with fixed load steps: the FE of the committed runs (the defaults
    # before issue 36 made "auto" and the adaptive control the defaults)
    jobs = {d: FemJob(material, history(d), mesh=mesh, label=f"partial d={d:g} {mesh}",
                      mesh_rule="yield", step_control="fixed")
            for d in depths}
    out = {}
    for d, job in jobs.items():
        cache = PAPER_CACHE if (d == 1.0 and mesh == "default") else CACHE
        [result] = run_campaign([job], cache, workers=1)
        curve = result.curve
        out[d] = {"key": job.key(), "cache": str(cache.relative_to(ROOT)),
                  **measures(curve["force_N"], curve["approach_m"])}
    return out


def law_runs(law: Path, depths=DEPTHS) -> dict[float, dict]:
    params = load_params(law)
    out = {}
    for d in depths:
        run = drive_by_force(params, list(history(d)), points=40)
        out[d] = measures(run.force, run.approach)
    return out


def with_shares(rows: dict[float, dict]) -> dict[float, dict]:
    """Each depth's valley rise over the full cycle's (its share), over the first reload and
    over all nine, beside Miner's d. (The first is the ratchet per cycle; the second also
    carries how fast it shakes down, which Miner's counting leaves to the cycle law.)"""
    first, full = rows[1.0]["second_valley_rise_m"], rows[1.0]["valley_rise_m"]
    for d, row in rows.items():
        row["first_reload_share"] = row["second_valley_rise_m"] / first if first else None
        row["share_of_full_cycle"] = row["valley_rise_m"] / full if full else None
        row["miner_share"] = d
    return rows


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--mesh", nargs="+", default=["coarse", "default"],
                        choices=["coarse", "default", "fine"])
    parser.add_argument("--depths", type=float, nargs="+", default=list(DEPTHS),
                        help="unloading depths d in (0, 1] (1 is always added: the shares are "
                             "of the full cycle's)")
    parser.add_argument("--law", type=Path, default=LAW)
    parser.add_argument("--json", type=Path, default=None, help="also write the results here")
    args = parser.parse_args(argv)
    if not all(0.0 < d <= 1.0 for d in args.depths):
        parser.error("--depths: each must be in (0, 1]")
    depths = tuple(sorted(set(args.depths) | {1.0}))
    results = {f"fe_{mesh}": with_shares(fe_runs(mesh, depths)) for mesh in args.mesh}
    results["law"] = with_shares(law_runs(args.law, depths))
    print("| d | Miner | " + " | ".join(
        f"{name}: valley rise µm, first reload / nine (share of the full cycle's); peak change "
        "µm" for name in results) + " |")
    print("| --- | --- |" + " --- |" * len(results))
    for d in depths:
        cells = [f"{r[d]['second_valley_rise_m'] * 1e6:.4f} / {r[d]['valley_rise_m'] * 1e6:.4f} "
                 f"({r[d]['first_reload_share']:.3f} / {r[d]['share_of_full_cycle']:.3f}); "
                 f"{r[d]['peak_change_m'] * 1e6:+.3f}" for r in results.values()]
        print(f"| {d:g} | {d:g} | " + " | ".join(cells) + " |")
    if args.json is not None:
        write_json_atomic(args.json, {
            "schema": "geocontact.verify-partial-unloading/1", "version": __version__,
            "inputs": {"material": "reference", "peak_force_N": PEAK_N, "peaks": PEAKS,
                       "depths": list(depths), "meshes": args.mesh,
                       "law": str(args.law.resolve().relative_to(ROOT))},
            "results": {name: {f"{d:g}": row for d, row in rows.items()}
                        for name, rows in results.items()}})
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
