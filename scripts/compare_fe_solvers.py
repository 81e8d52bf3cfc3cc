"""The FE solver's fast and reference linear-algebra paths side by side (issue 12): the same
force history on both, wall time, factorisations, and the largest relative differences of the
force-approach curve, residual approach and plastic work (goal: <= 0.2 %).

    PYTHONPATH=src .venv/bin/python scripts/compare_fe_solvers.py [--mesh coarse] [--force 6000]
"""

from __future__ import annotations

import argparse
import json

from geocontact.fem.solver_comparison import compare_linear_solvers
from geocontact.grain.material import load_material


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--material", default="reference")
    ap.add_argument("--mesh", default="coarse", choices=["coarse", "default", "fine"])
    ap.add_argument("--force", type=float, default=6000.0, help="peak force, N")
    args = ap.parse_args(argv)
    if not args.force > 0.0:
        ap.error(f"--force must be > 0 N, got {args.force:g}")
    report = compare_linear_solvers(load_material(args.material), [0.0, args.force, 0.0],
                                    mesh=args.mesh)
    print(json.dumps(report, indent=1))
    return 0 if report["within_accuracy"] else 1


if __name__ == "__main__":
    raise SystemExit(main())
