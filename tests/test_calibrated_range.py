"""No silent extrapolation (issue 37): every route that makes a law file records how deep it was
calibrated (``calibrated_range``), and ``geocontact law`` and the Python API say when a contact
goes beyond it (a warning with the count and the largest depth) or refuse it on request. Files
without the block load as before and say nothing."""

from __future__ import annotations

import csv
import dataclasses
import json
import math
import warnings
from pathlib import Path

import numpy as np
import pytest
from add_calibrated_range import from_record  # scripts/ (tests/conftest.py)
from conftest import make_params
from test_calibrate_fit import cycles_of

from geocontact.calibrate import fit_law
from geocontact.calibrate.campaign import fe_calibrated_range
from geocontact.cli import main
from geocontact.law import (
    BeyondCalibratedRangeError,
    BeyondCalibratedRangeWarning,
    Contact,
    ContactArrays,
    CyclicLaw,
    LawParams,
    _core,
    force_history,
    load_params,
)

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = ROOT / "examples"
# the weak grain's committed finite-strain FE run 0 -> 3000 N -> 0 (the paper's load; issue 37)
FE_RUN = ROOT / "datasets" / "fe-runs" / "paper-histories-finite" / "1ab0834a738d96adca4f"


def _fe_approaches() -> np.ndarray:
    with open(FE_RUN / "curve.csv") as f:
        return np.array([float(row["approach_m"]) for row in csv.DictReader(f)])


def _ranged(params: LawParams, depth: float) -> LawParams:
    """``params`` calibrated to ``depth``, without the cyclic extension (so the envelope's
    depth is the approach's: no ratchet shift)."""
    return dataclasses.replace(params, calibrated_depth=depth, cyclic=CyclicLaw(),
                               calibrated_range_extra={"max_force_N": 123.0})


# --- the routes write it ------------------------------------------------------------------------
def test_fit_law_records_its_deepest_level():
    truth = make_params()
    depths = [2, 5, 12, 30, 70, 150]
    d, f, levels = cycles_of(truth, depths)
    fitted = fit_law(truth.material, truth.yield_approach, d, f, levels)
    deepest = levels[-1]
    assert fitted.calibrated_depth == pytest.approx(150.0, rel=1e-12)
    assert fitted.calibrated_range == {
        "max_depth": fitted.calibrated_depth, "max_approach_m": deepest.max_approach,
        "max_force_N": deepest.max_force, "source": "the deepest of the 6 levels fitted"}
    # written and read back by both readers
    again = LawParams.from_dict(json.loads(fitted.to_json()))
    assert again.calibrated_range == fitted.calibrated_range
    assert _core.parse_params(fitted.to_json()).calibrated_depth == fitted.calibrated_depth


def test_shipped_calibrations_carry_what_their_own_record_gives():
    """The shipped FE calibrations' block is what ``scripts/add_calibrated_range.py`` derives from
    their levels (fit_errors.per_level, provenance.fe) and, for the weak grain, its committed
    FE runs: the deepest level's depth, force and contact radius (independently read here)."""
    for name in ("params-reference.json", "params-reference-weak.json"):
        shipped = load_params(EXAMPLES / name)
        again = from_record(shipped, ROOT / shipped.provenance["inputs"]["cache"]
                            if not Path(shipped.provenance["inputs"]["cache"]).is_absolute()
                            else None)
        assert again.calibrated_range == shipped.calibrated_range, name
        levels = shipped.fit_errors["per_level"]
        assert shipped.calibrated_depth == max(level["depth"] for level in levels)
        assert shipped.calibrated_range["max_force_N"] == max(
            shipped.provenance["fe"]["peak_forces_N"])
    weak = load_params(EXAMPLES / "params-reference-weak.json")
    key = weak.provenance["fe"]["cache_keys"][-1]
    with open(ROOT / "datasets" / "fe-runs" / "weak-finite" / key / "curve.csv") as f:
        rows = list(csv.DictReader(f))
    peak = max(rows, key=lambda r: float(r["force_N"]))
    assert weak.calibrated_range["contact_radius_ratio"] == pytest.approx(
        float(peak["contact_radius_m"]) / weak.material.radius, rel=1e-9)
    assert weak.calibrated_range["max_approach_m"] == pytest.approx(
        float(peak["approach_m"]), rel=1e-9)


def test_fe_range_leaves_out_a_contact_radius_it_does_not_know():
    assert "contact_radius_ratio" not in fe_calibrated_range(1e-3, 10.0, 7, {}, 0.1)
    summary = {"contact_resolution": {"elements_across_contact_radius": {
        "peak": {"contact_radius_m": 0.02}}}}
    assert fe_calibrated_range(1e-3, 10.0, 7, summary, 0.1)["contact_radius_ratio"] == (
        pytest.approx(0.2, rel=1e-15))


def test_universal_law_records_the_campaigns_top_level_at_the_material(tmp_path, capsys):
    out = tmp_path / "P.json"
    assert main(["params", "--material", "reference-weak", "--out", str(out)]) == 0
    params = load_params(out)
    # the screen says it too
    assert (f"calibrated to delta_max/delta_y = {params.calibrated_depth:.4g} "
            f"({params.calibrated_range['max_force_N']:.4g} N") in capsys.readouterr().out
    u = params.provenance["universal"]
    depth = u["valid_depth"]
    assert isinstance(depth, dict)
    # the top of the campaign's levels (in units of the analytic Fy) at this grain
    assert depth["levels_force_over_yield"][-1] == u["levels_force_over_yield"][-1]
    assert params.calibrated_depth == depth["max_depth"]
    analytic_fy = params.yield_extra["analytic_force_N"]
    assert params.calibrated_range["max_force_N"] == pytest.approx(
        u["levels_force_over_yield"][-1] * analytic_fy, rel=1e-12)
    # the law's own virgin curve there is the top level's force (the fit's loading error)
    law_force = float(params.virgin_force(params.calibrated_approach))
    assert law_force == pytest.approx(params.calibrated_range["max_force_N"], rel=0.05)


def test_lab_fit_records_the_records_deepest_cycle():
    from test_labtest import _master

    from geocontact.labtest import read_test
    from geocontact.labtest.fit import fit_once

    truth = json.loads((EXAMPLES / "tests" / "platens-quartzite.truth.json").read_text())
    m = truth["material"]
    fit = fit_once(read_test(EXAMPLES / "tests" / "platens-quartzite.clean.csv"), "platens",
                   m["radius"], machine_stiffness=truth["machine_stiffness_N_per_m"],
                   poissons_ratio=m["poissons_ratio"], friction_angle=m["friction_angle_deg"],
                   master=_master("platens-quartzite"))
    p = fit.params
    assert p.calibrated_range["source"].startswith("the deepest of the record's")
    # the record's largest approach (its last and highest peak) and force
    assert p.calibrated_range["max_approach_m"] == pytest.approx(fit.test.approach.max(),
                                                                 rel=1e-2)
    assert p.calibrated_range["max_force_N"] == pytest.approx(fit.test.force.max(), rel=1e-2)
    assert p.calibrated_depth == pytest.approx(
        p.calibrated_range["max_approach_m"] / p.yield_approach, rel=1e-12)


def test_illustrative_files_say_nothing_past_yield_is_fitted():
    for name in ("params-illustrative.json", "params-illustrative-weak.json"):
        p = load_params(EXAMPLES / name)
        assert p.calibrated_depth == 1.0
        assert "ILLUSTRATION" in p.calibrated_range["source"]


def test_the_range_follows_the_grain_size():
    """Depth is scale-free; the force scales by s^2 and the approach by s (docs/model.md §10)."""
    p = load_params(EXAMPLES / "params-reference-weak.json")
    q = p.for_radius(p.material.radius * 0.01)
    assert q.calibrated_depth == p.calibrated_depth
    assert q.calibrated_range["max_force_N"] == pytest.approx(
        p.calibrated_range["max_force_N"] * 1e-4, rel=1e-12)
    assert q.calibrated_range["max_approach_m"] == pytest.approx(
        p.calibrated_range["max_approach_m"] * 1e-2, rel=1e-12)
    assert q.calibrated_range["contact_radius_ratio"] == p.calibrated_range[
        "contact_radius_ratio"]


def test_a_range_below_yield_is_refused_in_code_as_in_a_file():
    with pytest.raises(ValueError, match=r"calibrated_range.max_depth: must be in \[1, inf\)"):
        make_params(calibrated_depth=0.5)


# --- geocontact law -----------------------------------------------------------------------------
def _approach_csv(tmp_path) -> Path:
    path = tmp_path / "A.csv"
    with open(path, "w") as f:
        f.write("approach_m\n" + "".join(f"{float(a)!r}\n" for a in _fe_approaches()))
    return path


def test_law_cli_warns_beyond_a_universal_laws_range_and_refuses_with_strict_range(
        tmp_path, capsys):
    """Issue 37's case: the universal law of the weak grain (calibrated to its campaign's top
    level, a few tens of N) along the FE run to 3000 N. The count and the depth are checked
    against the FE approaches and the file's delta_y directly."""
    params_path = tmp_path / "P.json"
    assert main(["params", "--material", "reference-weak", "--out", str(params_path)]) == 0
    capsys.readouterr()
    params = load_params(params_path)
    approaches = _fe_approaches()
    beyond = int(np.count_nonzero(approaches > params.calibrated_approach))
    deepest = approaches.max() / params.yield_approach
    assert 0 < beyond < approaches.size

    out = tmp_path / "F.csv"
    assert main(["law", "--params", str(params_path), "--approach",
                 str(_approach_csv(tmp_path)), "--out", str(out)]) == 0
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("warning: ")
    assert f"{beyond} of {approaches.size} steps" in err[0]
    assert f"largest delta_max/delta_y {deepest:.4g}" in err[0]
    assert f"{deepest / params.calibrated_depth:.3g} x its calibrated top" in err[0]
    meta = json.loads(Path(f"{out}.meta.json").read_text())
    assert meta["beyond_calibrated_range"]["steps_beyond"] == beyond
    assert meta["beyond_calibrated_range"]["largest_depth"] == pytest.approx(deepest, rel=1e-12)
    assert meta["calibrated_range"] == params.calibrated_range

    strict = tmp_path / "strict.csv"
    assert main(["law", "--params", str(params_path), "--approach",
                 str(_approach_csv(tmp_path)), "--out", str(strict), "--strict-range"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("error: approach_m: ")
    assert "--strict-range" in err and f"{beyond} of {approaches.size} steps" in err
    assert not strict.exists() and not Path(f"{strict}.meta.json").exists()


def test_law_cli_is_silent_within_the_range_and_for_files_without_one(tmp_path, capsys):
    """The FE calibration of the same grain (to 6000 N) covers the 3000 N run; a file without
    the block (an older file) is not checked."""
    calibrated = EXAMPLES / "params-reference-weak.json"
    older = tmp_path / "older.json"
    document = json.loads(calibrated.read_text())
    del document["calibrated_range"]
    older.write_text(json.dumps(document))
    assert math.isinf(load_params(older).calibrated_depth)
    for params_path in (calibrated, older):
        out = tmp_path / f"{params_path.stem}.csv"
        assert main(["law", "--params", str(params_path), "--approach",
                     str(_approach_csv(tmp_path)), "--out", str(out), "--strict-range"]) == 0
        assert capsys.readouterr().err == ""
        assert json.loads(Path(f"{out}.meta.json").read_text())[
            "beyond_calibrated_range"] is None


# --- the Python API -----------------------------------------------------------------------------
def test_contact_warns_once_and_counts_its_steps_beyond():
    p = _ranged(load_params(EXAMPLES / "params-reference.json"), 50.0)
    path = np.concatenate([np.linspace(0, 80, 81), np.linspace(80, 0, 41),
                           np.linspace(0, 120, 61)]) * p.yield_approach
    contact = Contact(p)
    with pytest.warns(BeyondCalibratedRangeWarning) as caught:
        for a in path:
            contact.update(a)
    assert len(caught) == 1  # once per contact, at the first step beyond
    assert "its calibrated top 50" in str(caught[0].message)
    assert caught[0].filename == __file__  # names the caller's line
    found = contact.range_excess()
    assert found.count == int(np.count_nonzero(path > 50.0 * p.yield_approach))
    assert found.total == path.size
    assert found.largest_depth == pytest.approx(120.0, rel=1e-12)
    assert found.over_top == pytest.approx(120.0 / 50.0, rel=1e-12)


def test_contact_refuses_on_request_and_is_silent_within_range():
    p = _ranged(load_params(EXAMPLES / "params-reference.json"), 50.0)
    strict = Contact(p, beyond_range="refuse")
    with pytest.raises(BeyondCalibratedRangeError, match=r"^calibrated_range: 1 of \d+ steps"):
        for a in np.linspace(0, 60, 61) * p.yield_approach:
            strict.update(a)
    assert strict.state.max_approach > 50.0 * p.yield_approach  # the step was taken
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        inside = Contact(p)
        for a in np.linspace(0, 50, 51) * p.yield_approach:
            inside.update(a)
        assert inside.range_excess() is None
    with pytest.raises(ValueError, match="beyond_range: must be one of warn, refuse, ignore"):
        Contact(p, beyond_range="loud")


def test_force_history_warns_once_with_the_whole_count():
    p = _ranged(load_params(EXAMPLES / "params-reference.json"), 50.0)
    path = np.linspace(0, 100, 101) * p.yield_approach
    with pytest.warns(BeyondCalibratedRangeWarning,
                      match=r"50 of 101 steps .* largest delta_max/delta_y 100, 2 x") as caught:
        force_history(p, path)
    assert len(caught) == 1
    with pytest.raises(BeyondCalibratedRangeError):
        force_history(p, path, beyond_range="refuse")


@pytest.mark.parametrize("threads", [1, 2])
def test_contact_arrays_warn_with_the_count_and_depth_once(threads):
    p = _ranged(load_params(EXAMPLES / "params-reference.json"), 50.0)
    n = 2000
    rng = np.random.default_rng(7)
    amplitude = rng.uniform(0.2, 100.0, n) * p.yield_approach
    contacts = ContactArrays(p, n, threads=threads)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        contacts.step(0.4 * amplitude)  # every contact within 40 delta_y
    with pytest.warns(BeyondCalibratedRangeWarning) as caught:
        contacts.step(0.8 * amplitude)
        contacts.step(amplitude)
    assert len(caught) == 1  # the first step beyond only
    expected_first = int(np.count_nonzero(0.8 * amplitude > 50.0 * p.yield_approach))
    assert f"{expected_first} of {n} contacts" in str(caught[0].message)
    assert caught[0].filename == __file__
    found = contacts.range_excess()
    assert found.count == int(np.count_nonzero(amplitude > 50.0 * p.yield_approach))
    assert found.largest_depth == pytest.approx(amplitude.max() / p.yield_approach, rel=1e-12)
    contacts.reset()  # re-armed
    with pytest.warns(BeyondCalibratedRangeWarning):
        contacts.step(amplitude)


def test_contact_arrays_refuse_and_scale_by_radius():
    p = _ranged(load_params(EXAMPLES / "params-reference.json"), 50.0)
    radii = np.array([0.5, 1.0, 2.0]) * p.material.radius
    contacts = ContactArrays(p, 3, radii=radii, beyond_range="refuse")
    # 60 delta_y of each grain's own (scaled) delta_y: every contact beyond, in its own units
    with pytest.raises(BeyondCalibratedRangeError, match="3 of 3 contacts"):
        contacts.step(60.0 * p.yield_approach * radii / p.material.radius)
    contacts = ContactArrays(p, 3, radii=radii, beyond_range="ignore")
    contacts.step(40.0 * p.yield_approach * radii / p.material.radius)
    assert contacts.range_excess() is None


def test_kernel_reports_the_deepest_envelope_of_the_step():
    """The compiled step returns max delta_max over the contacts (the state's, shifted
    coordinates), for any thread count; 0 for plain Hertz."""
    p = load_params(EXAMPLES / "params-reference-weak.json")
    n = 5000
    rng = np.random.default_rng(3)
    path = rng.uniform(-5.0, 300.0, (6, n)) * p.yield_approach
    for threads in (1, 2):
        core = _core.Contacts(_core.parse_params((EXAMPLES / "params-reference-weak.json")
                                                 .read_text()), n, threads)
        views = core.state_views()
        for row in path:
            deepest = core.step(np.ascontiguousarray(row))
            assert deepest == views["max_approach"].max()
    assert _core.Contacts.hertz(1e9, 10, 1).step(np.full(10, 1e-4)) == 0.0


def test_files_without_the_block_give_no_warning_anywhere():
    document = json.loads((EXAMPLES / "params-reference.json").read_text())
    del document["calibrated_range"]
    p = LawParams.from_dict(document)
    assert math.isinf(p.calibrated_depth) and p.calibrated_range == {}
    assert "calibrated_range" not in p.to_dict()
    deep = np.linspace(0, 1000, 50) * p.yield_approach
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        force_history(p, deep)
        ContactArrays(p, 50).step(deep)
        assert ContactArrays(p, 50).range_excess() is None


def test_commands_show_the_warning_as_one_line(capsys):
    """Any command whose contacts go beyond (cycles, seismic, ...) prints the API's warning as
    one ``warning:`` line; other warnings go to the previous handler."""
    from geocontact.cli import _one_line_warnings

    seen = []
    show = _one_line_warnings(lambda *args: seen.append(args[1]))
    show(BeyondCalibratedRangeWarning("3 of 5 contacts went beyond"),
         BeyondCalibratedRangeWarning, "x.py", 1)
    show(DeprecationWarning("old"), DeprecationWarning, "x.py", 2)
    assert capsys.readouterr().err == "warning: 3 of 5 contacts went beyond\n"
    assert seen == [DeprecationWarning]


def test_seismic_column_says_once_after_its_run(tmp_path, capsys):
    """The column's contacts report after the whole run (not at the static settle, so that a
    refused input stays one error line): one ``warning:`` line with the count of its contacts
    beyond the illustration's range (every loaded one: the static load is past yield) and the
    largest depth, the state's own."""
    pytest.importorskip("eqsig")
    t = np.arange(41) * 0.005
    record = tmp_path / "rec.csv"
    record.write_text("time_s,acceleration_g\n" + "".join(
        f"{float(a)!r},{0.2 * math.sin(2 * math.pi * 5.0 * a)!r}\n" for a in t))
    params = EXAMPLES / "params-illustrative.json"
    assert main(["seismic", str(record), "--params", str(params), "--out",
                 str(tmp_path / "quake"), "--no-figures", "--column", "3", "--gap", "0"]) == 0
    err = [line for line in capsys.readouterr().err.splitlines()
           if line.startswith("warning:")]  # beside the progress lines
    assert len(err) == 1 and err[0].startswith("warning: 3 of 3 contacts went beyond")
    assert f"calibrated range of {params}" in err[0]
