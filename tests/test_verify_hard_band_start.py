"""scripts/verify_hard_band_start.py end to end on a tiny case (the weak grain to 0.05 N, coarse
mesh, a few seconds of FE): the later mesh is coarser at the tip, the comparison reads the runs'
own curves, and the result file holds both runs and the comparison."""

import importlib.util
import json
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
_spec = importlib.util.spec_from_file_location(
    "verify_hard_band_start", ROOT / "scripts" / "verify_hard_band_start.py")
script = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(script)


def test_late_mesh_compared_with_the_fully_resolved_run(tmp_path, capsys):
    out = tmp_path / "hb.json"
    assert script.main(["--material", "reference-weak", "--force", "0.05", "--late", "4e-4",
                        "--resolved", "1", "--json", str(out)]) == 0
    doc = json.loads(out.read_text())
    full, late = doc["runs"]
    (row,) = doc["comparison"]
    assert late["a_min_over_R"] == 4e-4 and full["a_min_over_R"] is None
    assert late["elements"] < full["elements"]
    assert row["steps_compared"] > 0
    # the comparison is the late run's loading against the full run's, at the same approach
    d0, f0, _ = script.loading(full)
    d1, f1, a1 = script.loading(late)
    keep = a1 >= 4e-4 * 0.1
    ref = np.interp(d1[keep], d0, f0)
    assert row["largest_force_difference"] == pytest.approx(max(abs((f1[keep] - ref) / ref)),
                                                            rel=1e-12)
    assert row["max_approach_ratio"] == late["max_approach_m"] / full["max_approach_m"]
    assert "a_min = 0.0004 R" in capsys.readouterr().out
    assert doc["provenance"]["inputs"]["json"] == str(out)
