"""``geocontact report DIR``: results recognised, figures embedded, data beside them."""

import json
import shutil
from pathlib import Path

import numpy as np

from geocontact.cli import main
from geocontact.fem.run import run_history
from geocontact.grain.material import load_material

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def test_report_of_fe_run_and_law_file(tmp_path, capsys):
    run_history(load_material("reference"), [0.0, 30.0, 0.0], steps_per_segment=4,
                out=tmp_path / "run" / "fe", write_fields=False)
    shutil.copy(EXAMPLES / "params-illustrative.json", tmp_path / "run" / "P.json")
    assert main(["report", str(tmp_path / "run")]) == 0
    html = (tmp_path / "run" / "report.html").read_text()
    assert "FE run fe" in html and "Law parameters P.json" in html
    assert html.count("data:image/png;base64,") == 4
    for name in ("fe_force_approach", "fe_energy", "P_cycles", "P_residual_work"):
        assert (tmp_path / "run" / "figures" / f"{name}.csv").stat().st_size > 100
    assert "figures/fe_force_approach.csv" in html
    assert "Values below the run&#x27;s resolution" in html  # and what it is, per kind
    assert "report:" in capsys.readouterr().out


def test_report_bad_directory(tmp_path, capsys):
    assert main(["report", str(tmp_path / "missing")]) == 2
    assert "not a directory" in capsys.readouterr().err
    (tmp_path / "empty").mkdir()
    assert main(["report", str(tmp_path / "empty")]) == 2
    assert "no geocontact results" in capsys.readouterr().err
    bad = tmp_path / "bad"
    bad.mkdir()
    (bad / "summary.json").write_text("{not json")
    assert main(["report", str(bad)]) == 2
    assert "malformed JSON" in capsys.readouterr().err
    assert not (bad / "report.html").exists()


def test_report_of_a_calibration_shows_its_acceptance(tmp_path):
    for name in ("params-reference.json", "params-reference.acceptance.json"):
        shutil.copy(EXAMPLES / name, tmp_path / name)
    shutil.copytree(EXAMPLES / "params-reference.acceptance",
                    tmp_path / "params-reference.acceptance")
    assert main(["report", str(tmp_path)]) == 0
    html = (tmp_path / "report.html").read_text()
    assert "Calibration acceptance (params-reference.json)" in html
    assert "held-out-peak-low" in html
    # every FE-vs-law figure of the acceptance folder is embedded, each with its CSV named
    runs = json.loads((tmp_path / "params-reference.acceptance.json").read_text())["runs"]
    assert html.count("data:image/png;base64,") == 2 + len(runs)
    assert all(f"params-reference.acceptance/{r['name']}.csv" in html for r in runs)


def _figure_columns(path: Path) -> dict[str, np.ndarray]:
    """Every column of a figure's CSV (ragged: short columns end in blanks)."""
    rows = path.read_text().splitlines()
    names = rows[0].split(",")
    cells = [r.split(",") for r in rows[1:]]
    return {n: np.array([float(c[i]) for c in cells if i < len(c) and c[i]])
            for i, n in enumerate(names)}


def test_law_figure_is_fit_for_log_axes(tmp_path):
    """The log-log law figure: only positive points (nothing drawn through zero), and below
    delta_y the loading curve is Hertz's, of local log-slope 3/2 (not a chord from zero)."""
    shutil.copy(EXAMPLES / "params-reference.json", tmp_path / "P.json")
    assert main(["report", str(tmp_path)]) == 0
    data = _figure_columns(tmp_path / "figures" / "P_cycles.csv")
    assert any(name.startswith("unloading_") for name in data)
    for name, values in data.items():
        assert values.size > 50 and np.all(values > 0), name
    depths = [n.removeprefix("loading_approach_over_dy_") for n in data
              if n.startswith("loading_approach_over_dy_")]
    assert depths
    for depth in depths:
        x = data[f"loading_approach_over_dy_{depth}"]
        y = data[f"loading_force_over_fy_{depth}"]
        assert x.min() <= 1.001e-3
        elastic = x < 1.0
        slope = np.diff(np.log(y[elastic])) / np.diff(np.log(x[elastic]))
        assert np.max(np.abs(slope - 1.5)) < 1e-3, depth


def test_report_of_law_files_with_segments_and_a_table(tmp_path):
    """A law file with loading segments lists every segment, one with a residual table its
    knots' range, instead of the closed forms' numbers."""
    corpus = Path(__file__).resolve().parent / "data" / "bad-law-params"
    run = tmp_path / "run"
    run.mkdir()
    shutil.copy(corpus / "base-segments.json", run / "P.json")
    shutil.copy(corpus / "base-table.json", run / "Q.json")
    assert main(["report", str(run)]) == 0
    html = (run / "report.html").read_text()
    segments = json.loads((run / "P.json").read_text())["loading"]["segments"]
    assert html.count("from δ/δy = ") == len(segments["depth"])
    assert f"n = {segments['exponent'][-1]:.4g} from δ/δy = {segments['depth'][-1]:.4g}" in html
    assert "table of 5 knots" in html
