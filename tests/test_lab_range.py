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


def test_geocontact_fit_strict_range_refuses_in_one_line_and_writes_nothing(
        tmp_path, capsys, monkeypatch):
    """``geocontact fit --identify universal --strict-range`` on the noise-free platens test
    with a universal law calibrated (here, by construction) only to 5 delta_y: the record goes
    to about 40 delta_y, so it is refused before the bootstrap, in one line, nothing written."""
    from dataclasses import replace
    from pathlib import Path

    import geocontact.labtest.identify as identify
    from geocontact.cli import main

    law = identify.universal_law()
    if law is None:
        pytest.skip("the universal law is not in this installation")
    monkeypatch.setattr(identify, "universal_law",
                        lambda: lambda m: replace(law(m), calibrated_depth=5.0))
    tests = Path(__file__).resolve().parents[1] / "examples" / "tests"
    out = tmp_path / "P.json"
    argv = ["fit", str(tests / "platens-quartzite.clean.csv"), "--setup", "platens",
            "--radius", "4e-3", "--machine-stiffness", "3e6", "--poissons-ratio", "0.2",
            "--friction-angle", "20", "--identify", "universal", "--bootstrap", "0",
            "--strict-range", "--out", str(out)]
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert "beyond the universal law's calibrated depth 5 delta_y" in err
    assert "(--strict-range)" in err and "\n" not in err
    assert not out.exists()
