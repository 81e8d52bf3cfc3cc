"""Measure beta = S / (2 E* a) in the committed FE runs and write the lab fit's factor.

    PYTHONPATH=src nice -n 10 .venv/bin/python scripts/unloading_stiffness_factor.py [--check]

E from the unloading stiffness (docs/fit.md) divides each cycle's S by beta(a/R), the ratio this
project's FE unloadings give (``geocontact.labtest.stiffness``). Writes
src/geocontact/data/unloading-stiffness-factor.json from every run of datasets/fe-runs (prints
the fit, its scatter and the scatter per campaign, mesh and kinematics); ``--check`` recomputes
and compares with the committed file instead of writing it.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

from geocontact.labtest.stiffness import FACTOR_FILE, measure

ROOT = Path(__file__).resolve().parents[1]
CAMPAIGNS = ROOT / "datasets" / "fe-runs"
OUT = ROOT / "src" / "geocontact" / "data" / FACTOR_FILE


def campaigns() -> list[Path]:
    return sorted(p for p in CAMPAIGNS.iterdir() if p.is_dir())


def report(model: dict) -> None:
    b = model["coefficients"]
    print(f"beta(a/R) = {b[0]:.4f} + {b[1]:.4f} a/R + {b[2]:.4f} (a/R)^2 over "
          f"{model['unloadings']} unloadings of {model['runs']} runs, a/R "
          f"{model['contact_radius_over_radius_range'][0]:.2g}-"
          f"{model['contact_radius_over_radius_range'][1]:.2g}; RMS residual "
          f"{model['rms_residual']:.4f}")
    rows = model["rows"]
    x = np.array([r["contact_radius_over_radius"] for r in rows])
    fit = np.polynomial.polynomial.polyval(x, b)
    for key in ("campaign", "mesh", "kinematics"):
        for value in sorted({str(r[key]) for r in rows}):
            pick = np.array([str(r[key]) == value for r in rows])
            res = np.array([r["factor"] for r in rows])[pick] - fit[pick]
            print(f"  {key} {value}: {pick.sum()} unloadings, mean residual {res.mean():+.4f}, "
                  f"RMS {np.sqrt(np.mean(res**2)):.4f}")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--check", action="store_true",
                        help="compare with the committed file instead of writing it")
    args = parser.parse_args(argv)
    model = measure(campaigns())
    model["campaigns"] = [str(p.relative_to(ROOT)) for p in campaigns()]
    report(model)
    if args.check:
        committed = json.loads(OUT.read_text())
        same = np.allclose(committed["coefficients"], model["coefficients"], rtol=1e-9)
        print("matches the committed file" if same else "DIFFERS from the committed file")
        return 0 if same else 1
    OUT.write_text(json.dumps(model, indent=1) + "\n")
    print(f"wrote {OUT.relative_to(ROOT)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
