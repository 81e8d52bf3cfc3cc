"""geocontact: hysteretic elastic-plastic normal contact of Drucker-Prager grains.

Layout (data flows one way): ``material`` -> ``hertz`` (analytic) -> ``fem`` (virtual
experiment) -> ``calibrate`` -> ``law`` (what DEM uses) -> analyses -> ``report``; ``cli`` on top.
"""

from importlib.metadata import PackageNotFoundError, version

from .errors import ConvergenceError, GeocontactError, InputError
from .hertz import hertz_force, incipient_yield
from .material import Material, list_presets, load_material, preset

try:
    __version__ = version("geocontact")
except PackageNotFoundError:  # running from a source tree without installation
    __version__ = "0.0.0+unknown"

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
