"""Two finished FE runs of one force schedule, compared at the forces both recorded: the relative
difference of the approach (the second run against the first, the reference), over the forces
above ``--above`` N, and at each peak and each return to 0 N of the history.

The independent check of a load-step control in docs/fem.md ("The dissipation bound"): a run of
the default control against the finer run of another control on the same schedule, e.g.

    RUN=finite-coarse-contact-dense-segment-24
    PYTHONPATH=src .venv/bin/python scripts/compare_fe_runs.py \\
        datasets/staircase-auto/$RUN-adaptive-compiled \\
        datasets/staircase-dissipation/$RUN-dissipation-compiled --above 1

No FE run; reads each folder's curve.csv.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "src"))

from geocontact.errors import InputError  # noqa: E402
from geocontact.fem.identity import load_result  # noqa: E402


def waypoints(force: np.ndarray) -> np.ndarray:
    """Rows of each peak (the largest force, followed by a lower one) and each return to 0 N."""
    top = force.max()
    rows = [i for i in range(1, len(force) - 1)
            if (force[i] == top and force[i + 1] < top) or (force[i] == 0 and force[i - 1] > 0)]
    return np.array(rows + ([len(force) - 1] if force[-1] == 0 else []), dtype=int)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("reference", type=Path, help="finished run folder (the reference)")
    parser.add_argument("run", type=Path, help="finished run folder compared with it")
    parser.add_argument("--above", type=float, default=0.0, help="only forces above this, N")
    args = parser.parse_args(argv)
    try:
        ref, new = load_result(args.reference).curve, load_result(args.run).curve
    except InputError as exc:
        parser.error(str(exc))
    if len(ref["force_N"]) != len(new["force_N"]) or not np.allclose(
            ref["force_N"], new["force_N"], rtol=1e-9, atol=0.0):
        parser.error("the two runs did not record the same forces (not one schedule)")
    force = ref["force_N"]
    shown = force > args.above
    gap = new["approach_m"][shown] / ref["approach_m"][shown] - 1.0
    print(f"approach, {int(shown.sum())} recorded forces above {args.above:g} N: "
          f"{100 * gap.min():+.3f} to {100 * gap.max():+.3f} %, "
          f"RMS {100 * np.sqrt(np.mean(gap ** 2)):.3f} %")
    for i in waypoints(force):
        kind = "peak" if force[i] > 0 else "return to 0 N"
        gap_i = new["approach_m"][i] / ref["approach_m"][i] - 1.0
        print(f"  {kind} (row {i}): {100 * gap_i:+.3f} %")
    return 0


if __name__ == "__main__":
    sys.exit(main())
