"""The mesh resolves the contacts a history really has (issue 16; docs/fem.md, "Mesh resolution
of the contact").

The mesh is sized from the history's smallest load step as well as from the yield contact
radius, so a grain that never yields (sigma_c = 1e15 Pa) is resolved from its first load step to
its peak; a run whose contact spans too few elements says so.
"""

import json

import numpy as np
import pytest

from geocontact.fem.mesh import MIN_ELEMENTS_ACROSS_CONTACT, build_mesh, elements_across
from geocontact.fem.result import STEPS_PER_SEGMENT
from geocontact.fem.run import (
    contact_resolution,
    run_history,
    smallest_resolved_force,
    tip_contact_radius,
    yield_contact_radius_estimate,
)
from geocontact.grain import hertz
from geocontact.grain.material import Material, preset

STRONG = Material(10e9, 0.25, 1e15, 30.0, 0.0, 0.1)  # elastic for any load of interest
DECADES = (6.0, 60.0, 600.0, 6000.0)


def _hertz_contact_radius(material, force):
    return hertz.contact_radius(material, hertz.hertz_approach(material, force))


def incipient_force(material):
    return hertz.incipient_yield(material).force


def test_strong_grain_matches_hertz_over_three_decades_of_force():
    """One history 0 -> 6 -> 60 -> 600 -> 6000 N on the coarse mesh: approach and contact radius
    within 2 % of Hertz at every decade (before the fix: 35-46 % / 18-47 % off at 6000 N on the
    default mesh, 194 elements sized from a yield contact radius clipped to R/2)."""
    forces = [0.0, *DECADES]
    result = run_history(STRONG, forces, mesh="coarse", write_fields=False)
    c, s = result.curve, result.summary
    assert s["first_yield_force_N"] is None
    for force in DECADES:
        (k,) = [i for i, f in enumerate(c["force_N"]) if f == force]
        approach = hertz.hertz_approach(STRONG, force)
        assert c["approach_m"][k] == pytest.approx(approach, rel=0.02), force
        assert c["contact_radius_m"][k] == pytest.approx(
            _hertz_contact_radius(STRONG, force), rel=0.02), force
    resolution = s["contact_resolution"]["elements_across_contact_radius"]
    assert resolution["first_loaded_step"]["force_N"] < 1.0  # the first step of 0 -> 6 N
    assert resolution["first_loaded_step"]["elements"] >= MIN_ELEMENTS_ACROSS_CONTACT
    assert resolution["peak"]["elements"] > resolution["first_loaded_step"]["elements"]
    assert resolution["first_yield"] is None
    assert s["warnings"] == []


def test_yielding_runs_keep_the_verified_mesh():
    """Where the yield contact radius is already the smallest relevant one (the reference cycle,
    the paper's repeated history), the mesh is sized from 0.7 a_y as before."""
    material = preset("reference")
    for forces in ([0.0, 6000.0, 0.0], [0.0, 3000.0, 0.0, 3000.0, 0.0]):
        for mesh, steps in STEPS_PER_SEGMENT.items():
            smallest = smallest_resolved_force(material, forces, steps)
            assert smallest < incipient_force(material)
            assert tip_contact_radius(material, smallest, mesh) == (
                yield_contact_radius_estimate(material))
    # a strong grain: the first load step decides, with >= 3 elements across its contact
    smallest = smallest_resolved_force(STRONG, [0.0, 6000.0], STEPS_PER_SEGMENT["coarse"])
    assert tip_contact_radius(STRONG, smallest, "coarse") == pytest.approx(
        _hertz_contact_radius(STRONG, smallest))


def test_elements_across_counts_surface_edges_between_axis_and_contact_radius():
    mesh = build_mesh(0.1, 3e-4, 3e-3, "coarse")  # h_tip = 1e-4 m on the surface near the tip
    assert elements_across(mesh, 0.1, 0.0) == 0.0
    assert elements_across(mesh, 0.1, 3e-4) == pytest.approx(3.0, rel=0.03)
    assert elements_across(mesh, 0.1, 1.5e-4) == pytest.approx(1.5, rel=0.03)
    assert list(elements_across(mesh, 0.1, [1e-4, 2e-4])) == pytest.approx([1.0, 2.0], rel=0.03)


def test_under_resolved_run_warns_on_stderr_and_in_summary(tmp_path, capsys):
    """A small load on a mesh shared with a large one (mesh_force): the 6 N contact spans well
    under one element of a mesh sized for 6000 N."""
    out = tmp_path / "run"
    result = run_history(STRONG, [0.0, 6.0], mesh="coarse", steps_per_segment=2,
                         mesh_force=6000.0, out=out, write_fields=False)
    (warning,) = result.summary["warnings"]
    assert "under-resolved contact" in warning and "first loaded step" in warning
    points = result.summary["contact_resolution"]["elements_across_contact_radius"]
    assert points["first_loaded_step"]["elements"] < 1.0
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [f"warning: {warning}"]
    assert json.loads((out / "summary.json").read_text())["warnings"] == [warning]


def test_resolution_check_reads_first_step_first_yield_and_peak():
    """contact_resolution on a hand-made curve: counts at the three points, warns for the one
    under the threshold only, and counts an elastic point at the (smaller) Hertz radius."""
    mesh = build_mesh(0.1, 2.4e-4, 3e-3, "coarse")  # h_tip = 8e-5 m: 3.4 elements across a_y
    material = preset("reference")
    fy = incipient_force(material)
    a_y = _hertz_contact_radius(material, fy)
    curve = {"step": [0, 1, 2], "force_N": [0.0, 0.01 * fy, 10.0 * fy],
             "contact_radius_m": [0.0, 5e-4, 2e-3]}  # the FE radius at step 1 is too wide
    curve = {k: np.asarray(v) for k, v in curve.items()}
    summary, warnings = contact_resolution(material, mesh, curve, {"force_N": fy})
    points = summary["elements_across_contact_radius"]
    first = points["first_loaded_step"]
    assert first["contact_radius_m"] == pytest.approx(_hertz_contact_radius(material, 0.01 * fy))
    assert first["elements"] == pytest.approx(elements_across(mesh, 0.1, first["contact_radius_m"]))
    assert points["first_yield"]["contact_radius_m"] == pytest.approx(a_y)
    assert points["peak"]["contact_radius_m"] == 2e-3  # plastic: the FE radius
    low = [name for name, p in points.items() if p["elements"] < MIN_ELEMENTS_ACROSS_CONTACT]
    assert low == ["first_loaded_step"]
    (warning,) = warnings
    assert "first loaded step" in warning and "peak" not in warning
