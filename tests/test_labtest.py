"""geocontact fit (issue 13): reading, contact point, segmentation, set-ups, bad curves, and the
fit of a committed synthetic test (docs/fit.md).

The conditioning tests use curves made here with known answers: Hertz (F = K d^1.5, the closed
form) and the shipped law (examples/params-reference.json) driven along a displacement path,
then dirtied with a known offset, gap, noise and machine compliance."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from geocontact.errors import InputError
from geocontact.labtest import approach_of, condition, read_test
from geocontact.labtest.curve import Record, displacement_of, force_noise
from geocontact.labtest.fit import fit_once, youngs_modulus_of
from geocontact.law import Contact, load_params

ROOT = Path(__file__).resolve().parents[1]
TESTS = ROOT / "examples" / "tests"
R = 4e-3
E, NU = 30e9, 0.2
E_STAR = E / (2 * (1 - NU**2))
K = 4.0 / 3.0 * E_STAR * math.sqrt(R / 2)  # pair Hertz coefficient, F = K delta^1.5


def hertz_cycle(setup="pair", *, peak=1e-6, gap=0.2e-6, offset=0.0, noise=0.0, n=1500,
                machine_stiffness=None, seed=0, cycles=1):
    """Machine record of elastic load-unload cycles: gap, Hertz, back off; known answers."""
    rng = np.random.default_rng(seed)
    legs = [np.linspace(-gap, 0, n // 10)]
    for _ in range(cycles):
        legs += [np.linspace(0, peak, n // 3), np.linspace(peak, -0.1 * peak, n // 3)]
    delta = np.concatenate(legs)
    force = K * np.maximum(delta, 0) ** 1.5
    u = displacement_of(delta, setup)
    if machine_stiffness:
        u = u + force / machine_stiffness
    u = u + gap  # the machine's zero is where the record starts
    fmax = force.max()
    return Record(displacement=u, force=force + offset + rng.normal(0, noise * fmax, u.size),
                  time=np.arange(u.size, dtype=float), source="synthetic", columns={})


def law_path_record(peaks=(3e-6, 8e-6, 2e-5), *, noise=2e-3, offset=0.01, seed=1):
    """The shipped law (sigma_c = 10 MPa, R = 0.1 m) driven through load-unload cycles with a
    back-off past the residual approach after each; returns record and the true peaks."""
    params = load_params(ROOT / "examples" / "params-reference.json")
    c = Contact(params)
    path = [np.linspace(-2e-6, 0, 100)]
    for p in peaks:
        path += [np.linspace(0 if not path[1:] else path[-1][-1], p, 400),
                 np.linspace(p, 0.0, 400)]
    delta = np.concatenate(path)
    force = np.array([c.update(max(d, 0.0))[0] for d in delta])
    rng = np.random.default_rng(seed)
    fmax = force.max()
    rec = Record(displacement=delta + 2e-6, force=force + offset + rng.normal(0, noise * fmax,
                                                                           delta.size),
                 time=None, source="law", columns={})
    return rec, peaks, force


# --- contact point -----------------------------------------------------------------------------
def test_contact_point_on_noisy_hertz_with_offset():
    rec = hertz_cycle(offset=0.05, noise=3e-3, gap=0.3e-6)
    t = condition(rec, "pair", R)
    # the contact is at machine displacement = gap; the offset is removed
    assert t.contact["contact_displacement_m"] == pytest.approx(0.3e-6, abs=0.01e-6)
    assert t.contact["offset_N"] == pytest.approx(0.05, abs=3e-3 * K * 1e-9)
    assert t.contact["stiffness"] == pytest.approx(K, rel=0.03)
    assert t.noise == pytest.approx(3e-3 * K * 1e-9, rel=0.15)


def test_noise_estimate_is_the_load_cell_sigma():
    rng = np.random.default_rng(3)
    smooth = np.sin(np.linspace(0, 6, 3000)) * 100.0
    assert force_noise(smooth + rng.normal(0, 0.5, smooth.size)) == pytest.approx(0.5, rel=0.08)


def test_noise_estimate_does_not_take_uneven_sampling_for_noise():
    """A logger with jittered intervals (0.3-1.7 x the mean, as the synthetic records have) at a
    constant platen speed: the force is smooth in time, not in the point index, so the
    smoothing is in time. In the index, each jittered interval is a kink of slope x jitter that
    the residual takes for noise: 0.63 for the true 0.5 here (the flat test's record: 4.1e-4 of
    the peak for the 3e-4 it was made with)."""
    rng = np.random.default_rng(0)
    time = np.cumsum(rng.uniform(0.3, 1.7, 3000))
    force = 100.0 * np.abs(np.sin(np.pi * time / 150.0)) ** 1.5 + rng.normal(0, 0.5, time.size)
    assert force_noise(force, time) == pytest.approx(0.5, rel=0.08)
    assert force_noise(force) > 1.15 * 0.5  # in the index: the jitter counted as noise


def test_machine_compliance_is_subtracted():
    rec = hertz_cycle(machine_stiffness=2e5)  # half the grain's secant stiffness at the peak
    with_k = condition(rec, "pair", R, machine_stiffness=2e5)
    without = condition(rec, "pair", R)
    assert with_k.contact["stiffness"] == pytest.approx(K, rel=0.01)
    assert without.contact["stiffness"] < 0.9 * K


@pytest.mark.parametrize("setup", ["pair", "platens", "flat"])
def test_every_setup_gives_the_same_modulus(setup):
    """One Hertz pair curve measured through each set-up (docs/model.md §10) gives back E."""
    t = condition(hertz_cycle(setup), setup, R)
    k_pair = t.contact["stiffness"] * (2.0 ** -1.5 if setup == "flat" else 1.0)
    assert youngs_modulus_of(k_pair, R, NU) == pytest.approx(E, rel=0.005)
    # and the conditioned approach is the pair approach
    assert t.approach.max() == pytest.approx(1e-6, rel=0.01)


def test_setup_mapping():
    assert approach_of(np.array([1.0]), "flat")[0] == 2.0
    assert approach_of(np.array([1.0]), "platens")[0] == 1.0
    with pytest.raises(InputError, match="setup: unknown"):
        approach_of(np.array([1.0]), "anvil")


# --- segmentation -------------------------------------------------------------------------------
def test_segmentation_of_noisy_cycles():
    rec, peaks, clean = law_path_record()
    t = condition(rec, "pair", 0.1)
    assert len(t.cycles) == 3 and all(c.closed for c in t.cycles)
    for c, p in zip(t.cycles, peaks, strict=True):
        assert t.approach[c.peak] == pytest.approx(p, rel=0.02)
    # each cycle's loading starts where the previous unloading ended
    assert [c.start for c in t.cycles[1:]] == [c.end for c in t.cycles[:-1]]
    # the reloading (up to the previous peak) precedes the virgin part of cycles 2 and 3
    assert t.cycles[1].previous_max_approach == pytest.approx(peaks[0], rel=0.02)


def test_noise_below_the_turn_threshold_makes_no_cycles():
    rec = hertz_cycle(noise=2e-2)  # 2 % force noise; displacement clean
    assert len(condition(rec, "pair", R).cycles) == 1


# --- reading and units --------------------------------------------------------------------------
def _write(path, header, rows):
    path.write_text(header + "\n" + "\n".join(",".join(f"{v:.9g}" for v in r)
                                              for r in rows) + "\n")
    return path


def test_units_are_converted(tmp_path):
    rec = hertz_cycle()
    rows_si = np.column_stack([rec.time, rec.displacement, rec.force])
    a = read_test(_write(tmp_path / "a.csv", "time_s,displacement_m,force_N", rows_si))
    b = read_test(_write(tmp_path / "b.csv", "time_s,displacement_um,force_kN",
                         rows_si * [1, 1e6, 1e-3]))
    c = read_test(_write(tmp_path / "c.csv", "t,Stroke,Load", rows_si * [1, 1e3, 1]),
                  columns="time=t:s,displacement=Stroke:mm,force=Load:N")
    for r in (b, c):
        np.testing.assert_allclose(r.displacement, a.displacement, rtol=1e-8)
        np.testing.assert_allclose(r.force, a.force, rtol=1e-8, atol=1e-12)


# --- bad curves: one line naming the problem ---------------------------------------------------
def _csv(tmp_path, d, f, t=None, header="displacement_m,force_N"):
    cols = [d, f] if t is None else [t, d, f]
    if t is not None:
        header = "time_s," + header
    return _write(tmp_path / "bad.csv", header, np.column_stack(cols))


@pytest.mark.parametrize("case,match", [
    ("unit", "unknown unit 'in'"),
    ("nan", "row 5 is NaN"),
    ("few", "need >= 50"),
    ("time", "time must increase"),
    ("missing", "no force column"),
])
def test_bad_files(tmp_path, case, match):
    rec = hertz_cycle()
    d, f, t = rec.displacement, rec.force, rec.time
    if case == "unit":
        path = _csv(tmp_path, d, f, header="displacement_in,force_N")
    elif case == "nan":
        f = f.copy()
        f[3] = np.nan
        path = _csv(tmp_path, d, f)
    elif case == "few":
        path = _csv(tmp_path, d[:30], f[:30])
    elif case == "time":
        t = t.copy()
        t[10] = t[9]
        path = _csv(tmp_path, d, f, t)
    else:
        path = _write(tmp_path / "bad.csv", "displacement_m,load", np.column_stack([d, f]))
    with pytest.raises(InputError, match=match) as info:
        read_test(path)
    assert "\n" not in str(info.value)


def test_no_unloading():
    rec = hertz_cycle()
    keep = slice(0, int(np.argmax(rec.displacement)) + 1)  # loading only
    mono = Record(rec.displacement[keep], rec.force[keep], None, "x", {})
    with pytest.raises(InputError, match="no unloading"):
        condition(mono, "pair", R)


def test_gap_never_closed():
    rng = np.random.default_rng(0)
    u = np.concatenate([np.linspace(0, 1e-6, 300), np.linspace(1e-6, 0, 300)])
    rec = Record(u, rng.normal(0.0, 1e-3, u.size), None, "x", {})
    with pytest.raises(InputError, match="never closes the gap"):
        condition(rec, "pair", R)


def test_tension_beyond_noise():
    rec = hertz_cycle(noise=1e-3)
    f = rec.force.copy()
    f[-50:] = -0.2 * f.max()  # the grain pulls the platen: a sign or zero error
    with pytest.raises(InputError, match="tension beyond the load-cell noise"):
        condition(Record(rec.displacement, f, None, "x", {}), "pair", R)


def test_too_few_cycles_for_the_law():
    rec = hertz_cycle(cycles=2, peak=1e-6)
    with pytest.raises(InputError, match="closed load-unload cycle|never yields"):
        fit_once(rec, "pair", R)


# --- the fit of a committed synthetic test ------------------------------------------------------
def _master(name):
    from geocontact.labtest.identify import read_master

    return read_master(ROOT / "tests" / "data" / "labtest" / f"{name}.master.json")


@pytest.mark.parametrize("name,tolerances", [
    ("platens-quartzite.clean", {"E": 0.02, "fy": 0.10, "sigma": 0.05}),
    ("platens-quartzite", {"E": 0.05, "fy": 0.45, "sigma": 0.15}),
])
def test_fit_recovers_the_material(name, tolerances):
    """E, Fy (against the FE's first yield) and sigma_c of the committed platens test, with the
    FE master curve its identification ended on (tests/data/labtest, made by
    scripts/make_synthetic_lab_tests.py): noise-free within 2 %, 10 %, 5 %; with the test's noise
    (0.03 % of the peak force), offset, sampling and compliance within 5 %, 45 %, 15 %: about two
    of the bootstrap's standard errors on this record (2.5 %, 20 %, 6 %; docs/fit.md: the noise
    on the Hertz part and the sigma_c-E correlation)."""
    truth = json.loads((TESTS / "platens-quartzite.truth.json").read_text())
    m = truth["material"]
    rec = read_test(TESTS / f"{name}.csv")
    fit = fit_once(rec, "platens", m["radius"], machine_stiffness=truth[
        "machine_stiffness_N_per_m"], poissons_ratio=m["poissons_ratio"],
        friction_angle=m["friction_angle_deg"], master=_master("platens-quartzite"))
    p = fit.params
    assert p.material.youngs_modulus == pytest.approx(m["youngs_modulus"], rel=tolerances["E"])
    assert p.yield_force == pytest.approx(truth["fe_first_yield_force_N"], rel=tolerances["fy"])
    assert p.material.compressive_yield_stress == pytest.approx(
        m["compressive_yield_stress"], rel=tolerances["sigma"])
    # the cycles: peaks and residual approaches of the FE run behind the test (the first
    # cycle, 4 Fy, keeps a residual of 8 % of its approach, 7 nm = 0.21 dy: its error is the
    # contact point's, which the noisy record fixes to 0.3 dy, so it is checked to 0.1 dy)
    dy = truth["fe_first_yield_approach_m"]
    for k, (lv, fe) in enumerate(zip(fit.levels, truth["fe_cycles"], strict=True)):
        assert lv["max_force_N"] == pytest.approx(fe["max_force_N"], rel=0.02)
        assert lv["residual_approach_m"] == pytest.approx(
            fe["residual_approach_m"], **({"abs": 0.1 * dy} if k == 0 else {"rel": 0.10}))


# --- the command --------------------------------------------------------------------------------
def _law_test_csv(tmp_path):
    rec, _, _ = law_path_record(peaks=(6e-6, 2e-5, 6e-5, 1.5e-4), noise=5e-5, offset=0.3)
    path = tmp_path / "test.csv"
    _write(path, "displacement_mm,force_kN",
           np.column_stack([rec.displacement * 1e3, rec.force * 1e-3]))
    return path


def test_cli_writes_a_valid_law_a_result_folder_and_a_report(tmp_path, capsys):
    from geocontact.cli import main
    from geocontact.files import verify_manifest
    from geocontact.report import build_report

    curve = _law_test_csv(tmp_path)
    out = tmp_path / "P.json"
    args = ["fit", str(curve), "--setup", "pair", "--radius", "0.1", "--out", str(out),
            "--identify", "departure", "--bootstrap", "2", "--json"]
    assert main(args) == 0
    document = json.loads(capsys.readouterr().out)
    params = load_params(out)  # schema-valid
    assert params.provenance["source"].startswith("laboratory test")
    assert set(params.provenance["assumed"]) == {"poissons_ratio", "friction_angle_deg",
                                                 "hardening_ratio"}
    assert document["bootstrap"]["succeeded"] >= 2
    assert document["fitted"]["youngs_modulus_Pa"]["standard_error"] > 0
    # the shipped law's E (10 GPa at nu = 0.25) from the Hertz part
    assert params.material.youngs_modulus == pytest.approx(10e9, rel=0.05)
    folder = tmp_path / "P.fit"
    assert verify_manifest(folder) == []
    assert {"fit.png", "yield.png", "curve.csv", "fit.json"} <= {p.name for p in
                                                                 folder.iterdir()}
    html = build_report(folder).read_text()
    assert "Laboratory-test fit" in html and "none subtracted" in html
    # a second run replaces its own folder; a folder of the user's is refused
    args[args.index("--bootstrap") + 1] = "0"
    assert main([a for a in args if a != "--json"]) == 0
    # the screen says that no machine compliance was subtracted (none given)
    assert "machine compliance: none subtracted" in capsys.readouterr().out
    (folder / "mine.txt").write_text("notes")
    assert main(args) == 2
    assert "was not written by geocontact" in capsys.readouterr().err


@pytest.mark.parametrize("extra,match", [
    (["--setup", "anvil"], "invalid choice"),
    (["--radius", "-1"], "radius"),
    (["--bootstrap", "-2"], "--bootstrap"),
    (["--poissons-ratio", "0.7"], "--poissons-ratio"),
])
def test_cli_bad_arguments_are_one_line(tmp_path, capsys, extra, match):
    from geocontact.cli import main

    curve = _law_test_csv(tmp_path)
    base = {"--setup": "pair", "--radius": "0.1", "--out": str(tmp_path / "P.json")}
    for flag, value in zip(extra[::2], extra[1::2], strict=True):
        base[flag] = value
    argv = ["fit", str(curve), "--identify", "departure", "--bootstrap",
            base.pop("--bootstrap", "0")]
    for flag, value in base.items():
        argv += [flag, value]
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert match in err and "\n" not in err


def _prepared_truth(name: str):
    from geocontact.labtest.fit import prepare

    truth = json.loads((TESTS / f"{name}.truth.json").read_text())
    m = truth["material"]
    p = prepare(read_test(TESTS / f"{name}.clean.csv"), truth["setup"], m["radius"],
                machine_stiffness=truth["machine_stiffness_N_per_m"],
                poissons_ratio=m["poissons_ratio"], friction_angle=m["friction_angle_deg"])
    return truth, p


@pytest.mark.parametrize("name", ["platens-quartzite", "flat-sandstone"])
def test_universal_identification_finds_sigma_c_of_the_noise_free_tests(name):
    """--identify universal (no FE run): sigma_c of the noise-free synthetic tests within the
    acceptance's 5 % (docs/fit.md: +2.2 % and +1.9 %), at the minimum of the whole-record misfit
    (below at 0.9 and 1.1 times it); the virgin-only estimate is kept beside it."""
    from geocontact.calibrate.acceptance import path_weights
    from geocontact.labtest.identify import _record_misfit, identify_universal, universal_law

    truth, p = _prepared_truth(name)
    start = p.first_estimate()
    found = identify_universal(start, p.virgin_approach, p.virgin_force, p.test.noise,
                               beta_given=True, approach=p.test.approach, force=p.test.force)
    sigma = found["compressive_yield_stress_Pa"]
    assert sigma == pytest.approx(truth["material"]["compressive_yield_stress"], rel=0.05)
    assert found["virgin_only"]["compressive_yield_stress_Pa"] > 0
    d, f = np.asarray(p.test.approach), np.asarray(p.test.force)
    w = path_weights(d)
    at = [_record_misfit(universal_law(), start.with_(compressive_yield_stress=x * sigma), d, f, w)
          for x in (0.9, 1.0, 1.1)]
    assert at[1] < at[0] and at[1] < at[2]
    assert found["misfit"] == pytest.approx(at[1], rel=1e-9)


def test_universal_bootstrap_reidentifies_sigma_c(tmp_path):
    """In the universal mode the bootstrap identifies sigma_c again per sample: it has a
    standard error (the noisy platens test, 4 samples)."""
    from geocontact.labtest import fit_test

    truth = json.loads((TESTS / "platens-quartzite.truth.json").read_text())
    m = truth["material"]
    result = fit_test(read_test(TESTS / "platens-quartzite.csv"), "platens", m["radius"],
                      machine_stiffness=truth["machine_stiffness_N_per_m"],
                      poissons_ratio=m["poissons_ratio"], friction_angle=m["friction_angle_deg"],
                      identify="universal", bootstrap_samples=4, seed=1)
    boot = result.bootstrap
    assert boot["succeeded"] == 4
    se = boot["relative_standard_errors"]["compressive_yield_stress_Pa"]
    assert se is not None and 0.0 < se < 0.2
