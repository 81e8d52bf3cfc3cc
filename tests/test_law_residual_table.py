"""The tabulated residual-approach form (law/residual_table.py, docs/law.md): a monotone cubic
Hermite spline of logit(rho) against ln ln x, checked against scipy's independent splines, for
monotonicity, C1 joins, its ends, and through the law."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from scipy.interpolate import CubicHermiteSpline, PchipInterpolator

from geocontact.law import Contact, LawParams, load_params
from geocontact.law.residual_table import LOGIT_CAP, ResidualTable, knot_slopes

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def _weak_levels() -> tuple[list[float], list[float]]:
    """The 13 calibration levels of the shipped weak-grain file (x from 1.6 to 1.8e5)."""
    levels = json.loads((EXAMPLES / "params-reference-weak.json").read_text())
    per_level = levels["fit_errors"]["per_level"]
    return [lv["depth"] for lv in per_level], [lv["residual_ratio"] for lv in per_level]


def _random_tables(n_tables: int = 20):
    rng = np.random.default_rng(7)
    for _ in range(n_tables):
        n = int(rng.integers(3, 12))
        depth = np.sort(np.exp(np.cumsum(rng.uniform(0.05, 3.0, n))))
        ratio = np.sort(rng.uniform(0.001, 0.999, n))
        if np.all(np.diff(depth) > 0) and np.all(np.diff(ratio) > 0):
            yield ResidualTable(tuple(1.0 + depth), tuple(ratio))


TABLES = [ResidualTable(*_weak_levels()), *_random_tables()]


@pytest.mark.parametrize("table", TABLES)
def test_interior_slopes_are_scipys_pchip_slopes(table):
    sp = table.spline
    pchip = PchipInterpolator(sp.u, sp.g)
    assert np.allclose(sp.slope[1:-1], pchip.derivative()(sp.u[1:-1]), rtol=1e-12, atol=1e-14)
    # the ends: the end segments' secants (scipy's three-point ends differ; not compared)
    assert sp.slope[0] == pytest.approx((sp.g[1] - sp.g[0]) / (sp.u[1] - sp.u[0]), rel=1e-15)
    assert sp.slope[-1] == pytest.approx((sp.g[-1] - sp.g[-2]) / (sp.u[-1] - sp.u[-2]),
                                         rel=1e-15)


def test_slopes_vanish_where_the_secants_change_sign_or_vanish():
    u = np.array([0.0, 1.0, 2.0, 3.0, 4.0])
    g = np.array([0.0, 1.0, 0.5, 0.5, 2.0])
    slopes = knot_slopes(u, g)
    assert slopes[1] == 0.0 and slopes[2] == 0.0 and slopes[3] == 0.0
    assert np.allclose(slopes[1:-1], PchipInterpolator(u, g).derivative()(u[1:-1]), atol=0.0)


@pytest.mark.parametrize("table", TABLES)
def test_the_interpolant_is_the_cubic_hermite_spline_with_those_slopes(table):
    sp = table.spline
    reference = CubicHermiteSpline(sp.u, sp.g, sp.slope)
    u = np.linspace(sp.u[0], sp.u[-1], 2001)
    x = np.exp(np.exp(u))
    assert np.allclose(table.logit(x), reference(u), rtol=1e-12, atol=1e-12)
    rho = table(x)
    assert np.allclose(rho, 1.0 / (1.0 + np.exp(-reference(u))), rtol=1e-12, atol=1e-300)
    # through the knots
    assert np.allclose(table(np.asarray(table.depth)), table.ratio, rtol=1e-13, atol=0.0)


@pytest.mark.parametrize("table", TABLES)
def test_monotone_in_zero_one_and_zero_up_to_yield(table):
    x = np.concatenate([[0.0, 0.5, 1.0], 1.0 + np.geomspace(1e-12, 1e12, 20001)])
    rho = table(x)
    assert np.all(rho[:3] == 0.0)
    assert np.all(np.diff(rho) >= 0.0)
    assert np.all((rho[3:] >= 0.0) & (rho[3:] < 1.0))
    assert np.all(rho[3:][x[3:] > table.depth[0] / 2 + 0.5] > 0.0)


@pytest.mark.parametrize("table", TABLES)
def test_c1_at_every_knot_and_straight_lines_beyond_the_ends(table):
    """g(u) and dg/du continuous at the knots (one-sided differences), and linear in u with
    the end slope beyond each end knot."""
    sp = table.spline
    h = np.diff(sp.u)
    secant = np.diff(sp.g) / h

    def g_of_u(u):
        return table.logit(np.exp(np.exp(np.asarray(u, dtype=float))))

    # each segment's cubic ends with the next knot's value and slope (the coefficients)
    end_value = sp.g[:-1] + h * (sp.slope[:-1] + h * (sp.quadratic + h * sp.cubic))
    end_slope = sp.slope[:-1] + h * (2.0 * sp.quadratic + 3.0 * h * sp.cubic)
    assert np.allclose(end_value, sp.g[1:], rtol=1e-12, atol=1e-12)
    assert np.allclose(end_slope, sp.slope[1:], rtol=1e-9, atol=1e-9 * np.abs(secant).max())
    # and the evaluated function: one-sided differences on either side of every knot
    for k, uk in enumerate(sp.u):
        near = h[max(k - 1, 0):k + 1]
        eps = 1e-6 * near.min()
        left = (g_of_u(uk) - g_of_u(uk - eps)) / eps
        right = (g_of_u(uk + eps) - g_of_u(uk)) / eps
        assert g_of_u(uk) == pytest.approx(sp.g[k], abs=1e-12)
        scale = max(abs(sp.slope[k]), np.abs(secant[max(k - 1, 0):k + 1]).max(), 1.0)
        assert abs(left - sp.slope[k]) < 1e-4 * scale, k
        assert abs(right - sp.slope[k]) < 1e-4 * scale, k
    below = sp.u[0] - np.array([0.5, 1.0, 3.0])
    assert np.allclose(g_of_u(below), sp.g[0] + sp.slope[0] * (below - sp.u[0]), rtol=1e-12)
    above = sp.u[-1] + np.array([0.5, 1.0, 2.0])
    assert np.allclose(g_of_u(above), sp.g[-1] + sp.slope[-1] * (above - sp.u[-1]),
                       rtol=1e-12)


def test_ends_zero_at_yield_below_one_at_any_depth():
    """rho -> 0 as x -> 1 like a power of ln x (the line below the first knot), and stays
    below 1 at any depth (g capped): the unloading span delta_max - delta_res never vanishes."""
    table = TABLES[0]
    sp = table.spline
    x = 1.0 + np.array([1e-3, 1e-6, 1e-9])
    rho = table(x)
    # logit ~ g0 + m0 (ln ln x - u0): rho ~ exp(g0 - m0 u0) (ln x)^m0 as ln x -> 0
    assert np.allclose(rho, np.exp(sp.g[0] - sp.slope[0] * sp.u[0]) * np.log(x) ** sp.slope[0],
                       rtol=1e-3)
    steep = ResidualTable((2.0, 3.0, 4.0), (0.5, 0.9, 0.999999))
    huge = steep(np.array([10.0, 1e10, 1e300]))
    assert np.all(huge < 1.0)
    assert huge[-1] == 1.0 / (1.0 + np.exp(-LOGIT_CAP))


def test_a_tabulated_law_unloads_to_the_tables_residual_approach():
    """Through the reference Contact: a full cycle to each depth ends apart at rho(x) delta_max."""
    law = load_params(EXAMPLES / "params-reference-weak.json")
    depth, ratio = _weak_levels()
    doc = law.to_dict()
    doc["residual_approach"] = {"table": {"depth": depth, "ratio": ratio}}
    tabulated = LawParams.from_dict(doc)
    for x in (1.2, depth[3], 300.0, 2e5):
        contact = Contact(tabulated)
        dmax = x * tabulated.yield_approach
        contact.update(dmax)
        contact.update(0.0)
        assert contact.state.residual_approach == pytest.approx(
            float(tabulated.residual_ratio(x)) * dmax, rel=1e-14)
    assert tabulated.residual_ratio(depth[3]) == pytest.approx(ratio[3], rel=1e-13)


def _tabulated_weak() -> LawParams:
    law = load_params(EXAMPLES / "params-reference-weak.json")
    depth, ratio = _weak_levels()
    doc = law.to_dict()
    doc["residual_approach"] = {"table": {"depth": depth, "ratio": ratio}}
    return LawParams.from_dict(doc)


def test_closed_form_consumers_refuse_a_table_in_one_line():
    """Code that works on the closed form's parameters (the laboratory fit's reported values,
    the universal law's warm starts) says so for a tabulated law; the closed form reads."""
    from geocontact.errors import InputError
    from geocontact.labtest.fit import fitted_values

    tabulated = _tabulated_weak()
    with pytest.raises(InputError, match=r"^residual_approach: the laboratory fit needs the "
                                         r"closed form .*residual_approach.table\)$"):
        fitted_values(tabulated)
    closed = load_params(EXAMPLES / "params-reference.json")
    assert closed.residual_closed_form("x") == (closed.residual_limit, closed.residual_power,
                                                closed.residual_transition,
                                                closed.residual_log_power)
    assert fitted_values(closed)["residual_limit"] == closed.residual_limit


def test_report_of_a_tabulated_law_file(tmp_path):
    """The report's law section draws a tabulated law and lists its table."""
    from geocontact.report.html import Report
    from geocontact.report.law import law_section

    path = tmp_path / "tabulated.json"
    _tabulated_weak().save(path)
    report = Report("t", "", {})
    law_section(report, path, tmp_path, tmp_path / "figures")
    (heading, items), = report.sections
    depth, _ = _weak_levels()
    assert f"table of 13 knots, δmax/δy {depth[0]:.4g} to {depth[-1]:.4g}" in items[0]
    assert "ρ∞" not in items[0]
