"""Force-controlled driver, the paper's history presets, and the demo end to end."""

import json

import numpy as np
import pytest

from geocontact.analyses.force_driven import drive_by_force
from geocontact.errors import InputError
from geocontact.grain.force_history import load_history, preset_history


def test_presets_match_the_paper():
    assert preset_history("repeated", 3000) == [0.0] + [3000.0, 0.0] * 10
    dec = preset_history("mono-decreasing", 3000)[1::2]
    np.testing.assert_allclose(dec, [3000, 2500, 2000, 1500, 1000, 500, 100])
    inc = preset_history("mono-increasing", 3000)[1::2]
    assert inc[0] == pytest.approx(100) and inc[-1] == pytest.approx(3000) and len(inc) == 7


def test_force_driver_hits_targets_and_accounts_cycles(params):
    fmax = 200 * params.yield_force
    run = drive_by_force(params, [0.0, fmax, 0.0, fmax, 0.0], points=20)
    assert run.force.max() == pytest.approx(fmax, rel=1e-9)
    assert len(run.cycles) == 2
    first, second = run.cycles
    assert first["residual_approach_m"] > 0
    assert first["plastic_work_J"] == pytest.approx(
        float(params.envelope_plastic_work(first["max_approach_m"])), rel=1e-6)
    # second cycle to the same force: closed reload-unload loop, smaller dissipation
    assert 0 <= second["plastic_work_J"] < first["plastic_work_J"]
    assert second["residual_approach_m"] == pytest.approx(first["residual_approach_m"])


@pytest.mark.parametrize(
    "text, message",
    [
        ("[history]\nforces = [0, -5]\n", "history.forces[1]"),
        ("[history]\nforces = [0, nan]\n", "history.forces[1]"),
        ("[history]\npreset = \"sawtooth\"\n", "history.preset"),
        ("[history]\npreset = \"repeated\"\npeak_force = -1\n", "history.peak_force"),
        ("[history]\nspeed = 1\n", "history.speed"),
        ("[oops\n", "malformed TOML"),
    ],
)
def test_bad_history_files(tmp_path, text, message):
    (tmp_path / "h.toml").write_text(text)
    with pytest.raises(InputError, match=message.replace("[", r"\[").replace("]", r"\]")):
        load_history(tmp_path / "h.toml")


def test_demo_writes_a_complete_report(tmp_path):
    """The whole pipeline on tiny loads (--quick): calibration with acceptance, FE, cycles,
    sweeps, law histories, seismic, report; nothing half-written left behind."""
    from geocontact.cli import main

    out = tmp_path / "demo"
    assert main(["demo", "--quick", "--out", str(out), "--cache", str(tmp_path / "cache")]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["cases"]["reference"]["yield"]["force_N"] == pytest.approx(2.757, rel=1e-3)
    assert summary["calibration"]["levels"] == 3
    assert summary["fe_reference"]["cycles"][0]["max_force_N"] == pytest.approx(100.0)
    assert summary["seismic"]["main_shock"]["record"]["pga_m_s2"] == pytest.approx(3.0)
    html = (out / "report.html").read_text()
    for heading in ("Incipient yield", "Law parameters calibration/P.json",
                    "Calibration acceptance", "Cyclic history", "FE run fe-reference",
                    "Influence of material properties", "Seismic run", "Quick mode",
                    "DEM cyclic simple shear dem-cyclic-shear"):
        assert heading in html
    assert html.count("data:image/png;base64") >= 15
    params = json.loads((out / "calibration" / "P.json").read_text())
    assert params["schema"] == "geocontact.law/1"
    assert params["provenance"]["inputs"]["levels"] == 3
    assert (out / "fe-reference" / "fields").is_dir()
    # the sample study's small version: the calibrated law beside its elastic law, both with a
    # small-strain modulus
    shear = summary["dem_cyclic_shear"]["runs"]
    assert [r["law"] for r in shear] == ["geocontact", "elastic"]
    assert all(r["Gmax_Pa"] > 0 for r in shear)
    # the instant route beside the FE calibration: the universal law of the same grain, no FE
    # run, follows the FE reference cycle as the calibrated law does (both within 3 % RMS)
    universal = json.loads((out / "calibration" / "P-universal.json").read_text())
    assert universal["provenance"]["universal"]["points"] == summary["universal_law"][
        "dataset_points"]
    for law in ("FE calibration", "universal law"):
        assert summary["universal_law"][law]["force_rms_percent"] < 3.0
    assert "Law parameters calibration/P-universal.json" in html
    assert sorted(p.name for p in tmp_path.iterdir()) == ["cache", "demo"]  # no temp dirs
