"""FE verification against analytic and published results (docs/model.md §4-5, issue 3).

Coarse meshes and few load steps, so each test runs in seconds; docs/verification.md lists the
full-resolution runs (scripts/verify_*.py) that these tests guard.
"""

import math

import numpy as np
import pytest
from conftest import YIELD_FIXED

import geocontact.fem.run as fem_run
from geocontact.fem.identity import FeRunIdentity
from geocontact.fem.run import FULLY_PLASTIC_FRACTION, fully_plastic_onset, run_history
from geocontact.grain import hertz
from geocontact.grain.material import Material, preset
from geocontact.verification import published_fits as fits


def _drucker_prager(beta_deg):
    """The reference grain (E = 10 GPa, nu = 0.25, sigma_c = 10 MPa, R = 0.1 m) at friction
    angle beta."""
    return Material(10e9, 0.25, 10e6, beta_deg, 0.0, 0.1)


# --- incipient yield: FE against grain.hertz.incipient_yield ---------------------
@pytest.mark.parametrize("beta_deg", [30.0, 55.0, 60.0])
def test_first_yield_force_and_location_match_analytic(beta_deg):
    """The first yielding point on the axis below the surface for beta = 30 deg, with Fy within
    5 % of the analytic value; at the surface near the contact edge above the critical beta
    (49.06 deg for nu = 0.25, geocontact.grain.hertz), where the maximum jumps there.

    At the contact edge the FE first yield is located where the yield measure of the elastic
    solution, over the quadrature points and on the surface at the edge
    (ContactSolver.edge_surface_ratio), reaches 1. With the quadrature points alone the coarse
    mesh gave 1.22 (55 deg) and 1.15 (60 deg), and over tip sizes 0.3-0.7 x the yield contact
    radius it had scattered from 0.81 to 1.91 x the analytic force; with the surface at the edge
    it gives 1.087 and 1.049, on the surface at r = 1.02 / 1.01 a (docs/verification.md, item
    4). Checked here: that location and Fy within 10 % on this mesh; the 5 % of the default mesh
    is test_edge_first_yield_within_5_percent_on_the_default_mesh.
    """
    material = _drucker_prager(beta_deg)
    assert math.tan(math.radians(beta_deg)) < 3.0
    analytic = hertz.incipient_yield(material)
    result = run_history(material, [0.0, 3.0 * analytic.force], mesh="coarse",
                         write_fields=False, steps_per_segment=12)
    s = result.summary
    lo, hi = s["first_yield_bracket_N"]
    assert lo < s["first_yield_force_N"] <= hi
    a = analytic.contact_radius
    r, z = s["first_yield_location_m"]["r"] / a, s["first_yield_location_m"]["z"] / a
    if analytic.at_surface:
        assert analytic.r_over_a == pytest.approx(1.0, abs=1e-6)
        assert z < 0.01 and 0.98 < r < 1.1  # the surface, at the contact edge
        assert s["first_yield_force_N"] == pytest.approx(analytic.force, rel=0.10)
    else:
        assert s["first_yield_force_N"] == pytest.approx(analytic.force, rel=0.05)
        assert lo < analytic.force * 1.05 and hi > analytic.force * 0.95
        assert r < 0.15 and abs(z - analytic.z_over_a) < 0.15  # the axis, below the surface


@pytest.mark.parametrize("beta_deg", [45.0, 50.0, 60.0])
def test_edge_first_yield_within_5_percent_on_the_default_mesh(beta_deg):
    """Issue 36: the FE first yield within 5 % of the analytic one on the default mesh at
    beta = 45 deg (on the axis, F phi^-3 from the last elastic step), 50 and 60 deg (at the
    contact edge, located by elastic solves where the largest yield ratio of the elastic solution,
    over the quadrature points and on the surface at the edge, reaches 1: the ratio there grows
    faster than Hertz's F^(1/3), and F phi^-3 overshot to the plastic step). The bracket is the
    pair of steps around the crossing and holds the value. At 50 deg the quadrature points alone
    gave 1.083 (they sample the cusp at the edge below its peak, and the axis yielded first); the
    surface ratio at the edge (ContactSolver.edge_surface_ratio) gives 0.999. At 60 deg the
    quadrature points near the edge still reach 1 first (their ratio is above Hertz's there):
    this guards the value of record, 0.978 (docs/verification/edge_first_yield.md)."""
    material = _drucker_prager(beta_deg)
    analytic = hertz.incipient_yield(material)
    result = run_history(material, [0.0, 3.0 * analytic.force], mesh="default",
                         write_fields=False, steps_per_segment=12)
    s = result.summary
    lo, hi = s["first_yield_bracket_N"]
    assert lo < s["first_yield_force_N"] <= hi
    assert s["first_yield_force_N"] == pytest.approx(analytic.force, rel=0.05)
    assert ("first_yield_search" in s) == analytic.at_surface == (beta_deg > 49.1)


def test_surface_ratio_at_the_contact_edge_matches_hertz_on_the_default_mesh():
    """ContactSolver.edge_surface_ratio, the Drucker-Prager ratio on the surface at r = a
    recovered from the traction-free surface outside the contact, against the analytic one of
    the Hertz field (grain.hertz: 1 at the analytic first-yield force above the critical angle,
    and ~ F^(1/3) with the edge stresses): within 2.5 % at 0.95, 1 and 1.05 Fy at 55 deg on the
    default mesh (measured: +0.5, -0.5, -1.8 %), while the largest quadrature-point ratio near
    the edge scatters by 8 % over the same forces (0.917, 1.014, 0.934) as the edge moves
    between them."""
    material = _drucker_prager(55.0)
    analytic = hertz.incipient_yield(material)
    forces = [0.0, 3.0 * analytic.force]
    identity = FeRunIdentity.of(material, forces, "default", steps_per_segment=12)
    mesh = fem_run.history_mesh(material, identity.mesh_force, "default",
                                min_force=fem_run.smallest_resolved_force(material, forces, 12))
    solver = fem_run._solver(material, mesh, identity, "fast")  # the run's own
    solver.plastic = False
    for fraction in (0.95, 1.0, 1.05):
        force = fraction * analytic.force
        edge, a = solver.edge_surface_ratio(solver.solve_step(solver.initial_state(), force))
        assert a == pytest.approx(fem_run.hertz_contact_radius(material, force), rel=0.02)
        assert edge == pytest.approx(fraction ** (1.0 / 3.0), rel=0.025)


def test_edge_first_yield_is_where_the_elastic_solution_reaches_yield():
    """The located first yield (coarse mesh, beta = 60 deg) against elastic solves of the same
    model made here: below it by twice the search's tolerance the yield measure (the largest
    ratio over the quadrature points and on the surface at the contact edge) is under 1, above
    it by as much it is over 1; the bracket's ends are recorded steps (the last one elastic and
    under 1), and the F phi^-3 extrapolation of the quadrature points from the last elastic
    step, the value reported before issue 36, is past the located value."""
    material = _drucker_prager(60.0)
    analytic = hertz.incipient_yield(material)
    result = run_history(material, [0.0, 3.0 * analytic.force], mesh="coarse",
                         write_fields=False, steps_per_segment=12)
    s, c, solver = result.summary, result.curve, result.solver
    fy, (lo, hi) = s["first_yield_force_N"], s["first_yield_bracket_N"]
    search = s["first_yield_search"]
    assert 1 <= search["elastic_solves"] <= fem_run.FIRST_YIELD_SOLVES

    def elastic(force):
        solver.plastic = False
        try:
            return solver.solve_step(solver.initial_state(), force)
        finally:
            solver.plastic = True

    def measure(force):
        state = elastic(force)
        return max(float(np.max(solver.yield_ratio(state))),
                   solver.edge_surface_ratio(state)[0])

    margin = 2.0 * search["force_rtol"]
    assert measure(fy * (1.0 - margin)) < 1.0 < measure(fy * (1.0 + margin))
    k = int(np.nonzero(c["force_N"] == hi)[0][0])
    assert c["force_N"][k - 1] == lo and c["plastic_points"][k - 1] == 0
    assert measure(lo) < 1.0 <= measure(hi) or c["plastic_points"][k] > 0
    assert lo / float(np.max(solver.yield_ratio(elastic(lo)))) ** 3 > fy


def test_analytic_first_yield_moves_to_the_contact_edge_above_the_critical_angle():
    """The premise of the large-beta case: beta = 30 deg yields on the axis, 55 and 60 deg at
    the contact edge on the surface (geocontact.grain.hertz, tested there against Johnson)."""
    assert not hertz.incipient_yield(_drucker_prager(30.0)).at_surface
    for beta in (55.0, 60.0):
        assert hertz.incipient_yield(_drucker_prager(beta)).at_surface


# --- von Mises limit: FE loading curve against Jackson & Green (2005) --------------------------
def test_von_mises_loading_curve_matches_jackson_green_up_to_10_critical_interferences():
    """beta = 0, E/sigma_c = 1000, nu = 0.3 (preset von-mises) on the coarse mesh: P/P_c within
    5 % of the Jackson-Green fit at 2, 5 and 10 omega_c (measured: -1.5 to -2.5 %; the two
    published fits differ from each other by up to 4 % in this range), and within 5 % of
    Kogut-Etsion from 1 to 10 omega_c. At 1 omega_c the JG fit is 5.5 % above Hertz by
    construction, so it is not compared there."""
    material = preset("von-mises")
    jg = fits.jackson_green_critical(material)
    ke = fits.kogut_etsion_critical(material)
    peak = 1.2 * float(fits.jackson_green_load(material, 10.0)) * jg.force
    result = run_history(material, [0.0, peak], mesh="coarse", write_fields=False,
                         steps_per_segment=8)
    omega = result.curve["approach_m"] / 2.0  # ball-wall interference of the half model
    force = result.curve["force_N"]
    at = np.array([2.0, 5.0, 10.0])
    fe = fits.fe_load_at(omega, force, at * jg.interference) / jg.force
    np.testing.assert_allclose(fe, fits.jackson_green_load(material, at), rtol=0.05)
    at_ke = np.array([1.0, 2.0, 5.0, 10.0])
    fe_ke = fits.fe_load_at(omega, force, at_ke * ke.interference) / ke.force
    np.testing.assert_allclose(fe_ke, fits.kogut_etsion_load(at_ke), rtol=0.05)


def test_published_fits_critical_values_agree_with_the_analytic_first_yield():
    """KE's K H = 2.8 (0.454 + 0.41 nu) and JG's C = 1.295 exp(0.736 nu) are both fits of the
    Hertz p0 at first yield; for nu = 0.3 they agree with grain.hertz (p0 = 1.613 sigma_c)
    to 0.2 %, and P_c is the Hertz load at omega_c for a sphere on a rigid flat."""
    material = preset("von-mises")
    p0 = 1.0 / hertz.incipient_yield(material).dp_factor
    assert fits.jackson_green_c(0.3) == pytest.approx(p0, rel=0.002)
    assert 2.8 * (0.454 + 0.41 * 0.3) == pytest.approx(p0, rel=0.002)
    jg = fits.jackson_green_critical(material)
    e_flat = material.youngs_modulus / (1.0 - material.poissons_ratio**2)
    assert jg.force == pytest.approx(
        4.0 / 3.0 * (material.radius / e_flat) ** 2 * (fits.jackson_green_c(0.3) * math.pi
                                                        * material.compressive_yield_stress
                                                        / 2.0) ** 3, rel=1e-12)
    # the ball-ball analytic first yield is twice the ball-wall interference of the fits
    assert hertz.incipient_yield(material).approach / 2.0 == pytest.approx(
        jg.interference, rel=0.005)


# --- von Mises limit: unloading, residual approach and loop work against Etsion et al. (2005) --
@pytest.fixture(scope="module", params=[30.0, 100.0], ids=["30Fy", "100Fy"])
def von_mises_cycle(request):
    """One coarse von Mises cycle 0 -> F -> 0 (F = 30 or 100 analytic Fy, 8 steps per segment;
    omega_max = 11.4 and 29.2 omega_c), as ball-wall interference and force of the half model."""
    material = preset("von-mises")
    peak = request.param * hertz.incipient_yield(material).force
    result = run_history(material, [0.0, peak, 0.0], mesh="coarse", write_fields=False,
                         steps_per_segment=8)
    return material, result


def test_von_mises_unloading_residual_and_loop_work_match_etsion_kligerman_kadin(von_mises_cycle):
    """The FE unloading of the von Mises sphere (preset von-mises: E/sigma_c = 1000, nu = 0.3,
    inside EKK's range E/S_y = 200-1000, nu = 0.3, omega_max <= 110 omega_c) against the fits of
    Etsion, Kligerman & Kadin (2005), normalised with Kogut-Etsion's omega_c and P_c.

    Tolerances: the coarse mesh is within 1.2 % (residual approach) and 2.5 % (plastic work) of
    the fine one and 24 -> 40 load steps move them by 1.6 / 2.4 % (docs/verification.md, mesh
    convergence); the published fits are themselves uncertain: EKK's and Jackson-Chusoipin-
    Green's residual fits differ by 0.7 % at 11 omega_c and 8 % at 29 omega_c, KE's and JG's
    loading fits by up to 4 %. Hence 6 % on omega_res/omega_max, 3 % on the unloading exponent
    (a Hertzian 3/2 is 8-12 % off), 0.03 P_max on the unloading curve, 5 % on the loading work
    (as the loading-curve test) and 8 % on the loop work (the difference of two works, each
    within a few %). Measured (30 / 100 Fy): residual ratio +1.8 / +2.8 %, exponent +0.3 /
    +0.8 %, curve 0.012 / 0.010 P_max, loading work -1.8 / -0.5 %, loop work -2.9 / +0.9 %.
    """
    from geocontact.calibrate.fit import _power_exponent

    material, result = von_mises_cycle
    ke = fits.kogut_etsion_critical(material)
    omega = result.curve["approach_m"] / 2.0  # ball-wall interference of the half model
    force = result.curve["force_N"]
    (cycle,) = result.summary["cycles"]
    k = int(np.argmax(force))
    omega_max, force_max = omega[k], force[k]
    omega_res = cycle["residual_approach_m"] / 2.0
    w = omega_max / ke.interference
    assert 10.0 < w < 35.0  # well past first yield, inside the fits' range

    # residual interference
    assert omega_res / omega_max == pytest.approx(float(fits.etsion_residual_ratio(w)), rel=0.06)
    # unloading: the exponent of P/P_max = t^n fitted to the FE branch, and the curve itself
    # (with the FE's own omega_res, so that the shape is checked apart from the residual)
    unload_omega, unload_force = omega[k:], force[k:]
    n_fe, _ = _power_exponent(unload_omega, unload_force, omega_res, omega_max, force_max)
    n_ekk = float(fits.etsion_unloading_exponent(w))
    assert n_fe == pytest.approx(n_ekk, rel=0.03)
    t = np.clip((unload_omega - omega_res) / (omega_max - omega_res), 0.0, None)
    assert np.max(np.abs(unload_force / force_max - t**n_ekk)) < 0.03
    # works of the half model (curve and summary energies are for the pair, docs/model.md §2)
    unit = ke.force * ke.interference
    loading_work = result.curve["work_J"][k] / 2.0
    assert loading_work == pytest.approx(float(fits.kogut_etsion_loading_work(w)) * unit,
                                         rel=0.05)
    reference_loop = (float(fits.kogut_etsion_loading_work(w) * fits.etsion_loop_work_ratio(w))
                      * unit)
    assert cycle["loop_work_J"] / 2.0 == pytest.approx(reference_loop, rel=0.08)
    # the FE's plastic dissipation is the loop work less the elastic energy locked in by the
    # residual stresses (energy balance over the closed cycle)
    assert cycle["plastic_work_J"] < cycle["loop_work_J"]
    assert cycle["plastic_work_J"] + cycle["residual_elastic_energy_J"] == pytest.approx(
        cycle["loop_work_J"], rel=0.03)


def test_etsion_fits_limits_and_closed_form_work():
    """The fits as coded: no residual and a Hertzian 3/2 at first yield, EKK's and JCG's residual
    ratios within 1 % of each other at 11 omega_c and 8 % at 29 omega_c (the spread used in the
    tolerance above), and the KE loading work the integral of the KE load."""
    from scipy.integrate import quad

    assert fits.etsion_residual_ratio(1.0) == 0.0 and fits.jackson_residual_ratio(1.0) == 0.0
    assert fits.etsion_unloading_exponent(1.0) == 1.5
    np.testing.assert_allclose(fits.etsion_unloading_load(10.0, [1.0, 0.2]), [1.0, 0.0])
    ratio = fits.jackson_residual_ratio([11.4, 29.2]) / fits.etsion_residual_ratio([11.4, 29.2])
    np.testing.assert_allclose(ratio, [0.993, 1.081], atol=0.002)
    for w in (0.5, 3.0, 20.0):
        exact = quad(lambda x: float(fits.kogut_etsion_load(x)), 0.0, w, points=[1.0, 6.0])[0]
        assert fits.kogut_etsion_loading_work(w) == pytest.approx(exact, rel=1e-9)
    # an elastic cycle gives back (almost) all: 0 at w = 1 but for KE's 3 % jump there
    assert abs(float(fits.etsion_loop_work_ratio(1.0))) < 0.031
    assert np.all(np.diff(fits.etsion_loop_work_ratio([2.0, 10.0, 50.0, 110.0])) > 0)


# --- fully plastic onset ---------------------------------------------------------------------
def test_fully_plastic_onset_interpolates_the_first_loading_crossing():
    force = [0.0, 100.0, 200.0, 300.0, 250.0, 400.0]
    approach = [0.0, 1.0, 2.0, 3.0, 2.9, 4.0]
    fraction = [0.0, 0.5, 0.85, 1.0, 0.2, 1.0]
    onset = fully_plastic_onset(force, approach, fraction, threshold=0.95)
    t = (0.95 - 0.85) / (1.0 - 0.85)
    assert onset["force_N"] == pytest.approx(200.0 + 100.0 * t)
    assert onset["approach_m"] == pytest.approx(2.0 + t)
    assert onset["bracket_N"] == [200.0, 300.0]
    # an unloading step never counts, and a history that never gets there gives None
    assert fully_plastic_onset([0, 10, 5], [0, 1, 0.5], [0, 0.5, 1.0]) is None
    # a reload below the envelope is not virgin loading, however yielded its small contact
    assert fully_plastic_onset([0, 10, 0, 0.3, 10], [0, 1, 0.4, 0.5, 1], [0, 0.5, 0, 1.0, 0.5]
                               ) is None
    onset = fully_plastic_onset([0, 10, 0, 5, 20], [0, 1, 0.4, 0.7, 2], [0, 0.5, 0, 1.0, 1.0],
                                threshold=0.95)
    assert onset["bracket_N"] == [5.0, 20.0]  # past the envelope: virgin again
    assert fully_plastic_onset([0, 10, 20], [0, 1, 2], [0, 0.5, 0.9]) is None


def test_yielded_contact_fraction_is_zero_while_elastic_and_reported_per_step():
    """The yielded fraction of the contact area (curve.csv) is 0 before first yield, within
    [0, 1] always, and the core fraction of the reference grain rises past the Fp threshold on
    the way to 6000 N. Fp of the reference cycle: 1911 / 2050 / 2536 N on the fine / default /
    coarse mesh with their preset load steps (docs/verification.md); 2894 N here (coarse, 8
    steps per segment: the crossing falls in a 2111-2965 N step)."""
    material = _drucker_prager(30.0)
    result = run_history(material, [0.0, 6000.0], mesh="coarse", write_fields=False,
                         steps_per_segment=8, **YIELD_FIXED)
    c, s = result.curve, result.summary
    for column in ("yielded_contact_fraction", "yielded_core_fraction"):
        assert np.all((c[column] >= 0.0) & (c[column] <= 1.0 + 1e-12))
        assert np.all(c[column][c["force_N"] < s["first_yield_force_N"]] == 0.0)
    fp = s["fully_plastic_force_N"]
    assert fp is not None and 1500.0 < fp < 3500.0
    lo, hi = s["fully_plastic_bracket_N"]
    assert lo <= fp <= hi
    k = int(np.searchsorted(c["force_N"], hi))
    assert c["yielded_core_fraction"][k] >= FULLY_PLASTIC_FRACTION
