"""``geocontact report DIR``: figures and a self-contained HTML report for a run directory."""

from __future__ import annotations

from .common import add_force_flag


def register(sub) -> None:
    p = sub.add_parser(
        "report",
        help="figures and an HTML report for a run directory",
        description="Find the results in DIR and its sub-directories (FE runs, cycles analyses, "
        "law parameter files, sweeps, seismic runs) and write DIR/report.html with every "
        "figure embedded and its data as CSV in DIR/figures/.",
    )
    p.add_argument("directory", metavar="DIR", help="a run directory")
    p.add_argument("--title", default=None, help="report title")
    add_force_flag(p)
    p.set_defaults(run=run)


def run(args) -> int:
    from ..report import build_report

    path = build_report(args.directory, title=args.title, overwrite=args.force)
    print(f"report: {path}")
    return 0
