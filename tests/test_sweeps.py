"""Material sweeps: trend rules, statements checked with FE numbers, outputs."""

import json

import numpy as np
import pytest

from geocontact.analyses.sweeps import check_statement, load_sweeps, run_sweeps, trend
from geocontact.cli import main
from geocontact.errors import InputError


def test_trend_rules():
    assert trend([1.0, 2.0, 3.0], 0.1) == "increasing"
    assert trend([3.0, 2.0, 1.0], 0.1) == "decreasing"
    assert trend([1.0, 1.05, 1.02], 0.1) == "constant"
    assert trend([1.0, 2.0, 1.5], 0.1) == "non-monotone"
    st = {"text": "t", "quantity": "q", "trend": "varies"}
    assert check_statement(st, [1.0, 1.5], 0.1)["agrees"]
    assert not check_statement(st, [1.0, 1.01], 0.1)["agrees"]


def test_definitions_cover_the_papers_sweeps():
    d = load_sweeps()
    assert set(d["sweep"]) == {"E", "beta", "sigma_c", "m"}
    e = d["sweep"]["E"]["values"]
    assert min(e) == 1e9 and max(e) == 100e9
    assert all(v < np.degrees(np.arctan(3.0)) for v in d["sweep"]["beta"]["values"])


def test_hardening_sweep_on_fe(tmp_path):
    """m at a small peak (coarse): Fy does not depend on m, plasticity falls as m grows."""
    summary = run_sweeps(tmp_path / "sw", ["m"], mesh="coarse", peak_force=60.0,
                         cache_dir=tmp_path / "cache", workers=1, progress=False)
    entry = summary["sweeps"]["m"]
    res = [p["residual_ratio"] for p in entry["points"]]
    assert np.all(np.diff(res) < 0)  # less residual approach with hardening
    verdicts = {(s["quantity"], s["expected"]): s for s in entry["statements"]}
    assert verdicts[("peak_over_yield", "constant")]["agrees"]
    assert verdicts[("peak_over_yield", "constant")]["spread"] == pytest.approx(0.0, abs=1e-12)
    on_disk = json.loads((tmp_path / "sw" / "summary.json").read_text())
    assert on_disk["schema"] == "geocontact.sweeps/1"
    assert on_disk["provenance"]["inputs"]["peak_force_N"] == 60.0
    assert (tmp_path / "sw" / "curves_m.csv").read_text().startswith("approach_over_max@0")
    assert main(["report", str(tmp_path / "sw")]) == 0
    html = (tmp_path / "sw" / "report.html").read_text()
    assert "Influence of material properties" in html and "sweep_m.csv" in html


def test_bad_sweep_input(tmp_path, capsys):
    with pytest.raises(InputError, match="unknown sweep"):
        run_sweeps(tmp_path / "x", ["nu"], progress=False)
    assert main(["sweep", "--sweeps", "E", "--peak-force", "-5", "--out", str(tmp_path / "y")]) == 2
    assert "--peak-force" in capsys.readouterr().err  # the command's flag for peak_force
