"""``geocontact report DIR``: figures and a self-contained HTML report for a run directory."""

from __future__ import annotations

from ..report.common import FIGURES
from .common import add_force_flag, print_json


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
    p.add_argument("--json", action="store_true",
                   help="print what was written as one JSON document")
    p.set_defaults(run=run)


def run(args) -> int:
    from ..files import Output, claim
    from ..report import build_report

    with claim([Output(args.directory, "report", "DIR")], "report", overwrite=args.force):
        path = build_report(args.directory, title=args.title, overwrite=args.force)
    if args.json:
        figures = path.parent / FIGURES
        print_json({"report": str(path), "figures": str(figures),
                    "figure_files": sorted(p.name for p in figures.iterdir()
                                           if not p.name.startswith("."))})
    else:
        print(f"report: {path}")
    return 0
