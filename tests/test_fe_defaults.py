"""The FE defaults are the verified settings (issue 36; docs/fem.md "Defaults"): with no flags
``geocontact fem``, ``cycles``, ``calibrate``, ``study paper-histories`` and the Python API run
the mesh rule "auto" with the adaptive load-step control bounded by the plastic dissipation
("dissipation"); the flags still override; a run made
under the old defaults ("yield" meshes, fixed steps: every committed one) keeps its key and is
found by a job that names them; summary.json says what was chosen and why. No FE run here but
one short coarse run (seconds)."""

import inspect
import json
from pathlib import Path

import pytest
from conftest import fe_setting_reaching_the_run

from geocontact.analyses.cycles import run_cycles
from geocontact.analyses.paper_histories import single_load_jobs, study_jobs
from geocontact.fem.campaign import FemJob
from geocontact.fem.identity import FeRunIdentity
from geocontact.fem.run import run_history
from geocontact.fem.settings import (
    AUTO_DENSE_FORCE_RATIO,
    FeSettings,
    chosen_mesh_rule,
    recorded_choice,
    settings_choice,
)
from geocontact.grain.material import preset

REFERENCE = preset("reference")
ROOT = Path(__file__).resolve().parents[1]


def test_the_python_api_defaults_to_auto_and_adaptive():
    assert (FeSettings().mesh_rule, FeSettings().step_control) == ("auto", "dissipation")
    job = FemJob(REFERENCE, (0.0, 3000.0, 0.0))
    assert (job.mesh_rule, job.step_control) == ("auto", "dissipation")
    # resolved per run: far above 10 Fy the dense contact band, below it the yield meshes
    assert job.identity().mesh_rule == "contact-dense"
    assert FemJob(REFERENCE, (0.0, 5.0, 0.0)).identity().mesh_rule == "yield"
    # run_cycles passes its FE settings on as keywords (**fe_model): those not given are
    # FeSettings' own defaults, checked above
    fe_model = inspect.signature(run_cycles).parameters["fe_model"]
    assert fe_model.kind is inspect.Parameter.VAR_KEYWORD
    # run_history's settings are FeSettings' (settings=None: FeSettings(mesh, **keywords))
    assert inspect.signature(run_history).parameters["settings"].default is None


@pytest.mark.parametrize("setting, value", [("mesh_rule", "auto"),
                                            ("step_control", "dissipation")])
def test_fem_and_cycles_with_no_flags_run_auto_and_adaptive(setting, value, tmp_path,
                                                             monkeypatch):
    assert fe_setting_reaching_the_run(monkeypatch, tmp_path, setting, []) == [value, value]


@pytest.mark.parametrize("flags, setting, value", [
    (["--mesh-rule", "yield"], "mesh_rule", "yield"),
    (["--mesh-rule", "contact"], "mesh_rule", "contact"),
    (["--step-control", "fixed"], "step_control", "fixed"),
    (["--step-control", "adaptive"], "step_control", "adaptive"),
])
def test_the_flags_still_override(flags, setting, value, tmp_path, monkeypatch):
    assert fe_setting_reaching_the_run(monkeypatch, tmp_path, setting, flags) == [value, value]


class _Reached(Exception):
    pass


def _calibrate_model(monkeypatch, tmp_path, flags) -> tuple[dict, dict]:
    """The FE model and the recorded inputs ``geocontact calibrate`` passes on with ``flags``
    (the calibration itself captured, not made)."""
    import geocontact.calibrate.workflow as workflow
    from geocontact.cli import main

    seen = {}

    def capture(material, out, inputs, **kwargs):
        seen.update(fe_model=kwargs["fe_model"], inputs=dict(inputs))
        raise _Reached

    monkeypatch.setattr(workflow, "calibrate_to_file", capture)
    with pytest.raises(_Reached):
        main(["calibrate", "--material", "reference", "--mesh", "coarse", "--out",
              str(tmp_path / "p.json"), *flags])
    return seen["fe_model"], seen["inputs"]


def test_calibrate_with_no_flags_runs_auto_and_adaptive(monkeypatch, tmp_path):
    """The calibration's jobs get the FE defaults ("auto", adaptive); its provenance inputs
    name the adaptive control (absent: fixed, the files made before); --mesh-rule yield
    --step-control fixed (the shipped reference file's FE) give the jobs of the old defaults,
    recorded as before."""
    from geocontact.calibrate.campaign import calibration_jobs

    model, inputs = _calibrate_model(monkeypatch, tmp_path, [])
    assert model["mesh_rule"] == "auto" and "step_control" not in model
    assert inputs["step_control"] == "dissipation"
    jobs = calibration_jobs(REFERENCE, [30.0, 3000.0], "coarse", fe_model=model)
    assert {(j.mesh_rule, j.step_control) for j in jobs} == {("auto", "dissipation")}
    # the levels share a mesh sized for the top one, so one rule for all
    assert {j.identity().mesh_rule for j in jobs} == {"contact-dense"}
    model, inputs = _calibrate_model(monkeypatch, tmp_path,
                                     ["--mesh-rule", "yield", "--step-control", "fixed"])
    assert (model["mesh_rule"], model["step_control"]) == ("yield", "fixed")
    assert "step_control" not in inputs
    old = calibration_jobs(REFERENCE, [30.0, 3000.0], "coarse", fe_model=model)
    assert all("mesh_rule" not in j.identity().inputs() and "step_control" not in
               j.identity().inputs() for j in old)


def test_the_paper_study_defaults_and_the_committed_studys_pins():
    """With no FE model the study runs the defaults; the committed study's command (the weak
    grain's FE model with fixed steps, --others-mesh-rule yield) gives its runs as committed:
    the other materials on the "yield" meshes, every run and every single load with fixed
    steps (found by key in datasets/fe-runs/paper-histories-finite)."""
    names = ["repeated-10MPa", "mono-increasing-1MPa", "repeated-von-mises-10MPa"]
    _, plain = study_jobs("coarse", only=names)
    assert {(j.mesh_rule, j.step_control) for j in plain} == {("auto", "dissipation")}
    weak = {"kinematics": "finite", "mesh_rule": "contact", "max_step_ratio": 1.01,
            "step_control": "fixed"}
    _, pinned = study_jobs("default", only=names, fe_model=weak,
                           fe_model_materials=["reference-weak"],
                           others_fe_model={"mesh_rule": "yield"})
    assert [(j.mesh_rule, j.step_control) for j in pinned] == [
        ("yield", "fixed"), ("contact", "fixed"), ("yield", "fixed")]
    for single in single_load_jobs(pinned[1]):
        assert (single.mesh_rule, single.step_control, single.kinematics) == (
            "contact", "fixed", "finite")
    committed = ROOT / "datasets" / "fe-runs" / "paper-histories-finite"
    for job in (pinned[0], pinned[2], *single_load_jobs(pinned[1])[:1]):
        record = job.identity().inputs()
        found = [p for p in committed.glob("*/summary.json")
                 if json.loads(p.read_text())["identity"]["inputs"] == record]
        assert found, f"{job.label}: no committed run of these inputs"


def test_the_study_refuses_others_mesh_rule_without_materials(capsys):
    from geocontact.cli import main

    code = main(["study", "paper-histories", "--others-mesh-rule", "yield", "--out", "x"])
    err = capsys.readouterr().err.strip()
    assert code == 2 and err.count("\n") == 0 and "--others-mesh-rule" in err


def test_a_run_made_under_the_old_defaults_keeps_its_key():
    """Named "yield" and "fixed" (the makers of every committed run do) give the record and
    key a run had when they were the defaults: neither setting in its record."""
    old = FeRunIdentity.of(REFERENCE, [0.0, 3000.0, 0.0], mesh_rule="yield",
                           step_control="fixed")
    assert "mesh_rule" not in old.inputs() and "step_control" not in old.inputs()
    assert FemJob.of_inputs(old.inputs()).key() == old.key()
    default = FeRunIdentity.of(REFERENCE, [0.0, 3000.0, 0.0])
    assert default.key() != old.key()
    assert (default.inputs()["mesh_rule"], default.inputs()["step_control"]) == (
        "contact-dense", "dissipation")


def test_summary_says_what_was_chosen_and_why(tmp_path):
    """summary.json ``choice``: the rule and the control the run has, its mesh force over the
    analytic first-yield force, the rule "auto" gives there and the sentence saying so; a run
    made before it was recorded gets the same from its inputs (recorded_choice)."""
    result = run_history(REFERENCE, [0.0, 60.0, 0.0], "coarse", steps_per_segment=2,
                         write_fields=False)
    choice = result.summary["choice"]
    rule, ratio = chosen_mesh_rule(REFERENCE, 60.0)
    assert ratio > AUTO_DENSE_FORCE_RATIO and rule == "contact-dense"
    assert choice == {"mesh_rule": "contact-dense", "step_control": "dissipation",
                      "mesh_force_over_first_yield": pytest.approx(ratio, rel=1e-12),
                      "auto_dense_above": AUTO_DENSE_FORCE_RATIO,
                      "auto_mesh_rule": "contact-dense", "reason": choice["reason"]}
    assert choice["reason"] == (f"mesh rule auto: contact-dense (mesh force {ratio:.4g} x the "
                                "analytic first-yield force, above 10)")
    assert result.summary["mesh"]["rule"] == "contact-dense"
    assert result.summary["step_control"]["control"] == "dissipation"
    before = {k: v for k, v in result.summary.items() if k != "choice"}
    assert recorded_choice(before) == json.loads(json.dumps(choice))
    # a named rule: the run says what it has and what "auto" would have given
    named = settings_choice(REFERENCE, FeRunIdentity.of(
        REFERENCE, [0.0, 60.0, 0.0], mesh_rule="yield", step_control="fixed").settings)
    assert (named["mesh_rule"], named["auto_mesh_rule"], named["step_control"]) == (
        "yield", "contact-dense", "fixed")
