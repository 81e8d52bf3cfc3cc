"""The weak grain's repeated history with finite strain, per cycle: FE on two meshes and the law.

Regenerates the table of docs/cycles.md ("The weak grain's repeated history with finite strain")
from the committed FE runs (no FE work) and a law file:

    PYTHONPATH=src .venv/bin/python scripts/weak_ratchet_table.py \\
        [--law examples/params-reference-weak.json] [--json out/weak-ratchet.json]

Columns: per cycle N >= 2, the residual-approach increment over cycle 1's residual approach and
the plastic dissipation over cycle 1's, for the default-mesh run (cap 1.01) and the coarse-mesh
run (cap 1.02) of 10 x (0 -> 3000 N -> 0); then the law driven by the same forces against the
default-mesh run, in micrometres and millijoules.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "src"))

from geocontact import __version__  # noqa: E402
from geocontact.analyses.cycles import law_cycles_by_force  # noqa: E402
from geocontact.calibrate.cyclic_fit import cycle_table  # noqa: E402
from geocontact.fem.identity import load_result  # noqa: E402
from geocontact.law import load_params  # noqa: E402

DATASETS = ROOT / "datasets" / "fe-runs"
RUNS = {"default": DATASETS / "paper-histories-finite" / "79325e01f1a54b90900f",
        "coarse": DATASETS / "weak-finite-coarse" / "f4dcbc2b4ecb941f6ab2"}


def per_cycle(cycles: list[dict]) -> list[dict]:
    """Cycle N >= 2 of ``cyclic_fit.cycle_table``: increments and ratios to cycle 1."""
    return cycle_table(cycles)[1:]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--law", type=Path,
                        default=ROOT / "examples" / "params-reference-weak.json")
    parser.add_argument("--json", type=Path, default=None, help="also write the rows here")
    args = parser.parse_args(argv)
    results = {name: load_result(path) for name, path in RUNS.items()}
    forces = results["default"].summary["identity"]["inputs"]["forces_N"]
    law_cycles, _ = law_cycles_by_force(load_params(args.law), forces)
    fe = {name: per_cycle(r.summary["cycles"]) for name, r in results.items()}
    law = per_cycle(law_cycles)
    print("| N | Δδres/δres,1 default | coarse | Wp/Wp,1 default | coarse "
          "| Δδres law / FE default (µm) | Wp law / FE default (mJ) |")
    print("| --- | --- | --- | --- | --- | --- | --- |")
    for d, c, w in zip(fe["default"], fe["coarse"], law, strict=True):
        print(f"| {d['cycle']} | {d['residual_increment_ratio']:.2e} "
              f"| {c['residual_increment_ratio']:.2e} | {d['plastic_work_ratio']:.2e} "
              f"| {c['plastic_work_ratio']:.2e} "
              f"| {w['residual_approach_increment_m'] * 1e6:.3f} "
              f"/ {d['residual_approach_increment_m'] * 1e6:.3f} "
              f"| {w['plastic_work_J'] * 1e3:.2f} / {d['plastic_work_J'] * 1e3:.2f} |")
    total = {name: sum(r["residual_approach_increment_m"] for r in rows)
             for name, rows in (("law", law), ("fe_default", fe["default"]))}
    print(f"\nresidual growth over cycles 2-{len(law) + 1}: law {total['law'] * 1e6:.2f} µm, "
          f"FE (default mesh) {total['fe_default'] * 1e6:.2f} µm")
    if args.json is not None:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps({
            "version": __version__, "command": "scripts/weak_ratchet_table.py",
            "law": str(args.law), "runs": {k: str(v.relative_to(ROOT)) for k, v in RUNS.items()},
            "fe": fe, "law_cycles": law, "residual_growth_m": total}, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
