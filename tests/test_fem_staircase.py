"""The staircase of a growing contact (issue 15, part 1): the measures that detect it, the
"contact" mesh rule (small surface elements over the plastic range of contact radii) and the
"decade" step rule (geometric loading steps per decade of force). No FE run here: the runs are
in scripts/measure_staircase.py (docs/fem.md, "The staircase of a growing contact")."""

import math

import numpy as np
import pytest

from geocontact.errors import InputError
from geocontact.fem.mesh import CONTACT_SURFACE_GRADING, build_mesh, surface_vertex_radii
from geocontact.fem.reuse import FeRunIdentity
from geocontact.fem.run import contact_band_radius, history_mesh, load_schedule
from geocontact.fem.staircase import force_gap, slope_measures, staircase_measures
from geocontact.hertz import incipient_yield
from geocontact.material import preset


def _power_law(n=60):
    x = np.geomspace(1e-6, 1e-3, n)
    return x, 1e9 * x ** 1.2


def _staircase(n=60, stairs=12):
    """F flat between engagements (plateaus), then a steep riser."""
    x, f = _power_law(400)
    level = np.exp(np.floor(np.log(f) / (np.log(f[-1] / f[0]) / stairs)) * (
        np.log(f[-1] / f[0]) / stairs))
    keep = np.linspace(0, len(x) - 1, n).astype(int)
    return x[keep], np.maximum(level[keep], f[0])


def test_measures_tell_a_staircase_from_a_smooth_curve():
    x, f = _power_law()
    smooth = slope_measures(x, f, 0.0)
    assert smooth["slope_total_variation"] < 1e-6 and abs(smooth["slope_min"] - 1.2) < 1e-9
    xs, fs = _staircase()
    stairs = slope_measures(xs, fs, 0.0)
    assert stairs["slope_total_variation"] > 20 and stairs["slope_min"] < 0.1
    # the same smooth curve sampled at other points: no gap; a staircase against it: large
    x2, f2 = _power_law(37)
    assert force_gap((x, f), (x2, f2), 0.0)[0] < 1e-6
    assert force_gap((x, f), (xs, fs), 0.0)[0] > 0.1
    curves = {"a": {"force_N": np.r_[0.0, f], "approach_m": np.r_[0.0, x]},
              "b": {"force_N": np.r_[0.0, f2], "approach_m": np.r_[0.0, x2]}}
    measures = staircase_measures(curves, yield_force=1e-3, floor=10.0)
    assert measures["pairs"]["a vs b"]["force_gap_max"] < 1e-6


def test_contact_rule_refines_the_surface_over_the_plastic_contact_radii():
    """On the weak grain sized for 6000 N the surface edge at a contact radius a in the band is
    ~ a / CONTACT_SURFACE_GRADING (a node every 1.25 % of a on coarse), against a / 5 with the
    verified "yield" rule; inside the body (the depth growth) the meshes stay alike."""
    material = preset("reference-weak")
    meshes = {rule: history_mesh(material, 6000.0, "coarse", rule=rule)
              for rule in ("yield", "contact")}
    a_y = float(incipient_yield(material).contact_radius)
    assert 1.5 * a_y < contact_band_radius(material) < 5 * a_y  # the contact at 10 Fy
    spacing = {}
    for rule, mesh in meshes.items():
        ends = surface_vertex_radii(mesh, material.radius)
        mid = 0.5 * (ends[1:] + ends[:-1])
        sel = (mid > 0.002) & (mid < 0.02)  # contact radii of 50 ... 6000 N
        spacing[rule] = np.max(np.diff(ends)[sel] / mid[sel])
    assert spacing["yield"] > 0.15
    assert spacing["contact"] < 1.3 / CONTACT_SURFACE_GRADING["coarse"]
    counts = {rule: mesh.t.shape[1] for rule, mesh in meshes.items()}
    assert counts["contact"] < 5 * counts["yield"]  # linear in the grading, not quadratic


def test_yield_rule_is_the_verified_mesh():
    material = preset("reference")
    a = build_mesh(material.radius, 2e-4, 5e-3, "coarse")
    b = build_mesh(material.radius, 2e-4, 5e-3, "coarse", rule="yield")
    assert np.array_equal(a.p, b.p) and np.array_equal(a.t, b.t)
    with pytest.raises(InputError, match="^mesh_rule: unknown 'fine'"):
        build_mesh(material.radius, 2e-4, 5e-3, "coarse", rule="fine")


def test_decade_step_rule_adds_geometric_steps_only_where_decades_are_many():
    fy = 0.00276  # the weak grain's first-yield force
    forces = [0.0, 6000.0, 0.0]
    segment, _ = load_schedule(forces, 24, fy)
    decade, marks = load_schedule(forces, 24, fy, "decade")
    loading = np.array([f for f in decade[:marks[0]]])
    geometric_span = math.log10(6000.0 / (0.5 * fy))
    assert len(decade) > len(segment)
    ratios = loading[1:] / loading[:-1]
    # >= 12 per decade (one point of a near-duplicate pair within 2 % is merged away)
    assert np.max(ratios[loading[1:] > fy]) <= 10 ** (1 / 12) * 1.02
    assert marks[0] >= 12 * geometric_span
    # unloading is the same; a history of 1.6 decades (0.5 Fy ... 20 Fy) gets no extra steps
    assert decade[marks[0]:] == segment[len(segment) - (len(decade) - marks[0]):]
    short, _ = load_schedule([0.0, 20 * fy], 24, fy, "decade")
    assert short == load_schedule([0.0, 20 * fy], 24, fy)[0]
    with pytest.raises(InputError, match="^step_rule: unknown 'x'"):
        FeRunIdentity.of(preset("reference"), [0.0, 10.0], step_rule="x")
    assert "step_rule" in FeRunIdentity.of(preset("reference"), [0.0, 10.0],
                                           step_rule="decade").inputs()
