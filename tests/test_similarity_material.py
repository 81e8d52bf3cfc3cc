"""Similarity in material space (SPEC section 10, issue 12; docs/similarity.md): while the contact
is small against the sphere, E / sigma_c drops out of the normalised contact, F / Fy(x),
delta_res / delta_max(x), ...; beyond, the finite size of the sphere enters as the fitted
correction of the committed study (src/geocontact/data/similarity-data.*).

The FE test runs the same dimensionless problem (peak in units of Fy, mesh sized from the
contact radii) on grains of E / sigma_c = 10^3 and 10^3.5: only sigma_c and, through it, the
size of the contact against the sphere differ. Anything in the FE that broke the dimensionless
form (a tolerance, a gap or a mesh size in absolute units) would set them apart."""

import numpy as np
import pytest

from geocontact.calibrate import similarity as sim
from geocontact.errors import InputError
from geocontact.fem.campaign import run_campaign
from geocontact.material import preset

PEAK_OVER_YIELD = 28.0  # x ~ 10 on the reference grain
HISTORY = (0.0, 1.0, 0.0, 1.0, 0.0)


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """E / sigma_c = 10^2, 10^3, 10^3.5 to the same peak in F / Fy (6 steps a segment: not
    the committed study's 12, so the check of the fitted correction below is on new runs)."""
    base = preset("reference")
    jobs = [sim.study_job(sim.study_material(base, 10.0 ** e), PEAK_OVER_YIELD, "coarse",
                          HISTORY, steps_per_segment=6) for e in (2.0, 3.0, 3.5)]
    results = run_campaign(jobs, tmp_path_factory.mktemp("fem"), workers=1, progress=False)
    return [(sim.measure(job, result), sim.loading_curve(job, result))
            for job, result in zip(jobs, results, strict=True)]


def test_same_mesh_relative_to_the_contact(runs):
    (_, _), (low, _), (high, _) = runs
    # the graded mesh is sized from the contact radii alone: the same elements across the
    # contact at yield and at the peak (to gmsh's edge lengths, ~1 %)
    for key in ("elements_across_contact_at_peak", "elements_across_contact_at_yield"):
        assert low[key] == pytest.approx(high[key], rel=0.02)
    assert low["contact_radius_over_radius"] == pytest.approx(
        10 ** 0.5 * high["contact_radius_over_radius"], rel=0.03)


def test_modulus_ratio_drops_out_of_small_contacts(runs):
    (_, _), (low, _), (high, _) = runs
    # a / R = 0.009 and 0.003. Tolerances: the FE's own scatter between meshes of the same
    # dimensionless size (gmsh's edge lengths move the contact edge's node-by-node advance),
    # measured in the committed study over the contacts below 0.02 R: 0.43 % RMS in F at the
    # same x (x moves by 1/1.3 of it), 0.0006 in delta_res / delta_max, 0.0016 in Wp / Wt; and
    # the fitted finite-size difference between the two grains here, 0.3 % in F. Measured:
    # 0.3 % in x, 0.0015 and 0.005 in the ratios, 7e-4 in n_u. A sigma_c that entered in
    # absolute units (a tolerance, a gap, a mesh size) would move them by O(1).
    assert low["depth"] == pytest.approx(high["depth"], rel=1e-2)
    for key in ("residual_ratio", "plastic_work_ratio"):
        assert low[key] == pytest.approx(high[key], abs=8e-3)
    for key in ("unloading_exponent", "reloading_exponent"):
        assert low[key] == pytest.approx(high[key], abs=1e-2)
    assert low["fe_yield_over_analytic"] == pytest.approx(high["fe_yield_over_analytic"],
                                                          rel=2e-2)


def test_finite_size_correction_predicts_a_large_contact(runs):
    """E / sigma_c = 10^2 (a = 0.09 R): its force at the same x lies above the small-contact
    grain's by what the committed fit says (the elastic term, first order in a / R, wins at
    x = 10), well past the scatter."""
    (big, big_curve), (_, _), (small, small_curve) = runs
    x = big["depth"]
    f_small = np.exp(np.interp(np.log(x), np.log(small_curve["depth"][1:]),
                               np.log(small_curve["force_over_yield"][1:])))
    measured = big["peak_over_yield"] / f_small
    predicted = sim.finite_size_factor(x, big["approach_over_radius"]) \
        / sim.finite_size_factor(x, x * small["approach_over_radius"] / small["depth"])
    assert measured - 1.0 > 0.02  # a finite-size effect, not scatter (0.43 % RMS)
    # the fit's RMS residual is 0.9 % of F; its scatter over such points ~1 %
    assert measured == pytest.approx(predicted, abs=0.012)


# --- the committed dataset and its fit -----------------------------------------------------------
@pytest.fixture(scope="module")
def committed():
    data = sim._data_file(sim.DATASET)
    curves = sim._data_file(sim.CURVES)
    return sim.read_rows(data), sim.read_rows(curves)


def test_committed_fit_reproduces(committed):
    """The shipped correction is what the fit of the committed dataset gives (rerunnable)."""
    rows, curves = committed
    stored = sim.shipped_fit()
    for quantity in sim.FITTED:
        data = sim.deviations(rows, quantity, stored["half_space_below_contact_radius_over_radius"],
                              curves)
        fit = sim.fit_finite_size(data, quantity, stored["fit_max_approach_over_radius"])
        saved = stored["fits"][quantity]
        for name, value in fit.parameters.items():
            assert value == pytest.approx(saved["parameters"][name], rel=1e-5, abs=1e-9)
        assert fit.rms == pytest.approx(saved["rms"], rel=1e-5)
        assert fit.points == saved["points"]


def test_small_contacts_collapse_in_committed_data(committed):
    rows, _ = committed
    coarse = [r for r in rows if r["mesh"] == "coarse"]
    for peak in {r["peak_over_yield"] for r in coarse}:
        small = [r for r in coarse if r["peak_over_yield"] == peak
                 and r["contact_radius_over_radius"] < 0.02]
        if len(small) < 2:
            continue
        depth = [r["depth"] for r in small]
        assert np.ptp(depth) / np.mean(depth) < 5e-3
        assert np.ptp([r["residual_ratio"] for r in small]) < 5e-3


def test_finite_size_factor():
    fit = sim.shipped_fit()["fits"]["force"]
    p = fit["parameters"]
    s, x = 0.5 * fit["approach_over_radius_range"][1], 30.0
    expected = 1.0 + p["elastic"] * s ** 0.5 + p["plastic"] * s ** p["size_power"] \
        * x ** p["depth_power"]
    assert sim.finite_size_factor(x, s) == pytest.approx(expected)
    assert sim.finite_size_factor(x, 0.0) == 1.0
    assert np.allclose(sim.finite_size_factor(np.array([x, x]), np.array([0.0, s])),
                       [1.0, expected])
    assert sim.finite_size_factor(x, 1e-3, quantity="residual_ratio") > -0.1
    with pytest.raises(InputError, match="approach_over_radius: must be in"):
        sim.finite_size_factor(x, 2.0 * fit["approach_over_radius_range"][1] + 1.0)
    with pytest.raises(InputError, match="depth"):
        sim.finite_size_factor(1e6, s)
    with pytest.raises(InputError, match="quantity"):
        sim.finite_size_factor(x, s, quantity="friction")
