"""Bad input that used to give a traceback or a silent wrong answer (issue 16): each is now a
one-line ``error: ...`` naming the field and its allowed range, exit code 2."""

from __future__ import annotations

import contextlib
import json
import math
import os
import tempfile
from pathlib import Path

import numpy as np
import pytest

from geocontact import preset
from geocontact.cli import main
from geocontact.errors import InputError
from geocontact.grain.force_history import load_history
from geocontact.law import load_params

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
PARAMS = EXAMPLES / "params-illustrative.json"


def one_line_error(capsys, *fields: str) -> str:
    err = capsys.readouterr().err
    assert err.startswith("error: ") and err.count("\n") == 1, err
    for field in fields:
        assert field in err, err
    return err


@pytest.fixture
def approach_csv(tmp_path):
    path = tmp_path / "a.csv"
    path.write_text("approach_m\n0\n1e-4\n0\n")
    return path


def test_law_out_naming_an_existing_folder(tmp_path, approach_csv, capsys):
    # used to compute the law, then fail in os.replace with IsADirectoryError (a traceback)
    folder = tmp_path / "results"
    folder.mkdir()
    (folder / "keep.txt").write_text("mine")
    code = main(["law", "--params", str(PARAMS), "--approach", str(approach_csv),
                 "--out", str(folder)])
    assert code == 2
    one_line_error(capsys, "--out", "existing folder", "expected a file name")
    assert sorted(p.name for p in folder.iterdir()) == ["keep.txt"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.csv", "results"]


def test_law_out_below_a_file(tmp_path, approach_csv, capsys):
    code = main(["law", "--params", str(PARAMS), "--approach", str(approach_csv),
                 "--out", str(approach_csv / "f.csv")])
    assert code == 2
    one_line_error(capsys, "--out", "is a file")


@pytest.mark.parametrize("key", ["provenance", "fit_errors"])
@pytest.mark.parametrize("value", [["fe", "v1"], [["mesh", "coarse"]], "calibrated", 3, None])
def test_provenance_and_fit_errors_must_be_json_objects(tmp_path, approach_csv, capsys, key,
                                                        value):
    # a string or a list raised ValueError/TypeError from dict(); a list of pairs was silently
    # turned into an object
    doc = json.loads(PARAMS.read_text())
    doc[key] = value
    (tmp_path / "p.json").write_text(json.dumps(doc))
    code = main(["law", "--params", str(tmp_path / "p.json"), "--approach", str(approach_csv),
                 "--out", str(tmp_path / "f.csv")])
    assert code == 2
    one_line_error(capsys, f"{key}: must be a JSON object")
    assert not (tmp_path / "f.csv").exists()


def test_label_must_be_a_string(tmp_path):
    doc = json.loads(PARAMS.read_text())
    doc["label"] = {"name": "x"}
    (tmp_path / "p.json").write_text(json.dumps(doc))
    with pytest.raises(InputError, match="label: must be a string"):
        load_params(tmp_path / "p.json")


@pytest.mark.parametrize("text, field", [
    ('preset = "repeated"\npeak_force = true', "history.peak_force: expected a number"),
    ('preset = "repeated"\npeak_force = inf', "history.peak_force: must be a finite number"),
    ('preset = "repeated"\npeak_force = 1' + "0" * 400, "history.peak_force: must be a finite"),
    ("forces = [0, true, 0]", "history.forces[1]: expected a number"),
    ("forces = [0, 3000, 0]\npeak_force = 100.0", "history.peak_force: only with preset"),
])
def test_history_numbers(tmp_path, text, field):
    # peak_force = true read as 1 N, inf as an infinite load, and a peak_force beside forces
    # was silently ignored
    (tmp_path / "h.toml").write_text(f"[history]\n{text}\n")
    with pytest.raises(InputError, match=field.replace("[", r"\[").replace("]", r"\]")):
        load_history(tmp_path / "h.toml")


MATERIAL_TOML = """[material]
youngs_modulus = {E}
poissons_ratio = 0.25
compressive_yield_stress = 10e6
friction_angle_deg = 30.0
hardening_ratio = 0.0
[geometry]
radius = 0.1
"""


@pytest.mark.parametrize("value, message", [
    ("true", "youngs_modulus: expected a number"),
    ("1" + "0" * 400, "youngs_modulus: must be a finite number"),  # was OverflowError
])
def test_material_numbers(tmp_path, capsys, value, message):
    (tmp_path / "m.toml").write_text(MATERIAL_TOML.format(E=value))
    assert main(["yield", "--material", str(tmp_path / "m.toml")]) == 2
    one_line_error(capsys, message)


@pytest.mark.parametrize("value", [True, 10**400])
def test_parameter_file_numbers(tmp_path, value):
    doc = json.loads(PARAMS.read_text())
    doc["residual_approach"]["limit"] = value
    (tmp_path / "p.json").write_text(json.dumps(doc))
    with pytest.raises(InputError, match="residual_approach.limit"):
        load_params(tmp_path / "p.json")


@pytest.mark.parametrize("argv, fields", [
    (["fem", "--material", "reference", "--history", "H", "--out", "o", "--steps", "10001"],
     ["--steps", "[1, 10000]"]),
    (["cycles", "--material", "reference", "--history", "H", "--out", "o", "--steps", "0"],
     ["--steps", "[1, 10000]"]),
    (["calibrate", "--material", "reference", "--out", "P.json", "--levels", "51"],
     ["--levels", "[3, 50]"]),
    (["calibrate", "--material", "reference", "--out", "P.json", "--workers", "100000"],
     ["--workers", "[1, 256]"]),
    (["calibrate", "--material", "reference", "--out", "P.json", "--peak-forces",
      ",".join(str(1000 + 10 * k) for k in range(60))], ["--peak-forces", "3 to 50"]),
    (["sweep", "--out", "o", "--workers", "0"], ["--workers", "[1, 256]"]),
    (["seismic", "R.csv", "--params", str(PARAMS), "--out", "o", "--column", "101"],
     ["--column", "[1, 100]"]),
])
def test_counts_have_upper_bounds(tmp_path, monkeypatch, capsys, argv, fields):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "H").write_text('[history]\nforces = [0, 100, 0]\n')
    assert main(argv) == 2
    one_line_error(capsys, *fields)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["H"]


def test_bad_arguments_are_one_line_too(capsys):
    # argparse printed its usage (several lines) before the error
    assert main(["fem", "--material", "reference", "--history", "H", "--out", "o",
                 "--steps", "many"]) == 2
    one_line_error(capsys, "--steps", "invalid int value")
    assert main(["no-such-command"]) == 2
    one_line_error(capsys, "invalid choice")


# --- sweeps ---------------------------------------------------------------------------------
def test_sweep_named_twice_is_run_once(tmp_path, monkeypatch):
    """--sweeps E,E listed every point twice: the stiffness trend read as non-monotone and the
    paper's statements as disagreements."""
    import geocontact.analyses.sweeps as sweeps
    from geocontact.fem.result import FemResult
    from geocontact.grain.hertz import hertz_coefficient

    def fake_campaign(jobs, cache_dir, **_):
        results = []
        for job in jobs:  # a Hertz-like single cycle: stiffer with E, same Fmax/Fy shape
            fmax = max(job.forces)
            dmax = (fmax / hertz_coefficient(job.material)) ** (2.0 / 3.0)
            force = np.array([0.0, fmax, 0.0])
            approach = np.array([0.0, dmax, 0.3 * dmax])
            results.append(FemResult(
                curve={"force_N": force, "approach_m": approach,
                       "work_J": np.array([0.0, 0.4 * fmax * dmax, 0.2 * fmax * dmax])},
                summary={"cycles": [{"max_force_N": fmax, "max_approach_m": dmax,
                                     "residual_approach_m": 0.3 * dmax,
                                     "plastic_work_J": 0.2 * fmax * dmax}],
                         "wall_time_s": 0.0}))
        return results

    monkeypatch.setattr(sweeps, "run_campaign", fake_campaign)
    summary = sweeps.run_sweeps(tmp_path / "sw", ["E", "E"], progress=False)
    entry = summary["sweeps"]["E"]
    assert len(entry["points"]) == len(sweeps.load_sweeps()["sweep"]["E"]["values"])
    verdict = {s["quantity"]: s for s in entry["statements"]}
    assert verdict["secant_stiffness"]["found"] == "increasing"
    assert verdict["secant_stiffness"]["agrees"]


def test_sweep_definition_with_a_repeated_point_is_rejected():
    from geocontact.analyses.sweeps import load_sweeps

    text = ('base = "reference"\npeak_force = 6000.0\nconstant_tolerance = 0.1\n'
            '[sweep.E]\nparameter = "youngs_modulus"\nlabel = "E"\nscale = 1e-9\n'
            'values = [1e9, 2e9, 2e9, 5e9]\n')
    with pytest.raises(InputError, match="sweep E: values must be .* strictly increasing"):
        load_sweeps(text)


# --- seismic time step ----------------------------------------------------------------------
def chain_spectral_radius(spheres: int, dt: float, zeta: float, mass=1.0, k=1.0) -> float:
    """Amplification of one step of Column.run's scheme on the column linearised at tangent k
    (state x, v, a; dashpots 2 zeta sqrt(m_eff k), m_eff = m/2, m at the base)."""
    t = 2.0 * np.eye(spheres) - np.eye(spheres, k=1) - np.eye(spheres, k=-1)
    t[0, 0] = 1.0
    damping = 2.0 * zeta * math.sqrt(0.5 * mass * k) * t
    damping[-1, -1] += 2.0 * zeta * math.sqrt(mass * k) * (1.0 - math.sqrt(0.5))
    n = spheres
    step = np.zeros((3 * n, 3 * n))
    for j in range(3 * n):
        e = np.zeros(3 * n)
        e[j] = 1.0
        x, v, a = e[:n], e[n:2 * n], e[2 * n:]
        x1 = x + dt * v + 0.5 * dt * dt * a
        v_half = v + 0.5 * dt * a
        a1 = -(k * t @ x1 + damping @ v_half) / mass
        step[:, j] = np.concatenate([x1, v_half + 0.5 * dt * a1, a1])
    return float(np.max(np.abs(np.linalg.eigvals(step))))


@pytest.mark.parametrize("spheres", [1, 2, 5, 12])
def test_critical_time_step_is_the_linearised_columns_stability_limit(spheres):
    from geocontact.analyses.seismic.column import critical_time_step

    dt = critical_time_step(1.0, 1.0, spheres)
    assert chain_spectral_radius(spheres, 0.999 * dt, 0.0) <= 1.0 + 1e-9
    assert chain_spectral_radius(spheres, 1.001 * dt, 0.0) > 1.0 + 1e-6
    assert 1.0 <= dt <= 2.0 + 1e-12  # between sqrt(m/k) (long columns) and 2 sqrt(m/k)
    for zeta in (0.05, 0.5):  # with damping: a safe (lower) bound of the limit
        damped = critical_time_step(1.0, 1.0, spheres, zeta)
        assert damped < dt
        assert chain_spectral_radius(spheres, 0.999 * damped, zeta) <= 1.0 + 1e-9


def test_column_rejects_a_time_step_above_the_stability_limit():
    from make_illustrative_params import illustrative_params

    from geocontact.analyses.seismic.column import Column, ColumnModel, law_contacts

    params = illustrative_params(preset("reference"))
    model = ColumnModel(5, params.material.radius, 2650.0)
    column = Column(model, law_contacts(params))
    limit = column.dt / 0.2 * math.sin(9 * math.pi / 22) ** -1  # safety 0.2 of sqrt(m/k)
    Column(model, law_contacts(params), time_step=0.99 * limit)
    with pytest.raises(InputError, match=r"time_step: must be in \(0, .*\] s, the stability"):
        Column(model, law_contacts(params), time_step=1.01 * limit)
    with pytest.raises(InputError, match="time_step_safety"):  # strong damping: dt shrinks
        Column(ColumnModel(5, params.material.radius, 2650.0, damping_ratio=20.0),
               law_contacts(params))


def test_seismic_time_step_above_the_limit_is_a_one_line_error(tmp_path, capsys):
    pytest.importorskip("eqsig")
    t = np.arange(201) * 0.01
    acc = 0.3 * np.exp(-(((t - 0.5) / 0.25) ** 2)) * np.cos(2 * np.pi * 3.0 * t)
    record = tmp_path / "rec.csv"
    record.write_text("time_s,acceleration_g\n" + "".join(f"{a:.4f},{b:.8g}\n"
                                                           for a, b in zip(t, acc, strict=True)))
    code = main(["seismic", str(record), "--params", str(PARAMS), "--out", str(tmp_path / "o"),
                 "--time-step", "0.01", "--no-figures"])
    assert code == 2
    one_line_error(capsys, "--time-step", "stability limit")
    assert not (tmp_path / "o").exists()


# --- the generators' command lines ------------------------------------------------------------
@pytest.mark.parametrize("module", ["make_golden_vectors", "make_illustrative_params"])
def test_generators_report_bad_input_in_one_line(tmp_path, capsys, module):
    import importlib

    generator = importlib.import_module(module)  # scripts/ (tests/conftest.py)
    (tmp_path / "bad.json").write_text("{not json")
    (tmp_path / "bad.toml").write_text(MATERIAL_TOML.format(E="true"))
    option = ["--params", str(tmp_path / "bad.json")] if module == "make_golden_vectors" else [
        "--material", str(tmp_path / "bad.toml")]
    assert generator.main([*option, "--out", str(tmp_path / "out.json")]) == 2
    one_line_error(capsys, "params: malformed JSON" if module == "make_golden_vectors"
                   else "youngs_modulus")
    assert generator.main(["--out", str(tmp_path / "out.json"), "--bogus"]) == 2
    one_line_error(capsys, "unrecognized arguments")
    assert not (tmp_path / "out.json").exists()


@pytest.mark.parametrize("module", ["make_bad_law_documents", "universal_report",
                                    "verify_universal", "verify_envelope_control",
                                    "verify_backtracking", "verify_hard_band_start"])
def test_scripts_report_a_bad_flag_in_one_line(capsys, module):
    """Their parsers raise InputError, so they parse inside run_reporting_errors: a bad or
    missing flag is one line and exit code 2, never a traceback."""
    import importlib

    script = importlib.import_module(module)  # scripts/ (tests/conftest.py)
    assert script.main(["--bogus"]) == 2
    one_line_error(capsys, "--")


def test_verify_hard_band_start_refuses_bad_values_before_any_fe(tmp_path, capsys):
    import verify_hard_band_start as script  # scripts/ (tests/conftest.py)

    for flags, message in ((["--late", "0.2"], "--late: each a_min / R must be in [1e-05, 0.05]"),
                           (["--resolved", "0.5"], "--resolved: must be in [1, 100]"),
                           (["--point", "64"], "--point: must be a design point in [0, 63]"),
                           (["--force", "1e12"], "--force")):
        assert script.main(flags) == 2
        one_line_error(capsys, message)
    mine = tmp_path / "mine.json"
    mine.write_text("{}")
    assert script.main(["--force", "1e-9", "--json", str(mine)]) == 2
    one_line_error(capsys, "--json")
    assert mine.read_text() == "{}"


def test_verify_backtracking_refuses_bad_values_and_a_folder_it_did_not_make(tmp_path, capsys):
    """Out-of-range flags are one line each; --out is replaced only when the script's mark is in
    it, so a user's folder is never removed."""
    import verify_backtracking as script  # scripts/ (tests/conftest.py)

    for flags, message in ((["--point", "64"], "--point: must be a design point 0-63"),
                           (["--seconds", "1"], "--seconds: must be in [30, 86400]"),
                           (["--gain", "0"], "--gain: must be in (0, 100]")):
        assert script.main(flags) == 2
        one_line_error(capsys, message)
    mine = tmp_path / "results"
    mine.mkdir()
    (mine / "keep.txt").write_text("a user's file")
    assert script.main(["--out", str(mine)]) == 2
    one_line_error(capsys, "--out:", "was not made by this script")
    assert (mine / "keep.txt").read_text() == "a user's file"
    assert script.main(["--out", str(mine), "--logs-only"]) == 2
    one_line_error(capsys, "--logs-only:")


def test_golden_per_family_bounds(tmp_path, capsys):
    import make_golden_vectors as golden

    assert golden.main(["--out", str(tmp_path / "g.json"), "--per-family", "0"]) == 2
    # at least one history per parameter variant
    one_line_error(capsys, "--per-family", f"[{len(golden.VARIANTS)}, 10000]")


# --- found by tests/test_fuzz_cli.py ------------------------------------------------------------
@pytest.mark.parametrize("value, message", [
    ("5e-324", "youngs_modulus: must be in [1000, 1e+13] Pa"),  # NaN yield force, warnings
    ("1e20", "youngs_modulus: must be in [1000, 1e+13] Pa"),
])
def test_material_magnitudes(tmp_path, capsys, value, message):
    (tmp_path / "m.toml").write_text(MATERIAL_TOML.format(E=value))
    assert main(["yield", "--material", str(tmp_path / "m.toml")]) == 2
    one_line_error(capsys, message)


def test_yield_strain_and_radius_ranges():
    base = preset("reference")
    with pytest.raises(InputError, match=r"compressive_yield_stress: must be in \[100, 1e\+16\]"):
        base.with_(compressive_yield_stress=5e16)
    with pytest.raises(InputError, match=r"compressive_yield_stress: must be in \[100, 1e\+16\]"):
        base.with_(compressive_yield_stress=50.0)
    # an effectively elastic grain (the reference run against Hertz) is admitted
    assert base.with_(compressive_yield_stress=1e15).compressive_yield_stress == 1e15
    with pytest.raises(InputError, match=r"radius: must be in \[1e-09, 1000\] m"):
        base.with_(radius=1e-300)


def test_forces_beyond_what_the_fe_mesh_resolves(tmp_path, capsys):
    # --max-force 1.8e308 overflowed in the geometric peak series (a numpy warning)
    assert main(["calibrate", "--material", "reference", "--out", str(tmp_path / "P.json"),
                 "--max-force", "1.7976931348622103e+308"]) == 2
    one_line_error(capsys, "--max-force: must be <= 1.778e+07 N",
                   "Hertz contact radius exceeds 0.5 R")
    (tmp_path / "h.toml").write_text("[history]\nforces = [0, 1e9, 0]\n")
    assert main(["fem", "--material", "reference", "--history", str(tmp_path / "h.toml"),
                 "--out", str(tmp_path / "run")]) == 2
    one_line_error(capsys, "history.forces: must be <= 1.778e+07 N")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["h.toml"]


def test_seismic_density_range():
    from geocontact.analyses.seismic.column import ColumnModel

    # 1e-300 kg/m^3 ended in a ConvergenceError of the static column (exit 1)
    with pytest.raises(InputError, match=r"density: must be in \[1, 100000\] kg/m\^3"):
        ColumnModel(5, 0.1, 1e-300)


@pytest.mark.parametrize("name, text, option", [
    ("p.json", "[" * 100000 + "]" * 100000, "params"),
    ("m.toml", "a = " + "[" * 100000 + "]" * 100000, "material"),
    ("h.toml", "a = " + "[" * 100000 + "]" * 100000, "history"),
])
def test_deeply_nested_files(tmp_path, approach_csv, capsys, name, text, option):
    # json/tomllib raise RecursionError (a traceback) on a file nested this deep
    (tmp_path / name).write_text(text)
    argv = {"params": ["law", "--params", str(tmp_path / name), "--approach", str(approach_csv),
                       "--out", str(tmp_path / "f.csv")],
            "material": ["yield", "--material", str(tmp_path / name)],
            "history": ["fem", "--material", "reference", "--history", str(tmp_path / name),
                        "--out", str(tmp_path / "run")]}[option]
    assert main(argv) == 2
    one_line_error(capsys, f"{option}: malformed", "nested too deeply")


def test_law_approach_beyond_the_radius(tmp_path, capsys):
    # 1e308 gave force inf and dissipated energy NaN, exit 0
    (tmp_path / "a.csv").write_text("approach_m\n0\n1e308\n")
    assert main(["law", "--params", str(PARAMS), "--approach", str(tmp_path / "a.csv"),
                 "--out", str(tmp_path / "f.csv")]) == 2
    one_line_error(capsys, "approach_m: must be <= the sphere radius 0.1 m", "value 2")
    assert not (tmp_path / "f.csv").exists()


def test_other_output_files_naming_a_folder(tmp_path, capsys):
    import make_golden_vectors as golden
    import make_illustrative_params as illustrative

    folder = tmp_path / "existing"
    folder.mkdir()
    assert illustrative.main(["--out", str(folder)]) == 2
    one_line_error(capsys, "--out", "existing folder")
    assert golden.main(["--out", str(folder)]) == 2
    one_line_error(capsys, "--out", "existing folder")
    (tmp_path / "h.toml").write_text("[history]\nforces = [0, 300, 0]\n")
    assert main(["cycles", "--material", "reference", "--history", str(tmp_path / "h.toml"),
                 "--params", str(PARAMS), "--fit-params", str(folder),
                 "--out", str(tmp_path / "run")]) == 2
    one_line_error(capsys, "--fit-params", "existing folder")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["existing", "h.toml"]


def test_seismic_aftershock_count(tmp_path, capsys):
    assert main(["seismic", "R.csv", "--params", str(PARAMS), "--out", str(tmp_path / "o"),
                 "--aftershock", *["R.csv"] * 21]) == 2
    one_line_error(capsys, "--aftershock: at most 20 records")


def test_column_refuses_a_run_of_too_many_steps():
    from make_illustrative_params import illustrative_params

    from geocontact.analyses.seismic.column import Column, ColumnModel, law_contacts

    params = illustrative_params(preset("reference"))
    column = Column(ColumnModel(2, params.material.radius, 2650.0), law_contacts(params),
                    safety=1e-9)  # np.arange of ~1e13 steps: MemoryError
    with pytest.raises(InputError, match="time_step: .* steps for 40 s .*at most 1e\\+08"):
        column.steps_for(40.0)


def test_library_errors_name_parameters_and_the_command_line_names_flags(tmp_path, capsys):
    """The API's errors speak of its parameters (max_force, scheduler, overwrite=True); the
    command line shows the same error with its flags (--max-force, --scheduler, --force)."""
    from geocontact.calibrate.campaign import peak_forces
    from geocontact.errors import for_the_command_line
    from geocontact.files import check_replaceable

    with pytest.raises(InputError, match=r"^max_force: ") as caught:
        peak_forces(preset("reference"), max_force=-1.0)
    assert for_the_command_line(str(caught.value)).startswith("--max-force: ")
    user = tmp_path / "mine"
    user.mkdir()
    (user / "notes.txt").write_text("x")
    with pytest.raises(InputError, match=r"^out: .*pass overwrite=True$") as caught:
        check_replaceable(user, "fem")
    assert "--" not in str(caught.value)
    shown = for_the_command_line(str(caught.value))
    assert shown.startswith("--out: ") and shown.endswith("pass --force")


# --- the corpus of bad inputs and faults (issue 39) ---------------------------------------------
# Every command is replayed against each class of fault below; each case expects exit 2 and ONE
# line naming the option (or the documented refusal), never a traceback, and the user's files
# as they were. The expensive work is stubbed (conftest.no_work): a case that got past the
# checks would raise Reached instead of running. Add the new command's cases when a command
# is added.
CURVE = EXAMPLES / "tests" / "platens-quartzite.csv"
HISTORY = "[history]\nforces = [0, 100, 0, 100, 0, 100, 0]\n"


def command_line(tmp: Path, command: str, out: Path | None = None) -> list[str]:
    """A valid command line of ``command`` writing to ``out`` (its default beside ``tmp``)."""
    (tmp / "h.toml").write_text(HISTORY)
    (tmp / "a.csv").write_text("approach_m\n0\n1e-4\n0\n")
    o = str(out) if out is not None else None
    lines = {
        "calibrate": ["calibrate", "--material", "reference", "--mesh", "coarse", "--cache",
                      str(tmp / "cache"), "--out", o or str(tmp / "P.json")],
        "fit": ["fit", str(CURVE), "--setup", "platens", "--radius", "4e-3", "--out",
                o or str(tmp / "P.json")],
        "law": ["law", "--params", str(PARAMS), "--approach", str(tmp / "a.csv"), "--out",
                o or str(tmp / "F.csv")],
        "params": ["params", "--material", "reference", "--out", o or str(tmp / "P.json")],
        "cycles": ["cycles", "--material", "reference", "--history", str(tmp / "h.toml"),
                   "--mesh", "coarse", "--out", o or str(tmp / "run")],
        "fem": ["fem", "--material", "reference", "--history", str(tmp / "h.toml"), "--mesh",
                "coarse", "--out", o or str(tmp / "run")],
        "sweep": ["sweep", "--cache", str(tmp / "cache"), "--out", o or str(tmp / "run")],
        "seismic": ["seismic", "KOBE/NIS000", "--params", str(PARAMS), "--no-figures", "--out",
                    o or str(tmp / "run")],
        "demo": ["demo", "--quick", "--cache", str(tmp / "cache"), "--out",
                 o or str(tmp / "run")],
        "dem": ["dem", "oedometer", "--law", str(PARAMS), "--out", o or str(tmp / "run")],
        "dem seismic": ["dem", "seismic", "KOBE/NIS000", "--law", str(PARAMS), "--out",
                        o or str(tmp / "run")],
        "study paper-histories": ["study", "paper-histories", "--mesh", "coarse", "--cache",
                                  str(tmp / "cache"), "--out", o or str(tmp / "run")],
        "study similarity": ["study", "similarity", "--from-data", "--out",
                             o or str(tmp / "run")],
        "study dem-oedometer": ["study", "dem-oedometer", "--law", str(PARAMS), "--out",
                                o or str(tmp / "run")],
        "study shakedown": ["study", "shakedown", "--work", str(tmp / "work"), "--json",
                            o or str(tmp / "shakedown.json")],
    }
    return lines[command]


def refused(capsys, argv: list[str], *fields: str) -> str:
    """Run ``argv``: exit 2, one line naming ``fields``, no traceback, the work never reached."""
    from conftest import Reached

    capsys.readouterr()
    try:
        code = main(argv)
    except Reached:
        pytest.fail(f"{argv}: got past its checks to the work")
    assert code == 2, capsys.readouterr()
    return one_line_error(capsys, *fields)


# class 1: a file or folder of the user's at every output --------------------------------------
# (command, the output's name relative to tmp, what the user has there, extra argv, the option)
USER_OUTPUTS = [
    ("calibrate", "P.json", "file", [], "--out"),
    ("calibrate", "P.acceptance.json", "file", ["--acceptance"], "--out"),
    ("calibrate", "P.acceptance", "folder", ["--acceptance"], "--out"),
    ("fit", "P.json", "file", [], "--out"),
    ("fit", "P.fit", "folder", [], "--out"),
    ("law", "F.csv", "file", [], "--out"),
    ("law", "F.csv.meta.json", "file", [], "--out"),
    ("params", "P.json", "file", [], "--out"),
    ("cycles", "fit.json", "file", ["--params", str(PARAMS), "--fit-params", "{tmp}/fit.json"],
     "--fit-params"),
    ("cycles", "run", "folder", [], "--out"),
    ("cycles", "run", "file", [], "--out"),
    ("fem", "run", "folder", [], "--out"),
    ("fem", "run", "file", [], "--out"),
    ("sweep", "run", "folder", [], "--out"),
    ("seismic", "run", "folder", [], "--out"),
    ("demo", "run", "folder", [], "--out"),
    ("dem", "run", "folder", [], "--out"),
    ("dem seismic", "run", "folder", [], "--out"),
    ("study paper-histories", "run", "folder", [], "--out"),
    ("study similarity", "run", "folder", [], "--out"),
    ("study dem-oedometer", "run", "folder", [], "--out"),
    ("study shakedown", "shakedown.json", "file", [], "--json"),
]


@pytest.mark.parametrize("command, name, kind, extra, field", USER_OUTPUTS,
                         ids=[f"{c[0]}:{c[1]}:{c[2]}" for c in USER_OUTPUTS])
def test_corpus_a_users_file_at_every_output(tmp_path, capsys, no_work, command, name, kind,
                                             extra, field):
    mine = tmp_path / name
    if kind == "folder":
        mine.mkdir()
        (mine / "notes.txt").write_text("months of work\n")
    else:
        mine.write_text('{"my": "notes"}\n')
    argv = command_line(tmp_path, command) + [a.format(tmp=tmp_path) for a in extra]
    refused(capsys, argv, field, str(mine))
    if kind == "folder":
        assert (mine / "notes.txt").read_text() == "months of work\n"
        assert sorted(p.name for p in mine.iterdir()) == ["notes.txt"]
    else:
        assert mine.read_text() == '{"my": "notes"}\n'
    assert not list(tmp_path.glob(".*.lock"))


def test_report_keeps_a_users_report(tmp_path, capsys):
    run = tmp_path / "run"
    run.mkdir()
    (run / "P.json").write_text(PARAMS.read_text())
    (run / "report.html").write_text("<p>mine</p>")
    refused(capsys, ["report", str(run)], "report", "was not written by geocontact")
    assert (run / "report.html").read_text() == "<p>mine</p>"


def test_a_file_geocontact_wrote_is_replaced_and_a_changed_one_is_not(tmp_path, capsys):
    argv = command_line(tmp_path, "law")
    assert main(argv) == 0 and main(argv) == 0  # its own file: replaced
    out = tmp_path / "F.csv"
    out.write_text(out.read_text() + "# my remark\n")
    refused(capsys, argv, "--out", "changed since")
    assert out.read_text().endswith("# my remark\n")
    assert main(argv + ["--force"]) == 0
    assert "# my remark" not in out.read_text()


# class 2: unwritable destinations ---------------------------------------------------------------
@pytest.fixture
def unwritable(tmp_path):
    """A folder nothing can be written in: read-only by its mode, or (root ignores modes) a
    folder of /proc."""
    if os.geteuid() != 0:
        folder = tmp_path / "read-only"
        folder.mkdir()
        folder.chmod(0o555)
        yield folder
        folder.chmod(0o755)
    elif Path("/proc/self").is_dir():
        yield Path("/proc/self")
    else:
        pytest.skip("no folder is unwritable for root here")


UNWRITABLE = ["calibrate", "fit", "law", "params", "cycles", "fem", "sweep", "seismic", "demo",
              "dem", "dem seismic", "study paper-histories", "study similarity",
              "study dem-oedometer", "study shakedown"]
FIELD = {"study shakedown": "--json"}  # the option naming the output, where not --out


@pytest.mark.parametrize("command", UNWRITABLE)
def test_corpus_unwritable_destination(tmp_path, capsys, no_work, unwritable, command):
    name = "P.json" if command in ("calibrate", "fit", "params", "study shakedown") else (
        "F.csv" if command == "law" else "run")
    refused(capsys, command_line(tmp_path, command, unwritable / name),
            FIELD.get(command, "--out"), f"cannot write in {unwritable}")


@pytest.mark.parametrize("command", ["law", "fem"])
def test_corpus_destination_below_something_not_a_folder(tmp_path, capsys, no_work, command):
    (tmp_path / "plain").write_text("x")
    refused(capsys, command_line(tmp_path, command, tmp_path / "plain" / "sub" / "out"),
            "--out", str(tmp_path / "plain"))


def test_corpus_uncreatable_folder(tmp_path, capsys, no_work):
    if not Path("/sys").is_dir() or os.access("/sys", os.W_OK) and os.geteuid() != 0:
        pytest.skip("no /sys")
    refused(capsys, command_line(tmp_path, "fem", Path("/sys/geocontact-test/run")), "--out",
            "cannot")


# class 3: wrong kinds of path -------------------------------------------------------------------
def wrong_kinds(tmp: Path) -> list[tuple[list[str], list[str]]]:
    folder, plain = tmp / "folder", tmp / "plain.csv"
    folder.mkdir(exist_ok=True)
    plain.write_text("x\n")
    law = command_line(tmp, "law")
    return [
        (["law", "--params", str(PARAMS), "--approach", str(folder), "--out",
          str(tmp / "F.csv")], ["approach_m", "is a directory"]),
        (["law", "--params", str(folder), "--approach", str(tmp / "a.csv"), "--out",
          str(tmp / "F.csv")], ["params", "is a directory"]),
        (law[:-1] + [str(folder)], ["--out", "existing folder"]),
        (command_line(tmp, "calibrate")[:5] + ["--cache", str(plain), "--out",
                                               str(tmp / "P.json")], ["--cache", "is a file"]),
        (["sweep", "--cache", str(plain), "--out", str(tmp / "run")], ["--cache", "is a file"]),
        (["demo", "--cache", str(plain), "--out", str(tmp / "run")], ["--cache", "is a file"]),
        (command_line(tmp, "fit") + ["--cache", str(plain)], ["--cache", "is a file"]),
        (["fit", str(folder), "--setup", "platens", "--radius", "4e-3", "--out",
          str(tmp / "P.json")], ["curve", "is not a file"]),
        (["yield", "--material", str(folder)], ["material", "is a directory"]),
        (["fem", "--material", "reference", "--history", str(folder), "--out",
          str(tmp / "run")], ["history", "is a directory"]),
        (["seismic", str(folder), "--params", str(PARAMS), "--out", str(tmp / "run")],
         ["record", "is a directory"]),
        (["cycles", "--material", "reference", "--history", str(tmp / "h.toml"), "--params",
          str(folder), "--out", str(tmp / "run")], ["params", "is a directory"]),
        (["dem", "oedometer", "--law", str(folder), "--out", str(tmp / "run")],
         ["--law", "is a directory"]),
        (["report", str(plain)], ["DIR", "not a directory"]),
        (["params", "--material", "reference", "--out", str(folder)],
         ["--out", "expected a .json file name"]),
        (command_line(tmp, "cycles") + ["--params", str(PARAMS), "--fit-params", str(folder)],
         ["--fit-params", "existing folder"]),
    ]


WRONG_KINDS = len(wrong_kinds(Path(tempfile.mkdtemp(prefix="geocontact-kinds-"))))


@pytest.mark.parametrize("case", range(WRONG_KINDS))
def test_corpus_wrong_kind_of_path(tmp_path, capsys, no_work, case):
    argv, fields = wrong_kinds(tmp_path)[case]
    refused(capsys, argv, *fields)


# class 4: bounds on every numeric option ----------------------------------------------------------
# (command, extra argv, words of the one line)
BOUNDS = [
    ("fem", ["--steps", "0"], ["--steps", "[1, 10000]"]),
    ("fem", ["--max-step-ratio", "0.5"], ["max_step_ratio"]),
    ("fem", ["--resolve-from", "0.2"], ["resolve_from", "[1e-05, 0.05]"]),
    ("cycles", ["--resolve-from", "1e-7"], ["resolve_from", "[1e-05, 0.05]"]),
    ("calibrate", ["--resolve-from", "nan"], ["resolve_from", "[1e-05, 0.05]"]),
    ("cycles", ["--tolerance", "-1"], ["--tolerance"]),
    ("cycles", ["--steps", "10001"], ["--steps"]),
    ("calibrate", ["--levels", "2"], ["--levels"]),
    ("calibrate", ["--max-force", "-1"], ["--max-force"]),
    ("calibrate", ["--max-force", "1e9"], ["--max-force", "exceeds 0.5 R"]),
    ("calibrate", ["--workers", "0"], ["--workers"]),
    ("calibrate", ["--peak-forces", "100,-5,300"], ["--peak-forces"]),
    ("calibrate", ["--mesh-force", "100"], ["--mesh-force", "at least the highest peak, 6000 N"]),
    ("calibrate", ["--peak-forces", "10,500", "--mesh-force", "400"],
     ["--mesh-force", "at least the highest peak, 500 N"]),
    ("calibrate", ["--mesh-force", "nan"], ["--mesh-force"]),
    ("calibrate", ["--mesh-force", "1e9"], ["--mesh-force", "exceeds 0.5 R"]),
    ("sweep", ["--peak-force", "-1"], ["--peak-force"]),
    ("sweep", ["--workers", "257"], ["--workers"]),
    ("law", ["--radius", "0"], ["--radius"]),
    ("law", ["--radius", "1e9"], ["--radius"]),
    ("fit", ["--radius", "0"], ["--radius"]),
    ("fit", ["--bootstrap", "-1"], ["--bootstrap"]),
    ("fit", ["--poissons-ratio", "0.6"], ["--poissons-ratio"]),
    ("fit", ["--friction-angle", "100"], ["--friction-angle"]),
    ("fit", ["--hardening-ratio", "-1"], ["--hardening-ratio"]),
    ("fit", ["--machine-stiffness", "-1"], ["--machine-stiffness"]),
    ("seismic", ["--pga", "1e6"], ["--pga", "sphere radius"]),
    ("seismic", ["--pga", "0"], ["--pga"]),
    ("seismic", ["--aftershock", "KOBE/NIS090@1e7"], ["--pga", "sphere radius"]),
    ("seismic", ["--surcharge", "1e12"], ["--surcharge", "sphere radius"]),
    ("seismic", ["--surcharge", "-1"], ["--surcharge"]),
    ("seismic", ["--column", "0"], ["--column"]),
    ("seismic", ["--density", "0"], ["--density"]),
    ("seismic", ["--damping", "-1"], ["--damping"]),
    ("seismic", ["--gap", "-1"], ["--gap"]),
    ("seismic", ["--output-interval", "0"], ["--output-interval"]),
    ("seismic", ["--time-step-safety", "0"], ["--time-step-safety"]),
    ("seismic", ["--time-step", "10"], ["--time-step"]),
    ("dem", ["--grains", "0"], ["--grains", "[50, "]),
    ("dem", ["--ranks", "0"], ["--ranks"]),
    ("dem", ["--stress", "-1"], ["--stress"]),
    ("dem", ["--radius", "0"], ["--radius"]),
    ("dem", ["--spread", "-1"], ["--spread"]),
    ("dem", ["--inertia", "0"], ["--inertia"]),
    ("dem", ["--seeds", "0"], ["--seeds", "[1, 20]"]),
    ("dem", ["--seeds", "21"], ["--seeds", "[1, 20]"]),
    ("dem", ["--seeds", "3", "--seed", "2147483645"], ["--seed", "at most"]),
    ("dem seismic", ["--grains", "0"], ["--grains"]),
    ("dem seismic", ["--strain", "0"], ["--strain"]),
    ("dem seismic", ["--decimate", "0"], ["--decimate"]),
]


@pytest.mark.parametrize("command, extra, fields", BOUNDS,
                         ids=[f"{c[0]}{' '.join(c[1])}" for c in BOUNDS])
def test_corpus_numeric_bounds(tmp_path, capsys, no_work, command, extra, fields):
    refused(capsys, command_line(tmp_path, command) + extra, *fields)
    assert not (tmp_path / "run").exists() and not (tmp_path / "P.json").exists()
    assert not list(tmp_path.glob(".*.lock"))


def test_corpus_history_preset_needs_its_peak_force(tmp_path, capsys, no_work):
    argv = command_line(tmp_path, "fem")
    (tmp_path / "h.toml").write_text('[history]\npreset = "repeated"\n')  # was 3000 N
    refused(capsys, argv, "history.peak_force: missing")


def test_corpus_fit_params_with_too_few_cycles_fails_before_the_fe(tmp_path, capsys, no_work):
    argv = command_line(tmp_path, "cycles") + ["--params", str(PARAMS), "--fit-params",
                                               str(tmp_path / "fit.json")]
    (tmp_path / "h.toml").write_text("[history]\nforces = [0, 100, 0, 100, 0]\n")
    refused(capsys, argv, "--fit-params", "2 load-unload cycles", "at least 3")


# class 5: concurrent runs ----------------------------------------------------------------------
@contextlib.contextmanager
def running(path: Path):
    """Hold ``path``'s lock as a run in progress does (a lock of its own open file: the
    command's attempt conflicts with it even in this process)."""
    from geocontact.files import _acquire, _release

    fd = _acquire(path, "test")
    try:
        yield
    finally:
        _release(path, fd)


CONCURRENT = ["calibrate", "fit", "law", "params", "cycles", "fem", "sweep", "seismic", "demo",
              "dem", "dem seismic", "report", "study paper-histories", "study similarity",
              "study dem-oedometer", "study shakedown"]


@pytest.mark.parametrize("command", CONCURRENT)
def test_corpus_a_second_run_on_one_destination_is_refused(tmp_path, capsys, no_work, command):
    if command == "report":
        (tmp_path / "run").mkdir()
        argv = ["report", str(tmp_path / "run")]
    else:
        argv = command_line(tmp_path, command)
    out = Path(argv[1] if command == "report" else argv[-1])
    with running(out):
        refused(capsys, argv, "DIR" if command == "report" else FIELD.get(command, "--out"),
                "being written by another geocontact run", f"PID {os.getpid()}")


def test_a_killed_runs_lock_does_not_stay(tmp_path, capsys):
    """A run killed with SIGKILL holds its lock no more (the system drops it): the next run
    proceeds, and the lock file's stale PID does not matter."""
    import signal
    import subprocess
    import sys
    import time

    out = tmp_path / "F.csv"
    holder = subprocess.Popen([sys.executable, "-c", (
        "import sys, time\nfrom geocontact.files import Output, claim\n"
        f"with claim([Output({str(out)!r})], 'law'):\n"
        "    print('held', flush=True)\n    time.sleep(60)\n")], stdout=subprocess.PIPE, text=True)
    try:
        assert holder.stdout.readline().strip() == "held"
        argv = command_line(tmp_path, "law")
        refused(capsys, argv, "--out", f"PID {holder.pid}")
        holder.send_signal(signal.SIGKILL)
        holder.wait(timeout=10)
        deadline = time.monotonic() + 5.0
        while main(argv) != 0:  # the kernel releases the lock with the process
            assert time.monotonic() < deadline, capsys.readouterr().err
            time.sleep(0.05)
    finally:
        holder.kill()
        holder.wait()
    assert out.is_file() and not list(tmp_path.glob(".*.lock"))


# class 6: edited results --------------------------------------------------------------------------
EDITED = [("fem", "fem", "run", "--out"), ("cycles", "cycles", "run", "--out"),
          ("sweep", "sweep", "run", "--out"), ("seismic", "seismic", "run", "--out"),
          ("demo", "demo", "run", "--out"), ("dem", "dem", "run", "--out"),
          ("dem seismic", "dem", "run", "--out"), ("fit", "fit", "P.fit", "--out"),
          ("calibrate", "calibrate", "P.acceptance", "--out"),
          ("study paper-histories", "paper-histories", "run", "--out"),
          ("study similarity", "geocontact study similarity", "run", "--out"),
          ("study dem-oedometer", "dem-study", "run", "--out")]


@pytest.mark.parametrize("command, manifest_command, name, field", EDITED,
                         ids=[e[0] for e in EDITED])
def test_corpus_an_edited_result_is_the_users(tmp_path, capsys, no_work, command,
                                              manifest_command, name, field):
    from geocontact.files import atomic_directory

    with atomic_directory(tmp_path / name, manifest_command) as work:
        (work / "summary.json").write_text('{"steps": 3}\n')
    (tmp_path / name / "summary.json").write_text('{"steps": 3, "my": "correction"}\n')
    extra = ["--acceptance"] if command == "calibrate" else []
    refused(capsys, command_line(tmp_path, command) + extra, field, "changed since")
    assert "correction" in (tmp_path / name / "summary.json").read_text()


@pytest.mark.parametrize("command", ["params", "calibrate", "fit"])
def test_corpus_an_edited_parameter_file_is_the_users(tmp_path, capsys, no_work, command):
    from geocontact.files import record_written

    out = tmp_path / "P.json"
    out.write_text(PARAMS.read_text())
    record_written([out], command)  # as if the command wrote it
    out.write_text(PARAMS.read_text().replace('"label"', '"label" ', 1))
    refused(capsys, command_line(tmp_path, command), "--out", "changed since")


def test_force_takes_an_edited_result(tmp_path, capsys, no_work):
    from conftest import Reached

    from geocontact.files import atomic_directory

    with atomic_directory(tmp_path / "run", "fem") as work:
        (work / "summary.json").write_text("{}\n")
    (tmp_path / "run" / "summary.json").write_text('{"edited": 1}\n')
    with pytest.raises(Reached):  # past every check, to the FE mesh
        main(command_line(tmp_path, "fem") + ["--force"])


# --- smaller mismatches ------------------------------------------------------------------------
def test_shipped_presets_are_material_templates(tmp_path, capsys):
    from importlib import resources

    template = resources.files("geocontact") / "data" / "presets" / "reference.toml"
    (tmp_path / "m.toml").write_text(template.read_text())
    assert main(["yield", "--material", str(tmp_path / "m.toml"), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["force_N"] == pytest.approx(2.75721, rel=1e-5)
    (tmp_path / "m.toml").write_text("note = 3\n" + template.read_text())
    assert main(["yield", "--material", str(tmp_path / "m.toml")]) == 2
    err = one_line_error(capsys, "note: unknown key")
    assert "section" not in err


def test_yield_names_the_materials_radius_not_a_flag(tmp_path, capsys):
    (tmp_path / "m.toml").write_text(MATERIAL_TOML.format(E="10e9").replace("0.1", "1e9"))
    assert main(["yield", "--material", str(tmp_path / "m.toml")]) == 2
    err = one_line_error(capsys, "radius: must be in")
    assert "--radius" not in err
    assert main(["law", "--params", str(PARAMS), "--approach", "a.csv", "--out",
                 str(tmp_path / "F.csv"), "--radius", "0"]) == 2
    one_line_error(capsys, "--radius: must be in")  # law has the flag


def test_report_and_demo_take_json(tmp_path, capsys, monkeypatch):
    run = tmp_path / "run"
    run.mkdir()
    (run / "P.json").write_text(PARAMS.read_text())
    assert main(["report", str(run), "--json"]) == 0
    document = json.loads(capsys.readouterr().out)
    assert document["report"] == str(run / "report.html") and document["figure_files"]
    import geocontact.cli.demo as demo

    def fake_demo(out, progress, *, quick, cache_dir, overwrite):
        from geocontact.files import atomic_directory

        with atomic_directory(out, "demo", overwrite=overwrite) as work:
            (work / "summary.json").write_text('{"cases": {}}\n')
        return Path(out) / "report.html"

    monkeypatch.setattr(demo, "run_demo", fake_demo)
    assert main(["demo", "--quick", "--out", str(tmp_path / "demo"), "--json"]) == 0
    assert json.loads(capsys.readouterr().out) == {
        "report": str(tmp_path / "demo" / "report.html"), "cases": {}}


def test_corpus_counts():
    """The corpus by class (the issue's closing note): grows with every new command."""
    counts = {"a user's file at every output": len(USER_OUTPUTS) + 2,
              "unwritable destinations": len(UNWRITABLE) + 2 + 1,
              "wrong kinds of path": WRONG_KINDS + 1,
              "the plugin's parameter file (NaN, infinity, a folder)": 3 + 1,
              "bounds on numeric options": len(BOUNDS) + 2,
              "concurrent runs": len(CONCURRENT) + 1,
              "edited results": len(EDITED) + 3 + 1}
    assert all(n >= 4 for n in counts.values()), counts
    assert sum(counts.values()) >= 130, counts


# the LAMMPS plugin's parameter file: the C++ reader (params.hpp, the compiled core) gives the
# Python loader's message for a NaN or infinity literal; a folder: ctest (test_params.cpp)
@pytest.mark.parametrize("value", [math.nan, math.inf, -math.inf])
def test_corpus_non_finite_literal_in_a_parameter_file_both_readers(tmp_path, value):
    from geocontact.law import _core

    document = json.loads(PARAMS.read_text())
    document["residual_approach"]["limit"] = value
    text = json.dumps(document, indent=2)  # writes NaN, Infinity, -Infinity
    (tmp_path / "p.json").write_text(text)
    with pytest.raises(InputError, match=r"^params: malformed JSON in .*p\.json: -?(NaN|Infinity) "
                                         r"at line \d+ column \d+ \(JSON has no NaN") as python:
        load_params(tmp_path / "p.json")
    with pytest.raises(ValueError) as compiled:
        _core.parse_params(text, str(tmp_path / "p.json"))
    assert str(compiled.value) == str(python.value)
    document["residual_approach"]["limit"] = 0.5
    document["label"] = "NaN and -Infinity in a string are text"
    text = json.dumps(document, indent=2)
    (tmp_path / "p.json").write_text(text)
    load_params(tmp_path / "p.json")
    _core.parse_params(text, "p.json")


def test_corpus_parameter_file_naming_a_folder(tmp_path, capsys):
    assert main(["law", "--params", str(tmp_path), "--approach", "a.csv", "--out",
                 str(tmp_path / "F.csv")]) == 2
    one_line_error(capsys, f"params: {tmp_path} is a directory, expected a file")


def test_verify_backtracking_pairs_compares_twin_runs(tmp_path, capsys):
    """--pairs on a cache holding one committed run with full updates and its twin with
    backtracked ones (point 1's base, E/sigma_c 30: a few updates halved, 3.7e-9 apart): the pair
    passes; the twin's curve moved by 1e-6 of a column fails; a cache without twins is one line."""
    import json
    import shutil

    import verify_backtracking as script  # scripts/ (tests/conftest.py)

    cache = script.CACHE
    twins: dict = {}
    for summary in sorted(cache.glob("*/summary.json")):
        inputs = dict(json.loads(summary.read_text())["identity"]["inputs"])
        twins.setdefault(json.dumps({k: v for k, v in inputs.items() if k != "newton"},
                                    sort_keys=True), {})[inputs.get("newton", "full")] = (
            summary.parent)
    pair = next(runs for runs in twins.values() if set(runs) == {"full", "backtracking"})
    for run in pair.values():
        shutil.copytree(run, tmp_path / run.name)
    out = tmp_path / "pairs.json"
    assert script.main(["--pairs", "--cache", str(tmp_path), "--json", str(out)]) == 0
    assert json.loads(out.read_text())["pass"] is True
    curve = tmp_path / pair["backtracking"].name / "curve.csv"
    lines = curve.read_text().splitlines()
    header, row = lines[0].split(","), lines[-1].split(",")
    column = header.index("approach_m")
    row[column] = repr(float(row[column]) * (1.0 + 1e-6))
    curve.write_text("\n".join([*lines[:-1], ",".join(row)]) + "\n")
    capsys.readouterr()
    assert script.main(["--pairs", "--cache", str(tmp_path)]) == 1
    assert "FAIL" in capsys.readouterr().out
    (tmp_path / "none").mkdir()
    assert script.main(["--pairs", "--cache", str(tmp_path / "none")]) == 2
    one_line_error(capsys, "--pairs: no run in")
    assert script.main(["--pairs", "--pair-tolerance", "2"]) == 2
    one_line_error(capsys, "--pair-tolerance: must be in (0, 1)")
