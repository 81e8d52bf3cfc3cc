"""``geocontact demo``: the main job on the built-in reference case."""

from __future__ import annotations

import sys

from ..demo import run_demo
from .common import add_force_flag


def register(sub) -> None:
    p = sub.add_parser("demo", help="run the main job on the reference case, write a report")
    p.add_argument("--out", default="out/demo", help="output directory (default out/demo)")
    p.add_argument("--quick", action="store_true",
                   help="tiny loads and few FE steps: checks the pipeline in about a minute, "
                   "not the reference results")
    p.add_argument("--cache", default="out/cache/fem", help="FE result cache directory")
    add_force_flag(p)
    p.set_defaults(run=run)


def run(args) -> int:
    path = run_demo(args.out, progress=lambda m: print(m, file=sys.stderr), quick=args.quick,
                    cache_dir=args.cache, overwrite=args.force)
    print(f"report: {path}")
    return 0
