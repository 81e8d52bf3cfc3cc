"""``geocontact demo``: the main job on the built-in reference case."""

from __future__ import annotations

import sys

from ..demo import run_demo


def register(sub) -> None:
    p = sub.add_parser("demo", help="run the main job on the reference case, write a report")
    p.add_argument("--out", default="out/demo", help="output directory (default out/demo)")
    p.set_defaults(run=run)


def run(args) -> int:
    path = run_demo(args.out, progress=lambda m: print(m, file=sys.stderr))
    print(f"report: {path}")
    return 0
