"""The golden vectors checked by the C++ law (plugins/lammps/tests/golden.json) are exactly what
`python -m geocontact.law.golden` writes today: regenerate them, never edit them."""

import json
from pathlib import Path

from geocontact.law import load_params
from geocontact.law.golden import DEFAULT_PARAMS, generate

GOLDEN = Path(__file__).resolve().parents[1] / "plugins" / "lammps" / "tests" / "golden.json"


def test_committed_golden_vectors_match_the_python_reference():
    fresh = json.loads(json.dumps(generate(load_params(DEFAULT_PARAMS))))
    committed = json.loads(GOLDEN.read_text())
    assert committed == fresh, (
        "golden vectors are stale: run python -m geocontact.law.golden "
        "--out plugins/lammps/tests/golden.json")


def test_golden_vectors_cover_every_branch_and_every_parameter_variant():
    golden = json.loads(GOLDEN.read_text())
    assert len(golden["cases"]) >= 200
    branches = {b for case in golden["cases"] for b in case["branches"]}
    assert branches == {0, 1, 2, 3, 4}  # apart, virgin, unloading, reloading, ratchet
    assert {case["params"] for case in golden["cases"]} == {"cyclic_on", "cyclic_off",
                                                            "transition", "deep"}
    # the transition variant really exercises the residual form with x0 != 1
    assert golden["params"]["transition"]["residual_approach"]["transition_depth"] != 1.0
    # the deep variant: a third loading regime that the histories reach, and log power b != 1
    deep = golden["params"]["deep"]
    assert deep["residual_approach"]["log_power"] != 1.0
    dq = deep["loading"]["deep_plastic_approach_ratio"] * deep["yield"]["approach_m"]
    assert any(max(c["approaches"]) > dq for c in golden["cases"] if c["params"] == "deep")
