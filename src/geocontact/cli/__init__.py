"""The ``geocontact`` command line: a thin layer over the Python API.

Each sub-command lives in its own module of this package with a ``register(subparsers)``
function; ``COMMANDS`` lists them in the order ``--help`` shows them.
"""

from __future__ import annotations

import argparse
import importlib
import signal
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


class Terminated(KeyboardInterrupt):
    """SIGTERM, raised like Ctrl-C so that every ``finally`` runs (temporaries removed,
    checkpoints kept, Dask clusters closed)."""


def _on_sigterm(signum, frame):
    raise Terminated()


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    previous = None
    try:
        previous = signal.signal(signal.SIGTERM, _on_sigterm)
    except ValueError:  # not the main thread (an embedding application): leave it alone
        pass
    try:
        return int(args.run(args) or 0)
    except InputError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    except GeocontactError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 1
    except Terminated:
        print("terminated (SIGTERM); checkpoints kept, rerun with --resume where offered",
              file=sys.stderr)
        return 143
    except KeyboardInterrupt:
        print("interrupted; checkpoints kept, rerun with --resume where offered",
              file=sys.stderr)
        return 130
    finally:
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
