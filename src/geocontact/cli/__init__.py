"""The ``geocontact`` command line: a thin layer over the Python API.

Each sub-command lives in its own module of this package with a ``register(subparsers)``
function; ``COMMANDS`` lists them in the order ``--help`` shows them.
"""

from __future__ import annotations

import argparse
import importlib
import sys

from ..errors import GeocontactError, InputError

COMMANDS = ["demo", "yield_", "law", "fem", "calibrate", "cycles", "sweep", "seismic", "report",
            "presets"]


def build_parser() -> argparse.ArgumentParser:
    from .. import __version__

    parser = argparse.ArgumentParser(
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
    args = parser.parse_args(argv)
    try:
        return int(args.run(args) or 0)
    except InputError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    except GeocontactError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
