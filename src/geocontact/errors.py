"""Typed errors. Every message is one line naming the field and the allowed range."""

from __future__ import annotations

import argparse
import signal
import sys
from collections.abc import Callable


class GeocontactError(Exception):
    """Base class of every error geocontact raises on purpose."""


class InputError(GeocontactError, ValueError):
    """Bad user input: a value out of range, an unknown key, a malformed file.

    The CLI prints ``error: <message>`` and exits with code 2.
    """


class ConvergenceError(GeocontactError, RuntimeError):
    """A solver did not converge; the message names the step and the load."""


class ArgumentParser(argparse.ArgumentParser):
    """argparse with its complaints as InputError, so a bad argument is one line like any other
    bad input (argparse itself prints the usage too); ``--help`` still prints the usage."""

    def error(self, message: str):
        raise InputError(f"{self.prog}: {message} (see {self.prog} --help)")


class Terminated(KeyboardInterrupt):
    """SIGTERM, raised like Ctrl-C so that every ``finally`` runs (temporaries removed,
    checkpoints kept, Dask clusters closed)."""


def _on_sigterm(signum, frame):
    raise Terminated()


def run_reporting_errors(run: Callable[[], int | None]) -> int:
    """Run a command and turn the errors geocontact raises on purpose into one line on stderr
    and the exit code: 2 for bad input, 1 for any other GeocontactError, 130 on Ctrl-C and 143
    on SIGTERM (handled like Ctrl-C: a clean exit, checkpoints kept). Used by the
    ``geocontact`` CLI and the ``python -m geocontact...`` generators alike."""
    previous = None
    try:
        previous = signal.signal(signal.SIGTERM, _on_sigterm)
    except ValueError:  # not the main thread (an embedding application): leave it alone
        pass
    try:
        return int(run() or 0)
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
