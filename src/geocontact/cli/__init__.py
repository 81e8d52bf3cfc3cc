"""The ``geocontact`` command line: a thin layer over the Python API.

Each sub-command lives in its own module of this package with a ``register(subparsers)``
function; ``COMMANDS`` lists them in the order ``--help`` shows them.
"""

from __future__ import annotations

import importlib
import sys

from ..errors import ArgumentParser, run_reporting_errors

COMMANDS = ["demo", "yield_", "law", "fem", "calibrate", "cycles", "sweep", "seismic", "dem",
            "report", "presets", "params", "fit"]


def build_parser() -> ArgumentParser:
    from .._version import __version__

    parser = ArgumentParser(
        prog="geocontact",
        description="Hysteretic elastic-plastic contact of Drucker-Prager spheres.",
    )
    parser.add_argument("--version", action="version", version=f"geocontact {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for name in COMMANDS:
        importlib.import_module(f".{name}", __name__).register(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()

    def run() -> int:
        args = parser.parse_args(argv)
        return args.run(args)

    return run_reporting_errors(run)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
