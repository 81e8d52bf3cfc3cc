"""``geocontact calibrate``: FE campaign -> fit -> P.json, cached reruns, acceptance on held-out
FE runs, bad input; the residual-approach form with a transition depth; the shipped files.

Coarse mesh, few load steps and a low force range keep this fast; the numbers that matter
(default mesh, 7 levels to 6000 N) are in docs/calibration.md."""

import json
from pathlib import Path

import numpy as np
import pytest
from conftest import make_params

from geocontact.calibrate.acceptance import compare
from geocontact.calibrate.campaign import check_peaks, force_range, peak_forces
from geocontact.cli import main
from geocontact.errors import InputError
from geocontact.fem.campaign import FemJob, run_campaign
from geocontact.grain.material import load_material
from geocontact.law import Contact, ContactArrays, LawParams, force_history, load_params
from geocontact.law.params import saturating_ratio

pytestmark = pytest.mark.filterwarnings("ignore::DeprecationWarning",
                                        "ignore::UserWarning")

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"
# 4 levels from 2 Fy to 300 N (F/Fy ~ 110), 4 steps per segment: a small, fast campaign, on the
# "yield" meshes with fixed steps (the defaults before issue 36; "auto" would mesh it with the
# dense contact band, ~5x the elements: the defaults are tested in tests/test_fe_defaults.py).
ARGS = ["--material", "reference", "--mesh", "coarse", "--steps", "4", "--levels", "4",
        "--max-force", "300", "--workers", "2", "--mesh-rule", "yield", "--step-control", "fixed"]


@pytest.fixture(scope="module")
def calibrated(tmp_path_factory):
    root = tmp_path_factory.mktemp("calibrate")
    out = root / "P.json"
    code = main(["calibrate", *ARGS, "--cache", str(root / "cache"), "--out", str(out),
                 "--acceptance"])
    assert code == 0
    return root, out


def _cache_listing(cache: Path) -> dict[str, tuple[int, int]]:
    """Every file of the FE cache with its size and modification time (ns)."""
    return {str(p.relative_to(cache)): (p.stat().st_size, p.stat().st_mtime_ns)
            for p in sorted(cache.rglob("*")) if p.is_file()}


def test_cli_writes_a_valid_calibrated_parameter_file(calibrated):
    root, out = calibrated
    params = load_params(out)  # validates schema, ranges and the energy check
    doc = json.loads(out.read_text())
    assert doc["schema"] == "geocontact.law/1"
    fe = doc["provenance"]["fe"]
    assert fe["mesh"] == "coarse" and fe["steps_per_segment"] == 4
    assert (fe["kinematics"], fe["mesh_rule"], fe["step_rule"], fe["max_step_ratio"]) == (
        "small", "yield", "segment", None)
    assert "step_control" not in fe  # fixed load steps, named only when not fixed
    assert "newton" not in fe  # full Newton updates, named only when "backtracking"
    assert doc["provenance"]["inputs"]["kinematics"] == "small"
    assert len(fe["peak_forces_N"]) == 4 and len(fe["cache_keys"]) == 4
    assert all((root / "cache" / key / "summary.json").exists() for key in fe["cache_keys"])
    assert doc["provenance"]["command"] == "calibrate"
    # FE first yield used (law Fy == FE Fy), the analytic one recorded beside it
    y = doc["yield"]
    assert params.yield_force == pytest.approx(y["fe_force_N"], rel=1e-12)
    assert y["fe_over_analytic_force"] == pytest.approx(1.0, abs=0.05)
    assert "fully_plastic" in doc["fit_errors"]
    # the fit describes the FE cycles it came from
    e = doc["fit_errors"]
    assert e["loading_rms_relative"] < 0.03
    assert e["unloading_curve_rms_of_peak"] < 0.03
    assert e["elastic_recovery_rms_relative"] < 0.05


def test_calibration_records_its_deepest_fe_level_as_its_range(calibrated):
    """``calibrated_range``: the deepest level's delta_max/delta_y and force, and the contact
    radius at that run's peak (read here from its curve.csv) over R."""
    root, out = calibrated
    params = load_params(out)
    doc = json.loads(out.read_text())
    fe = doc["provenance"]["fe"]
    deepest = max(range(len(fe["peak_forces_N"])), key=fe["peak_forces_N"].__getitem__)
    assert params.calibrated_depth == max(level["depth"]
                                          for level in doc["fit_errors"]["per_level"])
    block = doc["calibrated_range"]
    assert block["max_force_N"] == fe["peak_forces_N"][deepest]
    curve = np.genfromtxt(root / "cache" / fe["cache_keys"][deepest] / "curve.csv",
                          delimiter=",", names=True)
    peak = int(np.argmax(curve["force_N"]))
    assert block["max_approach_m"] == pytest.approx(curve["approach_m"][peak], rel=1e-9)
    assert block["contact_radius_ratio"] == pytest.approx(
        curve["contact_radius_m"][peak] / params.material.radius, rel=1e-9)
    assert block["source"] == "the deepest of the 4 FE levels (peak 300 N)"


def test_law_reproduces_the_fe_curves_it_was_fitted_to(calibrated):
    root, out = calibrated
    table = json.loads((root / "P.acceptance.json").read_text())
    fitted = [r for r in table["runs"] if r["kind"] == "fitted"]
    assert len(fitted) == 4
    for row in fitted:
        assert row["force_rms_percent_of_peak"] < 5.0, row["name"]
    # the deeper levels' residual approach (the shallowest is ~2 % of dmax, FE-noise sized)
    for row in fitted[1:]:
        assert row["residual_approach_error_percent"] < 10.0, row["name"]


def test_acceptance_table_figures_and_data(calibrated):
    root, out = calibrated
    table = json.loads((root / "P.acceptance.json").read_text())
    held = [r for r in table["runs"] if r["kind"] == "held-out"]
    assert {r["name"] for r in held} == {"held-out-peak-low", "held-out-peak-high",
                                         "partial-unload-reload", "new-envelope"}
    for row in held:
        assert np.isfinite(row["force_rms_percent_of_peak"])
        png = root / "P.acceptance" / f"{row['name']}.png"
        assert png.stat().st_size > 1000
        data = np.genfromtxt(root / "P.acceptance" / f"{row['name']}.csv", delimiter=",",
                             names=True)
        assert {"approach_m", "fe_force_N", "law_force_N"} <= set(data.dtype.names)
    # a new envelope after a reload: the FE closes two cycles and both residuals are compared
    (envelope,) = [r for r in held if r["name"] == "new-envelope"]
    assert len(envelope["residuals"]) == 2


def test_rerun_reads_the_cache_and_runs_no_fe(calibrated, capsys, monkeypatch):
    """A rerun with the same inputs is served from the cache: no FE run starts (run_history and
    the Dask path are replaced by a failure), the cache is not touched, and the fit is the same.
    Counting FE runs instead of timing the rerun keeps the test independent of machine load."""
    import geocontact.fem.campaign as fem_campaign

    root, out = calibrated
    cache = root / "cache"
    before = _cache_listing(cache)
    keys = json.loads(out.read_text())["provenance"]["fe"]["cache_keys"]
    assert keys and all(key in {Path(f).parts[0] for f in before} for key in keys)
    started = []

    def no_fe_run(*args, **kwargs):
        started.append(args)
        raise AssertionError("an FE run started on a cached rerun")

    monkeypatch.setattr(fem_campaign, "run_history", no_fe_run)
    monkeypatch.setattr(fem_campaign, "_run_on_dask", no_fe_run)
    again = root / "again.json"
    assert main(["calibrate", *ARGS, "--cache", str(cache), "--out", str(again), "--json"]) == 0
    assert started == []
    assert _cache_listing(cache) == before
    printed = json.loads(capsys.readouterr().out)
    a, b = json.loads(out.read_text()), json.loads(again.read_text())
    assert printed["loading"] == b["loading"]
    for key in ("loading", "unloading", "reloading", "residual_approach", "yield"):
        assert a[key] == b[key]


def test_loading_form_segments_refits_from_the_cache(calibrated, monkeypatch):
    """--loading-form segments: the same FE runs (from the cache, none started), the virgin
    curve written as segments, the form recorded in the inputs and the fit errors."""
    import geocontact.fem.campaign as fem_campaign

    root, out = calibrated

    def no_fe_run(*args, **kwargs):
        raise AssertionError("an FE run started on a cached rerun")

    monkeypatch.setattr(fem_campaign, "run_history", no_fe_run)
    monkeypatch.setattr(fem_campaign, "_run_on_dask", no_fe_run)
    segmented = root / "segments.json"
    assert main(["calibrate", *ARGS, "--cache", str(root / "cache"), "--out", str(segmented),
                 "--loading-form", "segments"]) == 0
    doc = json.loads(segmented.read_text())
    assert set(doc["loading"]) == {"segments"}
    assert doc["loading"]["segments"]["depth"][0] == 1.0
    assert doc["provenance"]["inputs"]["loading_form"] == "segments"
    assert doc["provenance"]["loading_form"] == "segments"
    regimes = json.loads(out.read_text())
    assert "loading_form" not in regimes["provenance"]["inputs"]
    assert doc["residual_approach"] == regimes["residual_approach"]


def test_residual_form_table_from_the_same_runs(calibrated, capsys):
    """--residual-form table (from the cached runs, no FE work): the residual approach is the
    table through the levels, recorded in the provenance, with its leave-one-out errors; the
    default file records no residual form (files of the saturating form read as before)."""
    root, out = calibrated
    table_file = root / "P-table.json"
    assert main(["calibrate", *ARGS, "--cache", str(root / "cache"), "--out", str(table_file),
                 "--residual-form", "table"]) == 0
    printed = capsys.readouterr().out
    assert "residual table through the levels, leave-one-out max" in printed
    default, tabulated = json.loads(out.read_text()), json.loads(table_file.read_text())
    assert "residual_form" not in default["provenance"]
    assert "residual_form" not in default["provenance"]["inputs"]
    assert tabulated["provenance"]["residual_form"] == "table"
    assert tabulated["provenance"]["inputs"]["residual_form"] == "table"
    table = tabulated["residual_approach"]["table"]
    levels = default["fit_errors"]["per_level"]
    assert table["depth"] == [lv["depth"] for lv in levels]
    assert table["ratio"] == [lv["residual_ratio"] for lv in levels]
    for key in ("unloading", "reloading", "yield"):
        assert tabulated[key] == default[key]
    # the loading too, unless one of the two needed the near-yield energy bound on n1
    bounded = ["loading_first_exponent_bounded" in d["fit_errors"] for d in (default, tabulated)]
    assert (tabulated["loading"] == default["loading"]) == (bounded[0] == bounded[1])
    loo = tabulated["fit_errors"]["residual_table_leave_one_out"]
    assert len(loo["per_level"]) == 4 and loo["residual_ratio_max_relative"] > 0.0
    load_params(table_file)


@pytest.mark.parametrize("extra, message", [
    (["--residual-form", "spline"], "--residual-form"),
    (["--levels", "2"], "--levels"),
    (["--peak-forces", "10,abc"], "--peak-forces"),
    (["--peak-forces", "1,2,3"], "first yield"),
    (["--peak-forces", "100,100,200"], "distinct"),
    (["--max-force", "-5"], "--max-force"),
    (["--max-force", "3"], "not above"),
    (["--steps", "0"], "--steps"),
    (["--workers", "0"], "--workers"),
    (["--kinematics", "large"], "--kinematics"),
    (["--max-step-ratio", "0.9"], "max_step_ratio"),
])
def test_bad_input_is_one_line_exit_2(tmp_path, capsys, extra, message):
    args = ["calibrate", "--material", "reference", "--mesh", "coarse", "--cache",
            str(tmp_path), "--out", str(tmp_path / "P.json"), *extra]
    assert main(args) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("error:") and "\n" not in err and message in err
    assert not (tmp_path / "P.json").exists()


def test_bad_material_and_output_name(tmp_path, capsys):
    assert main(["calibrate", "--material", "granite", "--out", str(tmp_path / "P.json")]) == 2
    assert main(["calibrate", "--material", "reference", "--out", str(tmp_path / "P.txt")]) == 2
    for line in capsys.readouterr().err.strip().splitlines():
        assert line.startswith("error:")


def test_fe_model_reaches_every_run_of_a_calibration():
    """calibrate --kinematics/--mesh-rule/--step-rule (the weak grain's finite-strain
    calibration, issue 15) reach every FE run: the levels, the repeated-history run of the
    cyclic laws and the held-out runs; each is part of the run's identity (cache key)."""
    from geocontact.calibrate.acceptance import held_out_jobs
    from geocontact.calibrate.campaign import calibration_jobs, cyclic_job

    m = load_material("reference-weak")
    model = {"kinematics": "finite", "mesh_rule": "contact", "step_rule": "decade",
             "max_step_ratio": 1.02}
    peaks = peak_forces(m, 3, 300.0)

    def every(fe_model):
        return (calibration_jobs(m, peaks, "coarse", 4, fe_model)
                + [cyclic_job(m, 300.0, "coarse", 4, fe_model)]
                + [job for _, job in held_out_jobs(m, "coarse", 4, 300.0, fe_model)])

    finite, small = every(model), every(None)
    assert len(finite) == len(small) > 5
    assert all((j.kinematics, j.mesh_rule, j.step_rule, j.max_step_ratio)
               == tuple(model.values()) for j in finite)
    assert all(j.kinematics == "small" for j in small)
    assert not {j.key() for j in finite} & {j.key() for j in small}


def test_peak_forces_span_from_twice_yield_geometrically():
    material = load_material("reference")
    peaks = peak_forces(material, levels=7, max_force=6000.0)
    assert len(peaks) == 7 and peaks[-1] == pytest.approx(6000.0)
    assert peaks[0] == pytest.approx(2.0 * 2.757, rel=1e-3)
    ratios = np.diff(np.log(peaks))
    assert np.allclose(ratios, ratios[0])
    with pytest.raises(InputError):
        check_peaks(material, [10.0, 20.0])


# --- the residual-approach form with a transition depth (docs/law.md) ---------------------
def test_transition_depth_one_is_the_original_form():
    x = np.geomspace(1.0, 1e5, 50)
    assert np.array_equal(saturating_ratio(x, 0.8, 0.3, 1.0), -0.8 * np.expm1(-0.3 * np.log(x)))
    slow = saturating_ratio(x, 0.8, 0.3, 10.0)
    assert slow[0] == 0.0 and np.all(np.diff(slow) > 0) and np.all(slow < 0.8)
    assert np.all(slow[1:] < saturating_ratio(x, 0.8, 0.3, 1.0)[1:])


def test_transition_depth_round_trips_and_old_files_read_as_before():
    params = make_params(residual_transition=6.0, residual_limit=0.99, residual_power=0.3)
    doc = params.to_dict()
    assert doc["residual_approach"]["transition_depth"] == 6.0
    again = LawParams.from_dict(json.loads(json.dumps(doc)))
    assert again.residual_transition == 6.0
    assert "transition_depth" not in make_params().to_dict()["residual_approach"]
    with pytest.raises(InputError, match="transition_depth"):
        LawParams.from_dict({**doc, "residual_approach": {"limit": 0.9, "power": 0.3,
                                                          "transition_depth": -1.0}})


def test_kernel_and_reference_agree_with_a_transition_depth():
    params = make_params(residual_transition=6.0, residual_limit=0.99, residual_power=0.3)
    rng = np.random.default_rng(11)
    n, steps = 16, 300
    paths = np.cumsum(rng.normal(0.0, 3.0, size=(steps, n)), axis=0) * params.yield_approach
    arrays = ContactArrays(params, n)
    forces = np.array([arrays.step(paths[s])[0].copy() for s in range(steps)])
    for i in range(n):
        reference, _ = force_history(params, paths[:, i])
        np.testing.assert_allclose(forces[:, i], reference, rtol=1e-11,
                                   atol=1e-12 * max(max(reference), 1e-300))
    contact = Contact(params)
    contact.update(40 * params.yield_approach)
    assert contact.state.residual_approach == pytest.approx(
        float(params.residual_ratio(40.0)) * 40 * params.yield_approach, rel=1e-14)


# --- the shipped calibrated files ---------------------------------------------------------
# Force tolerance (% of peak) on a fresh coarse FE cycle of the file's kinematics: both files meet
# the 5 % goal (docs/calibration.md). sigma_c = 10 MPa is calibrated on the default mesh;
# sigma_c = 1 MPa on the default mesh too, with finite strain and the contact mesh rule (the
# committed campaign datasets/fe-runs/weak-finite), so the check's coarse mesh differs from it.
# The weak grain's check run caps its loading steps at a factor 1.1 in force: without a cap the
# approach of its perfectly plastic flattening moves several % with the load step (docs/fem.md,
# "The staircase of a growing contact", item 2), more than the law's error. Measured (22 s): the
# shipped file 1.1 % force RMS, 0.3 % residual; the earlier small-strain file 4.6 %, 3.0 %. The
# reference grain's deep file (to 120 kN, finite strain) is checked at 2.8 kN, between its levels
# (the same cap: the flattening is step dependent there too).
@pytest.mark.parametrize("name, material, meshes, cap, tolerance", [
    ("params-reference.json", "reference", {"default", "fine"}, None, 5.0),
    ("params-reference-weak.json", "reference-weak", {"default", "fine", "coarse"}, 1.1, 5.0),
    ("params-reference-deep.json", "reference", {"default"}, 1.1, 5.0),
])
def test_shipped_calibrations_match_a_fresh_fe_run(tmp_path, name, material, meshes, cap,
                                                   tolerance):
    """The shipped file is an FE calibration of its material, and the law driven with it follows
    an FE cycle it never saw (another mesh rule or mesh, another peak) within the 5 % goal."""
    params = load_params(EXAMPLES / name)
    doc = json.loads((EXAMPLES / name).read_text())
    fe = doc["provenance"]["fe"]
    assert doc["provenance"]["source"].startswith("FE calibration")
    assert fe["mesh"] in meshes
    if fe["mesh"] == "coarse":  # the pilot: the contact mesh rule, so the check's mesh differs
        assert fe["mesh_rule"] == "contact"
    assert len(fe["peak_forces_N"]) >= 6
    assert params.material == load_material(material)
    low, high = force_range(params.material, doc["calibrated_range"]["max_force_N"])
    peak = low * (high / low) ** 0.625  # between levels (7 levels: 0.5, 0.67; 13: 7/12, 8/12)
    # the "yield" meshes with fixed steps (the defaults before issue 36): for the weak grain
    # another rule than the calibration's, and as cheap as the check was made to be
    job = FemJob(params.material, (0.0, peak, 0.0), mesh="coarse", steps_per_segment=8,
                 kinematics=fe.get("kinematics", "small"), max_step_ratio=cap,
                 mesh_rule="yield", step_control="fixed")
    (result,) = run_campaign([job], tmp_path, progress=False)
    comparison = compare(params, job, result, name="check", kind="held-out")
    assert comparison.force_rms_percent < tolerance
    assert comparison.residual_error_percent < 10.0


def test_calibration_fits_the_cyclic_laws_to_its_repeated_fe_run(calibrated):
    """The campaign's repeated-history FE run (10 cycles to half the top peak) feeds the
    cyclic power laws, or the file says why not (the run ratchets)."""
    root, out = calibrated
    doc = json.loads(out.read_text())
    cyclic = doc["provenance"]["cyclic"]
    assert cyclic["history_forces_N"] == [0.0] + [150.0, 0.0] * 10
    assert (root / "cache" / cyclic["cache_key"] / "summary.json").exists()
    assert cyclic["status"] in ("fitted", "not fitted", "not needed")
    if cyclic["status"] == "fitted":
        assert doc["cyclic"]["enabled"] is True
        assert doc["cyclic"]["form"] == "shakedown"
        errors = doc["fit_errors"]["cyclic"]
        for name in ("residual_increment_ratio", "plastic_work_ratio"):
            assert [c["cycle"] for c in errors[name]["per_cycle"]]
            assert errors[name]["max_log10"] >= 0.0
    else:
        assert doc["cyclic"]["enabled"] is False and cyclic["reason"]


def _cycles_result(increments, work):
    from geocontact.fem.result import FemResult

    residual = np.cumsum(increments)
    cycles = [{"max_force_N": 3000.0, "max_approach_m": 1e-4 + r, "residual_approach_m": r,
               "plastic_work_J": w} for r, w in zip(residual, work, strict=True)]
    return FemResult(curve={}, summary={"cycles": cycles})


def test_fit_cyclic_accepts_a_steep_decay_with_coefficient_above_one():
    """c N^-p with c > 1 is a valid law when the cycle-2 ratio c 2^-p is below 1 (FE runs of
    the reference case fit c ~ 2, p ~ 4); a ratchetting run leaves the extension off."""
    from geocontact.calibrate.campaign import cyclic_job, fit_cyclic
    from geocontact.grain.material import preset

    params = make_params()
    job = cyclic_job(preset("reference"), 300.0, "coarse", 4)
    n = np.arange(1, 11)
    from geocontact.calibrate.cyclic_fit import law_first_cycle

    residual_1, _ = law_first_cycle(params, 3000.0)  # the law's own cycle 1 (the fit's unit)
    inc = np.where(n == 1, residual_1, residual_1 * 2.3 * n**-4.0)
    fitted = fit_cyclic(params, job, _cycles_result(inc, inc * 1e3))
    assert fitted.cyclic.enabled
    assert fitted.cyclic.residual_ratio_coefficient == pytest.approx(2.3, rel=1e-6)
    assert fitted.cyclic.residual_ratio_power == pytest.approx(4.0, rel=1e-6)
    again = LawParams.from_dict(json.loads(json.dumps(fitted.to_dict())))
    assert again.cyclic.residual_ratio(2.0) == pytest.approx(2.3 / 16, rel=1e-6)
    ratchet = np.where(n == 1, 1e-4, 2e-6)
    kept = fit_cyclic(params, job, _cycles_result(ratchet, ratchet * 1e3))
    assert not kept.cyclic.enabled
    assert kept.provenance["cyclic"]["status"] == "not fitted"
    assert "does not decay" in kept.provenance["cyclic"]["reason"]
    # increments at round-off from cycle 2 (the sigma_c = 1 MPa FE run): nothing to fit
    flat = np.where(n == 1, 1e-4, 3e-10 * (-1.0) ** n)
    kept = fit_cyclic(params, job, _cycles_result(flat, np.where(n == 1, 1.0, 1e-9)))
    assert not kept.cyclic.enabled
    assert kept.provenance["cyclic"]["status"] == "not needed"


def test_params_and_acceptance_reference_each_other_and_stale_ones_go(calibrated, tmp_path):
    """P.json, P.acceptance.json and P.acceptance/ are one result: each names the other by
    hash; a rerun without --acceptance removes the acceptance that no longer describes P."""
    import shutil

    from geocontact.calibrate.workflow import check_acceptance
    from geocontact.files import read_manifest

    root, out = calibrated
    work = tmp_path / "copy"
    shutil.copytree(root, work, ignore=shutil.ignore_patterns("cache"))
    params = work / out.name
    assert check_acceptance(params) == []
    doc = json.loads(params.read_text())
    assert doc["provenance"]["acceptance"]["file"] == "P.acceptance.json"
    assert read_manifest(work / "P.acceptance")["command"] == "calibrate"
    # a P.json edited (or rewritten alone) after the acceptance no longer matches it
    params.write_text(params.read_text().replace('"label"', '"label" ', 1))
    problems = check_acceptance(params)
    assert problems and "hash differs" in problems[0]
    # recalibrating without --acceptance (from the cache) removes the stale table and figures
    stale = work / "P.acceptance" / "fitted-1.png"
    assert stale.exists()
    # the edited P.json is the user's now: replaced only with --force (README, "Results you
    # can trust")
    assert main(["calibrate", *ARGS, "--cache", str(root / "cache"), "--out", str(params)]) == 2
    assert main(["calibrate", *ARGS, "--cache", str(root / "cache"), "--out", str(params),
                 "--force"]) == 0
    assert not stale.exists() and not (work / "P.acceptance.json").exists()
    assert not (work / "P.acceptance").exists()


def test_a_mesh_force_keeps_the_runs_of_a_campaign_whose_top_moves():
    """``mesh_force``: every level and held-out run is sized for it, so the levels of a
    campaign whose top peak is lowered (or raised) keep their keys; by default the mesh is the
    top peak's, as before."""
    from geocontact.calibrate.acceptance import held_out_jobs
    from geocontact.calibrate.campaign import calibration_jobs
    from geocontact.grain.material import preset

    material = preset("reference")
    wide = calibration_jobs(material, [10.0, 100.0, 1000.0], "coarse", mesh_force=6e5)
    narrow = calibration_jobs(material, [10.0, 100.0], "coarse", mesh_force=6e5)
    assert [j.key() for j in narrow] == [j.key() for j in wide[:2]]
    assert {j.identity().mesh_force for j in wide} == {6e5}
    default = calibration_jobs(material, [10.0, 100.0], "coarse")
    assert {j.identity().mesh_force for j in default} == {100.0}
    assert default[0].key() != narrow[0].key()
    held = held_out_jobs(material, "coarse", max_force=1000.0, mesh_force=6e5)
    assert {job.identity().mesh_force for _, job in held} == {6e5}
    assert {job.identity().mesh_force for _, job in held_out_jobs(
        material, "coarse", max_force=1000.0)} >= {1000.0}
