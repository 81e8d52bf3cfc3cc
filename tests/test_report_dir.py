"""``geocontact report DIR``: results recognised, figures embedded, data beside them."""

import shutil
from pathlib import Path

from geocontact.cli import main
from geocontact.fem.run import run_history
from geocontact.material import load_material

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
