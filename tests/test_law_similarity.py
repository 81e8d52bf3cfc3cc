"""The law for grains of any size by similarity (docs/model.md §10): spheres of radius r = s R of
the
calibrated material follow F_r(d) = s^2 F_R(d / s), with energies s^3 and every approach s
times, along any history (the FE proof is tests/test_fem_similarity.py)."""

import json
import math

import numpy as np
import pytest

from geocontact.cli import main
from geocontact.errors import InputError
from geocontact.law import Contact, load_params
from geocontact.law.params import LawParams

CALIBRATED = "examples/params-reference.json"  # cyclic extension, third regime, log power


def _history(params: LawParams, n: int = 4000) -> np.ndarray:
    """A random history of loading, partial unloading, reloading and separation, up to 400 dy."""
    rng = np.random.default_rng(7)
    dy = params.yield_approach
    turns = np.concatenate([[0.0], rng.uniform(-5, 400, 60) * dy])
    path = np.concatenate([np.linspace(a, b, n // 60) for a, b in zip(turns[:-1], turns[1:],
                                                                     strict=True)])
    return path


@pytest.mark.parametrize("scale", [1e-3, 0.1, 0.37, 3.0, 250.0])
@pytest.mark.parametrize("source", [CALIBRATED, "examples/params-illustrative.json"])
def test_law_of_scaled_spheres_is_the_scaled_law(source, scale):
    base = load_params(source)
    scaled = base.for_radius(scale * base.material.radius)
    assert scaled.material.radius == pytest.approx(scale * base.material.radius, rel=1e-15)
    path = _history(base)
    a, b = Contact(base), Contact(scaled)
    for d in path:
        fa, ka = a.update(d)
        fb, kb = b.update(scale * d)
        assert fb == pytest.approx(scale**2 * fa, rel=1e-12,
                                   abs=1e-12 * scale**2 * base.yield_force)
        assert kb == pytest.approx(scale * ka, rel=1e-12, abs=1e-12 * scale * base.yield_force
                                   / base.yield_approach)
        assert b.dissipated_energy == pytest.approx(
            scale**3 * a.dissipated_energy,
            rel=1e-11, abs=1e-12 * scale**3 * base.yield_force * base.yield_approach)
    sa, sb = a.state, b.state
    for name in ("max_approach", "residual_approach", "ratchet_shift"):
        assert getattr(sb, name) == pytest.approx(scale * getattr(sa, name), rel=1e-12,
                                                  abs=1e-15 * scale)
    assert sb.cycles == sa.cycles and sb.branch == sa.branch


def test_recorded_values_scale_with_their_units():
    base = load_params(CALIBRATED)
    s = 0.01
    scaled = base.for_radius(s * base.material.radius)
    assert scaled.yield_force == pytest.approx(s**2 * base.yield_force, rel=1e-13)
    assert scaled.fully_plastic_approach == pytest.approx(s * base.fully_plastic_approach)
    assert scaled.yield_extra["fe_force_N"] == pytest.approx(s**2 * base.yield_extra["fe_force_N"])
    a0, a1 = base.yield_extra["analytic"], scaled.yield_extra["analytic"]
    assert a1["contact_radius_m"] == pytest.approx(s * a0["contact_radius_m"])
    assert a1["peak_pressure_Pa"] == a0["peak_pressure_Pa"]  # stresses do not scale
    assert scaled.fit_errors["loading_rms_relative"] == base.fit_errors["loading_rms_relative"]
    assert scaled.provenance["similarity"]["scale"] == pytest.approx(s)
    # the scaled parameter file is itself a valid one (written and read back)
    again = LawParams.from_dict(json.loads(scaled.to_json()))
    assert again.yield_approach == scaled.yield_approach


def test_analytic_yield_of_the_scaled_material_is_the_scaled_yield():
    """Independent of the law: Hertz incipient yield of spheres of radius r (geocontact.grain.hertz)
    is that of R scaled (force s^2, approach s), as the law's rescaling assumes."""
    from geocontact.grain.hertz import incipient_yield

    base = load_params(CALIBRATED)
    s = 0.05
    y0 = incipient_yield(base.material)
    y1 = incipient_yield(base.material.with_(radius=s * base.material.radius))
    assert y1.force == pytest.approx(s**2 * y0.force, rel=1e-9)
    assert y1.approach == pytest.approx(s * y0.approach, rel=1e-9)


def test_bad_radius_is_a_one_line_error(tmp_path, capsys):
    base = load_params(CALIBRATED)
    for bad in (0.0, -1.0, math.inf, math.nan):
        with pytest.raises(InputError, match="radius"):
            base.for_radius(bad)
    (tmp_path / "a.csv").write_text("approach_m\n0\n1e-5\n0\n")
    code = main(["law", "--params", CALIBRATED, "--approach", str(tmp_path / "a.csv"),
                 "--out", str(tmp_path / "f.csv"), "--radius", "-0.01"])
    err = capsys.readouterr().err.strip()
    assert code == 2 and err.count("\n") == 0 and "radius" in err


def test_law_cli_radius(tmp_path, capsys):
    base = load_params(CALIBRATED)
    s = 0.02
    d = np.array([0.0, 50, 20, 120, 0.0]) * base.yield_approach
    for name, values in (("big.csv", d), ("small.csv", s * d)):
        (tmp_path / name).write_text("approach_m\n" + "".join(f"{float(v)!r}\n" for v in values))
    assert main(["law", "--params", CALIBRATED, "--approach", str(tmp_path / "big.csv"),
                 "--out", str(tmp_path / "F.csv")]) == 0
    capsys.readouterr()
    assert main(["law", "--params", CALIBRATED, "--approach", str(tmp_path / "small.csv"),
                 "--out", str(tmp_path / "f.csv"),
                 "--radius", repr(s * base.material.radius), "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["radius_m"] == pytest.approx(s * base.material.radius)
    big = np.genfromtxt(tmp_path / "F.csv", delimiter=",", names=True, dtype=None,
                        encoding=None)
    small = np.genfromtxt(tmp_path / "f.csv", delimiter=",", names=True, dtype=None,
                          encoding=None)
    np.testing.assert_allclose(small["force_N"], s**2 * big["force_N"], rtol=1e-12, atol=0)
    np.testing.assert_allclose(small["residual_approach_m"], s * big["residual_approach_m"],
                               rtol=1e-12, atol=0)


def test_contact_arrays_with_radii_follow_each_grains_scaled_law():
    """The compiled path with one radius per contact equals the Python reference of each
    contact's rescaled law (for_radius), to the golden tolerance of the compiled path."""
    from geocontact.law import ContactArrays

    base = load_params(CALIBRATED)
    radii = np.array([0.1, 0.01, 0.037, 0.25, 2.0, 1e-3])
    many = ContactArrays(base, radii.size, radii=radii)
    single = [Contact(base.for_radius(r)) for r in radii]
    unit = _history(base, 1200) / base.material.radius  # approach / radius: the same shape
    dissipated = np.zeros(radii.size)
    for d in unit:
        forces, stiffnesses = many.step(d * radii)
        for i, c in enumerate(single):
            f, k = c.update(d * radii[i])
            assert forces[i] == pytest.approx(f, rel=1e-9, abs=1e-9 * c.params.yield_force)
            assert stiffnesses[i] == pytest.approx(k, rel=1e-9, abs=1e-9 * c.params.yield_force
                                                   / c.params.yield_approach)
    for i, c in enumerate(single):
        dissipated[i] = c.dissipated_energy
        assert many.residual_approach[i] == pytest.approx(
            c.state.residual_approach + c.state.ratchet_shift, rel=1e-9)
    np.testing.assert_allclose(many.dissipated_energy, dissipated, rtol=1e-8)
    with pytest.raises(InputError, match="radii"):
        ContactArrays(base, 3, radii=[0.1, -0.1, 0.1])
    with pytest.raises(InputError, match="radii"):
        ContactArrays(base, 3, radii=[0.1, 0.2])


@pytest.mark.parametrize(("r1", "r2"), [(0.01, 0.01), (0.004, 0.02), (1e-3, 7e-4)])
def test_law_hpp_owns_the_similarity_rule_of_pairs_and_walls(r1, r2):
    """The binding of law.hpp's pair_similarity and wall_similarity (used by the LAMMPS plugin,
    the kernel's radii and for_radius): two grains as identical spheres of r_eq = 2 r1 r2 /
    (r1 + r2), scaled by s = r_eq / R; a grain on a flat as the half of the pair of two such
    grains at d = 2 w (docs/model.md §10)."""
    from geocontact.law import _core

    big = 0.1
    s = 2 * r1 * r2 / ((r1 + r2) * big)
    pair = _core.pair_similarity(r1, r2, big)
    assert pair.scale == pytest.approx(s, rel=1e-15)
    assert (pair.approach, pair.force, pair.stiffness, pair.energy) == pytest.approx(
        (1 / s, s**2, s, s**3), rel=1e-15)
    wall = _core.wall_similarity(r1, big)
    w = r1 / big
    assert (wall.scale, wall.approach, wall.force, wall.stiffness, wall.energy) == pytest.approx(
        (w, 2 / w, w**2, 2 * w, 0.5 * w**3), rel=1e-15)
    # for_radius takes the same rule for two grains of radius r1
    base = load_params(CALIBRATED)
    assert base.for_radius(r1).provenance["similarity"]["scale"] == _core.pair_similarity(
        r1, r1, base.material.radius).scale
