"""Cyclic-history analysis (geocontact.analyses.cycles): synthetic sequences with known
answers, the law along paths, the cyclic parameter fit, and the ``geocontact cycles`` command on
a short FE run."""

import json
import math
from pathlib import Path

import numpy as np
import pytest

from geocontact.analyses import cycles as cy
from geocontact.calibrate import cyclic_fit as cf
from geocontact.errors import InputError
from geocontact.files import written_by_us
from geocontact.law import load_params

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def synthetic(residual_increments, plastic_work, max_approach=1e-4, max_force=3000.0):
    """FE-like cycle records from given per-cycle residual increments and plastic work."""
    residual = np.cumsum(residual_increments)
    return [{"max_force_N": max_force, "max_approach_m": max_approach + r,
             "residual_approach_m": float(r), "plastic_work_J": float(w)}
            for r, w in zip(residual, plastic_work, strict=True)]


def power_sequence(first, c, p, n):
    """Cycle 1 = first, cycle N >= 2 = first * c N^-p."""
    return [first] + [first * c * k ** (-p) for k in range(2, n + 1)]


def test_increments_and_ratios_to_the_first_cycle():
    rows = cf.cycle_table(synthetic([4e-5, 1e-5, 5e-6], [0.2, 0.05, 0.01]))
    assert [r["residual_approach_m"] for r in rows] == pytest.approx([4e-5, 5e-5, 5.5e-5])
    assert [r["residual_approach_increment_m"] for r in rows] == pytest.approx([4e-5, 1e-5, 5e-6])
    assert [r["residual_increment_ratio"] for r in rows] == pytest.approx([1.0, 0.25, 0.125])
    assert [r["plastic_work_ratio"] for r in rows] == pytest.approx([1.0, 0.25, 0.05])


def test_power_law_fit_recovers_known_coefficient_and_power():
    n = np.arange(1, 11)
    ratio = np.where(n == 1, 1.0, 0.3 * n ** -1.7)
    fit = cf.fit_power_law(n, ratio)
    assert fit.coefficient == pytest.approx(0.3, rel=1e-9)
    assert fit.power == pytest.approx(1.7, rel=1e-9)
    assert fit.cycles_used == list(range(2, 11))  # cycle 1 is 1 by definition, not fitted
    assert fit.rms_log10_error < 1e-12 and fit.power_standard_error < 1e-9
    # multiplicative noise of +-10 % shows up in the fit errors
    noisy = ratio * np.where(n % 2 == 0, 1.1, 1 / 1.1)
    fit = cf.fit_power_law(n, noisy)
    assert fit.rms_log10_error == pytest.approx(math.log10(1.1), rel=0.1)
    assert fit.max_relative_error > 0.08
    assert fit.power == pytest.approx(1.7, abs=0.15)


def test_geometric_fit_recovers_a_constant_factor_per_cycle():
    n = np.arange(1, 11)
    ratio = np.where(n == 1, 1.0, 0.08 * 0.5**n)
    geo = cf.fit_geometric(n, ratio)
    assert geo.coefficient == pytest.approx(0.08, rel=1e-9)
    assert geo.factor == pytest.approx(0.5, rel=1e-9)
    # 0.08 * 0.5^N < 1e-3 first at N = 7 (0.08/128 = 6.25e-4; N = 6 gives 1.25e-3)
    assert geo.critical_cycle(1e-3) == 7
    # the power law fits such data worse than the geometric law does
    power = cf.fit_power_law(n, ratio)
    assert power.rms_log10_error > 10 * max(geo.rms_log10_error, 1e-12)
    a = cf.analyse(synthetic(ratio * 1e-5, ratio), tolerance=1e-3)
    assert a.to_dict()["fits"]["geometric"]["residual_increment_ratio"]["critical_cycle"] == 7
    assert a.critical_cycles["measured"]["residual_increment"] == 7


def test_power_law_fit_skips_non_positive_ratios_and_needs_two_points():
    fit = cf.fit_power_law([1, 2, 3, 4, 5], [1.0, 0.1, -1e-6, 0.1 * 4**-2, 0.1 * 5**-2])
    assert fit.cycles_excluded == [3]
    assert fit.cycles_used == [2, 4, 5]
    assert cf.fit_power_law([1, 2, 3], [1.0, 0.1, 0.0]) is None


def test_critical_cycle_measured_and_from_the_fit():
    # ratio 0.5 N^-1 < 0.011 first at N = 46 (0.5/45 = 0.0111, 0.5/46 = 0.0109)
    n = 60
    a = cf.analyse(synthetic(power_sequence(1e-5, 0.5, 1.0, n), power_sequence(1.0, 0.5, 1.0, n)),
                   tolerance=0.011)
    assert a.critical_cycles["measured"]["residual_increment"] == 46
    assert a.critical_cycles["fitted"]["residual_increment"] == 46  # ceil((c/tol)^(1/p))
    assert a.critical_cycle == 46
    # a looser tolerance shortens it: 0.5 N^-1 < 0.1 first at N = 6
    b = cf.analyse(synthetic(power_sequence(1e-5, 0.5, 1.0, 10), power_sequence(1.0, 0.5, 1.0, 10)),
                   tolerance=0.1)
    assert b.critical_cycles["measured"]["elastic_shakedown"] == 6


def test_elastic_shakedown_plastic_shakedown_and_ratchetting():
    n = 10
    fast = power_sequence(1.0, 0.2, 3.0, n)  # 0.2 * 10^-3 = 2e-4 < 1 % at the end
    elastic_sd = cf.analyse(synthetic(np.array(fast) * 1e-5, fast))
    assert elastic_sd.state == cf.ELASTIC_SHAKEDOWN
    assert elastic_sd.eventual_state == cf.ELASTIC_SHAKEDOWN
    # residual approach stops after cycle 1, every later closed loop still dissipates 20 %
    plastic_sd = cf.analyse(synthetic([1e-5] + [0.0] * (n - 1), [1.0] + [0.2] * (n - 1)))
    assert plastic_sd.state == cf.PLASTIC_SHAKEDOWN
    assert plastic_sd.eventual_state == cf.PLASTIC_SHAKEDOWN
    # the same residual increment every cycle: ratchetting, now and for ever
    ratchet = cf.analyse(synthetic([1e-5] + [2e-6] * (n - 1), [1.0] + [0.2] * (n - 1)))
    assert ratchet.state == cf.RATCHETTING and ratchet.eventual_state == cf.RATCHETTING
    assert ratchet.residual_fit.power == pytest.approx(0.0, abs=1e-12)
    assert ratchet.critical_cycles["fitted"]["residual_increment"] is None
    # growing increments (monotonically increasing peaks): ratchetting
    growing = cf.analyse(synthetic([1e-6 * k for k in range(1, 8)], [0.1 * k for k in range(1, 8)]))
    assert growing.state == cf.RATCHETTING and growing.residual_fit.power < 0


def test_slow_decay_ratchets_now_but_shakes_down_eventually():
    n = 10
    slow = power_sequence(1.0, 0.5, 1.0, n)  # ratio 0.05 at N = 10, 0.01 at N = 50
    a = cf.analyse(synthetic(np.array(slow) * 1e-5, slow), horizon=1000)
    assert a.state == cf.RATCHETTING
    assert a.eventual_state == cf.ELASTIC_SHAKEDOWN
    assert a.critical_cycles["fitted"]["elastic_shakedown"] == 50
    # within a horizon shorter than the fitted critical cycle it still ratchets
    assert cf.analyse(synthetic(np.array(slow) * 1e-5, slow), horizon=20).eventual_state \
        == cf.RATCHETTING


def test_elastic_history_and_single_cycle():
    elastic = cf.analyse(synthetic([0.0, 0.0, 0.0], [0.0, 0.0, 0.0]))
    assert elastic.state == cf.ELASTIC and elastic.residual_fit is None
    single = cf.analyse(synthetic([1e-5], [1.0]))
    assert single.state == cf.UNDETERMINED


def test_bad_inputs_give_one_line_errors():
    with pytest.raises(InputError, match="tolerance"):
        cf.analyse(synthetic([1e-5, 1e-6], [1.0, 0.1]), tolerance=1.5)
    with pytest.raises(InputError, match="no complete cycle"):
        cf.analyse([])
    with pytest.raises(InputError, match="not closed"):
        cf.analyse([{"max_force_N": 1.0, "max_approach_m": 1e-5, "residual_approach_m": None,
                     "plastic_work_J": 0.0}])
    with pytest.raises(InputError, match="must end at zero force"):
        cy.check_cyclic_history([0.0, 100.0, 0.0, 100.0])


def test_shakedown_rule_is_the_seismic_one():
    from geocontact.analyses.seismic import classify

    assert classify.shakedown_rule is cf.shakedown_rule
    assert cf.shakedown_rule(0.2, 1.0, 0.0, 1.0, 0.05) == cf.RATCHETTING
    assert cf.shakedown_rule(0.01, 1.0, 0.2, 1.0, 0.05) == cf.PLASTIC_SHAKEDOWN
    assert cf.shakedown_rule(0.01, 1.0, 0.01, 1.0, 0.05) == cf.ELASTIC_SHAKEDOWN


def test_law_along_its_own_force_path_gives_the_same_cycles(params):
    fmax = 300 * params.yield_force
    forces = [0.0, fmax, 0.0, fmax, 0.0, 0.5 * fmax, 0.0]
    by_force, path = cy.law_cycles_by_force(params, forces)
    d, f = path["approach_m"], path["force_N"]
    zeros = [0] + [i for i in range(1, f.size) if f[i] <= 0.0 < f[i - 1]]
    windows = list(zip(zeros[:-1], zeros[1:], strict=True))
    along, _ = cy.law_cycles_along_path(params, d, windows)
    assert len(along) == len(by_force) == 3
    for a, b in zip(along, by_force, strict=True):
        assert a["residual_approach_m"] == pytest.approx(b["residual_approach_m"], rel=1e-9)
        assert a["plastic_work_J"] == pytest.approx(b["plastic_work_J"], rel=1e-6)
        assert a["plastic_work_J"] == pytest.approx(a["dissipated_energy_J"], rel=1e-9, abs=1e-15)
    # without the cyclic extension the law's closed loops dissipate but never ratchet
    analysis = cf.analyse(along[:2])
    assert analysis.cycles[1]["residual_approach_increment_m"] == pytest.approx(0.0, abs=1e-15)
    assert analysis.state == cf.PLASTIC_SHAKEDOWN


def test_with_cyclic_fills_the_law_and_round_trips(params, tmp_path):
    """The fit lands the law's cycle N on the FE's in metres and joules: coefficients over the
    law's own cycle 1 at the FE's peak force (closed form), powers exact on a power series."""
    n = 10
    fmax = 200 * params.yield_force
    res = power_sequence(1e-5, 0.3, 1.5, n)
    wp = power_sequence(0.5, 0.2, 1.2, n)
    analysis = cf.analyse(synthetic(res, wp, max_force=fmax), tolerance=0.01)
    fitted = cf.with_cyclic(params, analysis, provenance={"note": "synthetic"})
    dmax = params.virgin_approach(fmax)
    residual_1 = float(params.residual_ratio(dmax / params.yield_approach)) * dmax
    work_1 = float(params.envelope_plastic_work(dmax))
    assert fitted.cyclic.enabled and fitted.cyclic.form == "shakedown"
    assert fitted.cyclic.residual_ratio_coefficient == pytest.approx(0.3 * 1e-5 / residual_1,
                                                                     rel=1e-9)
    assert fitted.cyclic.residual_ratio_power == pytest.approx(1.5, rel=1e-9)
    assert fitted.cyclic.plastic_work_ratio_coefficient == pytest.approx(0.2 * 0.5 / work_1,
                                                                         rel=1e-9)
    assert fitted.cyclic.plastic_work_ratio_power == pytest.approx(1.2, rel=1e-9)
    assert fitted.provenance["cyclic"]["note"] == "synthetic"
    errors = fitted.fit_errors["cyclic"]["residual_increment_ratio"]
    assert [c["cycle"] for c in errors["per_cycle"]] == list(range(2, n + 1))
    assert errors["max_log10"] < 1e-9
    fitted.save(tmp_path / "p.json")
    again = load_params(tmp_path / "p.json")
    assert again.cyclic == fitted.cyclic
    # the law with the fitted extension ratchets by the FE's increments in metres and
    # dissipates the FE's plastic work in joules, cycle by cycle
    law, _ = cy.law_cycles_by_force(again, [0.0] + [fmax, 0.0] * 4)
    rows = cf.cycle_table(law)
    for k in (2, 3, 4):
        assert rows[k - 1]["residual_approach_increment_m"] == pytest.approx(res[k - 1], rel=1e-6)
        assert rows[k - 1]["plastic_work_J"] == pytest.approx(wp[k - 1], rel=1e-6)


def test_minimax_fit_bounds_the_worst_cycle():
    """A curved series (local log-slope rising, as the FE's is): the minimax power law's worst
    factor is below the least-squares one's."""
    n = np.arange(1, 11)
    series = np.exp(-0.5 * n) * n**-2.0
    minimax = cf.fit_power_law_minimax(n, series, 1.0)
    least = cf.fit_power_law(n, series)
    worst_least = np.max(np.abs(np.log10(least(n[1:]) / series[1:])))
    assert minimax.max_log10_error < worst_least
    assert minimax.max_log10_error == pytest.approx(
        max(abs(math.log10(c["law_over_fe"])) for c in minimax.per_cycle), rel=1e-9)


def test_with_cyclic_refuses_a_ratchetting_history(params):
    ratchet = cf.analyse(synthetic([1e-5] + [2e-6] * 5, [1.0] * 6))
    with pytest.raises(InputError, match="does not decay"):
        cf.with_cyclic(params, ratchet)


def test_ratio_law_leaves_out_a_ratchets_onset():
    """The weak grain's finite-strain FE: the per-cycle ratio rises over cycles 2-5 (onset of
    the ratchet), then decays slowly. Over all cycles no decaying power law exists; from the
    largest ratio on, the law is recovered exactly, and the earlier cycles' errors are kept."""
    n = np.arange(1, 11)
    law = 1.4e-3 * n**-0.07
    series = np.where(n < 5, law * np.array([1.0, 0.47, 0.83, 0.96, 1, 1, 1, 1, 1, 1]), law)
    series[0] = 1.0
    assert cf.fit_power_law_minimax(n, series, 1.0).power <= 0.0
    fit = cf.fit_ratio_law(n, series, 1.0)
    assert fit.from_cycle == 5
    assert fit.coefficient == pytest.approx(1.4e-3, rel=1e-9)
    assert fit.power == pytest.approx(0.07, rel=1e-7)
    assert [row["cycle"] for row in fit.per_cycle] == list(range(2, 11))
    assert [row["fitted"] for row in fit.per_cycle] == [False] * 3 + [True] * 6
    assert fit.per_cycle[0]["law_over_fe"] == pytest.approx(1 / 0.47, rel=1e-9)


def test_ratio_law_unchanged_where_the_ratio_decays_or_only_rises():
    n = np.arange(1, 11)
    decaying = np.exp(-0.5 * n) * n**-2.0
    assert (cf.fit_ratio_law(n, decaying, 1.0)
            == cf.fit_power_law_minimax(n, decaying, 1.0))
    rising = 1e-3 * n**0.3  # a ratchet that grows: nothing to leave out, still refused
    fit = cf.fit_ratio_law(n, rising, 1.0)
    assert fit == cf.fit_power_law_minimax(n, rising, 1.0) and fit.power < 0.0


def test_with_cyclic_fits_a_ratchet_after_its_onset(params):
    """The law's cyclic part from a history whose residual increments rise first: fitted from
    the largest one on, the onset's errors under fit_errors (not hidden)."""
    increments = [1e-5] + [2e-8, 4e-8, 5e-8, 4.8e-8, 4.7e-8, 4.6e-8]
    work = [1.0] + [3e-3 * k**-0.5 for k in range(2, 8)]
    fitted = cf.with_cyclic(params, cf.analyse(synthetic(increments, work)))
    errors = fitted.fit_errors["cyclic"]["residual_increment_ratio"]
    assert fitted.cyclic.enabled and fitted.cyclic.residual_ratio_power > 0.0
    assert errors["fitted_from_cycle"] == 4
    assert errors["max_log10_before"] == pytest.approx(
        max(abs(math.log10(row["law_over_fe"])) for row in errors["per_cycle"][:2]), rel=1e-12)
    assert "fitted_from_cycle" not in fitted.fit_errors["cyclic"]["plastic_work_ratio"]


def test_reloading_stiffness_after_higher_prior_peaks():
    # two reloads to 100 N from rest: the second needs half the approach (stiffer)
    curve = {
        "force_N": np.array([0.0, 50.0, 100.0, 0.0, 100.0, 200.0, 0.0, 100.0, 0.0]),
        "approach_m": np.array([0.0, 1.0, 2.0, 1.5, 2.5, 3.0, 2.5, 3.0, 2.5]) * 1e-5,
    }
    rows = cy.reloading_stiffness(curve, [(0, 3), (3, 6), (6, 8)], 100.0)
    assert [r["prior_peak_N"] for r in rows] == [0.0, 100.0, 200.0]
    assert [r["approach_to_level_m"] for r in rows] == pytest.approx([2e-5, 1e-5, 0.5e-5])
    assert rows[2]["secant_stiffness_N_per_m"] == pytest.approx(100.0 / 0.5e-5)
    assert cy.reloading_stiffness(curve, [(0, 3)], 150.0)[0]["approach_to_level_m"] is None


def test_cycles_command_on_a_short_fe_history(tmp_path, capsys):
    """3 cycles to 300 N on the coarse mesh with few steps; FE and law side by side."""
    from geocontact.cli import main

    history = tmp_path / "h.toml"
    history.write_text("[history]\nforces = [0, 300, 0, 300, 0, 300, 0]\n")
    example = EXAMPLES / "params-illustrative.json"
    out = tmp_path / "run"
    code = main(["cycles", "--material", "reference", "--history", str(history), "--params",
                 str(example), "--mesh", "coarse", "--steps", "4", "--out", str(out),
                 "--fit-params", str(tmp_path / "fitted.json"), "--json"])
    assert code == 0
    summary = json.loads(capsys.readouterr().out)
    assert json.loads((out / "summary.json").read_text()) == summary
    fe = summary["analyses"]["fe"]
    assert len(fe["cycles"]) == 3
    c1, c2, c3 = fe["cycles"]
    # the first cycle does nearly all the plastic work; later increments are small but positive
    assert c1["residual_approach_increment_m"] > 0
    assert 0 < c2["residual_increment_ratio"] < 0.05 and c3["residual_increment_ratio"] < \
        c2["residual_increment_ratio"]
    assert 0 < c2["plastic_work_ratio"] < 0.05
    assert fe["state"] == cf.ELASTIC_SHAKEDOWN
    assert set(summary["analyses"]) == {"fe", "law_along_fe_approach", "law_by_force"}
    assert summary["version"] and summary["provenance"]["inputs"]["forces_N"][1] == 300.0
    csv = (out / "cycles.csv").read_text().splitlines()
    assert csv[0].startswith("source,cycle,") and len(csv) == 1 + 9
    assert (out / "fe" / "curve.csv").exists() and (out / "fe" / "summary.json").exists()
    fitted = load_params(tmp_path / "fitted.json")
    assert fitted.cyclic.enabled
    assert fitted.cyclic.residual_ratio_power == pytest.approx(fe["fits"][
        "residual_increment_ratio"]["power"])
    # a resumed run reuses the finished FE run (same cycles, no new FE wall time)
    assert main(["cycles", "--material", "reference", "--history", str(history), "--mesh",
                 "coarse", "--steps", "4", "--out", str(out), "--resume", "--json"]) == 0
    again = json.loads(capsys.readouterr().out)
    assert again["analyses"]["fe"]["cycles"] == fe["cycles"]
    # no checkpoint or lock left; the ledger records fitted.json as written by geocontact
    assert sorted(p.name for p in tmp_path.iterdir()) == [".geocontact-files.json",
                                                         "fitted.json", "h.toml", "run"]
    assert written_by_us(tmp_path / "fitted.json")
    # the report recognises the cyclic-history run (and its FE run in fe/)
    assert main(["report", str(out)]) == 0
    html = (out / "report.html").read_text()
    assert "Cyclic history" in html and "FE run fe" in html
    assert (out / "figures" / "cycles_cycles_ratios.csv").exists()


@pytest.mark.parametrize(
    "extra, message",
    [
        (["--tolerance", "2"], "tolerance"),
        (["--fit-params", "x.json"], "--fit-params: needs --params"),
        (["--steps", "0"], "--steps"),
    ],
)
def test_cycles_command_bad_input(tmp_path, capsys, extra, message):
    from geocontact.cli import main

    history = tmp_path / "h.toml"
    history.write_text("[history]\nforces = [0, 300, 0]\n")
    code = main(["cycles", "--material", "reference", "--history", str(history), "--mesh",
                 "coarse", "--out", str(tmp_path / "o"), *extra])
    err = capsys.readouterr().err.strip()
    assert code == 2 and message in err and len(err.splitlines()) == 1


def test_cycles_command_refuses_open_history_and_foreign_params(tmp_path, capsys):
    from geocontact.cli import main

    history = tmp_path / "h.toml"
    history.write_text("[history]\nforces = [0, 300, 0, 300]\n")
    assert main(["cycles", "--material", "reference", "--history", str(history), "--out",
                 str(tmp_path / "o")]) == 2
    assert "must end at zero force" in capsys.readouterr().err
    history.write_text("[history]\nforces = [0, 300, 0]\n")
    weak = EXAMPLES / "params-illustrative-weak.json"
    assert main(["cycles", "--material", "reference", "--history", str(history), "--params",
                 str(weak), "--out", str(tmp_path / "o")]) == 2
    assert "params.material.compressive_yield_stress" in capsys.readouterr().err
    assert not (tmp_path / "o").exists()


def test_a_ratio_that_dips_below_the_tolerance_and_rises_has_no_critical_cycle():
    """A ratchet's onset (the weak grain with finite strain, docs/cycles.md): the residual
    increment ratio is below the tolerance at cycle 2 and above it from cycle 3. Neither the
    measured critical cycle (the ratio must stay below in every later cycle) nor the fitted
    one (a power law that grows, p < 0, or a geometric one with q > 1, never stays below) is
    cycle 2; a ratio that stays below keeps its first cycle."""
    from geocontact.calibrate.cyclic_fit import GeometricLaw, PowerLaw

    rising = [1.0, 6.6e-4, 1.1e-3, 1.2e-3, 1.25e-3, 1.26e-3]
    a = cf.analyse(synthetic(np.array(rising) * 1e-5, [1.0] + [2.6e-3] * 5), tolerance=1e-3)
    assert a.residual_fit.power < 0
    assert a.critical_cycles["measured"]["residual_increment"] is None
    assert a.critical_cycles["fitted"]["residual_increment"] is None
    assert a.critical_cycles["measured"]["elastic_shakedown"] is None
    # at a looser tolerance every later cycle is below it: cycle 2, measured and fitted
    loose = cf.analyse(synthetic(np.array(rising) * 1e-5, [1.0] + [2.6e-3] * 5),
                       tolerance=1e-2)
    assert loose.critical_cycles["measured"]["residual_increment"] == 2
    assert loose.critical_cycles["fitted"]["residual_increment"] is None  # it grows for ever
    fit = dict(cycles_used=[2, 3], cycles_excluded=[], rms_log10_error=0.0,
               max_relative_error=0.0)
    assert PowerLaw(7e-4, -0.3, power_standard_error=None, **fit).critical_cycle(1e-3) is None
    assert PowerLaw(7e-4, 0.0, power_standard_error=None, **fit).critical_cycle(1e-3) == 2
    assert PowerLaw(2e-3, 0.0, power_standard_error=None, **fit).critical_cycle(1e-3) is None
    assert GeometricLaw(5e-4, 1.1, **fit).critical_cycle(1e-3) is None
    assert GeometricLaw(5e-4, 1.0, **fit).critical_cycle(1e-3) == 2
