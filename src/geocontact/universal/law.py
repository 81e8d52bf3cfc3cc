"""``for_material``: the law of any material of the universal law's range, no FE run.

The universal law interpolates the FE campaign's normalised data over (beta, nu, m, E/sigma_c)
and fits the law to them with ``calibrate.fit.fit_law`` (``interpolate.universal_params``).
"""

from __future__ import annotations

from ..errors import InputError
from ..grain.material import Material
from ..law.params import LawParams
from .interpolate import universal_params


def for_material(material: Material, *, extrapolate: bool = False) -> LawParams:
    """The law of two identical spheres of ``material`` (its radius included) from the
    universal law, in well under a second. A material outside the campaign's range is refused
    with a one-line InputError naming the field and the range, unless ``extrapolate``; the
    parameters' ``provenance["universal"]`` carries the dataset's hash, its number of points
    and the leave-one-out error expected at the material."""
    if not isinstance(material, Material):
        raise InputError(f"material: expected a geocontact.grain.material.Material, got "
                         f"{type(material).__name__}")
    return universal_params(material, extrapolate=extrapolate)
