"""geocontact: hysteretic elastic-plastic normal contact of Drucker-Prager grains.

Layout (data flows one way): ``material`` -> ``hertz`` (analytic) -> ``fem`` (virtual
experiment) -> ``calibrate`` -> ``law`` (what DEM uses) -> analyses -> ``report``; ``cli`` on top.
"""

from ._version import __version__
from .errors import ConvergenceError, GeocontactError, InputError
from .hertz import hertz_force, incipient_yield
from .material import Material, list_presets, load_material, preset

__all__ = [
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
