"""The finite-strain option of the FE engine (fem.finite_strain, issue 15): the consistent tangent
against finite differences of the internal force, objectivity (a superposed finite rotation
rotates the stress and leaves the plastic state), the small-strain engine at small loads, the
energy balance, the identity of a finite-strain run and one-line errors."""

import math

import numpy as np
import pytest

from geocontact.errors import InputError
from geocontact.fem.finite_strain import (
    RR,
    RZ,
    TT,
    ZR,
    ZZ,
    FiniteStrainSolver,
    FiniteUpdate,
    block,
    sym_block,
    unblock,
)
from geocontact.fem.identity import FeRunIdentity
from geocontact.fem.mesh import build_mesh
from geocontact.fem.run import run_history
from geocontact.fem.solver import ContactSolver
from geocontact.grain.material import preset


@pytest.fixture(scope="module")
def material():
    return preset("reference")


@pytest.fixture(scope="module")
def mesh(material):
    return build_mesh(material.radius, 0.02 * material.radius, 0.05 * material.radius, "coarse")


def _large_deformation(solver, seed=0):
    """A smooth displacement field with strains of several per cent and rotations, plus noise."""
    rng = np.random.default_rng(seed)
    basis = solver.basis
    x, z = solver.mesh.doflocs
    radius = solver.material.radius
    u = np.zeros(solver.ndofs)
    dofs_r = np.concatenate([basis.nodal_dofs[0], basis.facet_dofs[0]])
    dofs_z = np.concatenate([basis.nodal_dofs[1], basis.facet_dofs[1]])
    u[dofs_r] = 0.05 * x * (1 - z / radius) + 0.02 * x * z / radius
    u[dofs_z] = -0.08 * (radius - z) * np.exp(-x / radius) + 0.01 * x
    u += 1e-4 * radius * rng.standard_normal(solver.ndofs)
    u[solver.axis_dofs] = 0.0
    return u


def assert_tangent_is_the_derivative(solver, radius, plastic, seeds=(0, 1)):
    """The solver's tangent times a random direction equals the central finite difference of
    its internal force, with an error falling as h^2 (a wrong tangent would stall at O(1))."""
    old = solver.initial_state()
    u = _large_deformation(solver, seed=seeds[0])
    update, _, local = solver._evaluate(old, u, elastic=False)
    if plastic:
        assert np.count_nonzero(update.status) > 100  # cone and apex returns are exercised
    stiffness = solver.stiffness(local)
    rng = np.random.default_rng(seeds[1])
    v = 1e-3 * radius * rng.standard_normal(solver.ndofs)
    v[solver.axis_dofs] = 0.0
    errors = []
    for h in (1e-3, 1e-4):
        plus = solver._evaluate(old, u + h * v, elastic=False, tangent=False)[1]
        minus = solver._evaluate(old, u - h * v, elastic=False, tangent=False)[1]
        fd = (plus - minus) / (2 * h)
        errors.append(np.linalg.norm(fd - stiffness @ v) / np.linalg.norm(fd))
    assert errors[1] < 1e-6
    assert errors[1] < 0.05 * errors[0]


@pytest.mark.parametrize("plastic", [False, True])
def test_tangent_is_the_derivative_of_the_internal_force(material, mesh, plastic):
    solver = FiniteStrainSolver(material, mesh, plastic=plastic)
    assert_tangent_is_the_derivative(solver, material.radius, plastic)


def _rotation(angle):
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, -s], [s, c]])


def test_rigid_rotation_gives_no_stress_and_rotates_a_plastic_state(material):
    """Finite-rotation patch test at the quadrature points of a patch: F = Q (a rotation about the
    hoop axis, up to 90 degrees) gives zero stress; a superposed rotation of a plastically
    deformed state rotates the Kirchhoff stress (tau -> Q tau Q^T) and leaves eqps and the
    return (status) as they are."""
    from geocontact.fem.plasticity import DruckerPrager

    model = DruckerPrager.from_material(material)
    points = 50
    angles = np.linspace(0.0, 0.5 * math.pi, points)
    q = np.stack([_rotation(a) for a in angles])  # (points, 2, 2)
    zero_cp, zero_eqps = np.zeros((4, points)), np.zeros(points)
    rigid = FiniteUpdate(model, unblock(q - np.eye(2), np.zeros(points)), zero_cp, zero_eqps)
    assert np.max(np.abs(rigid.stress)) < 1e-6 * model.yield_stress
    # a deformation that yields (compression along z with shear), then the same rotated
    rng = np.random.default_rng(2)
    h = np.zeros((5, points))
    h[ZZ] = -0.05 + 0.01 * rng.standard_normal(points)
    h[RR] = 0.01 * rng.standard_normal(points)
    h[RZ], h[ZR] = 0.03, -0.01
    h[TT] = 0.005
    first = FiniteUpdate(model, h, zero_cp, zero_eqps)
    assert np.all(first.status != 0)
    rotated_f = q @ (np.eye(2) + block(h))
    second = FiniteUpdate(model, unblock(rotated_f - np.eye(2), h[TT]), zero_cp, zero_eqps)
    tau1, tau2 = sym_block(first.stress), sym_block(second.stress)
    expected = q @ tau1 @ np.swapaxes(q, -1, -2)
    scale = np.max(np.abs(first.stress))
    assert np.max(np.abs(tau2 - expected)) < 1e-9 * scale
    assert np.allclose(second.stress[2], first.stress[2], rtol=0, atol=1e-9 * scale)
    assert np.allclose(second.eqps, first.eqps, rtol=1e-9, atol=0)
    assert np.array_equal(second.status, first.status)
    # the plastic metric C_p^-1 is a reference-configuration quantity: unchanged by Q
    assert np.allclose(second.cp, first.cp, atol=1e-9)


def test_small_strain_limit_is_the_small_strain_engine(material, mesh):
    """At a tiny displacement the finite-strain internal force is the small-strain B-bar one."""
    finite = FiniteStrainSolver(material, mesh, plastic=False)
    small = ContactSolver(material, mesh, plastic=False)
    u = 1e-7 * _large_deformation(finite)
    f_finite = finite._evaluate(finite.initial_state(), u, elastic=True, tangent=False)[1]
    f_small = small._response(small.initial_state(), u, elastic=True)[4]
    assert np.linalg.norm(f_finite - f_small) < 1e-6 * np.linalg.norm(f_small)


@pytest.fixture(scope="module")
def runs(material):
    """The reference grain to 10 Fy and back, small and finite strain, coarse mesh."""
    forces = [0.0, 27.6, 0.0]
    return {k: run_history(material, forces, mesh="coarse", steps_per_segment=4,
                           write_fields=False, kinematics=k) for k in ("small", "finite")}


def test_equal_to_small_strain_at_small_loads(runs):
    small, finite = runs["small"], runs["finite"]
    assert finite.summary["kinematics"] == "finite"
    assert finite.summary["identity"]["inputs"]["kinematics"] == "finite"
    a, b = small.curve, finite.curve
    # the load steps near Fy follow each run's probed yield force: compare at equal forces
    # along the loading branch, interpolating the finite-strain run
    top_a, top_b = np.argmax(a["force_N"]), np.argmax(b["force_N"])
    force = a["force_N"][1:top_a + 1]
    approach = np.interp(force, b["force_N"][:top_b + 1], b["approach_m"][:top_b + 1])
    exact = np.isin(force, b["force_N"])
    assert np.count_nonzero(exact) >= 4
    assert np.max(np.abs(approach / a["approach_m"][1:top_a + 1] - 1)[exact]) < 0.005
    fy_small, fy_finite = (r.summary["first_yield_force_N"] for r in (small, finite))
    assert abs(fy_finite / fy_small - 1) < 0.005
    cs, cf = small.summary["cycles"][0], finite.summary["cycles"][0]
    assert abs(cf["plastic_work_J"] / cs["plastic_work_J"] - 1) < 0.01
    assert abs(cf["residual_approach_m"] / cs["residual_approach_m"] - 1) < 0.01


def test_energy_balance(runs):
    """Work of the force = elastic energy + plastic dissipation along the whole cycle, to the
    accuracy of the trapezoidal work of the force on 4 steps per segment (0.6 %), the same
    as the small-strain engine's (whose dissipation is exact for the discrete increments)."""
    gaps = {}
    for name, result in runs.items():
        c = result.curve
        gaps[name] = (c["work_J"] - c["elastic_energy_J"] - c["plastic_dissipation_J"]) / np.max(
            c["work_J"])
    assert np.max(np.abs(gaps["finite"])) < 0.01
    assert np.max(np.abs(gaps["finite"] - gaps["small"])) < 5e-5
    c = runs["finite"].curve
    assert c["plastic_dissipation_J"][-1] > 0.5 * c["work_J"][-1]


def test_contact_pressure_is_on_the_current_area(material, mesh):
    """Finite strain divides the nodal contact force by the ring area of the current
    configuration: a homogeneous stretch lambda about the contact point scales every ring area by
    lambda^2 exactly; a radial stretch a alone gives the closed-form ring areas."""
    import dataclasses

    solver = FiniteStrainSolver(material, mesh)
    basis = solver.basis
    x, z = solver.mesh.doflocs
    dofs_r = np.concatenate([basis.nodal_dofs[0], basis.facet_dofs[0]])
    dofs_z = np.concatenate([basis.nodal_dofs[1], basis.facet_dofs[1]])
    stretch = 1.3
    u = np.zeros(solver.ndofs)
    u[dofs_r], u[dofs_z] = (stretch - 1) * x, (stretch - 1) * z
    areas = solver._tributary_areas(solver.candidate_points, u)
    assert np.allclose(areas, stretch**2 * solver.candidate_area, rtol=1e-10, atol=0.0)
    state = dataclasses.replace(solver.initial_state(), displacement=u)
    solver.contact_forces = lambda s: np.full(len(solver.candidate_r), 2.0)  # N per node
    r, pressure = solver.contact_pressure(state)
    assert np.allclose(r, stretch * solver.candidate_r)
    ring = solver.candidate_r > 0  # the axis node takes its neighbour's pressure
    assert np.allclose(pressure[ring], 2.0 / (stretch**2 * solver.candidate_area[ring]))
    # r -> a r, z unchanged: dA = 2 pi a r |(a t_r, t_z)| dS; on the hemisphere (r, z) =
    # R (sin t, 1 - cos t) its whole surface is 2 pi a R^2 int_0^pi/2 sin t sqrt(a^2 cos^2 t +
    # sin^2 t) dt, which the ring areas of all its nodes (a partition of unity) add up to
    from scipy.integrate import quad

    a = 1.2
    u[:] = 0.0
    u[dofs_r] = (a - 1) * x
    every = np.arange(solver.mesh.doflocs.shape[1])
    total = 2 * math.pi * a * material.radius**2 * quad(
        lambda t: math.sin(t) * math.sqrt(a**2 * math.cos(t) ** 2 + math.sin(t) ** 2), 0,
        math.pi / 2)[0]
    assert solver._tributary_areas(every).sum() == pytest.approx(
        2 * math.pi * material.radius**2, rel=1e-4)  # the reference hemisphere (P2 facets)
    assert solver._tributary_areas(every, u).sum() == pytest.approx(total, rel=1e-4)


def test_axis_node_takes_its_neighbours_pressure(material, mesh):
    """The axis node's ring area is zero up to round-off (measured 1.2e-14 m^2 against 1.8e-4
    on a coarse mesh at a/R = 0.16, which made a 709 sigma_c peak pressure): it must not be
    divided by, in either kinematics."""
    for kind in (ContactSolver, FiniteStrainSolver):
        solver = kind(material, mesh)
        area = solver.candidate_area.copy()
        assert solver.candidate_r[0] == 0.0 and area[0] < 1e-9 * area.max()
        area[0] = 1e-10 * area.max()  # round-off, as measured
        force = np.full(len(area), 1e-3)
        pressure = solver._pressure(force, area)
        assert pressure[0] == pressure[1] == pytest.approx(1e-3 / area[1])


def test_pressure_output_equals_small_strain_at_small_loads(runs):
    """The current-area pressure reduces to the small-strain output where strains are small."""
    peak = {k: float(np.max(r.curve["peak_pressure_Pa"])) for k, r in runs.items()}
    assert peak["finite"] == pytest.approx(peak["small"], rel=0.005)


def test_identity_and_errors(material):
    small = FeRunIdentity.of(material, [0.0, 10.0])
    finite = FeRunIdentity.of(material, [0.0, 10.0], kinematics="finite")
    contact = FeRunIdentity.of(material, [0.0, 10.0], mesh_rule="contact")
    assert len({small.key(), finite.key(), contact.key()}) == 3
    # the defaults are not written, so the keys of earlier runs stay as they were
    assert "kinematics" not in small.inputs() and "mesh_rule" not in small.inputs()
    with pytest.raises(InputError, match="^kinematics: unknown 'large'"):
        FeRunIdentity.of(material, [0.0, 10.0], kinematics="large")
    with pytest.raises(InputError, match="^mesh_rule: unknown 'x'"):
        FeRunIdentity.of(material, [0.0, 10.0], mesh_rule="x")


def test_finite_strain_components_are_consistent():
    """block/unblock round trip and the component names of the 5-vectors."""
    v = np.arange(5.0)[:, None] + 1.0
    m = block(v)
    assert m[0, 0, 0] == v[RR, 0] and m[0, 0, 1] == v[RZ, 0] and m[0, 1, 0] == v[ZR, 0]
    assert np.array_equal(unblock(m, v[TT]), v)
