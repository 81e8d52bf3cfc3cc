"""The FE settings in one object (fem.settings.FeSettings, issue 36): its defaults, its one-line
refusals, the identity it records, the CLI flags it owns, and run_history's three parts."""

import argparse

import numpy as np
import pytest

from geocontact.errors import InputError
from geocontact.fem.campaign import FemJob
from geocontact.fem.identity import FeRunIdentity
from geocontact.fem.result import STEPS_PER_SEGMENT, TOLERANCE, VOLUMETRIC_DEFAULT
from geocontact.fem.run import run_history
from geocontact.fem.settings import MODEL_FLAGS, FeSettings
from geocontact.grain.material import preset

REFERENCE = preset("reference")
FORCES = [0.0, 60.0, 0.0]


def test_defaults_are_the_verified_settings_and_resolve_per_history():
    s = FeSettings()
    assert (s.mesh, s.tolerance, s.volumetric, s.mesh_rule, s.kinematics, s.step_rule,
            s.max_step_ratio, s.contact, s.kernels, s.step_control) == (
        "coarse", TOLERANCE, VOLUMETRIC_DEFAULT, "auto", "small", "segment", None, "node",
        "compiled", "dissipation")
    # the kernels' default is the contact's: the facet contact has no compiled path
    assert FeSettings(contact="facet").kernels == "numpy"
    assert FeSettings(kernels=None) == FeSettings(kernels="compiled")
    resolved = FeSettings(mesh="default").resolved(FORCES, REFERENCE)
    assert resolved.steps_per_segment == STEPS_PER_SEGMENT["default"]
    assert resolved.mesh_force == 60.0
    # two spellings of one run are one identity
    assert FeSettings(steps_per_segment=12, mesh_force=60).resolved(FORCES, REFERENCE) == (
        FeSettings().resolved(FORCES, REFERENCE))
    # "auto" resolved from the material and the load: 60 N is ~20 x the reference's Fy
    assert resolved.mesh_rule == "contact-dense"


@pytest.mark.parametrize("keywords, message", [
    ({"mesh": "huge"}, "^mesh: unknown preset 'huge'"),
    ({"steps_per_segment": 0}, "^steps_per_segment: must be an integer >= 1, got 0$"),
    ({"steps_per_segment": 2.5}, "^steps_per_segment: must be an integer >= 1"),
    ({"tolerance": float("nan")}, "^tolerance: must be a positive number"),
    ({"volumetric": "x"}, r"^volumetric: unknown 'x' \(allowed: bbar-p1, bbar-p0, full\)$"),
    ({"kinematics": "large"}, r"^kinematics: unknown 'large' \(allowed: small, finite\)$"),
    ({"max_step_ratio": 3.0}, r"^max_step_ratio: must be a number in \(1, 2\] or None"),
    ({"kernels": "compiled", "contact": "facet"},
     r"^kernels: 'compiled' is the engine with the node contact \(got contact 'facet'\)$"),
    ({"mesh_force": -1.0}, "^mesh_force: must be a positive number, got -1.0$"),
    ({"newton": "damped"}, r"^newton: unknown 'damped' \(allowed: full, backtracking\)$"),
])
def test_a_setting_the_fe_refuses_is_one_line_naming_it(keywords, message):
    with pytest.raises(InputError, match=message) as caught:
        FeSettings(**keywords)
    assert "\n" not in str(caught.value)


def test_a_mesh_force_below_the_largest_force_is_refused_for_the_history():
    with pytest.raises(InputError, match="^mesh_force: must be >= the largest force 60 N"):
        FeSettings(mesh_force=50.0).resolved(FORCES)


def test_the_identity_records_the_settings_as_before_and_round_trips():
    """The record keeps the first identity's keys (mesh ... volumetric) and adds a later
    setting only when not at its default when it entered the record (RECORD_DEFAULTS: the
    "yield" meshes, fixed steps), so earlier keys stay valid; a default run (the rule "auto"
    chose, adaptive steps) names both; a recorded identity gives back its settings."""
    plain = FeRunIdentity.of(REFERENCE, FORCES, mesh_rule="yield", step_control="fixed").inputs()
    assert set(plain) == {"material", "forces_N", "mesh", "steps_per_segment", "tolerance",
                          "mesh_force_N", "volumetric"}
    default = FeRunIdentity.of(REFERENCE, FORCES).inputs()
    assert {k: v for k, v in default.items() if k not in plain} == {
        "mesh_rule": "contact-dense", "step_control": "dissipation"}
    finite = FeSettings(kinematics="finite", max_step_ratio=1.01, kernels="numpy")
    identity = FeRunIdentity.of_settings(REFERENCE, FORCES, finite)
    inputs = identity.inputs()
    assert (inputs["kinematics"], inputs["max_step_ratio"], inputs["kernels"]) == (
        "finite", 1.01, "numpy")
    assert identity.kinematics == "finite" and identity.steps_per_segment == 12
    assert FeSettings.of_record(inputs) == identity.settings
    assert FeRunIdentity.of(REFERENCE, FORCES, kinematics="finite", max_step_ratio=1.01,
                            kernels="numpy").key() == identity.key()
    # the kernels at the contact's default are not recorded (compiled, node; numpy, facet)
    assert "kernels" not in FeRunIdentity.of(REFERENCE, FORCES, kernels="compiled").inputs()
    facet = FeRunIdentity.of(REFERENCE, FORCES, contact="facet", kernels="numpy")
    assert "kernels" not in facet.inputs() and "compiled_code" not in facet.to_dict()
    assert facet.inputs()["contact"] == "facet"
    node_numpy = FeRunIdentity.of(REFERENCE, FORCES, kernels="numpy").inputs()
    assert node_numpy["kernels"] == "numpy" and "contact" not in node_numpy
    # the Newton updates: recorded only when backtracking, a run with full updates keeps its key
    assert "newton" not in default
    backtracked = FeRunIdentity.of(REFERENCE, FORCES, newton="backtracking")
    assert backtracked.inputs()["newton"] == "backtracking"
    assert backtracked.key() != FeRunIdentity.of(REFERENCE, FORCES).key()
    assert FeSettings.of_record(backtracked.inputs()) == backtracked.settings
    assert FemJob.of_inputs(backtracked.inputs()).key() == backtracked.key()
    job = FemJob(REFERENCE, tuple(FORCES), kinematics="finite", max_step_ratio=1.01)
    assert job.settings() == FeSettings(kinematics="finite", max_step_ratio=1.01)
    assert job.key() == FeRunIdentity.of(REFERENCE, FORCES, kinematics="finite",
                                         max_step_ratio=1.01).key()


def test_the_cli_flags_default_to_the_settings_and_give_its_keywords():
    parser = argparse.ArgumentParser()
    FeSettings.add_model_flags(parser)
    defaults = FeSettings()
    args = parser.parse_args([])
    assert {name: getattr(args, name) for name in MODEL_FLAGS} == {
        name: getattr(defaults, name) for name in MODEL_FLAGS}
    assert FeSettings.model_of(args) == {name: getattr(defaults, name) for name in MODEL_FLAGS}
    chosen = parser.parse_args(["--kinematics", "finite", "--contact", "facet",
                                "--max-step-ratio", "1.02", "--newton", "backtracking"])
    assert FeSettings(**FeSettings.model_of(chosen)) == FeSettings(
        kinematics="finite", contact="facet", max_step_ratio=1.02, newton="backtracking")


def test_run_history_takes_the_settings_or_their_keywords_with_one_result():
    by_keywords = run_history(REFERENCE, FORCES, "coarse", steps_per_segment=3,
                              write_fields=False)
    by_settings = run_history(REFERENCE, FORCES, settings=FeSettings(steps_per_segment=3),
                              write_fields=False)
    assert by_settings.summary["identity"] == by_keywords.summary["identity"]
    for name, values in by_keywords.curve.items():
        np.testing.assert_array_equal(by_settings.curve[name], values, err_msg=name)
    with pytest.raises(TypeError, match="not both"):
        run_history(REFERENCE, FORCES, "coarse", settings=FeSettings())


def test_run_history_leaves_its_messages_to_the_caller(capsys):
    """An under-resolved contact (a 6 N load on a mesh sized for 6000 N) goes to ``notify``,
    not to stderr; the summary lists it as before."""
    strong = REFERENCE.with_(compressive_yield_stress=1e15)  # elastic at any load here
    messages = []
    result = run_history(strong, [0.0, 6.0], "coarse", steps_per_segment=2, mesh_force=6000.0,
                         write_fields=False, notify=messages.append)
    (warning,) = result.summary["warnings"]
    assert messages == [f"warning: {warning}"]
    assert capsys.readouterr().err == ""
