"""docs/fit.md acceptance on the committed lab records, E from the unloading stiffness, and the
contact point the FE master curve places.

The two original synthetic tests of examples/tests/ (platens-quartzite, flat-sandstone) are fitted
with the FE master curve their identification ended on (tests/data/labtest) and the law is driven
along the grain's check history, a different FE history committed as its run
(``make_synthetic_lab_tests.py --check-curves``): the goals of docs/fit.md, force RMS <= 5 % of
the peak and residual approach <= 10 %, on the noisy records; sigma_c within 5 % and E within
2 % on the noise-free ones, whichever contact point (whole record or its refinement on the Hertz
onset) the master curve's misfit chooses.

E from the unloading stiffness (S = 2 beta E* a at each peak; Sneddon 1965, Oliver & Pharr 1992):
the relation against the closed form (Hertz) and the committed FE runs, beta(a/R) as the
committed FE runs give it, and the record without a resolved Hertz part (sparse-quartzite),
where it gives E and sigma_c.
"""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from geocontact.labtest import read_test
from geocontact.labtest.fit import Peak, fit_once, provenance_of, unloading_law
from geocontact.labtest.identify import read_master, unloading_modulus

ROOT = Path(__file__).resolve().parents[1]
TESTS = ROOT / "examples" / "tests"
DATA = ROOT / "tests" / "data" / "labtest"
CHECK = {"platens-quartzite": "quartzite-check.json", "flat-sandstone": "sandstone-check.json"}
FORCE_RMS_GOAL = 5.0   # docs/fit.md acceptance: force RMS along the check history, % of peak
RESIDUAL_GOAL = 10.0   # and the residual approach at each return to zero, %
SIGMA_C_GOAL = 0.05    # noise-free sigma_c
MODULUS_GOAL = 0.02    # noise-free E (tests/test_labtest.py: the platens test's 2 %)
E_TOLERANCE = 0.05     # docs/fit.md: E from the unloading stiffness on a record without Hertz


def _fit(name: str, record: str, master: str | None = None):
    truth = json.loads((TESTS / f"{name}.truth.json").read_text())
    m = truth["material"]
    fit = fit_once(read_test(TESTS / f"{record}.csv"), truth["setup"], m["radius"],
                   machine_stiffness=truth["machine_stiffness_N_per_m"],
                   poissons_ratio=m["poissons_ratio"], friction_angle=m["friction_angle_deg"],
                   master=read_master(DATA / f"{master or name}.master.json"))
    return truth, fit


def _check_history(name: str):
    """The grain's check-history FE run as calibrate.acceptance.compare reads a run and job."""
    data = json.loads((DATA / CHECK[name]).read_text())
    return (SimpleNamespace(forces=tuple(data["forces_N"]), identity=lambda: None),
            SimpleNamespace(curve=data["curve"], summary=data["summary"]))


@pytest.mark.parametrize("name", list(CHECK))
def test_the_committed_tests_meet_the_acceptance(name):
    from geocontact.calibrate.acceptance import compare

    _, noisy = _fit(name, name)
    job, run = _check_history(name)
    c = compare(noisy.params, job, run, name=f"{name}-check", kind="held-out",
                description="a different FE history of the same grain")
    assert c.force_rms_percent <= FORCE_RMS_GOAL
    assert c.residual_error_percent <= RESIDUAL_GOAL
    truth, clean = _fit(name, f"{name}.clean")
    m = truth["material"]
    assert clean.params.material.compressive_yield_stress == pytest.approx(
        m["compressive_yield_stress"], rel=SIGMA_C_GOAL)
    assert clean.params.material.youngs_modulus == pytest.approx(m["youngs_modulus"],
                                                                  rel=MODULUS_GOAL)
    # the choice of contact point is made, and said, by the master curve's misfit
    assert clean.contact["choice"]["by"].startswith("misfit of the FE master curve")
    assert clean.modulus_route["route"] == "hertz_part"


def test_unloading_stiffness_of_a_hertz_unloading_is_2_e_star_a():
    """Closed form: a Hertz unloading F = K d^1.5 (K = 4/3 E* sqrt(R*)) has the initial slope
    S = 1.5 F / d = 2 E* a with a = sqrt(R* d); the unloading law's S gives it, and
    ``unloading_modulus`` with an elastic master curve (g = x^1.5, a = sqrt(x)) returns E*
    whatever the sigma_c scale, divided by the FE's beta(a/R) it applies (a Hertz half-space
    unloading has beta = 1)."""
    from geocontact.grain.material import Material
    from geocontact.labtest.stiffness import factor

    radius, e_star = 4e-3, 15e9
    k = 4.0 / 3.0 * e_star * math.sqrt(radius / 2)
    dmax = 2e-7
    d = np.linspace(dmax, 0.0, 400)
    law = unloading_law(d, k * d**1.5, Peak(dmax, k * dmax**1.5))
    stiffness = law[1] * k * dmax**1.5 / (dmax - law[0])
    assert stiffness == pytest.approx(2 * e_star * math.sqrt(radius / 2 * dmax), rel=1e-3)
    material = Material(youngs_modulus=2 * (1 - 0.2**2) * e_star, poissons_ratio=0.2,
                        compressive_yield_stress=20e6, friction_angle_deg=20.0,
                        hardening_ratio=0.0, radius=radius)
    x = np.geomspace(0.01, 1e3, 200)
    master = {"x": x, "g": x**1.5, "a": np.sqrt(x), "material": material,
              "yield_approach_m": 3e-8}
    for s in (0.5, 1.0, 2.0):
        found = unloading_modulus(master, [(dmax, stiffness), (0.5 * dmax, 2 * e_star * math.sqrt(
            radius / 2 * 0.5 * dmax))] * 2, s)
        beta = factor(math.sqrt(radius / 2 * dmax) / radius)
        assert found["scale"] * beta == pytest.approx(1.0, rel=2e-3)


def test_the_fe_unloadings_follow_s_equals_2_e_star_a():
    """The relation the unloading route rests on, in this project's FE (the committed runs of
    datasets/fe-runs/partial-unloading, 1088 Fy): the slope of the first unloading step (at most
    5 % of the peak force, so the secant is the tangent) is 2 E* a of the FE's own contact
    radius at the peak within 5 %."""
    runs = sorted((ROOT / "datasets" / "fe-runs" / "partial-unloading").glob("*/summary.json"))
    checked = 0
    for path in runs:
        m = json.loads(path.read_text())["inputs"]["material"]
        rows = list(csv.DictReader((path.parent / "curve.csv").open()))
        f = np.array([float(r["force_N"]) for r in rows])
        d = np.array([float(r["approach_m"]) for r in rows])
        a = np.array([float(r["contact_radius_m"]) for r in rows])
        k = int(np.argmax(np.diff(f) < 0))
        if k == 0 or f[k + 1] < 0.95 * f[k]:
            continue
        e_star = m["youngs_modulus"] / (2 * (1 - m["poissons_ratio"] ** 2))
        slope = (f[k] - f[k + 1]) / (d[k] - d[k + 1])
        assert slope / (2 * e_star * a[k]) == pytest.approx(1.0, abs=0.05)
        checked += 1
    assert checked >= 5


def test_the_unloading_stiffness_factor_is_the_committed_fe_runs_own():
    """beta(a/R) = S / (2 E* a), which E from the unloadings divides by, is what the committed
    FE runs give (``scripts/unloading_stiffness_factor.py`` recomputed from the runs it lists:
    the committed file is neither stale nor edited by hand), and tends to Sneddon's
    half-space value 1 at small contacts (Sneddon 1965; within the FE unloadings' scatter) and
    grows with the contact (a sphere is not a half-space)."""
    from geocontact.labtest import stiffness

    committed = json.loads((ROOT / "src" / "geocontact" / "data" / stiffness.FACTOR_FILE)
                           .read_text())
    # the runs the committed fit was made of (FE runs committed since leave it as it is until
    # the script is rerun)
    found = stiffness.measure(sorted(p for p in (ROOT / "datasets" / "fe-runs").iterdir()
                                     if p.is_dir()),
                              runs={r["run"] for r in committed["rows"]})
    # a least-squares polynomial fit amplifies the last bits of its data: the same runs and code
    # give the coefficients 1.6e-9 apart on another CPU (numpy's kernels are chosen per machine;
    # measured 2026-12-07), far below any edit or staleness of the file
    assert found["coefficients"] == pytest.approx(committed["coefficients"], rel=1e-7)
    assert found["unloadings"] == committed["unloadings"] >= 50
    small = float(stiffness.factor(1e-3))
    assert small == pytest.approx(1.0, abs=max(0.03, 2 * found["rms_residual"]))
    beta = stiffness.factor(np.linspace(1e-3, 0.3, 30))
    assert np.all(np.diff(beta) > 0)


@pytest.mark.parametrize("record", ["sparse-quartzite", "sparse-quartzite.clean"])
def test_a_record_without_a_hertz_part_takes_e_from_its_unloadings(record):
    """sparse-quartzite (its first loading in about 12 points: no Hertz part) takes E from the
    unloading stiffness S = 2 beta E* a (beta(a/R) of the FE unloadings), with a standard error,
    and says so: E within 2 % (+0.5 %, noise-free +1.1 %) and sigma_c within docs/fit.md's 5 %
    (-0.1 %, -4.2 %); with beta = 1 they were +1.9 %, +2.6 % and -4.2 %, -8.0 %, and from the
    Hertz part (the route before) E -19 %, sigma_c +93 % on the noise-free record."""
    truth, fit = _fit("sparse-quartzite", record, master="platens-quartzite")
    route = fit.modulus_route
    assert route["route"] == "unloading_stiffness"
    assert route["unloading_stiffness_standard_error_Pa"] > 0
    assert route["stiffness_factor_standard_error_Pa"] > 0
    assert all(1.0 < b < 1.1 for b in route["stiffness_factor_per_cycle"])
    assert fit.params.material.youngs_modulus == pytest.approx(
        truth["material"]["youngs_modulus"], rel=MODULUS_GOAL)
    assert fit.params.material.compressive_yield_stress == pytest.approx(
        truth["material"]["compressive_yield_stress"], rel=SIGMA_C_GOAL)
    assert "unloading stiffness" in provenance_of(fit)["fitted_from_curve"][
        "material.youngs_modulus"]
    # with K fixed by that E the contact point is refined on the dozen first-loading points:
    # within 0.05 dy of the generator's (the whole record alone: 0.24-0.28 dy off)
    key = "clean_contact_displacement_m" if record.endswith("clean") else "contact_displacement_m"
    assert "modulus_refinement" in fit.contact
    assert abs(fit.contact["contact_displacement_m"] - truth[key]) <= 0.05 * truth[
        "fe_first_yield_approach_m"]


def test_a_record_with_a_hertz_part_keeps_it_and_the_unloadings_agree():
    """The noise-free platens test resolves its Hertz part: E comes from it; the unloading
    stiffness's estimate, beside it, agrees with the true E within 5 %."""
    truth, fit = _fit("platens-quartzite", "platens-quartzite.clean")
    route = fit.modulus_route
    assert route["route"] == "hertz_part"
    assert route["unloading_stiffness_Pa"] == pytest.approx(truth["material"]["youngs_modulus"],
                                                            rel=E_TOLERANCE)


def test_the_load_cell_noise_does_not_pull_the_flat_test_s_contact():
    """The flat test's noisy sigma_c bias (docs/fit.md, "The flat test's bias"): the noise-free
    record with the generator's load-cell noise alone (3e-4 of the peak force; the realizations'
    first draw of scripts/verify_lab_fit.py). With the contact fit's robust loss at 3 sigma the
    whole record's contact moved -0.024 dy and sigma_c came out +11 % (the onset refinement,
    chosen, +11 %); with the loss at the power laws' form error it is -0.009 dy and +5.4 to
    +6.2 % over three draws (labfit3); with the master curve's contact refinement and its
    selection of points on the smoothed force (docs/fit.md, "The contact point and the master
    curve") +1.0 % over the same three. Checked: the whole record's contact is chosen, sigma_c
    within 3 % and E within 2 %."""
    from geocontact.labtest.curve import Record

    truth = json.loads((TESTS / "flat-sandstone.truth.json").read_text())
    m = truth["material"]
    clean = read_test(TESTS / "flat-sandstone.clean.csv")
    rng = np.random.default_rng(2024)
    rng.normal(0, 1, clean.force.size)  # the displacement's draw, not used: the same force noise
    peak = float(clean.force.max())
    noisy = Record(clean.displacement, clean.force + 1e-3 * peak
                   + rng.normal(0, 3e-4 * peak, clean.force.size), clean.time, "realization", {})
    fit = fit_once(noisy, truth["setup"], m["radius"],
                   machine_stiffness=truth["machine_stiffness_N_per_m"],
                   poissons_ratio=m["poissons_ratio"], friction_angle=m["friction_angle_deg"],
                   master=read_master(DATA / "flat-sandstone.master.json"))
    assert fit.contact["choice"]["chosen"] == "whole_record"
    assert fit.params.material.compressive_yield_stress == pytest.approx(
        m["compressive_yield_stress"], rel=0.03)
    assert fit.params.material.youngs_modulus == pytest.approx(m["youngs_modulus"], rel=0.02)


def test_the_master_curve_places_the_contact_of_a_short_hertz_part():
    """ramp-quartzite.clean (first cycle 8 Fy: a short Hertz part). Its contact from the Hertz
    onset was -0.027 dy (E -3.0 %, sigma_c +8.7 %): the FE-made record's onset is the chord from
    the contact to the FE's first load step (4 x Hertz at 0.006 dy), which the onset fit and the
    log-depth weights of the master curve's scale fit both took for the curve. Now the points
    below 5 x the resolution floor are not in the scale fit, and the contact is refined by the
    master curve itself (contact_point.master_refinement): within 0.01 dy, sigma_c within
    docs/fit.md's 5 %."""
    truth, fit = _fit("ramp-quartzite", "ramp-quartzite.clean", master="platens-quartzite")
    m = truth["material"]
    assert fit.params.material.compressive_yield_stress == pytest.approx(
        m["compressive_yield_stress"], rel=SIGMA_C_GOAL)
    assert fit.params.material.youngs_modulus == pytest.approx(m["youngs_modulus"],
                                                                rel=MODULUS_GOAL)
    dy = truth["fe_first_yield_approach_m"]
    assert abs(fit.contact["contact_displacement_m"] - truth["clean_contact_displacement_m"]) \
        <= 0.01 * dy
    assert "master_refinement" in fit.contact
    assert not fit.contact["master_refinement"]["on_bound"]


def test_the_virgin_points_are_selected_without_truncating_the_noise():
    """The master curve's scale fit keeps the virgin points above 5 sigma. Selected on the
    noisy force, the kept points near that threshold are those the noise lifted (a truncated
    sample): their mean noise is positive, the onset looks early, and on the flat test the
    contact was -0.008 dy and sigma_c +4 % on average. Selected on the force smoothed along the
    approach, the kept points' noise has no mean."""
    from geocontact.labtest.identify import _weighted_virgin

    rng = np.random.default_rng(5)
    d = np.linspace(1e-9, 1e-6, 40000)
    true = (d / d[-1]) ** 1.5
    sigma = 3e-4
    f = true + rng.normal(0.0, sigma, d.size)
    kept, force, _ = _weighted_virgin(d, f, sigma)
    near = np.interp(kept, d, true) < 8.0 * sigma  # the band the threshold cuts through
    assert near.sum() > 150
    noise = force[near] - np.interp(kept[near], d, true)
    assert abs(float(noise.mean())) < 0.15 * sigma
