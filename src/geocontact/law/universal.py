"""``for_material``: the law of any material of the universal law's range, no FE run.

The universal law (``geocontact.universal``) interpolates the FE campaign's normalised data over
(beta, nu, m, E/sigma_c) and fits the law to them with ``calibrate.fit.fit_law``; imported here
lazily, so ``geocontact.law`` stays importable without the FE stack.
"""

from __future__ import annotations

from ..material import Material
from .params import LawParams


def for_material(material: Material, *, extrapolate: bool = False) -> LawParams:
    """The law of two identical spheres of ``material`` (its radius included) from the
    universal law, in well under a second. A material outside the campaign's range is refused
    with a one-line InputError naming the field and the range, unless ``extrapolate``; the
    parameters' ``provenance["universal"]`` carries the dataset's hash, its number of points
    and the leave-one-out error expected at the material."""
    from ..universal.interpolate import universal_params

    if not isinstance(material, Material):
        from ..errors import InputError

        raise InputError(f"material: expected a geocontact.material.Material, got "
                         f"{type(material).__name__}")
    return universal_params(material, extrapolate=extrapolate)
