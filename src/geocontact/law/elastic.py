"""The elastic law of a grain: the same material and the same file format, its yield moved to
where no contact goes, so that the law is Hertz's F = (4/3) E* sqrt(R*) delta^3/2 on every path
(docs/dem.md, "A like-for-like elastic baseline").

A DEM comparison of the hysteretic law against an elastic contact is like for like only if the
two runs differ in the normal law alone: the same pair style, tangential spring, damping, rolling
and twisting resistance, energy ledger and outputs. The elastic law file gives that through the
same ``pair geocontact`` and ``fix wall/geocontact``: the law below its yield approach is Hertz
exactly (loading and unloading on one curve, no dissipation, tests/test_law.py), and here the
yield approach is R/2, where the contact radius of Hertz's theory reaches the grain's radius
(a^2 = R* delta with R* = R/2), far beyond the validity of any contact law of spheres. A contact
that went that deep would still be reported: the file's calibrated range is its yield point.
"""

from __future__ import annotations

from dataclasses import replace

from .contact_radius import RadiusTable
from .params import LawParams

# the yield approach of the elastic law over the grain radius R (a = R at it, Hertz)
YIELD_APPROACH_OVER_RADIUS = 0.5


def elastic_law(params: LawParams) -> LawParams:
    """``params``' grain with an elastic contact (module docstring): yield at R/2, the cyclic
    extension off, no fitted contact radius (Hertz's is exact), its own label and provenance."""
    return replace(
        params,
        yield_approach=YIELD_APPROACH_OVER_RADIUS * params.material.radius,
        cyclic=replace(params.cyclic, enabled=False),
        radius_table=RadiusTable(),
        yield_extra={},
        calibrated_depth=1.0,  # exact up to yield; a contact beyond it is reported
        calibrated_range_extra={"source": "elastic law: Hertz up to its yield approach R/2"},
        label=f"elastic (Hertz) law of the grain of: {params.label}"[:200],
        provenance={"source": "geocontact.law.elastic.elastic_law",
                    "plastic_law_label": params.label},
        fit_errors={},
    )
