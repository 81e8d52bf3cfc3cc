"""The law's command line and parameter files (docs/interfaces.md): round trips and one-line
errors."""

import json

import numpy as np
import pytest
from make_illustrative_params import illustrative_params

from geocontact.cli import main
from geocontact.grain.material import preset
from geocontact.law import Contact, LawParams, load_params

EXAMPLES = __import__("pathlib").Path(__file__).resolve().parents[1] / "examples"


def test_shipped_examples_are_regenerated_by_their_command():
    for name, material in (("params-illustrative.json", "reference"),
                           ("params-illustrative-weak.json", "reference-weak")):
        shipped = json.loads((EXAMPLES / name).read_text())
        fresh = illustrative_params(preset(material)).to_dict()
        assert json.loads(json.dumps(fresh)) == shipped
        assert "ILLUSTRATION" in shipped["label"]


def test_parameter_file_round_trip(tmp_path):
    params = load_params(EXAMPLES / "params-illustrative.json")
    params.save(tmp_path / "p.json")
    again = load_params(tmp_path / "p.json")
    assert again.to_dict() == params.to_dict()


def test_law_command_writes_forces(tmp_path, capsys):
    approach = np.concatenate([np.linspace(0, 3e-4, 50), np.linspace(3e-4, -1e-5, 50)])
    (tmp_path / "a.csv").write_text("approach_m\n" + "\n".join(map(repr, approach.tolist())) + "\n")
    code = main(["law", "--params", str(EXAMPLES / "params-illustrative.json"),
                 "--approach", str(tmp_path / "a.csv"), "--out", str(tmp_path / "f.csv"),
                 "--json"])
    assert code == 0
    summary = json.loads(capsys.readouterr().out)
    table = np.genfromtxt(tmp_path / "f.csv", delimiter=",", names=True, dtype=None,
                          encoding="utf-8")
    contact = Contact(load_params(EXAMPLES / "params-illustrative.json"))
    expected = [contact.update(a)[0] for a in approach]
    np.testing.assert_allclose(table["force_N"], expected, rtol=1e-15)
    assert summary["dissipated_energy_J"] > 0
    assert summary["residual_approach_m"] > 0
    assert summary["provenance"]["geocontact_version"]


@pytest.mark.parametrize(
    "content, message",
    [
        ("force\n1\n", "no column 'approach_m'"),
        ("approach_m\n1e-5\nabc\n", ":3: approach_m must be a number"),
        ("approach_m\n1e-5\nnan\n", "must be finite"),
        ("approach_m\n", "has no rows"),
    ],
)
def test_law_command_bad_approach_file(tmp_path, capsys, content, message):
    (tmp_path / "a.csv").write_text(content)
    code = main(["law", "--params", str(EXAMPLES / "params-illustrative.json"),
                 "--approach", str(tmp_path / "a.csv"), "--out", str(tmp_path / "f.csv")])
    err = capsys.readouterr().err
    assert code == 2
    assert message in err and err.count("\n") == 1
    assert not (tmp_path / "f.csv").exists()


@pytest.mark.parametrize(
    "edit, field",
    [
        (lambda d: d.update(schema="other/9"), "schema"),
        (lambda d: d["material"].update(poissons_ratio=0.5), "poissons_ratio"),
        (lambda d: d["material"].update(youngs_modulus=-1.0), "youngs_modulus"),
        (lambda d: d["material"].update(friction_angle_deg=75.0), "friction_angle_deg"),
        (lambda d: d["residual_approach"].update(limit=1.2), "residual_approach.limit"),
        # NaN is no JSON: refused before any field is read, at its place in the file, with the
        # message of the C++ reader (issue 39)
        (lambda d: d["unloading"].update(exponent_power=float("nan")), "params: malformed JSON"),
        (lambda d: d["unloading"].update(exponent_power=float("nan")), "NaN at line 1 column"),
        (lambda d: d["loading"].update(colour=1), "loading.colour: unknown key"),
        (lambda d: d["yield"].update(force_N=1.0), "yield.force_N"),
        (lambda d: d.pop("reloading"), "reloading: missing"),
        (lambda d: d["cyclic"]["residual_ratio"].update(coefficient=3.0, power=1.4),
         "cyclic.residual_ratio: the cycle-2 ratio"),
        (lambda d: d["cyclic"]["plastic_work_ratio"].update(coefficient=-0.1),
         "cyclic.plastic_work_ratio.coefficient"),
    ],
)
def test_bad_parameter_files_give_one_line_errors(tmp_path, capsys, edit, field):
    document = json.loads((EXAMPLES / "params-illustrative.json").read_text())
    edit(document)
    (tmp_path / "p.json").write_text(json.dumps(document))
    (tmp_path / "a.csv").write_text("approach_m\n0\n")
    code = main(["law", "--params", str(tmp_path / "p.json"),
                 "--approach", str(tmp_path / "a.csv"), "--out", str(tmp_path / "f.csv")])
    err = capsys.readouterr().err
    assert code == 2
    assert field in err and err.count("\n") == 1


def test_malformed_json_is_one_line_error(tmp_path, capsys):
    (tmp_path / "p.json").write_text("{ not json")
    (tmp_path / "a.csv").write_text("approach_m\n0\n")
    code = main(["law", "--params", str(tmp_path / "p.json"),
                 "--approach", str(tmp_path / "a.csv"), "--out", str(tmp_path / "f.csv")])
    assert code == 2
    assert "malformed JSON" in capsys.readouterr().err


def test_params_need_consistent_yield(tmp_path):
    params = load_params(EXAMPLES / "params-illustrative.json")
    assert isinstance(params, LawParams)
    assert params.yield_force == pytest.approx(2.7572, rel=1e-4)
