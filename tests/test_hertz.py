"""Hertz contact, Huber's stress field and incipient Drucker-Prager yield (docs/model.md §4)."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import integrate

from geocontact.cli import main
from geocontact.grain.hertz import (
    contact_radius,
    drucker_prager_measure,
    hertz_approach,
    hertz_coefficient,
    hertz_force,
    hertz_stiffness,
    incipient_yield,
    peak_pressure,
    pressure_and_equivalent_stress,
    stress_field,
)
from geocontact.grain.material import Material, preset

POISSONS_RATIOS = [-0.5, 0.0, 0.25, 0.3, 0.45, 0.499]


@pytest.fixture
def reference() -> Material:
    return preset("reference")


# --- Hertz ---------------------------------------------------------------------------------


def test_hertz_formulas(reference):
    approach = np.array([1e-9, 1e-7, 1e-6, 1e-5])
    E_star, R_star = reference.effective_modulus, reference.effective_radius
    a = contact_radius(reference, approach)
    p0 = peak_pressure(reference, approach)
    force = hertz_force(reference, approach)
    np.testing.assert_allclose(a, np.sqrt(R_star * approach), rtol=1e-14)
    np.testing.assert_allclose(p0, 2 * E_star * a / (math.pi * R_star), rtol=1e-14)
    np.testing.assert_allclose(force, 4 / 3 * E_star * math.sqrt(R_star) * approach**1.5,
                               rtol=1e-14)
    # Independent: the force is the integral of the Hertz pressure, F = (2/3) pi a^2 p0.
    np.testing.assert_allclose(force, 2 / 3 * math.pi * a**2 * p0, rtol=1e-13)
    assert hertz_coefficient(reference) == pytest.approx(force[0] / approach[0] ** 1.5, rel=1e-14)


def test_hertz_no_contact_and_scalars(reference):
    for func in (hertz_force, contact_radius, peak_pressure, hertz_stiffness):
        assert func(reference, -1e-6) == 0.0
        assert func(reference, 0.0) == 0.0
        assert isinstance(func(reference, 1e-6), float)
    assert hertz_approach(reference, -5.0) == 0.0


def test_hertz_approach_inverts_force(reference):
    approach = np.geomspace(1e-10, 1e-3, 50)
    np.testing.assert_allclose(hertz_approach(reference, hertz_force(reference, approach)),
                               approach, rtol=1e-13)
    force = np.geomspace(1e-3, 1e5, 50)
    np.testing.assert_allclose(hertz_force(reference, hertz_approach(reference, force)), force,
                               rtol=1e-13)


def test_stiffness_is_derivative_of_force(reference):
    for approach in (1e-8, 1e-6, 1e-4):
        h = 1e-5 * approach
        force_above, force_below = (hertz_force(reference, approach + sign * h) for sign in (1, -1))
        numerical = (force_above - force_below) / (2 * h)
        assert hertz_stiffness(reference, approach) == pytest.approx(numerical, rel=1e-8)


# --- Huber's stress field: closed-form checks ------------------------------------------------


def axis_stresses(z, nu):
    """Johnson eq. 3.46: on the axis r = 0 (a = 1, p0 = 1)."""
    sigma_r = -((1 + nu) * (1 - z * np.arctan(1 / z)) - 0.5 / (1 + z**2))
    return sigma_r, -1 / (1 + z**2)


@pytest.mark.parametrize("nu", POISSONS_RATIOS)
def test_axis_matches_johnson_3_46(nu):
    z = np.concatenate([np.geomspace(1e-8, 1e3, 200), np.linspace(0.01, 3, 100)])
    expected_r, expected_z = axis_stresses(z, nu)
    for rho in (0.0, 1e-9):  # on the axis and a hair off it (the 0/0 of eq. 3.45)
        field = stress_field(rho, z, nu)
        np.testing.assert_allclose(field.sigma_r, expected_r, rtol=1e-10, atol=1e-15)
        np.testing.assert_allclose(field.sigma_theta, expected_r, rtol=1e-10, atol=1e-15)
        np.testing.assert_allclose(field.sigma_z, expected_z, rtol=1e-10)
        np.testing.assert_allclose(field.tau_rz, 0.0, atol=1e-8)
    field = stress_field(0.0, 0.0, nu)  # the centre of the contact
    assert field.sigma_r == pytest.approx(-(1 + 2 * nu) / 2, rel=1e-14)
    assert field.sigma_z == pytest.approx(-1.0, rel=1e-14)


@pytest.mark.parametrize("nu", POISSONS_RATIOS)
def test_surface_matches_johnson_3_44(nu):
    # inside the contact (Johnson eq. 3.44)
    r = np.concatenate([np.geomspace(1e-4, 0.5, 60), 1 - np.geomspace(1e-8, 0.5, 60)])
    root = np.sqrt(1 - r**2)
    # (1 - root^3)/r^2 rewritten with 1 - root^2 = r^2 to avoid cancellation at small r
    edge_term = (1 - 2 * nu) / 3 * (1 + root + root**2) / (1 + root)
    field = stress_field(r, 0.0, nu)
    np.testing.assert_allclose(field.sigma_r, edge_term - root, rtol=1e-10, atol=1e-14)
    np.testing.assert_allclose(field.sigma_theta, -edge_term - 2 * nu * root, rtol=1e-10,
                               atol=1e-14)
    np.testing.assert_allclose(field.sigma_z, -root, rtol=1e-10)
    np.testing.assert_array_equal(field.tau_rz, 0.0)
    # outside: pure shear sigma_r = -sigma_theta = (1 - 2 nu) a^2 / (3 r^2), sigma_z = 0
    r = np.concatenate([1 + np.geomspace(1e-10, 1, 60), np.geomspace(2, 1e4, 60)])
    field = stress_field(r, 0.0, nu)
    np.testing.assert_allclose(field.sigma_r, (1 - 2 * nu) / (3 * r**2), rtol=1e-10)
    np.testing.assert_allclose(field.sigma_theta, -(1 - 2 * nu) / (3 * r**2), rtol=1e-10)
    np.testing.assert_array_equal(field.sigma_z, 0.0)
    np.testing.assert_array_equal(field.tau_rz, 0.0)


def test_contact_edge_is_continuous():
    nu = 0.25
    at_edge = np.array(stress_field(1.0, 0.0, nu))
    np.testing.assert_allclose(at_edge, [(1 - 2 * nu) / 3, -(1 - 2 * nu) / 3, 0.0, 0.0],
                               atol=1e-15)
    angle = np.linspace(0, math.pi / 2, 7)
    for distance in (1e-6, 1e-10, 1e-14):
        field = np.array(stress_field(1 + distance * np.cos(angle), distance * np.sin(angle), nu))
        # the field is Hoelder-1/2 continuous at the edge (sqrt(1 - r^2) on the surface)
        assert np.all(np.abs(field - at_edge[:, None]) < 5 * math.sqrt(distance))
        field = np.array(stress_field(1 - distance * np.cos(angle), distance * np.sin(angle), nu))
        assert np.all(np.abs(field - at_edge[:, None]) < 5 * math.sqrt(distance))


# --- Huber's stress field: independent check by superposing Boussinesq point loads ----------


def boussinesq(r, z, nu):
    """Stresses per unit normal point load at the origin (Johnson section 3.2, compression < 0).

    Written with (1/r^2)(1 - z/rho) = 1/(rho (rho + z)) so that r = 0 needs no limit.
    """
    rho = math.hypot(r, z)
    c = (1 - 2 * nu) / (rho * (rho + z))
    sigma_r = (c - 3 * z * r**2 / rho**5) / (2 * math.pi)
    sigma_theta = -(1 - 2 * nu) * (1 / (rho * (rho + z)) - z / rho**3) / (2 * math.pi)
    sigma_z = -3 * z**3 / (2 * math.pi * rho**5)
    tau_rz = -3 * r * z**2 / (2 * math.pi * rho**5)
    return sigma_r, sigma_theta, sigma_z, tau_rz


def superposed_hertz_field(x, z, nu):
    """sigma_r, sigma_theta, sigma_z, tau_rz at (x, 0, z) under p = sqrt(1 - s^2) on s < 1.

    Each point-load field is rotated from its own cylindrical axes to the global ones (on the
    x-axis sigma_r = sigma_xx, sigma_theta = sigma_yy, tau_rz = tau_xz). s = sin t removes the
    square-root edge of the pressure: p s ds = cos^2 t sin t dt.
    """

    def integrand(psi, t):
        s = math.sin(t)
        dx, dy = x - s * math.cos(psi), -s * math.sin(psi)
        sr, st_, sz, trz = boussinesq(math.hypot(dx, dy), z, nu)
        phi = math.atan2(dy, dx)
        c2, s2 = math.cos(phi) ** 2, math.sin(phi) ** 2
        weight = math.cos(t) ** 2 * s
        return weight * np.array([sr * c2 + st_ * s2, sr * s2 + st_ * c2, sz, trz * math.cos(phi)])

    def over_psi(t):
        # the field is symmetric in y: integrate half the circle and double
        return 2 * integrate.quad_vec(lambda psi: integrand(psi, t), 0, math.pi,
                                      epsabs=1e-11)[0]

    return integrate.quad_vec(over_psi, 0, math.pi / 2, epsabs=1e-10)[0]


@pytest.mark.parametrize(
    "r, z", [(0.0, 0.5), (0.5, 0.5), (0.5, 0.1), (0.9, 0.3), (1.3, 0.4), (0.4, 1.2)]
)
def test_matches_superposed_boussinesq(r, z):
    nu = 0.25
    expected = superposed_hertz_field(r, z, nu)
    np.testing.assert_allclose(np.array(stress_field(r, z, nu)), expected, atol=1e-9)


def test_far_field_is_boussinesq():
    """Far away the contact acts as a point load P = (2/3) pi a^2 p0 (tests the 1/u series)."""
    nu = 0.3
    for r, z in [(300.0, 400.0), (0.0, 1e3), (2e3, 1.0)]:
        expected = (2 * math.pi / 3) * np.array(boussinesq(r, z, nu))
        scale = np.max(np.abs(expected))
        np.testing.assert_allclose(np.array(stress_field(r, z, nu)), expected,
                                   atol=1e-4 * scale)


# --- no NaN anywhere ---------------------------------------------------------------------------


def test_no_nan_on_grid_through_special_points():
    special = [0.0, 1e-300, 1e-12, 1e-6, 1 - 1e-12, 1.0, 1 + 1e-12, 3.0, 1e6]
    axis = np.unique(np.concatenate([special, np.linspace(0, 3, 301)]))
    rho, zeta = np.meshgrid(axis, axis, indexing="ij")
    for nu in POISSONS_RATIOS:
        field = np.array(stress_field(rho, zeta, nu))
        assert np.all(np.isfinite(field))
        assert np.all(np.isfinite(drucker_prager_measure(stress_field(rho, zeta, nu), 1.0)))


coordinate = st.one_of(
    st.floats(0, 1e4, allow_nan=False),
    st.floats(0, 1e-6),
    st.floats(1 - 1e-6, 1 + 1e-6),
    st.sampled_from([0.0, 1.0]),
)


@settings(max_examples=400, deadline=None)
@given(r=coordinate, z=coordinate, nu=st.floats(-0.99, 0.499))
def test_field_is_finite_and_bounded(r, z, nu):
    field = np.array(stress_field(r, z, nu))
    assert np.all(np.isfinite(field))
    assert np.all(np.abs(field) <= 2.0)  # |sigma| <= (1 + 2|nu|)/2 + 1 everywhere


def test_negative_coordinates_are_rejected():
    with pytest.raises(ValueError, match="r_over_a"):
        stress_field(-0.1, 0.5, 0.3)


def test_equivalent_stress_of_uniaxial_compression():
    field = stress_field(0.0, 0.0, 0.5 - 1e-12)  # incompressible: hydrostatic at the centre
    p, q = pressure_and_equivalent_stress(field)
    assert p == pytest.approx(1.0, rel=1e-9) and q == pytest.approx(0.0, abs=1e-9)


# --- incipient yield -----------------------------------------------------------------------


def jackson_green_von_mises(nu):
    """p0_y / sigma_y fit of Jackson & Green (2005, J. Tribol. 127) for the von Mises criterion."""
    return 1.30075 + 0.87825 * nu + 0.54373 * nu**2


def test_von_mises_limit():
    first = incipient_yield(preset("von-mises"))  # beta = 0, nu = 0.3
    ratio = first.peak_pressure / 200e6
    assert 1.60 <= ratio <= 1.62  # Johnson (1985) p. 155: 1.60 Y at 0.48 a
    assert ratio == pytest.approx(jackson_green_von_mises(0.3), rel=1e-3)
    assert first.r_over_a == 0.0
    assert first.z_over_a == pytest.approx(0.48, abs=0.005)
    assert not first.at_surface
    # on the axis q = |sigma_z - sigma_r| (Johnson eq. 3.46), so C is its maximum
    z = np.linspace(0.3, 0.7, 40001)
    sigma_r, sigma_z = axis_stresses(z, 0.3)
    assert first.dp_factor == pytest.approx(np.max(sigma_r - sigma_z), rel=1e-9)


def test_reference_case(reference):
    first = incipient_yield(reference)
    a = first.contact_radius
    assert first.force == hertz_force(reference, first.approach)  # same formula, continuous
    assert a == pytest.approx(contact_radius(reference, first.approach), rel=1e-14)
    assert first.peak_pressure == pytest.approx(peak_pressure(reference, first.approach),
                                                rel=1e-14)
    assert first.peak_pressure * first.dp_factor == pytest.approx(10e6, rel=1e-14)
    assert first.r_over_a == 0.0 and 0.5 < first.z_over_a < 0.8
    data = first.to_dict()
    assert data["force_N"] == first.force and data["location_z_over_a"] == first.z_over_a


@pytest.mark.parametrize("nu, friction_angle", [(0.25, 30.0), (0.1, 45.0), (0.25, 48.0),
                                                (0.4, 20.0), (0.25, 60.0)])
def test_search_is_global(nu, friction_angle):
    """No point of a dense grid of the half-space beats the reported maximum."""
    material = preset("reference").with_(poissons_ratio=nu, friction_angle_deg=friction_angle)
    first = incipient_yield(material)
    rho, zeta = np.meshgrid(np.linspace(0, 3, 401), np.linspace(0, 3, 401), indexing="ij")
    grid = drucker_prager_measure(stress_field(rho, zeta, nu), material.tan_beta)
    assert first.dp_factor >= grid.max() - 1e-12
    at_location = drucker_prager_measure(stress_field(first.r_over_a, first.z_over_a, nu),
                                         material.tan_beta)
    assert at_location == pytest.approx(first.dp_factor, rel=1e-14)


def test_large_friction_angle_yields_at_contact_edge(reference):
    material = reference.with_(friction_angle_deg=60.0)
    first = incipient_yield(material)
    assert first.at_surface and first.z_over_a == 0.0
    assert first.r_over_a == pytest.approx(1.0, abs=1e-6)
    # the edge is in pure shear (1 - 2 nu)/3 (eq. 3.44): p = 0, q = (1 - 2 nu)/sqrt(3)
    nu = material.poissons_ratio
    assert first.dp_factor == pytest.approx(
        (1 - 2 * nu) / math.sqrt(3) / material.cohesion_factor, rel=1e-12
    )
    assert not incipient_yield(reference).at_surface


def test_first_yield_jumps_from_axis_to_edge():
    """For nu = 0.25 the maximum leaves the axis (z ~ 0.81 a) for the contact edge at 49.06 deg."""
    below = incipient_yield(preset("reference").with_(friction_angle_deg=49.0))
    above = incipient_yield(preset("reference").with_(friction_angle_deg=49.1))
    assert below.r_over_a == 0.0 and below.z_over_a == pytest.approx(0.81, abs=0.01)
    assert above.at_surface and above.r_over_a == pytest.approx(1.0, abs=1e-6)


def test_scaling_with_strength_and_radius(reference):
    base = incipient_yield(reference)
    stronger = incipient_yield(reference.with_(compressive_yield_stress=3 * 10e6))
    assert stronger.force / base.force == pytest.approx(27.0, rel=1e-9)
    assert stronger.approach / base.approach == pytest.approx(9.0, rel=1e-9)
    larger = incipient_yield(reference.with_(radius=0.4))
    assert larger.force / base.force == pytest.approx(16.0, rel=1e-9)
    assert larger.approach / base.approach == pytest.approx(4.0, rel=1e-9)
    assert larger.contact_radius / base.contact_radius == pytest.approx(4.0, rel=1e-9)


# --- command line --------------------------------------------------------------------------


def test_cli_yield_json(capsys, reference):
    assert main(["yield", "--material", "reference", "--json"]) == 0
    document = json.loads(capsys.readouterr().out)
    first = incipient_yield(reference)
    assert document["material"] == reference.to_dict()
    for key in ("force_N", "approach_m", "contact_radius_m", "peak_pressure_Pa",
                "location_r_over_a", "location_z_over_a", "dp_factor"):
        assert document[key] == pytest.approx(first.to_dict()[key], rel=1e-15)


def test_cli_yield_table(capsys):
    assert main(["yield", "--material", "reference"]) == 0
    out = capsys.readouterr().out
    assert "Fy" in out and "N" in out


@pytest.mark.parametrize(
    "text, field",
    [("[material]\nyoungs_modulus = ", "malformed TOML"),
     (preset("reference").to_toml().replace("poissons_ratio = 0.25", "poissons_ratio = 0.7"),
      "poissons_ratio")],
)
def test_cli_yield_bad_material(capsys, tmp_path, text, field):
    path = tmp_path / "bad.toml"
    path.write_text(text)
    assert main(["yield", "--material", str(path)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: ") and err.count("\n") == 1 and field in err
