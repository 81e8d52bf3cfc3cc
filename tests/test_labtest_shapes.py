"""geocontact fit takes the records a lab brings (issue 37): the contact point from the whole
record, on the synthetic records of examples/tests/ made from one FE run of the quartzite grain
(scripts/make_synthetic_lab_tests.py, SHAPES) with 0.4 % load-cell noise:

* ramp: cycles of increasing amplitude, the first at 6 % of the largest (8, 20, 50, 130 Fy);
* approach: a long approach before contact (3 x the test's travel at zero force), flat set-up;
* sparse: the first loading in about 12 points, uneven sampling.

Each is fitted (with the FE master curve the quartzite test's identification ended on,
tests/data/labtest) and meets docs/fit.md's acceptance along the grain's check history (its FE
run in tests/data/labtest); its contact point is within the stated tolerance of the true one
(truth.json). Records that cannot be fitted are
refused with one line that says what they lack."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from geocontact.cli.fit_output import law_along, path_rms_percent
from geocontact.errors import InputError
from geocontact.labtest import condition, read_test
from geocontact.labtest.curve import Record, displacement_of
from geocontact.labtest.fit import fit_once

ROOT = Path(__file__).resolve().parents[1]
TESTS = ROOT / "examples" / "tests"
SHAPES = ("ramp-quartzite", "approach-quartzite", "sparse-quartzite")
# the contact point: within this share of the FE's first-yield approach (3.4e-8 m pair
# approach here; the first cycle peaks at 4.1 of it): at 0.4 % noise the standard error of u0
# is 0.1-0.2 of it (contact["contact_displacement_se_m"])
CONTACT_TOLERANCE_OF_YIELD = 0.5
FORCE_RMS_GOAL = 5.0  # docs/fit.md acceptance: force RMS, % of the peak
RESIDUAL_GOAL = 0.10  # docs/fit.md acceptance: residual approach at each return to zero


def _master():
    from geocontact.labtest.identify import read_master

    return read_master(ROOT / "tests" / "data" / "labtest" / "platens-quartzite.master.json")


def _fit(name: str):
    truth = json.loads((TESTS / f"{name.removesuffix('.clean')}.truth.json").read_text())
    m = truth["material"]
    fit = fit_once(read_test(TESTS / f"{name}.csv"), truth["setup"], m["radius"],
                   machine_stiffness=truth["machine_stiffness_N_per_m"],
                   poissons_ratio=m["poissons_ratio"], friction_angle=m["friction_angle_deg"],
                   master=_master())
    return truth, fit


def _check_history():
    """The FE run of the quartzite grain's check history (tests/data/labtest, written by
    scripts/make_synthetic_lab_tests.py write_check_curve) as calibrate.acceptance.compare
    reads a run and its job."""
    from types import SimpleNamespace

    data = json.loads((ROOT / "tests" / "data" / "labtest" / "quartzite-check.json").read_text())
    # the run's key is in its summary: the job's identity is not needed (fem.identity.run_key)
    return (SimpleNamespace(forces=tuple(data["forces_N"]), identity=lambda: None),
            SimpleNamespace(curve=data["curve"], summary=data["summary"]))


@pytest.mark.parametrize("name", SHAPES)
def test_each_shape_is_fitted_with_its_contact_point(name):
    from geocontact.calibrate.acceptance import compare

    truth, fit = _fit(name)
    test = fit.test
    # the contact point against the generator's (the approach is the pair's: x2 on a flat)
    pair = 2.0 if truth["setup"] == "flat" else 1.0
    error = pair * abs(test.contact["contact_displacement_m"] - truth["contact_displacement_m"])
    assert error <= CONTACT_TOLERANCE_OF_YIELD * truth["fe_first_yield_approach_m"]
    # every cycle found, the first (6 % of the peak) included
    assert len(fit.levels) == len(truth["peaks_over_yield"])
    # the law along the record itself
    smooth, law = law_along(fit.params, test.approach)
    assert path_rms_percent(smooth, law - test.force, test.peak_force) <= FORCE_RMS_GOAL
    # docs/fit.md acceptance: along a different FE history of the grain (three cycles to 30 Fy,
    # a partial unload, a new peak of 100 Fy) force RMS <= 5 % and residual approach <= 10 %
    job, run = _check_history()
    c = compare(fit.params, job, run, name=name, kind="held-out")
    assert c.force_rms_percent <= FORCE_RMS_GOAL
    assert c.residual_error_percent <= 100.0 * RESIDUAL_GOAL


def test_noise_free_long_approach_identifies_sigma_c():
    """docs/fit.md's noise-free goal (sigma_c within 5 %) on the long-approach record (+3.6 %
    measured); on the ramp and sparse records it is not met (docs/fit.md: their Hertz part is
    short or unsampled and E* and sigma_c trade), which this test does not hide: it checks that
    the contact point of those is still found (within the tolerance above)."""
    truth, fit = _fit("approach-quartzite.clean")
    m = truth["material"]
    assert fit.params.material.compressive_yield_stress == pytest.approx(
        m["compressive_yield_stress"], rel=0.05)
    for name in ("ramp-quartzite.clean", "sparse-quartzite.clean"):
        truth, fit = _fit(name)
        pair = 2.0 if truth["setup"] == "flat" else 1.0
        error = pair * abs(fit.test.contact["contact_displacement_m"]
                           - truth["clean_contact_displacement_m"])
        assert error <= CONTACT_TOLERANCE_OF_YIELD * truth["fe_first_yield_approach_m"]


def test_the_issue_record_is_fitted_from_the_command_line(tmp_path, capsys):
    """The record of the issue (first cycle at 6 % of the peak, 0.4 % noise, uneven sampling)
    was refused with 'only 0 points of the first loading rise above the noise floor'; the
    command now fits it (universal identification: no FE run)."""
    from geocontact.cli import main

    truth = json.loads((TESTS / "ramp-quartzite.truth.json").read_text())
    m = truth["material"]
    out = tmp_path / "P.json"
    assert main(["fit", str(TESTS / "ramp-quartzite.csv"), "--setup", "platens", "--radius",
                 str(m["radius"]), "--machine-stiffness",
                 str(truth["machine_stiffness_N_per_m"]), "--poissons-ratio",
                 str(m["poissons_ratio"]), "--friction-angle", str(m["friction_angle_deg"]),
                 "--identify", "universal", "--bootstrap", "0", "--out", str(out)]) == 0
    screen = capsys.readouterr().out
    assert "contact point at displacement" in screen and "4 cycles" in screen
    assert "refined on the Hertz onset" in screen or "from the whole record" in screen
    assert out.is_file()


# --- what cannot be fitted: one line saying what the record lacks ------------------------------
R, E, NU = 4e-3, 30e9, 0.2
K = 4.0 / 3.0 * E / (2 * (1 - NU**2)) * math.sqrt(R / 2)


def _hertz_record(peaks, *, noise, gap=0.2e-6, n=600, seed=0):
    rng = np.random.default_rng(seed)
    legs = [np.linspace(-gap, 0, n // 10)]
    for p in peaks:
        legs += [np.linspace(legs[-1][-1], p, n // 3), np.linspace(p, -0.1 * p, n // 3)]
    delta = np.concatenate(legs)
    force = K * np.maximum(delta, 0) ** 1.5
    return Record(displacement_of(delta, "pair") + gap,
                  force + rng.normal(0, noise, delta.size), None, "synthetic", {})


def test_a_record_at_the_noise_is_refused_saying_so():
    """Three cycles (peak 0.24 N) sampled sparsely through a load cell of sigma 0.022 N: 14
    points of the whole record above the noise floor are too few to place the contact."""
    rec = _hertz_record([0.1e-6, 0.2e-6, 0.4e-6], noise=0.022, n=60)
    with pytest.raises(InputError, match=r"only 14 points of the whole record rise above the "
                                         r"noise floor .* need >= 20 .* load further") as info:
        condition(rec, "pair", R)
    assert "\n" not in str(info.value)


def test_a_contact_the_record_does_not_fix_is_refused_saying_so():
    """The same cycles with more points but the force within a few sigma over most of them
    (sigma 0.025 N): the fit's standard error of the contact exceeds half the first peak's
    depth. At sigma 0.02 N the record fixes it since the robust loss's scale is the noise, not
    3 x the noise (docs/fit.md, "The flat test's bias"): found within its standard error (0.44
    of the first depth; the error is 0.02)."""
    rec = _hertz_record([0.1e-6, 0.2e-6, 0.4e-6], noise=0.02, n=120)
    c = condition(rec, "pair", R).contact
    assert c["contact_displacement_se_m"] < 0.5e-7
    assert abs(c["contact_displacement_m"] - 0.2e-6) < c["contact_displacement_se_m"]
    rec = _hertz_record([0.1e-6, 0.2e-6, 0.4e-6], noise=0.025, n=120)
    with pytest.raises(InputError, match=r"contact point is not determined by the record .* "
                                         r"needs a loading that rises from zero force") as info:
        condition(rec, "pair", R)
    assert "\n" not in str(info.value)


def test_the_contact_point_of_a_dense_hertz_record_is_found():
    """On a pure Hertz record the whole-record fit is Hertz with the envelope's bend unused:
    the contact at the gap, K within 1 % (closed form)."""
    rec = _hertz_record([1e-6, 1e-6], noise=1e-3, n=1500)
    t = condition(rec, "pair", R)
    assert t.contact["contact_displacement_m"] == pytest.approx(0.2e-6, abs=0.005e-6)
    assert t.contact["stiffness"] == pytest.approx(K, rel=0.01)


def test_a_record_that_never_yields_is_refused_saying_so():
    """Three elastic (Hertz) cycles: the contact point is found, but there is no plastic law
    to fit; the message says to load past first yield."""
    rec = _hertz_record([0.6e-6, 0.8e-6, 1e-6], noise=1e-3, n=1500)
    with pytest.raises(InputError, match=r"never yields .* load past first yield") as info:
        fit_once(rec, "pair", R)
    assert "\n" not in str(info.value)
