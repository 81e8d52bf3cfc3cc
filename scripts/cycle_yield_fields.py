"""Where a repeated history's later cycles yield, from the ParaView fields of finished FE runs.

For every cycle N >= 2 of each run (written by ``geocontact fem``, with ``fields/``): the cells
whose equivalent plastic strain grew over the cycle (end of cycle N-1 to end of cycle N, more
than 1e-7), the largest growth and where it is (radius over the first peak's contact radius a,
depth under the undeformed sphere surface over a), and the growth-weighted shares near the
surface (depth < 0.05 a) and at the contact edge (0.8 a < r < 1.1 a). docs/cycles.md ("Findings
with the weak grain's FE of record") compares a finite- and a small-strain run this way:

    geocontact fem --material reference-weak --history H.toml --mesh coarse --steps 12 \\
        --mesh-rule contact --max-step-ratio 1.02 [--kinematics finite] --out out/why-{small,finite}
    PYTHONPATH=src .venv/bin/python scripts/cycle_yield_fields.py out/why-small out/why-finite

with H.toml: ``[history] forces = [0, 3000, 0, 3000, 0, 3000, 0]`` (about 10 and 30 min of a core).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "src"))

from geocontact.analyses.cycles import fe_cycle_windows  # noqa: E402
from geocontact.errors import InputError, run_reporting_errors  # noqa: E402
from geocontact.fem.checkpoint import field_name  # noqa: E402
from geocontact.fem.identity import load_result  # noqa: E402

GROWTH = 1e-7  # eqps growth over a cycle counted as yielding in it


def _cells(run: Path, step: int, radius: float):
    """Reference centroids (r, z), depth under the undeformed surface, and eqps of a step."""
    import meshio

    path = run / "fields" / field_name(step)
    if not path.is_file():
        raise InputError(f"run: {run} has no field file {path.name} (written by geocontact fem)")
    mesh = meshio.read(path)
    centroids = mesh.points[mesh.cells[0].data[:, :3], :2].mean(axis=1)
    depth = radius - np.hypot(centroids[:, 0], centroids[:, 1] - radius)
    return centroids, depth, np.asarray(mesh.cell_data["eqps"][0], dtype=float)


def cycle_yield(run: Path) -> list[dict]:
    """One row per cycle N >= 2 of the finished run ``run`` (with its fields)."""
    result = load_result(run)
    radius = float(result.summary["identity"]["inputs"]["material"]["radius"])
    force = np.asarray(result.curve["force_N"], dtype=float)
    contact = np.asarray(result.curve["contact_radius_m"], dtype=float)
    steps = np.asarray(result.curve["step"], dtype=int)
    windows = fe_cycle_windows(result.curve, result.summary["cycles"])
    start, end = windows[0]
    a = float(contact[start + int(np.argmax(force[start:end + 1]))])
    rows = []
    ends = [int(steps[end]) for _, end in windows]  # the step closing each cycle
    for n, (before_step, after_step) in enumerate(zip(ends[:-1], ends[1:], strict=True), 2):
        centroids, depth, before = _cells(run, before_step, radius)
        _, _, after = _cells(run, after_step, radius)
        growth = after - before
        grew = growth > GROWTH
        weight = np.where(grew, growth, 0.0)
        total = float(weight.sum())
        top = int(np.argmax(growth))
        r = centroids[:, 0]
        rows.append({
            "cycle": n, "cells_yielded": int(grew.sum()), "largest_growth": float(growth[top]),
            "largest_at_r_over_a": float(r[top] / a),
            "largest_at_depth_over_a": float(depth[top] / a),
            "share_near_surface": float(weight[depth < 0.05 * a].sum() / total) if total else None,
            "share_at_contact_edge": (float(weight[(r > 0.8 * a) & (r < 1.1 * a)].sum() / total)
                                      if total else None),
            "first_peak_contact_radius_m": a,
        })
    return rows


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("runs", nargs="+", type=Path, help="finished geocontact fem folders")
    args = ap.parse_args(argv)
    for run in args.runs:
        rows = cycle_yield(run)
        print(f"{run} (a = {1e3 * rows[0]['first_peak_contact_radius_m']:.2f} mm)" if rows else
              f"{run}: one cycle only")
        for r in rows:
            print(f"  cycle {r['cycle']}: eqps grew in {r['cells_yielded']} cells; largest "
                  f"{r['largest_growth']:.3g} at r/a {r['largest_at_r_over_a']:.3f}, depth/a "
                  f"{r['largest_at_depth_over_a']:.4f}; growth within 0.05 a of the surface "
                  f"{r['share_near_surface']:.2f}, at the contact edge "
                  f"{r['share_at_contact_edge']:.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(run_reporting_errors(main))
