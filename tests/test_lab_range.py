"""No silent extrapolation in the lab route (issue 37): ``geocontact fit --identify universal``
finds sigma_c by driving the universal law along the record, and says in one line when the
record goes deeper than that law was calibrated (its ``calibrated_range.max_depth``)."""

from __future__ import annotations

import numpy as np
import pytest

from geocontact.grain.material import Material
from geocontact.labtest.identify import beyond_calibrated_depth, universal_law


@pytest.fixture(scope="module")
def params():
    law = universal_law()
    if law is None:
        pytest.skip("the universal law is not in this installation")
    return law(Material(youngs_modulus=30e9, poissons_ratio=0.2, compressive_yield_stress=25e6,
                        friction_angle_deg=20.0, hardening_ratio=0.0, radius=4e-3))


def test_a_record_within_the_calibrated_depth_is_not_warned(params):
    top, dy = params.calibrated_depth, params.yield_approach
    assert np.isfinite(top)
    found = beyond_calibrated_depth(params, np.linspace(0.0, 0.9 * top * dy, 200))
    assert found["warning"] is None and found["points_beyond"] == 0
    assert found["largest_depth"] == pytest.approx(0.9 * top)


def test_a_record_beyond_it_is_warned_in_one_line_with_the_count_and_the_depth(params):
    top, dy = params.calibrated_depth, params.yield_approach
    approach = np.linspace(0.0, 2.0 * top * dy, 201)
    found = beyond_calibrated_depth(params, approach)
    assert found["points_beyond"] == int(np.sum(approach > top * dy * (1 + 1e-12))) > 0
    assert found["largest_depth"] == pytest.approx(2.0 * top)
    assert "\n" not in found["warning"] and "beyond the universal law's calibrated depth" in (
        found["warning"])
    assert f"{2.0 * top:.3g}" in found["warning"]
