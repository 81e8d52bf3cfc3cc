"""scripts/check_calibrations.py: the comparison of regenerated calibrations with the shipped
ones, on small synthetic documents (the real rerun is the default-mesh FE campaign, minutes to
half an hour; docs/calibration.md)."""

import importlib.util
import json
import re
import shlex
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
_spec = importlib.util.spec_from_file_location("check_calibrations",
                                               ROOT / "scripts" / "check_calibrations.py")
check = importlib.util.module_from_spec(_spec)
sys.modules[_spec.name] = check  # dataclasses look their module up while the class is made
_spec.loader.exec_module(check)


def _document(**changes):
    """A small parameter document shaped like the shipped ones."""
    doc = {
        "schema": "geocontact.law/1",
        "loading": {"elastic_plastic_exponent": 1.4778985904580817,
                    "fully_plastic_approach_m": 6.543823265926041e-06},
        "residual_approach": {"limit": 0.948320701324462, "transition_depth": 0.999999999},
        "cyclic": {"enabled": True, "critical_cycle": 3},
        "fit_errors": {"per_level_energy": [
            {"peak_force_N": 5.51442617326556, "fe_loop_work_J": 7.067838776596281e-08,
             "second_cycle_residual_increment_ratio": 5.3e-14}]},
        "provenance": {"created_utc": "2026-11-21T23:34:22+00:00", "python": "3.11.7",
                       "geocontact_version": "0.1.0",
                       "fe": {"mesh": "default", "cache_keys": ["872bf1b6960d0dd090a9"],
                              "wall_time_s": [36.4]},
                       "inputs": {"cache": "out/cache/fem"}},
    }
    for path, value in changes.items():
        *parents, key = path.split(".")
        node = doc
        for p in parents:
            node = node[int(p)] if isinstance(node, list) else node[p]
        if isinstance(node, list):
            node[int(key)] = value
        else:
            node[key] = value
    return doc


def _mismatches(a, b, **kw):
    return [r.path for r in check.compare_documents(a, b, **kw) if r.status == "MISMATCH"]


def test_identical_documents_match():
    assert _mismatches(_document(), _document()) == []


def test_timestamps_wall_times_interpreter_and_cache_path_are_ignored():
    regenerated = _document(**{"provenance.created_utc": "2030-01-01T00:00:00+00:00",
                               "provenance.python": "3.12.1",
                               "provenance.fe.wall_time_s": [99.0, 1.0],
                               "provenance.inputs.cache": "/tmp/elsewhere"})
    rows = check.compare_documents(_document(), regenerated)
    assert not [r for r in rows if r.status == "MISMATCH"]
    assert {r.path for r in rows if r.status == "ignored"} == {
        "provenance.created_utc", "provenance.python", "provenance.fe.wall_time_s",
        "provenance.inputs.cache"}


def test_the_hashes_that_tie_a_calibration_to_its_acceptance_table_are_ignored():
    """Each file holds its own timestamp, so a rerun always changes the other's hash of it."""
    shipped = _document(**{"provenance.created_utc": "2026-01-01T00:00:00+00:00"})
    shipped["provenance"]["acceptance"] = {"sha256": "a" * 64, "file": "x.acceptance.json"}
    rerun = json.loads(json.dumps(shipped))
    rerun["provenance"]["acceptance"]["sha256"] = "b" * 64
    assert _mismatches(shipped, rerun) == []
    assert _mismatches({"params_sha256": "a" * 64}, {"params_sha256": "b" * 64}) == []
    rerun["provenance"]["acceptance"]["file"] = "y.acceptance.json"
    assert _mismatches(shipped, rerun) == ["provenance.acceptance.file"]


def test_a_fitted_number_off_by_more_than_the_tolerance_is_a_mismatch():
    exponent = 1.4778985904580817
    assert _mismatches(_document(), _document(
        **{"loading.elastic_plastic_exponent": exponent * (1 + 1e-4)})) == [
        "loading.elastic_plastic_exponent"]
    # within 1e-6 relative it passes, and the tolerance is the caller's
    slightly = _document(**{"loading.elastic_plastic_exponent": exponent * (1 + 5e-7)})
    assert _mismatches(_document(), slightly) == []
    assert _mismatches(_document(), slightly, rtol=1e-7) == ["loading.elastic_plastic_exponent"]
    # a dimensional number has no absolute floor, however small it is
    assert _mismatches(_document(), _document(
        **{"fit_errors.per_level_energy.0.fe_loop_work_J": 7.07e-08})) == [
        "fit_errors.per_level_energy[0].fe_loop_work_J"]


def test_round_off_sized_dimensionless_values_pass_within_the_absolute_floor():
    again = _document(**{
        "fit_errors.per_level_energy.0.second_cycle_residual_increment_ratio": -2.0e-13})
    assert _mismatches(_document(), again) == []
    again = _document(**{
        "fit_errors.per_level_energy.0.second_cycle_residual_increment_ratio": 1e-6})
    assert _mismatches(_document(), again) != []


@pytest.mark.parametrize("path, value", [
    ("cyclic.critical_cycle", 4),            # an integer must be equal
    ("cyclic.enabled", False),               # a boolean
    ("provenance.fe.mesh", "coarse"),        # a string
    ("residual_approach.transition_depth", None),
    ("residual_approach.limit", "0.948320701324462"),  # a type change
])
def test_other_values_must_be_equal(path, value):
    assert _mismatches(_document(), _document(**{path: value})) == [path]


def test_missing_or_extra_keys_and_list_lengths_are_mismatches():
    fewer = _document()
    del fewer["loading"]["fully_plastic_approach_m"]
    more = _document()
    more["loading"]["deep_plastic_exponent"] = 1.3
    longer = _document()
    longer["fit_errors"]["per_level_energy"].append({"peak_force_N": 17.7})
    assert _mismatches(_document(), fewer) == ["loading.fully_plastic_approach_m"]
    assert _mismatches(_document(), more) == ["loading.deep_plastic_exponent"]
    assert _mismatches(_document(), longer) == ["fit_errors.per_level_energy"]


def test_cache_keys_and_versions_are_reported_not_failed():
    rows = check.compare_documents(_document(), _document(**{
        "provenance.fe.cache_keys": ["0000"], "provenance.geocontact_version": "0.2.0"}))
    assert not [r for r in rows if r.status == "MISMATCH"]
    assert {r.path for r in rows if r.status == "info"} == {
        "provenance.fe.cache_keys", "provenance.geocontact_version"}


def test_a_contact_radius_only_a_rerun_knows_is_reported_not_failed():
    """A shipped file given its calibrated range from its own record lacks the contact radius
    when the FE summaries were not at hand (scripts/add_calibrated_range.py); a rerun has
    it. Any other difference of the block is a mismatch."""
    shipped = _document(calibrated_range={"max_depth": 249.0, "max_force_N": 6000.0})
    rerun = _document(calibrated_range={"max_depth": 249.0, "max_force_N": 6000.0,
                                        "contact_radius_ratio": 0.05})
    rows = check.compare_documents(shipped, rerun)
    assert [r.path for r in rows if r.status == "info"] == [
        "calibrated_range.contact_radius_ratio"]
    assert _mismatches(shipped, rerun) == []
    assert _mismatches(rerun, shipped) == ["calibrated_range.contact_radius_ratio"]
    deeper = _document(calibrated_range={"max_depth": 250.0, "max_force_N": 6000.0})
    assert _mismatches(shipped, deeper) == ["calibrated_range.max_depth"]


def _folder(tmp_path, name, **changes):
    folder = tmp_path / name
    folder.mkdir()
    for file in check.CALIBRATIONS:
        (folder / file).write_text(json.dumps(_document(**changes)))
    return folder


def test_cli_compare_only_exit_status_and_table(tmp_path, capsys):
    shipped = _folder(tmp_path, "shipped")
    same = _folder(tmp_path, "same", **{"provenance.created_utc": "2031-01-01T00:00:00+00:00"})
    assert check.main(["--examples", str(shipped), "--compare-only", str(same)]) == 0
    assert "all shipped calibrations regenerate" in capsys.readouterr().out
    off = _folder(tmp_path, "off", **{"residual_approach.limit": 0.95})
    assert check.main(["--examples", str(shipped), "--compare-only", str(off)]) == 1
    out = capsys.readouterr().out
    assert "| residual_approach.limit | 0.9483207013 | 0.95 |" in out and "MISMATCH" in out
    empty = tmp_path / "empty"
    empty.mkdir()
    assert check.main(["--examples", str(shipped), "--compare-only", str(empty)]) == 1
    assert "MISSING" in capsys.readouterr().out


def test_never_writes_into_the_shipped_folder(tmp_path, capsys):
    shipped = _folder(tmp_path, "shipped")
    before = {p.name: p.read_bytes() for p in shipped.iterdir()}
    for keep in (shipped, shipped / "sub"):
        assert check.main(["--examples", str(shipped), "--keep", str(keep)]) == 2
        assert "never overwritten" in capsys.readouterr().err
    assert {p.name: p.read_bytes() for p in shipped.iterdir()} == before
    assert check.main(["--rtol", "-1", "--compare-only", str(shipped)]) == 2


def test_reruns_what_the_makefile_calibrate_examples_target_runs():
    """The script's CALIBRATIONS are the Makefile's calibrate-examples commands (less
    ``--mesh $(CALIBRATE_MESH)``, --acceptance and --out, which the script sets itself, and
    --force: the script writes into a new temporary folder)."""
    makefile = (ROOT / "Makefile").read_text()
    recipe = re.search(r"^calibrate-examples:.*?\n((?:\t.*\n)+)", makefile, re.M).group(1)
    # the recipe's variables defined with := (a list too long for a line: $\ joins without a
    # space, as make does), but the mesh's, which the script sets itself
    defined = {name: " ".join(re.sub(r"\$\\\n\s*", "", value).replace("\\\n", " ").split())
               for name, value in re.findall(r"^(\w+) :=((?:.*\\\n)*.*)$", makefile, re.M)}
    recipe = re.sub(r"\$\((\w+)\)", lambda m: defined.get(m.group(1), m.group(0))
                    if m.group(1) not in ("VENV", "CALIBRATE_MESH") else m.group(0), recipe)
    commands = [shlex.split(line) for line in recipe.replace("\\\n", " ").splitlines()]
    found = {}
    for words in commands:
        assert words[1] == "calibrate", words
        args = words[2:]
        out = args[args.index("--out") + 1]
        rest, skip = [], False
        for word in args:
            if skip:
                skip = False
            elif word == "--out" or (word == "--mesh" and
                                     args[args.index(word) + 1] == "$(CALIBRATE_MESH)"):
                skip = True
            elif word not in ("--acceptance", "--force"):
                rest.append(word)
        found[Path(out).name] = rest
        assert Path(out).parent.name == "examples"
    assert found == check.CALIBRATIONS


def test_rerun_calls_calibrate_like_the_makefile_into_a_temporary_folder(tmp_path, monkeypatch,
                                                                         capsys):
    """The orchestration without the FE: ``geocontact calibrate`` is replaced by a stand-in that
    writes the document it is asked for; the outputs land in a temporary folder, are compared,
    and are gone afterwards."""
    import geocontact.cli

    shipped = _folder(tmp_path, "shipped")
    calls = []

    def calibrate(argv):
        calls.append(argv)
        out = Path(argv[argv.index("--out") + 1])
        out.write_text(json.dumps(_document(**{"provenance.created_utc": "now"})))
        return 0

    monkeypatch.setattr(geocontact.cli, "main", calibrate)
    cache = tmp_path / "cache"
    assert check.main(["--examples", str(shipped), "--cache", str(cache), "--mesh", "fine"]) == 0
    # the script's mesh and cache go to a calibration that names none; one that names its own
    # keeps them, its cache resolved in the repository
    expected = []
    for args in check.CALIBRATIONS.values():
        own = "--cache" in args
        args = [str(check.ROOT / a) if own and i and args[i - 1] == "--cache" else a
                for i, a in enumerate(args)]
        expected.append(["calibrate", *args, *([] if "--mesh" in args else ["--mesh", "fine"]),
                         *([] if own else ["--cache", str(cache)]), "--acceptance"])
    assert [c[:c.index("--out")] for c in calls] == expected
    assert [c[c.index("--mesh") + 1] for c in calls] == ["fine", "default", "default"]
    assert calls[1][calls[1].index("--cache") + 1] == str(
        check.ROOT / "datasets" / "fe-runs" / "weak-finite")
    assert calls[2][calls[2].index("--cache") + 1] == str(
        check.ROOT / "datasets" / "fe-runs" / "reference-deep")
    outs = [Path(c[c.index("--out") + 1]) for c in calls]
    assert all(not check._inside(o, shipped) and not o.exists() for o in outs)
    assert "no FE cache" in capsys.readouterr().err
    monkeypatch.setattr(geocontact.cli, "main", lambda argv: 1)
    assert check.main(["--examples", str(shipped), "--cache", str(cache)]) == 2
