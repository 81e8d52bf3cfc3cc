"""The dent a plastic contact leaves, against the plugin's `memory place` rule (docs/dem.md, "FE
check of the 2 a_max rule"; geocontact.analyses.dent, scripts/verify_dent_extent.py).

The measures first, on profiles with closed-form answers; then one coarse FE run of the
reference grain (F = 10 Fy, small strain): its hollow ends near a_max, so a new contact disc of
radius a_max whose centre has moved DENT_TRAVEL_FACTOR x a_max covers none of it, and the rim
round it changes the new contact's approach by only a few per cent of the residual depth.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from geocontact.analyses import dent as dents


def synthetic(depth, a: float = 1.0, far: float = 10.0) -> dents.ResidualDent:
    r = np.linspace(0.0, far * a, 4001)
    return dents.ResidualDent(r, depth(r), a, float(depth(np.zeros(1))[0]))


def test_the_punch_weighted_mean_has_its_closed_forms():
    """Over a disc of radius a centred on the axis, the weight (a^2 - t^2)^(-1/2) gives
    <1> = 1 and <t^2> = 2 a^2 / 3 (int_0^(pi/2) sin^3 = 2/3); a disc far out sees nothing of a
    dent confined to r < 1."""
    a = 0.7
    assert dents.punch_mean(synthetic(lambda r: np.ones_like(r)), 0.0, a) == pytest.approx(1.0)
    assert dents.punch_mean(synthetic(lambda r: r**2), 0.0, a) == pytest.approx(
        2.0 * a * a / 3.0, rel=1e-4)
    cap = synthetic(lambda r: np.clip(1.0 - r**2, 0.0, None))
    assert dents.punch_mean(cap, 2.0 + 1e-9, 1.0) == 0.0
    assert dents.punch_mean(cap, 1.9, 1.0) > 0.0
    assert dents.disc_peak(cap, 0.0) == pytest.approx(1.0)
    assert dents.disc_peak(cap, 1.5) == pytest.approx(0.75, rel=1e-3)  # at r = 0.5


def test_extent_hollow_and_rim_of_a_known_profile():
    """D = cos(pi r / 2) e^(-r): the hollow ends at r = 1, the rim is the minimum of the next
    lobe, and |D| falls below a fraction f of D0 past the last crossing of f."""
    dent = synthetic(lambda r: np.cos(0.5 * math.pi * r) * np.exp(-r))
    assert dents.hollow_radius(dent) == pytest.approx(1.0, abs=1e-5)
    height, where = dents.rim(dent)
    lobe = np.linspace(1.0, 3.0, 200001)
    values = np.cos(0.5 * math.pi * lobe) * np.exp(-lobe)
    assert height == pytest.approx(values.min(), rel=1e-4)
    assert where == pytest.approx(lobe[np.argmin(values)], abs=3e-3)
    r = np.linspace(0.0, 10.0, 400001)
    above = r[np.abs(np.cos(0.5 * math.pi * r) * np.exp(-r)) >= 0.05]
    assert dents.extent(dent, 0.05) == pytest.approx(above[-1], abs=3e-3)


@pytest.fixture(scope="module")
def fe_dent():
    """The reference grain loaded to 10 Fy and unloaded, coarse mesh, 6 steps a segment."""
    from verify_dent_extent import dent_of

    return dent_of("reference", 10.0, "small", steps_per_segment=6)


def test_the_fe_dent_ends_near_a_max_so_the_rule_leaves_it(fe_dent):
    """The hollow of the FE's residual surface ends within 0.85-1.05 a_max (the rule assumes a_max),
    so past DENT_TRAVEL_FACTOR x a_max a new contact disc of radius a_max covers no hollow; what
    it meets there is the rim (D < 0), which changes its approach by less than 10 % of the
    dent's centre depth (and the opposite way to the dent); at the dent's centre the same disc
    meets the hollow."""
    dent, run = fe_dent
    a, d0 = dent.contact_radius_m, dent.centre_depth_m
    assert d0 > 0 and d0 == pytest.approx(dent.residual_approach_m, rel=1e-9)
    hollow = dents.hollow_radius(dent) / a
    assert 0.85 < hollow < 1.05
    assert 1.0 + hollow <= dents.DENT_TRAVEL_FACTOR
    rule = dents.DENT_TRAVEL_FACTOR * a
    far = np.linspace(rule - a, rule + a, 201)
    assert np.all(dent.depth_at(far) <= 0.0)  # no hollow under the disc at the rule
    felt = dents.punch_mean(dent, rule) / d0
    assert -0.10 < felt <= 0.0
    assert dents.punch_mean(dent, 0.0) / d0 > 0.1
    height, where = dents.rim(dent)
    assert height < 0 and 1.0 < where / a < 2.0
