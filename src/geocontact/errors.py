"""Typed errors. Every message is one line naming the field and the allowed range."""

from __future__ import annotations

import argparse
import signal
import sys
import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager


class GeocontactError(Exception):
    """Base class of every error geocontact raises on purpose."""


class InputError(GeocontactError, ValueError):
    """Bad user input: a value out of range, an unknown key, a malformed file.

    The CLI prints ``error: <message>`` and exits with code 2.
    """


class ConvergenceError(GeocontactError, RuntimeError):
    """A solver did not converge; the message names the step and the load."""


class ContactBeyondMeshError(ConvergenceError):
    """An FE run whose measured contact outgrew the mesh's refined zone (fem.mesh
    ``CONTACT_RADIUS_LIMIT``): the run stands for its steps before, as one that stopped
    converging does."""


def check_count(field: str, value: int | None, high: int, why: str = "") -> None:
    """An optional integer argument in [1, high]; ``why`` says where the bound comes from."""
    if value is not None and not 1 <= value <= high:
        raise InputError(f"{field}: must be in [1, {high}]{' (' + why + ')' if why else ''}, "
                         f"got {value}")


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


HELD_SIGNALS = (signal.SIGINT, signal.SIGTERM)


@contextmanager
def interrupts_held() -> Iterator[None]:
    """Ctrl-C and SIGTERM held while the block runs and delivered when it ends (to the handlers
    there were before): a file being written is finished, or removed by its writer, never cut
    in the middle of a library's own cleanup. An interrupt raised inside ``zipfile``'s close
    (np.savez) came out as "ValueError: Can't close the ZIP file while there is an open writing
    handle": a traceback and exit code 1 in place of the clean 143 of a SIGTERM. Outside the
    main thread (where Python runs no signal handler) the block runs as it is."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    pending: list[int] = []

    def hold(signum, frame):
        pending.append(signum)

    previous = {number: signal.signal(number, hold) for number in HELD_SIGNALS}
    try:
        yield
    finally:
        for number, handler in previous.items():
            signal.signal(number, handler)
        if pending:  # the first one, to the handler it was meant for
            signal.raise_signal(pending[0])


# Library errors name the Python parameter (``max_force: ...``); on the command line the same
# error names the flag that set it. A message starting with one of these names is shown with
# the flag instead, and the API's ``overwrite=True`` hint as ``--force``.
CLI_FLAGS = {"max_force": "--max-force", "levels": "--levels", "peaks": "--peak-forces",
             "scheduler": "--scheduler", "unit": "--unit", "out": "--out",
             "grains": "--grains", "ranks": "--ranks", "contact": "--contact",
             "stress": "--stress", "radius": "--radius", "spread": "--spread",
             "inertia": "--inertia", "targets": "--targets", "seed": "--seed",
             "walls": "--walls", "law": "--law", "fe_model_materials": "--fe-model-materials",
             "pga": "--pga", "surcharge": "--surcharge", "strain": "--strain",
             "decimate": "--decimate", "gap": "--gap", "output_interval": "--output-interval",
             "time_step_safety": "--time-step-safety", "time_step": "--time-step",
             "damping_ratio": "--damping", "density": "--density", "peak_force": "--peak-force",
             "tolerance": "--tolerance", "poissons_ratio": "--poissons-ratio",
             "friction_angle_deg": "--friction-angle", "hardening_ratio": "--hardening-ratio",
             "machine_stiffness": "--machine-stiffness", "amplitudes": "--amplitudes",
             "cycles": "--cycles", "seeds": "--seeds", "baseline": "--baseline",
             "friction": "--friction", "damping": "--damping"}


def for_the_command_line(message: str, flags: set[str] | None = None) -> str:
    """An error message of the library as the command line shows it (``CLI_FLAGS``); with
    ``flags`` (the options of the command that ran) only a flag the command has is named: a
    material file's ``radius`` is not ``--radius`` in ``geocontact yield``."""
    name, colon, rest = message.partition(":")
    if colon and name in CLI_FLAGS and (flags is None or CLI_FLAGS[name] in flags):
        message = CLI_FLAGS[name] + colon + rest
    return (message.replace("pass overwrite=True", "pass --force")
            .replace("(unit: g, m/s2 or cm/s2)", "(--unit g|m/s2|cm/s2)"))


def run_reporting_errors(run: Callable[[], int | None],
                         flags: Callable[[], set[str] | None] = lambda: None) -> int:
    """Run a command and turn the errors geocontact raises on purpose into one line on stderr
    and the exit code: 2 for bad input, 1 for any other GeocontactError, 130 on Ctrl-C and 143
    on SIGTERM (handled like Ctrl-C: a clean exit, checkpoints kept). Used by the
    ``geocontact`` CLI and the ``python -m geocontact...`` generators alike; messages name the
    command line's flags (``for_the_command_line``; ``flags()``: the options of the command
    that ran, when known)."""
    previous = None
    try:
        previous = signal.signal(signal.SIGTERM, _on_sigterm)
    except ValueError:  # not the main thread (an embedding application): leave it alone
        pass
    try:
        return int(run() or 0)
    except InputError as exc:
        print(f"error: {for_the_command_line(str(exc), flags())}", file=sys.stderr)
        return 2
    except GeocontactError as exc:
        print(f"error: {for_the_command_line(str(exc), flags())}", file=sys.stderr)
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
