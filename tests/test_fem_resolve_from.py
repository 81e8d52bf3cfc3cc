"""Starting the resolved mesh later (``resolve_from``, issue 37; docs/fem.md "Starting the
resolved mesh later"): the mesh resolves contacts from resolve_from x R on instead of from the
first load step's, the setting is in the run's identity only when given, every route takes it
(the Python API, ``geocontact fem``, ``calibrate`` and ``cycles`` through the model flags), and
bad values are one-line errors."""

import numpy as np
import pytest

from geocontact.errors import InputError
from geocontact.fem.campaign import FemJob
from geocontact.fem.identity import FeRunIdentity
from geocontact.fem.mesh import elements_across
from geocontact.fem.run import history_mesh, tip_contact_radius
from geocontact.fem.settings import RESOLVE_FROM_RANGE, FeSettings
from geocontact.grain.material import preset


def test_the_mesh_resolves_contacts_from_resolve_from_on():
    """The weak grain (a_y ~ 2.6e-4 R): with resolve_from = 3e-3 R the surface elements at the
    tip are sized for that contact, so a contact of 3e-3 R has as many elements across it as
    the default mesh gives its first contact, and the mesh has fewer elements."""
    material = preset("reference-weak")
    full = history_mesh(material, 300.0, "coarse")
    late = history_mesh(material, 300.0, "coarse", resolve_from=3e-3)
    tip = tip_contact_radius(material, 1e-3, "coarse")
    assert tip < 3e-3 * material.radius
    assert late.nelements < full.nelements
    across_late = elements_across(late, material.radius, 3e-3 * material.radius)
    across_full = elements_across(full, material.radius, 3e-3 * material.radius)
    assert across_late < across_full
    # at a contact 10x larger both resolve it
    assert elements_across(late, material.radius, 3e-2 * material.radius) >= 8
    # a value below the tip rule's changes nothing
    same = history_mesh(material, 300.0, "coarse", resolve_from=RESOLVE_FROM_RANGE[0])
    assert same.nelements == full.nelements
    assert np.array_equal(same.p, full.p)


def test_the_identity_records_it_only_when_given():
    material = preset("reference-weak")
    forces = (0.0, 300.0, 0.0)
    plain = FemJob(material, forces, kinematics="finite")
    late = FemJob(material, forces, kinematics="finite", resolve_from=3e-3)
    assert "resolve_from" not in plain.identity().inputs()
    assert late.identity().inputs()["resolve_from"] == 3e-3
    assert plain.key() != late.key()
    again = FemJob.of_inputs(late.identity().inputs())
    assert again.key() == late.key()
    assert FeRunIdentity.of(material, forces, "coarse", kinematics="finite").key() == plain.key()
    assert "contacts resolved from a = 0.003 R" in late.identity().settings.describe(300.0)


@pytest.mark.parametrize("value", [0.0, 1e-6, 0.06, float("nan"), True, "0.01"])
def test_a_value_out_of_range_is_a_one_line_error(value):
    with pytest.raises(InputError, match=r"^resolve_from: must be a contact radius over R in "
                                         r"\[1e-05, 0\.05\] or None, got "):
        FeSettings(resolve_from=value)


def test_the_model_flags_pass_it_on_only_when_given():
    import argparse

    parser = argparse.ArgumentParser()
    FeSettings.add_model_flags(parser)
    assert "resolve_from" not in FeSettings.model_of(parser.parse_args([]))
    model = FeSettings.model_of(parser.parse_args(["--resolve-from", "0.003"]))
    assert model["resolve_from"] == 0.003


def test_cycles_runs_the_fe_with_it(tmp_path):
    """``run_cycles`` takes the FE settings as keywords (``**fe_model``) and passes every one to
    the FE run and its identity: resolve_from is recorded in the FE run of the analysis."""
    import json

    from geocontact.analyses.cycles import run_cycles

    material = preset("reference-weak")
    run_cycles(material, [0.0, 0.05, 0.0, 0.05, 0.0], tmp_path / "c", mesh="coarse",
               steps_per_segment=3, mesh_rule="yield", step_control="fixed",
               resolve_from=1e-3)
    summary = json.loads((tmp_path / "c" / "fe" / "summary.json").read_text())
    assert summary["identity"]["inputs"]["resolve_from"] == 1e-3
    with pytest.raises(TypeError, match="unknown FE settings resolve_for"):
        run_cycles(material, [0.0, 0.05, 0.0], tmp_path / "d", resolve_for=1e-3)
