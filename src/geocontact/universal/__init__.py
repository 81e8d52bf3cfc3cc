"""The universal law: law parameters for any material of the campaign's box, no FE run.

``design`` (the material space and the campaign's point list), ``dataset`` (the normalised data
per point, shipped in ``geocontact/data/universal``), ``campaign`` (the FE runs that fill it),
``interpolate`` (the surfaces over material space and the law of a new material), ``law``
(``for_material``, the public entry point). Sits beside ``calibrate``, whose runs and fit it uses.
"""

from .law import for_material

__all__ = ["for_material"]
