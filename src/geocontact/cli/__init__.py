"""The ``geocontact`` command line: a thin layer over the Python API.

Each sub-command lives in its own module of this package with a ``register(subparsers)``
function; ``COMMANDS`` lists them in the order ``--help`` shows them.
"""

from __future__ import annotations

import argparse
import importlib
import sys
import warnings

from .._version import __version__
from ..errors import ArgumentParser, run_reporting_errors

COMMANDS = ["demo", "first_yield", "law", "fem", "calibrate", "cycles", "sweep", "seismic", "dem",
            "report", "presets", "params", "fit", "study"]


def build_parser() -> ArgumentParser:

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
    chosen: dict[str, set[str]] = {}

    def run() -> int:
        # a study (``geocontact study NAME ...``) parses its own flags: only it gets the rest
        args, rest = parser.parse_known_args(argv)
        if rest and not getattr(args, "own_flags", False):
            parser.error(f"unrecognized arguments: {' '.join(rest)}")
        args.rest = rest
        chosen["flags"] = _flags(parser, args.command)
        with warnings.catch_warnings():
            warnings.showwarning = _one_line_warnings(warnings.showwarning)
            return args.run(args)

    return run_reporting_errors(run, lambda: chosen.get("flags"))


def _flags(parser: ArgumentParser, command: str) -> set[str]:
    """The options of sub-command ``command`` (``--out``, ...)."""
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return set(sub.choices[command]._option_string_actions)


def _one_line_warnings(show):
    """``warnings.showwarning`` that prints a warning meant for the user (a contact beyond its
    law's calibrated range) as one ``warning:`` line, like the commands' own, and hands any
    other to ``show``."""
    from ..law.calibrated_range import BeyondCalibratedRangeWarning

    def one_line(message, category, filename, lineno, file=None, line=None) -> None:
        if issubclass(category, BeyondCalibratedRangeWarning):
            print(f"warning: {message}", file=sys.stderr if file is None else file)
        else:
            show(message, category, filename, lineno, file, line)

    return one_line


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
