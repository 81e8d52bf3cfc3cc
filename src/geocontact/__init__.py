"""geocontact: hysteretic elastic-plastic normal contact of Drucker-Prager grains.

Layout (README, "Architecture"; imports flow one way): ``grain`` (the material, Hertz and the
force histories) -> ``fem`` (the virtual experiment) -> ``law`` (what DEM uses) -> ``calibrate``,
``universal``, ``labtest`` (laws from FE runs, from the universal campaign, from a lab record) ->
``analyses`` -> ``report`` -> ``cli``; ``errors``, ``files``, ``figures`` and ``schema`` are the
ground every layer stands on.
"""

import importlib
import importlib.abc
import importlib.util
import sys
import warnings

from ._version import __version__
from .errors import ConvergenceError, GeocontactError, InputError
from .grain.hertz import hertz_force, incipient_yield
from .grain.material import Material, list_presets, load_material, preset

# Modules that moved in 0.x (README, "Architecture"): the old names import the new modules, with
# a DeprecationWarning, until the release after next. One table, no module per old name.
MOVED = {
    "geocontact.io": "geocontact.files",
    "geocontact.material": "geocontact.grain.material",
    "geocontact.hertz": "geocontact.grain.hertz",
    "geocontact.force_history": "geocontact.grain.force_history",
    "geocontact.resolution": "geocontact.fem.roundoff",
    "geocontact.cyclic_fit": "geocontact.calibrate.cyclic_fit",
    "geocontact.lammps_plugin": "geocontact.analyses.lammps_plugin",
    "geocontact.demo": "geocontact.cli.demo",
    "geocontact.cycles": "geocontact.analyses.cycles",
    "geocontact.sweeps": "geocontact.analyses.sweeps",
    "geocontact.paper_histories": "geocontact.analyses.paper_histories",
    "geocontact.histories": "geocontact.analyses.force_driven",
    "geocontact.seismic": "geocontact.analyses.seismic",
    "geocontact.report_sections": "geocontact.report",
    "geocontact.fem.reuse": "geocontact.fem.identity",
    "geocontact.fem.speed": "geocontact.fem.solver_comparison",
    "geocontact.fem.pair": "geocontact.fem.two_spheres",
    "geocontact.cli.yield_": "geocontact.cli.first_yield",
    "geocontact.law.universal": "geocontact.universal.law",
    "geocontact.labtest.output": "geocontact.cli.fit_output",
}


class _MovedModules(importlib.abc.MetaPathFinder, importlib.abc.Loader):
    """Imports an old module name as the module it moved to (the same module object)."""

    def find_spec(self, name, path=None, target=None):
        if name not in MOVED:
            return None
        return importlib.util.spec_from_loader(name, self)

    def create_module(self, spec):
        warnings.warn(f"{spec.name} moved to {MOVED[spec.name]}; the old name goes in a later "
                      "release", DeprecationWarning, stacklevel=3)
        module = importlib.import_module(MOVED[spec.name])
        spec.loader_state = module.__spec__  # its own spec, which the import system overwrites
        return module

    def exec_module(self, module):
        # the import system gave the module the old name's spec: give it back its own, so its
        # relative imports, pickling and multiprocessing see where it really lives
        module.__spec__ = module.__spec__.loader_state


if not any(isinstance(finder, _MovedModules) for finder in sys.meta_path):
    sys.meta_path.append(_MovedModules())

__all__ = [
    "MOVED",
    "ConvergenceError",
    "GeocontactError",
    "InputError",
    "Material",
    "hertz_force",
    "incipient_yield",
    "__version__",
    "list_presets",
    "load_material",
    "preset",
]
