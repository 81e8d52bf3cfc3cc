"""Bad input that used to give a traceback or a silent wrong answer (issue 16): each is now a
one-line ``error: ...`` naming the field and its allowed range, exit code 2."""

from __future__ import annotations

import json
import math
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
    one_line_error(capsys, "time_step", "stability limit")
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
    one_line_error(capsys, "--max-force: must be <= 1.364e+05 N", "a <= R/2")
    (tmp_path / "h.toml").write_text("[history]\nforces = [0, 1e9, 0]\n")
    assert main(["fem", "--material", "reference", "--history", str(tmp_path / "h.toml"),
                 "--out", str(tmp_path / "run")]) == 2
    one_line_error(capsys, "history.forces: must be <= 1.364e+05 N")
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
