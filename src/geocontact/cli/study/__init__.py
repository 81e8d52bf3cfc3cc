"""``geocontact study NAME``: the project's studies, each a campaign of FE runs or DEM samples with
its analysis and tables (docs/cycles.md, docs/similarity.md, docs/dem.md). Each study is a module
of this package with its own flags (``geocontact study NAME --help``) and a ``main(argv)``."""

from __future__ import annotations

import importlib

# name -> (module, one line for --help)
STUDIES = {
    "paper-histories": ("paper_histories", "the paper's loading histories on the FE, with the "
                        "findings table (docs/cycles.md)"),
    "similarity": ("similarity", "the similarity of material space: FE runs over E/sigma_c and "
                   "the finite-size correction (docs/similarity.md)"),
    "shakedown": ("shakedown", "the law's shakedown against the FE, cycle by cycle "
                  "(docs/cycles.md)"),
    "dem-oedometer": ("dem_oedometer", "the full-size DEM oedometer on 1 and 2 ranks, both laws "
                      "(docs/dem.md)"),
}


def register(sub) -> None:
    p = sub.add_parser("study", help="run one of the project's studies (paper histories, "
                       "similarity, shakedown, DEM oedometer)",
                       description=__doc__.splitlines()[0])
    studies = p.add_subparsers(dest="study", required=True, metavar="STUDY")
    for name, (module, summary) in STUDIES.items():
        s = studies.add_parser(name, help=summary, add_help=False)
        s.set_defaults(run=_runner(name, module), own_flags=True)


def _runner(name: str, module: str):
    def run(args) -> int:
        study = importlib.import_module(f".{module}", __name__)
        return study.main(args.rest, prog=f"geocontact study {name}")
    return run
