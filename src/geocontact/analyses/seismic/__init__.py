"""Seismic and aftershock loading of a column of hysteretic contacts (docs/model.md §8).

``records`` (acceleration records in) -> ``column`` (velocity-Verlet column of spheres on a moving
base, the law at every contact) -> ``classify`` (rainflow loading-history class, shakedown state,
the paper's peak-time-fraction rule) -> ``analysis`` (events, outputs, figures).
"""
