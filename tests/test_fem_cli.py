"""``geocontact fem``: files of docs/interfaces.md, errors, checkpoint / resume, atomic output."""

import csv
import json

import meshio
import numpy as np
import pytest

import geocontact.fem.run as fem_run
from geocontact.cli import main
from geocontact.errors import ConvergenceError
from geocontact.fem.checkpoint import checkpoint_path
from geocontact.fem.run import run_history
from geocontact.grain.force_history import preset_history
from geocontact.grain.material import preset

FORCES = [0.0, 60.0, 0.0]


def _history(tmp_path, text="[history]\nforces = [0, 60, 0]\n"):
    path = tmp_path / "h.toml"
    path.write_text(text)
    return path


def test_cli_writes_curve_summary_and_fields(tmp_path, capsys):
    out = tmp_path / "run"
    code = main(["fem", "--material", "reference", "--history", str(_history(tmp_path)),
                 "--mesh", "coarse", "--steps", "6", "--out", str(out), "--json"])
    assert code == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary == json.loads((out / "summary.json").read_text())
    for key in ("first_yield_force_N", "first_yield_approach_m", "fully_plastic_force_N",
                "cycles", "mesh", "wall_time_s", "cpu_time_s", "version", "inputs"):
        assert key in summary
    assert summary["cpu_time_s"] > 0.0
    assert set(summary["mesh"]) >= {"elements", "nodes"}
    (cycle,) = summary["cycles"]
    assert set(cycle) >= {"max_force_N", "max_approach_m", "residual_approach_m",
                          "plastic_work_J"}
    with open(out / "curve.csv") as fh:
        rows = list(csv.DictReader(fh))
    assert set(rows[0]) >= {"step", "force_N", "approach_m", "contact_radius_m",
                            "plastic_dissipation_J", "elastic_energy_J",
                            "yielded_contact_fraction", "yielded_core_fraction"}
    assert float(rows[-1]["force_N"]) == 0.0
    assert max(float(r["force_N"]) for r in rows) == 60.0
    vtus = sorted((out / "fields").glob("*.vtu"))
    assert len(vtus) == 2  # the peak and the end of the cycle
    fields = meshio.read(vtus[0])
    assert {"eqps", "yield_state", "mises"} <= set(fields.cell_data)
    # nothing half-written or left over beside the result: only the history and the run
    assert sorted(p.name for p in tmp_path.iterdir()) == ["h.toml", "run"]
    assert not checkpoint_path(out).exists()


def test_cli_bad_input_is_one_line_error(tmp_path, capsys):
    code = main(["fem", "--material", "reference", "--history",
                 str(_history(tmp_path, "[history]\nforces = [0, -5]\n")),
                 "--out", str(tmp_path / "x")])
    err = capsys.readouterr().err.strip()
    assert code == 2 and err.count("\n") == 0 and "history.forces[1]" in err
    assert not (tmp_path / "x").exists()


def test_preset_histories():
    assert preset_history("repeated", 3000.0) == [0.0] + [3000.0, 0.0] * 10
    dec = preset_history("mono-decreasing", 3000.0)[1::2]
    assert dec == pytest.approx([3000, 2500, 2000, 1500, 1000, 500, 100])
    inc = preset_history("mono-increasing", 3000.0)[1::2]
    assert inc[0] == pytest.approx(100.0) and inc[-1] == 3000.0 and len(inc) == 7


def test_interrupted_run_keeps_checkpoint_and_resumes(tmp_path, monkeypatch):
    material = preset("reference")
    out = tmp_path / "run"
    full = run_history(material, FORCES, mesh="coarse", steps_per_segment=6,
                       write_fields=False)
    real_advance = fem_run._advance

    # after a few solves (the adaptive control, the default, numbers its solves, not only the
    # requested steps)
    def failing_advance(solver, state, target, step):
        if step > 5:
            raise ConvergenceError(f"step {step}: simulated failure at F = {target:.6g} N")
        return real_advance(solver, state, target, step)

    monkeypatch.setattr(fem_run, "_advance", failing_advance)
    with pytest.raises(ConvergenceError, match=r"^step \d+: simulated failure"):
        run_history(material, FORCES, mesh="coarse", steps_per_segment=6, out=out)
    assert checkpoint_path(out).exists()
    assert not out.exists()  # no half-written result directory
    monkeypatch.setattr(fem_run, "_advance", real_advance)
    resumed = run_history(material, FORCES, mesh="coarse", steps_per_segment=6, out=out,
                          resume=True, write_fields=False)
    for column in ("force_N", "approach_m", "plastic_dissipation_J"):
        np.testing.assert_allclose(resumed.curve[column], full.curve[column], rtol=1e-9,
                                   atol=1e-15)
    assert resumed.summary["first_yield_force_N"] == pytest.approx(
        full.summary["first_yield_force_N"])
    assert (out / "summary.json").exists() and not checkpoint_path(out).exists()


def _interrupted(material, out, monkeypatch, after: int = 5) -> None:
    """A run of FORCES into ``out`` that fails after ``after`` load steps, its checkpoint kept."""
    real_advance = fem_run._advance

    def failing_advance(solver, state, target, step):
        if step > after:
            raise ConvergenceError(f"step {step}: simulated failure at F = {target:.6g} N")
        return real_advance(solver, state, target, step)

    monkeypatch.setattr(fem_run, "_advance", failing_advance)
    with pytest.raises(ConvergenceError):
        run_history(material, FORCES, mesh="coarse", steps_per_segment=6, out=out,
                    write_fields=False)
    monkeypatch.setattr(fem_run, "_advance", real_advance)


def test_cpu_time_is_carried_through_a_checkpoint(tmp_path, monkeypatch):
    """``cpu_time_s``: the process CPU time of the run, the checkpointed part included (the
    resumed run reports at least what its checkpoint recorded); a checkpoint written before it
    was recorded gives null, not this session's time alone."""
    material = preset("reference")
    for old_checkpoint in (False, True):
        out = tmp_path / f"run-{old_checkpoint}"
        _interrupted(material, out, monkeypatch)
        ckpt = checkpoint_path(out)
        with np.load(ckpt) as data:
            saved = {k: data[k] for k in data.files}
        assert float(saved["cpu_time_s"]) > 0.0
        if old_checkpoint:
            del saved["cpu_time_s"]
            with open(ckpt, "wb") as fh:
                np.savez(fh, **saved)
        resumed = run_history(material, FORCES, mesh="coarse", steps_per_segment=6, out=out,
                              resume=True, write_fields=False)
        cpu = resumed.summary["cpu_time_s"]
        if old_checkpoint:
            assert cpu is None
        else:
            assert cpu > float(saved["cpu_time_s"])
        assert json.loads((out / "summary.json").read_text())["cpu_time_s"] == cpu


def test_elastic_run_reports_round_off_plastic_work_as_zero(tmp_path, capsys):
    """An elastic run (sigma_c = 1e15 Pa) dissipates nothing: its plastic work is round-off of
    either sign, printed and summarised as 0 against the run's stated resolution; curve.csv
    keeps the raw values."""
    material = tmp_path / "elastic.toml"
    material.write_text("[material]\nyoungs_modulus = 10e9\npoissons_ratio = 0.25\n"
                        "compressive_yield_stress = 1e15\nfriction_angle_deg = 30.0\n"
                        "hardening_ratio = 0.0\n\n[geometry]\nradius = 0.1\n")
    history = _history(tmp_path, "[history]\nforces = [0, 60, 0, 60, 0]\n")
    out = tmp_path / "run"
    assert main(["fem", "--material", str(material), "--history", str(history), "--mesh",
                 "coarse", "--steps", "3", "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    summary = json.loads((out / "summary.json").read_text())
    energy, approach = summary["resolution"]["energy"], summary["resolution"]["approach"]
    cycles = summary["cycles"]
    assert len(cycles) == 2
    expected = 1e-12 * max(c["max_force_N"] for c in cycles) * max(c["max_approach_m"]
                                                                    for c in cycles)
    assert energy["value"] == pytest.approx(expected) and energy["unit"] == "J"
    assert "largest force" in energy["definition"]
    assert approach["value"] == pytest.approx(1e-12 * cycles[0]["max_approach_m"])
    assert all(c["plastic_work_J"] == 0.0 and c["loop_work_J"] == 0.0
               and c["residual_approach_m"] == 0.0 for c in cycles)
    assert printed.count("plastic work 0 J (below the resolution") == 2
    assert printed.count("residual 0 m (below the resolution") == 2
    assert f"resolution {energy['value']:.2g} J: 1e-12 x" in printed
    with open(out / "curve.csv") as fh:
        raw = [float(r["plastic_dissipation_J"]) for r in csv.DictReader(fh)]
    assert max(abs(w) for w in raw) < energy["value"]  # raw round-off, kept as computed


def test_fe_model_flags_reach_the_run(tmp_path, monkeypatch, capsys):
    """--kinematics, --mesh-rule, --step-rule, --max-step-ratio and --newton of ``geocontact
    fem`` and ``cycles`` are passed to the FE run (captured here instead of running it); a bad
    value is a one-line error."""
    seen = []

    class Stop(Exception):
        pass

    def capture(*args, **kwargs):
        seen.append({k: kwargs.get(k)
                     for k in ("kinematics", "mesh_rule", "step_rule", "max_step_ratio",
                               "newton")})
        raise Stop

    monkeypatch.setattr(fem_run, "run_history", capture)
    history = str(_history(tmp_path))
    flags = ["--kinematics", "finite", "--mesh-rule", "contact", "--step-rule", "decade",
             "--max-step-ratio", "1.01", "--newton", "backtracking"]
    for command in ("fem", "cycles"):
        with pytest.raises(Stop):
            main([command, "--material", "reference", "--history", history, "--mesh", "coarse",
                  "--out", str(tmp_path / command), *flags])
    assert seen == [{"kinematics": "finite", "mesh_rule": "contact", "step_rule": "decade",
                     "max_step_ratio": 1.01, "newton": "backtracking"}] * 2
    code = main(["fem", "--material", "reference", "--history", history,
                 "--out", str(tmp_path / "x"), "--kinematics", "large"])
    err = capsys.readouterr().err.strip()
    assert code == 2 and err.count("\n") == 0 and "--kinematics" in err
    code = main(["fem", "--material", "reference", "--history", history,
                 "--out", str(tmp_path / "x"), "--newton", "damped"])
    err = capsys.readouterr().err.strip()
    assert code == 2 and err.count("\n") == 0 and "--newton" in err
    monkeypatch.undo()  # the real run: a cap <= 1 is refused before any work, in one line
    code = main(["fem", "--material", "reference", "--history", history,
                 "--out", str(tmp_path / "y"), "--max-step-ratio", "0.5"])
    err = capsys.readouterr().err.strip()
    assert code != 0 and err.count("\n") == 0 and "max_step_ratio" in err
