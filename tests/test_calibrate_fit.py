"""The fitter recovers known parameters from cycles of a known law (with and without noise):
a check of the fitting machinery, independent of where real cycles come from."""

import numpy as np
import pytest
from conftest import make_params

from geocontact.calibrate import LevelData, fit_law
from geocontact.law import Contact


def cycles_of(params, depths, noise=0.0, seed=0):
    rng = np.random.default_rng(seed)
    dy = params.yield_approach
    levels = []
    for depth in depths:
        c = Contact(params)
        dmax = depth * dy
        for d in np.linspace(0, dmax, 100):
            c.update(d)
        fmax, dres = c.state.force, c.state.residual_approach
        total = float(params.virgin_work(dmax))
        down = np.linspace(dmax, dres, 80)
        fd = np.array([c.update(d)[0] for d in down])
        wp = c.dissipated_energy
        up = np.linspace(dres, dmax, 80)
        fr = np.array([c.update(d)[0] for d in up])
        def wobble(n):
            return 1 + noise * rng.standard_normal(n)

        levels.append(LevelData(dmax, fmax, dres, wp, total, down, fd * wobble(fd.size),
                                up, fr * wobble(fr.size)))
    d = np.geomspace(0.2, max(depths), 200) * dy
    f = params.virgin_force(d) * (1 + noise * rng.standard_normal(d.size))
    return d, f, levels


def test_fit_recovers_known_parameters():
    truth = make_params(elastic_plastic_exponent=1.3, fully_plastic_approach_ratio=30.0,
                        fully_plastic_exponent=1.12, unloading_power=-0.04,
                        reloading_power=-0.07, residual_limit=0.85, residual_power=0.32,
                        plastic_work_limit=0.0)
    d, f, levels = cycles_of(truth, [2, 5, 12, 30, 70, 150, 300])
    fitted = fit_law(truth.material, truth.yield_approach, d, f, levels)
    assert fitted.elastic_plastic_exponent == pytest.approx(1.3, rel=2e-3)
    assert fitted.fully_plastic_approach_ratio == pytest.approx(30.0, rel=0.05)
    assert fitted.fully_plastic_exponent == pytest.approx(1.12, rel=5e-3)
    assert fitted.unloading_power == pytest.approx(-0.04, abs=2e-3)
    assert fitted.reloading_power == pytest.approx(-0.07, abs=2e-3)
    assert fitted.residual_limit == pytest.approx(0.85, rel=1e-3)
    assert fitted.residual_power == pytest.approx(0.32, rel=1e-3)
    assert fitted.fit_errors["residual_ratio_rms"] < 1e-6


def test_fit_is_stable_under_noise():
    truth = make_params()
    d, f, levels = cycles_of(truth, [2, 5, 12, 30, 70, 150], noise=0.01, seed=3)
    fitted = fit_law(truth.material, truth.yield_approach, d, f, levels)
    # forces of the fitted law stay within a few per cent of the truth on a held-out depth
    dmax = 50 * truth.yield_approach
    peaks = []
    for p in (truth, fitted):
        c = Contact(p)
        peaks.append(c.update(dmax)[0])
    assert peaks[1] == pytest.approx(peaks[0], rel=0.03)
    assert fitted.fit_errors["unloading_curve_rms_of_peak"] < 0.02


def test_fit_recovers_a_third_loading_regime_and_a_stretched_residual_form():
    """Five decades of depth (a weak sphere): the log-slope falls in three steps and the
    residual ratio follows the stretched form; the fitter finds both."""
    truth = make_params(elastic_plastic_exponent=1.42, fully_plastic_approach_ratio=80.0,
                        fully_plastic_exponent=1.2, deep_plastic_approach_ratio=5000.0,
                        deep_plastic_exponent=0.95, residual_limit=0.95, residual_power=0.08,
                        residual_transition=2.0, residual_log_power=1.7, plastic_work_limit=0.0)
    depths = [2, 8, 40, 240, 1500, 1.2e4, 1.2e5]
    d, f, levels = cycles_of(truth, depths)
    fitted = fit_law(truth.material, truth.yield_approach, d, f, levels)
    assert fitted.deep_plastic_approach_ratio == pytest.approx(5000.0, rel=0.15)
    assert fitted.deep_plastic_exponent == pytest.approx(0.95, rel=0.01)
    assert fitted.fully_plastic_exponent == pytest.approx(1.2, rel=0.01)
    assert fitted.fit_errors["loading_rms_relative"] < 0.01
    x = np.array(depths, dtype=float)
    assert fitted.residual_ratio(x) == pytest.approx(truth.residual_ratio(x), rel=1e-3)
    assert fitted.fit_errors["residual_ratio_max_relative"] < 1e-3


def test_two_regime_curves_get_no_third_regime():
    truth = make_params(elastic_plastic_exponent=1.3, fully_plastic_approach_ratio=30.0,
                        fully_plastic_exponent=1.12)
    d, f, levels = cycles_of(truth, [2, 5, 12, 30, 70, 150, 300, 3000])
    fitted = fit_law(truth.material, truth.yield_approach, d, f, levels)
    assert np.isinf(fitted.deep_plastic_approach_ratio)


def test_segments_form_recovers_segments_on_its_grid():
    """The segments form puts one start per decade of the data's depth, equally spaced in log
    depth: a law made of such segments is recovered exactly, through fit_law and the file."""
    from geocontact.law import LawParams
    from geocontact.law.params import LoadingSegments

    truth = make_params(loading_segments=LoadingSegments(
        (1.0, 10.0, 100.0, 1000.0, 10000.0), (1.42, 1.3, 1.2, 1.1, 0.95)),
        residual_limit=0.95, residual_power=0.08, residual_transition=2.0,
        residual_log_power=1.7, plastic_work_limit=0.0)
    d, f, levels = cycles_of(truth, [2, 8, 40, 240, 1500, 1.2e4, 1e5])
    fitted = fit_law(truth.material, truth.yield_approach, d, f, levels,
                     loading_form="segments")
    assert fitted.loading_segments.depth == pytest.approx(truth.loading_segments.depth,
                                                          rel=1e-9)
    assert fitted.loading_segments.exponent == pytest.approx(truth.loading_segments.exponent,
                                                             rel=1e-9)
    assert fitted.fit_errors["loading_rms_relative"] < 1e-9
    again = LawParams.from_dict(fitted.to_dict())
    assert again.loading_segments == fitted.loading_segments


def test_segments_form_follows_a_bending_curve_the_regimes_miss():
    """A virgin curve whose log-slope falls steadily over five decades (a weak grain's): three
    regimes miss it by more than the segments form, which stays within 1 %."""
    from geocontact.calibrate.fit import fit_loading
    from geocontact.grain.hertz import hertz_coefficient

    params = make_params()
    dy, kh = params.yield_approach, hertz_coefficient(params.material)
    fy = kh * dy**1.5
    x = np.geomspace(1.0, 2e5, 400)
    # log-slope 1.45 at yield falling linearly in log x to 1.0 at 2e5: F/Fy = x^(a - b ln x)
    b = 0.45 / (2.0 * np.log(2e5))
    f = fy * x ** (1.45 - b * np.log(x))
    regimes = fit_loading(x * dy, f, dy, kh)
    segments = fit_loading(x * dy, f, dy, kh, form="segments")
    assert len(segments["loading_segments"].depth) == 6  # 5.3 decades: 6 segments
    assert segments["rms_relative_error"] < 0.01
    assert segments["rms_relative_error"] < 0.5 * regimes["rms_relative_error"]


def test_segments_form_adds_segments_where_one_per_decade_misses_the_goal():
    """A contact that runs away at the top (the reference grain loaded to a/R 0.35: log-slope
    1.35 -> 0.4 over its last decade): one segment per decade misses the 2 % loading goal, so
    the form steps its density up until the fit meets it; a gently bending curve keeps one per
    decade (the shipped weak-grain file is fitted at that density)."""
    from geocontact.calibrate import fit
    from geocontact.grain.hertz import hertz_coefficient

    params = make_params()
    dy, kh = params.yield_approach, hertz_coefficient(params.material)
    fy = kh * dy**1.5
    lx = np.linspace(0.0, np.log(6000.0), 600)
    start = np.log(600.0)
    slope = np.where(lx < start, 1.48 - 0.02 * lx,
                     1.48 - 0.02 * start - 1.0 * (lx - start) / (lx[-1] - start))
    y = np.concatenate([[0.0], np.cumsum(0.5 * (slope[1:] + slope[:-1]) * np.diff(lx))])
    d, f = np.exp(lx) * dy, fy * np.exp(y)
    one = fit._fit_segments_at(lx[1:], y[1:], fit._trapezoid_weights(lx[1:]), 1)
    assert one["rms_relative_error"] > fit.LOADING_GOAL
    denser = fit.fit_loading(d, f, dy, kh, form="segments")
    assert denser["rms_relative_error"] <= fit.LOADING_GOAL
    assert len(denser["loading_segments"].depth) > len(one["loading_segments"].depth)
    gentle = fit.fit_loading(d[lx < start], f[lx < start], dy, kh, form="segments")
    assert len(gentle["loading_segments"].depth) == 3  # 2.8 decades: at least 3 segments


def test_unknown_loading_form_is_a_one_line_error():
    from geocontact.errors import InputError

    truth = make_params()
    d, f, levels = cycles_of(truth, [2, 5, 12])
    with pytest.raises(InputError, match="^loading form: must be one of regimes, segments, "):
        fit_law(truth.material, truth.yield_approach, d, f, levels, loading_form="spline")


def test_table_form_puts_its_knots_at_the_levels_and_reports_leave_one_out():
    """residual_form="table": the knots are the levels' depths and residual ratios; the
    in-sample errors are zero by construction (and named so), the leave-one-out errors are
    each interior level predicted from the others; the file round-trips through both readers."""
    import json

    from geocontact.law import LawParams, _core

    truth = make_params(elastic_plastic_exponent=1.3, fully_plastic_approach_ratio=30.0,
                        fully_plastic_exponent=1.12, unloading_power=-0.04,
                        reloading_power=-0.07, residual_limit=0.85, residual_power=0.32,
                        plastic_work_limit=0.0)
    depths = [2, 5, 12, 30, 70, 150, 300]
    d, f, levels = cycles_of(truth, depths)
    fitted = fit_law(truth.material, truth.yield_approach, d, f, levels, residual_form="table")
    saturating = fit_law(truth.material, truth.yield_approach, d, f, levels)
    assert fitted.residual_tabulated and not saturating.residual_tabulated
    x = [lv.max_approach / truth.yield_approach for lv in levels]
    rho = [lv.residual_approach / lv.max_approach for lv in levels]
    assert fitted.residual_table.depth == tuple(x)
    assert fitted.residual_table.ratio == tuple(rho)
    e = fitted.fit_errors
    assert e["residual_ratio_in_sample_max_relative_zero_by_construction"] < 1e-13
    assert e["elastic_recovery_in_sample_max_relative_zero_by_construction"] < 1e-13
    assert "residual_ratio_max_relative" not in e and "residual_ratio_rms" not in e
    loo = e["residual_table_leave_one_out"]
    interior = [lv for lv in loo["per_level"] if not lv["extrapolated"]]
    assert len(interior) == len(depths) - 2
    assert loo["residual_ratio_max_relative"] == max(abs(lv["ratio_relative_error"])
                                                     for lv in interior)
    # a smooth truth sampled every half decade: each interior level within 1 % from the others
    assert 1e-5 < loo["residual_ratio_max_relative"] < 0.01
    assert 1e-5 < loo["elastic_recovery_max_relative"] < 0.01
    # the other parameters are the saturating fit's
    assert fitted.elastic_plastic_exponent == saturating.elastic_plastic_exponent
    assert fitted.unloading_power == saturating.unloading_power
    again = LawParams.from_dict(json.loads(fitted.to_json()))
    assert again.residual_table == fitted.residual_table
    cpp = _core.parse_params(fitted.to_json())
    assert cpp.residual_ratio(40.0) == pytest.approx(float(fitted.residual_ratio(40.0)),
                                                     rel=1e-14)


def test_table_form_needs_ratios_rising_with_depth():
    from geocontact.errors import InputError

    truth = make_params()
    d, f, levels = cycles_of(truth, [2, 5, 12, 30, 70])
    levels[3].residual_approach = 0.999 * levels[2].residual_approach / levels[2].max_approach \
        * levels[3].max_approach
    with pytest.raises(InputError, match=r"^calibration: the tabulated residual form needs "
                                         r"residual ratios rising strictly with depth; the level "
                                         r"at delta_max/delta_y = 30 has .* use the saturating"):
        fit_law(truth.material, truth.yield_approach, d, f, levels, residual_form="table")
    fit_law(truth.material, truth.yield_approach, d, f, levels)  # the closed form fits them
    with pytest.raises(InputError, match=r"^residual form: must be one of saturating, table"):
        fit_law(truth.material, truth.yield_approach, d, f, levels, residual_form="spline")


def _flattened_near_yield(depths, scales):
    """Cycles of a law whose loading exponent sits near the near-yield energy bound, with the
    first levels' residual ratios scaled down: a table through them starts flat."""
    truth = make_params(elastic_plastic_exponent=1.49, fully_plastic_approach_ratio=30.0,
                        fully_plastic_exponent=1.12, unloading_power=-0.04,
                        reloading_power=-0.07, residual_limit=0.95, residual_power=0.3,
                        plastic_work_limit=0.0)
    d, f, levels = cycles_of(truth, depths)
    for lv, scale in zip(levels, scales, strict=False):
        lv.residual_approach *= scale
    return truth, d, f, levels


def test_table_that_creates_energy_keeps_the_table_with_a_bounded_loading_exponent():
    """The "creates energy" fallback with a table: first the loading refit with n1 at the
    near-yield bound, the table kept."""
    truth, d, f, levels = _flattened_near_yield([1.5, 3, 8, 20, 60, 200], [0.1, 0.5])
    fitted = fit_law(truth.material, truth.yield_approach, d, f, levels, residual_form="table")
    assert fitted.residual_tabulated
    assert "created energy" in fitted.fit_errors["loading_first_exponent_bounded"]
    assert "residual_table_leave_one_out" in fitted.fit_errors


def test_table_that_still_creates_energy_gives_way_to_the_saturating_form():
    """When the bounded loading exponent does not help, the table (the data themselves) has
    nothing to restrict: the saturating form's restricted fits follow, recorded as such."""
    truth, d, f, levels = _flattened_near_yield([3, 5, 8, 20, 60, 200], [0.05, 0.3])
    fitted = fit_law(truth.material, truth.yield_approach, d, f, levels, residual_form="table")
    assert not fitted.residual_tabulated
    restricted = fitted.fit_errors["residual_form_restricted"]
    assert restricted.startswith("the table through the levels given up for the saturating "
                                 "form, ")
    assert "residual_table_leave_one_out" not in fitted.fit_errors
    assert "residual_ratio_max_relative" in fitted.fit_errors
