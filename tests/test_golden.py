"""The golden vectors checked by the C++ law (plugins/lammps/tests/golden.json) are what
`python scripts/make_golden_vectors.py` writes today: regenerate them, never edit them."""

import json
import math
from pathlib import Path

from make_golden_vectors import DEFAULT_PARAMS, generate

from geocontact.law import load_params

GOLDEN = Path(__file__).resolve().parents[1] / "plugins" / "lammps" / "tests" / "golden.json"


# numpy's and libm's last bits differ between CPUs (SIMD code paths chosen at run time): the
# same generator wrote vectors 1.5e-13 apart on two machines. Any change of the law moves them
# by far more than this.
ROUNDING = 1e-12


def _differences(committed, fresh, where="golden"):
    """Where two JSON documents differ: structure, strings, integers and booleans exactly,
    floats beyond ROUNDING (relative)."""
    if isinstance(committed, dict) and isinstance(fresh, dict):
        if committed.keys() != fresh.keys():
            return [f"{where}: keys {sorted(committed)} != {sorted(fresh)}"]
        return [d for k in committed for d in _differences(committed[k], fresh[k],
                                                            f"{where}.{k}")]
    if isinstance(committed, list) and isinstance(fresh, list):
        if len(committed) != len(fresh):
            return [f"{where}: {len(committed)} entries != {len(fresh)}"]
        return [d for i, (a, b) in enumerate(zip(committed, fresh, strict=True))
                for d in _differences(a, b, f"{where}[{i}]")]
    if isinstance(committed, float) and isinstance(fresh, float):
        if math.isclose(committed, fresh, rel_tol=ROUNDING, abs_tol=0.0):
            return []
    elif type(committed) is type(fresh) and committed == fresh:
        return []
    return [f"{where}: {committed!r} != {fresh!r}"]


def test_committed_golden_vectors_match_the_python_reference():
    fresh = json.loads(json.dumps(generate(load_params(DEFAULT_PARAMS))))
    committed = json.loads(GOLDEN.read_text())
    differences = _differences(committed, fresh)
    assert not differences, (
        f"golden vectors are stale ({len(differences)} differences, first: {differences[0]}): "
        "run python scripts/make_golden_vectors.py --out plugins/lammps/tests/golden.json")


def test_the_staleness_check_sees_a_change_of_the_law_but_not_rounding():
    committed = json.loads(GOLDEN.read_text())
    case = committed["cases"][0]
    rounded = json.loads(json.dumps(committed))
    rounded["cases"][0]["forces"] = [f * (1 + 1e-14) for f in case["forces"]]
    assert _differences(committed, rounded) == []
    changed = json.loads(json.dumps(committed))
    peak = max(range(len(case["forces"])), key=case["forces"].__getitem__)
    changed["cases"][0]["forces"][peak] = case["forces"][peak] * (1 + 1e-9)
    assert len(_differences(committed, changed)) == 1
    changed = json.loads(json.dumps(committed))
    changed["cases"][0]["branches"][0] += 1
    assert len(_differences(committed, changed)) == 1


def test_golden_vectors_cover_every_branch_and_every_parameter_variant():
    golden = json.loads(GOLDEN.read_text())
    assert len(golden["cases"]) >= 200
    branches = {b for case in golden["cases"] for b in case["branches"]}
    assert branches == {0, 1, 2, 3, 4}  # apart, virgin, unloading, reloading, ratchet
    assert {case["params"] for case in golden["cases"]} == {"cyclic_on", "cyclic_off",
                                                            "transition", "deep", "shakedown",
                                                            "table", "segments"}
    # the shakedown form: its histories reload from zero force after the first cycle (k_N)
    assert golden["params"]["shakedown"]["cyclic"]["form"] == "shakedown"
    assert any(3 in c["branches"] and c["final_state"]["cycles"] >= 3.0
               for c in golden["cases"] if c["params"] == "shakedown")
    # the transition variant really exercises the residual form with x0 != 1
    assert golden["params"]["transition"]["residual_approach"]["transition_depth"] != 1.0
    # the deep variant: a third loading regime that the histories reach, and log power b != 1
    deep = golden["params"]["deep"]
    assert deep["residual_approach"]["log_power"] != 1.0
    dq = deep["loading"]["deep_plastic_approach_ratio"] * deep["yield"]["approach_m"]
    assert any(max(c["approaches"]) > dq for c in golden["cases"] if c["params"] == "deep")
    # the table variant: a residual table, its histories leaving the curve below its first
    # knot, between knots and beyond its last (both straight-line ends of the spline)
    table = golden["params"]["table"]
    knots = table["residual_approach"]["table"]["depth"]
    assert set(table["residual_approach"]) == {"table"} and len(knots) >= 3
    depths = [c["final_state"]["max_approach"] / table["yield"]["approach_m"]
              for c in golden["cases"] if c["params"] == "table"]
    assert any(1.0 < x < knots[0] for x in depths) and max(depths) > knots[-1]
    assert any(knots[0] < x < knots[-1] for x in depths)


def test_golden_vectors_through_the_compiled_binding():
    """The same vectors replayed through geocontact.law.ContactArrays (the C++ header via the
    binding, all histories of a parameter variant as one array of contacts), with the ctest's
    tolerance. Histories are right-aligned: the steps before a shorter one starts hold its
    contact at approach 0, which leaves an untouched contact exactly as it was."""
    import numpy as np

    from geocontact.law import ContactArrays, LawParams

    tolerance = 1e-11  # as plugins/lammps/tests/test_golden.cpp
    golden = json.loads(GOLDEN.read_text())
    checked = 0
    for variant, doc in golden["params"].items():
        cases = [c for c in golden["cases"] if c["params"] == variant]
        params = LawParams.from_dict(doc)
        steps = max(len(c["approaches"]) for c in cases)
        path = np.zeros((steps, len(cases)))
        for j, c in enumerate(cases):
            path[steps - len(c["approaches"]):, j] = c["approaches"]
        arrays = ContactArrays(params, len(cases), threads=2)
        forces, stiffnesses, branches = (np.empty((steps, len(cases))) for _ in range(3))
        for s in range(steps):
            f, k = arrays.step(path[s])
            # the branch view, not `state`: reading the state would bring the virgin contacts'
            # envelopes up to date at every step, and the replay is of the lazy step alone
            forces[s], stiffnesses[s], branches[s] = f, k, arrays.branch
        state = arrays.state.as_dict()  # the envelopes brought up to date
        for j, c in enumerate(cases):
            start = steps - len(c["approaches"])
            scale_f = max(max(map(abs, c["forces"])), 1e-300)
            scale_k = max(max(map(abs, c["stiffnesses"])), 1e-300)
            scale_d = max(max(map(abs, c["approaches"])), 1e-300)
            assert np.all(np.abs(forces[start:, j] - c["forces"]) <= tolerance * scale_f), c["name"]
            assert np.all(np.abs(stiffnesses[start:, j] - c["stiffnesses"])
                          <= tolerance * scale_k), c["name"]
            assert branches[start:, j].tolist() == c["branches"], c["name"]
            final = c["final_state"]
            scales = {"approach": scale_d, "force": scale_f, "max_approach": scale_d,
                      "max_force": scale_f, "residual_approach": scale_d,
                      "unloading_exponent": 1.0, "reloading_exponent": 1.0,
                      "branch_value": max(1.0, abs(final["branch_value"])),
                      "ratchet_shift": scale_d, "pending_ratchet": scale_d,
                      "cycles": max(1.0, final["cycles"]), "work": scale_f * scale_d}
            for key, scale in scales.items():
                assert abs(state[key][j] - final[key]) <= tolerance * scale, (c["name"], key)
            assert state["branch"][j] == final["branch"], c["name"]
            for key, values in (("elastic_energy", arrays.elastic_energy),
                                ("dissipated_energy", arrays.dissipated_energy)):
                assert abs(values[j] - c[key]) <= tolerance * scale_f * scale_d, (c["name"], key)
            checked += 1
    assert checked == len(golden["cases"])
    # the segments variant: the virgin curve as segments, every segment reached by some history
    segments = golden["params"]["segments"]
    starts = segments["loading"]["segments"]["depth"]
    assert set(segments["loading"]) == {"segments"} and len(starts) >= 4
    reached = [max(c["approaches"]) / segments["yield"]["approach_m"]
               for c in golden["cases"] if c["params"] == "segments"]
    assert max(reached) > starts[-1]
    for a, b in zip(starts[:-1], starts[1:], strict=True):
        assert any(a < x < b for x in reached), (a, b)
