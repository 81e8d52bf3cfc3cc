"""``geocontact sweep``: the material-influence sweeps of the paper (E, beta, sigma_c, m)."""

from __future__ import annotations

from ..fem.limits import check_workers
from ..files import Output, check_output_folder, claim
from .common import add_force_flag, print_json


def register(sub) -> None:
    p = sub.add_parser(
        "sweep",
        help="FE sweeps of E, beta, sigma_c, m at a fixed peak force; the paper's trends checked",
        description="One FE run 0 -> Fmax -> 0 per sweep point (data/sweeps.toml), run as a Dask "
        "campaign with a result cache; writes DIR/summary.json, points.csv, curves_*.csv.",
    )
    p.add_argument("--sweeps", default=None,
                   help="comma-separated sweep names (default: all of E,beta,sigma_c,m)")
    p.add_argument("--peak-force", type=float, default=None,
                   help="peak force in N (default: the file's, 6000 N)")
    p.add_argument("--mesh", default="default", choices=["coarse", "default", "fine"])
    p.add_argument("--scheduler", default=None, help="address of a running Dask scheduler")
    p.add_argument("--workers", type=int, default=None, help="local Dask worker processes")
    p.add_argument("--cache", default="out/cache/fem", help="FE result cache directory")
    p.add_argument("--out", required=True, help="result directory (written atomically)")
    add_force_flag(p)
    p.add_argument("--json", action="store_true", help="print summary.json on stdout")
    p.set_defaults(run=run)


def run(args) -> int:
    from ..analyses.sweeps import run_sweeps

    check_workers(args.workers)
    if args.scheduler is not None:
        from ..fem.campaign import check_scheduler_address

        check_scheduler_address(args.scheduler)
    names = [n.strip() for n in args.sweeps.split(",")] if args.sweeps else None
    check_output_folder(args.cache, "--cache")
    with claim([Output(args.out, "folder", "--out")], "sweep", overwrite=args.force):
        summary = run_sweeps(args.out, names, mesh=args.mesh, peak_force=args.peak_force,
                             cache_dir=args.cache, scheduler=args.scheduler,
                             workers=args.workers, overwrite=args.force)
    if args.json:
        print_json(summary)
        return 0
    for name, entry in summary["sweeps"].items():
        for st in entry["statements"]:
            mark = "agrees" if st["agrees"] else "DISAGREES"
            print(f"{name}: {st['quantity']} expected {st['expected']}, found {st['found']} "
                  f"(spread {st['spread']:.1%}) -> {mark}: {st['statement']}")
    return 0
