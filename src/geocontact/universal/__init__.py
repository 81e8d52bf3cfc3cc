"""The universal law: law parameters for any material of the campaign's box, no FE run.

``design`` (the material space and the campaign's point list), ``dataset`` (the normalised data
per point, shipped in ``geocontact/data/universal``), ``campaign`` (the FE runs that fill it),
``interpolate`` (the surfaces over material space and the law of a new material). Sits between
``calibrate`` (whose runs and fit it uses) and ``law`` (``geocontact.law.for_material``).
"""
