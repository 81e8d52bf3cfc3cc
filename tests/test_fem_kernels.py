"""The compiled element kernels and factorisers (fem.compiled, issue 36): the finite-strain and
the small-strain kernels equal to the numpy paths of fem.finite_strain and fem.solver to round-off
at every point and in every element matrix (cone and apex returns, each volumetric treatment,
from a virgin and from a plastic state), their tangent the derivative of their internal force
(central differences), the bordered system and its factorisers (UMFPACK, KLU, PARDISO, SuperLU)
the same solution, and load steps and runs solved with them the same as with the numpy path
within the Newton tolerance."""

import hashlib
from pathlib import Path

import numpy as np
import pytest
from conftest import YIELD_FIXED
from test_fem_finite_strain import _large_deformation, assert_tangent_is_the_derivative

from geocontact.errors import InputError
from geocontact.fem.compiled import (
    CompiledFiniteStrainSolver,
    CompiledSmallStrainSolver,
    available_factorisers,
    compiled_solver,
    kernels,
    make_factoriser,
)
from geocontact.fem.finite_strain import FiniteStrainSolver
from geocontact.fem.identity import FeRunIdentity, compiled_code_hash, difference
from geocontact.fem.mesh import build_mesh
from geocontact.fem.plasticity import APEX, CONE
from geocontact.fem.run import run_history
from geocontact.fem.solver import ContactSolver
from geocontact.grain.material import preset

ROUND_OFF = 1e-13  # relative to the largest entry of each output


@pytest.fixture(scope="module")
def material():
    return preset("reference")


@pytest.fixture(scope="module")
def mesh(material):
    return build_mesh(material.radius, 0.02 * material.radius, 0.05 * material.radius, "coarse")


def _close(numpy_value, compiled_value, scale=None):
    scale = np.max(np.abs(numpy_value)) if scale is None else scale
    return np.max(np.abs(numpy_value - compiled_value)) <= ROUND_OFF * scale


def _both(material, mesh, **kwargs):
    return (FiniteStrainSolver(material, mesh, **kwargs),
            compiled_solver(material, mesh, factoriser="superlu", **kwargs))


def _compare(reference, compiled, old, u, *, elastic=False):
    a, force_a, local_a = reference._evaluate(old, u, elastic=elastic)
    b, force_b, local_b = compiled._evaluate(old, u, elastic=elastic)
    assert np.array_equal(a.status, b.status)
    for numpy_value, compiled_value in ((a.stress, b.stress), (a.eqps, b.eqps),
                                        (force_a, force_b), (local_a, local_b)):
        assert _close(numpy_value, compiled_value)
    # C_p^-1 - I and the plastic strain increment are differences (zero where elastic): their
    # round-off is that of the identity and of the strain
    assert _close(a.cp, b.cp, 1.0)
    assert _close(a.trial_strain - a.elastic_strain, b.plastic_strain,
                  np.max(np.abs(a.trial_strain)))
    return a


@pytest.mark.parametrize("volumetric", [(True, 1), (True, 0), (False, 0)])
def test_kernels_equal_the_numpy_path(material, mesh, volumetric):
    bbar, order = volumetric
    reference, compiled = _both(material, mesh, bbar=bbar, volumetric_order=order)
    old = reference.initial_state()
    u = _large_deformation(reference)
    assert np.count_nonzero(_compare(reference, compiled, old, u).status == APEX) > 1000
    # a hundredth of it: mostly cone returns
    first = _compare(reference, compiled, old, 0.01 * u)
    assert np.count_nonzero(first.status == CONE) > 1000
    assert np.count_nonzero(first.status == APEX) > 0
    _compare(reference, compiled, old, u, elastic=True)
    # from the plastic state just reached (C_p^-1 != I, eqps > 0), loaded further
    plastic = reference.initial_state()
    plastic.strain, plastic.eqps = first.cp, first.eqps
    _compare(reference, compiled, plastic, 0.011 * u)
    _compare(reference, compiled, plastic, 0.009 * u)


def test_kernels_equal_the_numpy_path_for_von_mises(mesh):
    material = preset("von-mises")  # tan(beta) = 0: no apex
    reference, compiled = _both(material, mesh)
    first = _compare(reference, compiled, reference.initial_state(),
                     0.1 * _large_deformation(reference))
    assert np.count_nonzero(first.status == CONE) > 1000


@pytest.mark.parametrize("plastic", [False, True])
def test_compiled_tangent_is_the_derivative_of_the_internal_force(material, mesh, plastic):
    solver = compiled_solver(material, mesh, plastic=plastic)
    assert_tangent_is_the_derivative(solver, material.radius, plastic, seeds=(3, 4))


def _plastic_system(material, mesh):
    solver = compiled_solver(material, mesh)
    old = solver.initial_state()
    local = solver._evaluate(old, 0.01 * _large_deformation(solver), elastic=False)[2]
    active = np.zeros(len(solver.candidate_dofs), dtype=bool)
    active[:5] = True
    reduced = solver._reduced(active)
    return solver, local, reduced


def test_bordered_system_is_the_engines(material, mesh):
    solver, local, reduced = _plastic_system(material, mesh)
    expected = FiniteStrainSolver._bordered_system(solver, local, reduced).toarray()
    assembled = solver._bordered_system(local, reduced).toarray()
    assert np.max(np.abs(assembled - expected)) <= ROUND_OFF * np.max(np.abs(expected))


@pytest.mark.parametrize("scale", [0.01, 0.03, 1.0])
def test_finite_strain_tangent_is_symmetric(material, mesh, scale):
    """With associated flow the return mapping's D^ep is symmetric, so the Kirchhoff stress is
    locally the gradient of a potential of eps_e^trial = ln(F C_p^-1 F^T) / 2 at fixed C_p; the
    consistent tangent of the exponential-map update is then the Hessian of that potential in F
    (Simo 1992), symmetric, F-bar included (variational). Checked from the virgin state and from
    a plastic one (C_p != I), cone and apex returns (scale 1: mostly apex)."""
    solver = compiled_solver(material, mesh)
    u = scale * _large_deformation(solver)
    old = solver.initial_state()
    for _ in range(2):
        update, _, local = solver._evaluate(old, u, elastic=False)
        assert np.count_nonzero(update.status) > 100
        k = solver.stiffness(local)
        assert abs(k - k.T).max() <= 1e-14 * abs(k).max()
        old = solver.initial_state()
        old.strain, old.eqps = update.cp, update.eqps
        u = 1.2 * u


@pytest.mark.parametrize("name", [n for n in available_factorisers() if n != "superlu"])
def test_factorisers_solve_the_bordered_system(material, mesh, name):
    solver, local, reduced = _plastic_system(material, mesh)
    matrix = solver._bordered_system(local, reduced)
    factoriser = make_factoriser(name, reduced.indptr, reduced.indices)
    rng = np.random.default_rng(5)
    for scale in (1.0, 2.0):  # the second factorisation reuses the symbolic analysis
        a = matrix.copy()
        a.data = a.data * (1.0 + 0.1 * scale * rng.random(a.nnz))
        if name in ("cholmod", "cholmod-simplicial", "pardiso-sym"):  # symmetric (the tangent is)
            a = ((a + a.T) / 2).tocsc()
            a.sort_indices()
        assert factoriser.factor(a.data)
        rhs = rng.standard_normal(a.shape[0])
        x = factoriser.solve(rhs)
        assert np.linalg.norm(a @ x - rhs) <= 1e-10 * np.linalg.norm(rhs) * np.abs(a).max()
        assert np.allclose(x, np.linalg.solve(a.toarray(), rhs), rtol=1e-8, atol=1e-14)


def test_factoriser_reports_a_singular_matrix(material, mesh):
    if "umfpack" not in available_factorisers():
        pytest.skip("geocontact.fem._sparse_lu not built (no SuiteSparse)")
    _, _, reduced = _plastic_system(material, mesh)
    for name in ("umfpack", "klu"):
        factoriser = make_factoriser(name, reduced.indptr, reduced.indices)
        assert not factoriser.factor(np.zeros(reduced.nnz))
    with pytest.raises(ValueError, match="factoriser must be one of"):
        compiled_solver(material, mesh, factoriser="lapack")


@pytest.mark.parametrize("name", available_factorisers())
def test_load_steps_equal_the_numpy_path(name):
    """0 -> 3 load steps past first yield -> back to 0 with the weak grain (plastic, finite
    strain): the same forces, approaches and plastic work as the numpy path within the Newton
    tolerance."""
    material = preset("reference-weak")
    radius = material.radius
    mesh = build_mesh(radius, 0.02 * radius, 0.05 * radius, "coarse")
    reference = FiniteStrainSolver(material, mesh, force_scale=40.0)
    compiled = compiled_solver(material, mesh, factoriser=name, force_scale=40.0)
    assert isinstance(compiled, CompiledFiniteStrainSolver)
    states = {"numpy": reference.initial_state(), "compiled": compiled.initial_state()}
    for force in (10.0, 25.0, 40.0, 15.0):
        states["numpy"] = reference.solve_step(states["numpy"], force)
        states["compiled"] = compiled.solve_step(states["compiled"], force)
        a, b = states["numpy"], states["compiled"]
        assert abs(b.top_displacement / a.top_displacement - 1.0) < 1e-7
        assert np.array_equal(a.active, b.active)
    assert a.plastic_dissipation > 0.0
    assert abs(b.plastic_dissipation / a.plastic_dissipation - 1.0) < 1e-6
    assert np.max(np.abs(b.eqps - a.eqps)) <= 1e-6 * np.max(a.eqps)


def test_identity_of_the_compiled_kernels(material):
    from geocontact.fem import identity

    numpy_path = FeRunIdentity.of(material, [0.0, 10.0], kinematics="finite", kernels="numpy")
    compiled = FeRunIdentity.of(material, [0.0, 10.0], kinematics="finite")
    assert numpy_path.key() != compiled.key()
    # the default (compiled, with the node contact) is not written, numpy is
    assert "kernels" not in compiled.inputs()
    assert numpy_path.inputs()["kernels"] == "numpy"
    assert "numpy kernels" in numpy_path.describe()
    assert "kernels" not in compiled.describe()
    assert (identity.recorded_kernels(compiled.to_dict()),
            identity.recorded_kernels(numpy_path.to_dict())) == ("compiled", "numpy")
    with pytest.raises(InputError, match="^kernels: unknown 'fortran'"):
        FeRunIdentity.of(material, [0.0, 10.0], kinematics="finite", kernels="fortran")
    # the compiled code (fem/compiled.py and the C++ the module was built from) is part of a
    # compiled run's identity only
    assert "compiled_code" not in numpy_path.to_dict()
    assert compiled.to_dict()["compiled_code"] == compiled_code_hash()
    assert kernels().SOURCE_HASH == hashlib.sha256(
        (Path(identity.__file__).parent / "_kernels.cpp").read_bytes()).hexdigest()
    small = FeRunIdentity.of(material, [0.0, 10.0], kernels="numpy")
    assert small.inputs()["kernels"] == "numpy"
    assert small.key() != FeRunIdentity.of(material, [0.0, 10.0]).key()
    for kinematics in ("small", "finite"):
        with pytest.raises(InputError, match="^kernels: 'compiled' is the engine with the node "
                                             "contact"):
            FeRunIdentity.of(material, [0.0, 10.0], kinematics=kinematics, contact="facet",
                             kernels="compiled")


def test_run_history_with_compiled_kernels_equals_the_numpy_path(material):
    """The reference grain to 10 Fy and back (coarse, 4 steps per segment; the run of
    tests/test_fem_finite_strain.py) through run_history on both paths: the same steps, and the
    curve and the cycle's residual approach and plastic work within the Newton tolerance."""
    forces = [0.0, 27.6, 0.0]
    runs = {k: run_history(material, forces, mesh="coarse", steps_per_segment=4,
                           write_fields=False, kinematics="finite", kernels=k)
            for k in ("numpy", "compiled")}
    a, b = runs["numpy"], runs["compiled"]
    assert "compiled_code" in b.summary["identity"] and "kernels" not in b.summary["identity"][
        "inputs"]  # the default
    # the same schedule (its steps near Fy follow the probed yield force, equal to round-off)
    assert np.allclose(a.curve["force_N"], b.curve["force_N"], rtol=1e-9, atol=0.0)
    approach = np.max(np.abs(b.curve["approach_m"] - a.curve["approach_m"]))
    assert approach <= 1e-6 * np.max(a.curve["approach_m"])
    ca, cb = a.summary["cycles"][0], b.summary["cycles"][0]
    assert abs(cb["residual_approach_m"] / ca["residual_approach_m"] - 1) < 1e-5
    assert abs(cb["plastic_work_J"] / ca["plastic_work_J"] - 1) < 1e-6


# --- small strain ----------------------------------------------------------------------------
def _small_pair(material, mesh, **kwargs):
    return ContactSolver(material, mesh, **kwargs), CompiledSmallStrainSolver(material, mesh,
                                                                              **kwargs)


def _small_compare(reference, compiled, old, u, *, elastic=False):
    """The numpy path's response at ``u`` (stress, strain, eqps, status, internal force and
    element matrices) against the compiled one's; returns the numpy path's status."""
    stress, strain, eqps, status, force, tangent = reference._response(old, u, elastic=elastic)
    local = reference.element_matrices(tangent)
    result = compiled._response(old, u, elastic=elastic)
    assert np.array_equal(status, result[3])
    # a strain is a difference of nodal displacements (B u): its round-off is that of
    # sum |B| |u|, a few hundred times the strain here, and the stress and eqps inherit it
    magnified = np.einsum("jceq,je->ceq", np.abs(reference.B),
                          np.abs(u[reference.element_dofs]))
    condition = max(1.0, np.max(magnified) / np.max(np.abs(strain)))
    for numpy_value, compiled_value in ((stress, result[0]), (strain, result[1]),
                                        (eqps, result[2])):
        assert _close(numpy_value, compiled_value, condition * np.max(np.abs(numpy_value)))
    for numpy_value, compiled_value in ((force, result[4]),
                                        (local, compiled.element_matrices(result[5]))):
        assert _close(numpy_value, compiled_value)
    return status


def _small_strain_field(solver):
    """A smooth field with strains of ~1e-3 and noise: the reference grain mostly on the cone
    (ten times it: mostly at the apex)."""
    return 0.01 * _large_deformation(solver)


@pytest.mark.parametrize("volumetric", [(True, 0), (True, 1), (False, 0)])
def test_small_strain_kernels_equal_the_numpy_path(material, mesh, volumetric):
    """Virgin and plastic states, cone and apex returns, the elastic predictor: stresses,
    strains, plastic strain, internal force and element matrices to round-off."""
    bbar, order = volumetric
    reference, compiled = _small_pair(material, mesh, bbar=bbar, volumetric_order=order)
    old = reference.initial_state()
    u = _small_strain_field(reference)
    assert np.count_nonzero(_small_compare(reference, compiled, old, 10.0 * u) == APEX) > 1000
    status = _small_compare(reference, compiled, old, u)
    assert np.count_nonzero(status == CONE) > 1000
    assert np.count_nonzero(status == APEX) > 0
    _small_compare(reference, compiled, old, u, elastic=True)
    # from the plastic state just reached (stress, strain and eqps > 0), loaded further
    stress, strain, eqps = reference._response(old, u, elastic=False)[:3]
    plastic = reference.initial_state()
    plastic.stress, plastic.strain, plastic.eqps = stress, strain, eqps
    assert np.max(eqps) > 0.0
    assert np.count_nonzero(_small_compare(reference, compiled, plastic, 1.1 * u) == CONE) > 100
    _small_compare(reference, compiled, plastic, 0.9 * u)  # unloading: elastic returns


def test_small_strain_kernels_equal_the_numpy_path_for_von_mises(mesh):
    material = preset("von-mises")  # tan(beta) = 0: no apex
    reference, compiled = _small_pair(material, mesh)
    status = _small_compare(reference, compiled, reference.initial_state(),
                            0.1 * _large_deformation(reference))
    assert np.count_nonzero(status == CONE) > 1000


@pytest.mark.parametrize("plastic", [False, True])
def test_compiled_small_strain_tangent_is_the_derivative_of_the_internal_force(material, mesh,
                                                                             plastic):
    """K v against the central difference of the internal force along v, its error falling as
    h^2 (a wrong tangent would stall at O(1)); plastic: from a plastic state, loaded further."""
    solver = CompiledSmallStrainSolver(material, mesh, plastic=plastic)
    old = solver.initial_state()
    u = _small_strain_field(solver)
    if plastic:
        stress, strain, eqps, status = solver._response(old, u, elastic=False)[:4]
        assert np.count_nonzero(status) > 1000
        old.stress, old.strain, old.eqps = stress, strain, eqps
        u = 1.2 * u
    _, _, _, status, _, local = solver._evaluate(old, u, plastic=plastic, tangent=True)
    if plastic:
        assert np.count_nonzero(status == CONE) > 1000
    stiffness = solver.stiffness(local)
    v = 1e-3 * np.max(np.abs(u)) * np.random.default_rng(7).standard_normal(solver.ndofs)
    v[solver.axis_dofs] = 0.0
    errors = []
    for h in (1e-2, 1e-3):
        plus = solver._evaluate(old, u + h * v, plastic=plastic, tangent=False)[4]
        minus = solver._evaluate(old, u - h * v, plastic=plastic, tangent=False)[4]
        fd = (plus - minus) / (2 * h)
        errors.append(np.linalg.norm(fd - stiffness @ v) / np.linalg.norm(fd))
    assert errors[1] < 1e-6
    if plastic:  # the cone's normal turns with the stress: O(h^2)
        assert errors[1] < 0.05 * errors[0]
    else:  # linear: exact to round-off
        assert errors[0] < 1e-9


def test_small_strain_bordered_system_is_the_engines(material, mesh):
    solver = CompiledSmallStrainSolver(material, mesh)
    local = solver._response(solver.initial_state(), _small_strain_field(solver),
                             elastic=False)[5]
    active = np.zeros(len(solver.candidate_dofs), dtype=bool)
    active[:5] = True
    reduced = solver._reduced(active)
    expected = ContactSolver._bordered_system(solver, local, reduced).toarray()
    assembled = solver._bordered_system(local, reduced).toarray()
    assert np.max(np.abs(assembled - expected)) <= ROUND_OFF * np.max(np.abs(expected))


def test_compiled_small_strain_refuses_the_facet_contact(material, mesh):
    with pytest.raises(ValueError, match="node contact"):
        CompiledSmallStrainSolver(material, mesh, contact="facet")


def test_small_strain_run_with_compiled_kernels_equals_the_numpy_path():
    """The weak grain to 40 N (far past first yield) and back, coarse mesh, 6 steps per
    segment, through run_history on both paths: the same steps and Newton iterations, the
    curve, residual approach and plastic work within the Newton tolerance (1e-8; measured
    ~1e-13: the paths differ by round-off only)."""
    material = preset("reference-weak")
    forces = [0.0, 40.0, 0.0]
    runs = {k: run_history(material, forces, mesh="coarse", steps_per_segment=6,
                           write_fields=False, kernels=k, **YIELD_FIXED)
            for k in ("numpy", "compiled")}
    a, b = runs["numpy"], runs["compiled"]
    assert a.summary["identity"]["inputs"]["kernels"] == "numpy"
    assert "kernels" not in b.summary["identity"]["inputs"]  # the default
    assert np.allclose(a.curve["force_N"], b.curve["force_N"], rtol=1e-9, atol=0.0)
    assert np.max(a.curve["plastic_points"]) > 100
    assert np.array_equal(a.curve["iterations"], b.curve["iterations"])
    approach = np.max(np.abs(b.curve["approach_m"] - a.curve["approach_m"]))
    assert approach <= 1e-8 * np.max(a.curve["approach_m"])
    ca, cb = a.summary["cycles"][0], b.summary["cycles"][0]
    assert abs(cb["residual_approach_m"] / ca["residual_approach_m"] - 1) < 1e-8
    assert abs(cb["plastic_work_J"] / ca["plastic_work_J"] - 1) < 1e-8


def test_a_compiled_run_of_other_kernels_is_not_reused(material, monkeypatch):
    """An edit of the compiled kernels changes a compiled run's key, and its recorded identity
    is then told apart (``difference``), while the numpy path's key stays."""
    from geocontact.fem import identity

    compiled = FeRunIdentity.of(material, [0.0, 10.0])
    numpy_path = FeRunIdentity.of(material, [0.0, 10.0], kernels="numpy")
    recorded, numpy_key = compiled.to_dict(), numpy_path.key()
    monkeypatch.setattr(identity, "compiled_code_hash", lambda: "0" * 16)
    assert compiled.key() != recorded["key"]
    assert numpy_path.key() == numpy_key
    assert difference(recorded, compiled) == "made by other compiled kernels"
    assert difference(recorded, compiled, rounding=True) == "made by other compiled kernels"


def test_kernels_flag_reaches_the_runs(tmp_path, monkeypatch, capsys):
    """``--kernels numpy`` of ``geocontact fem`` and ``cycles`` reaches the FE run (captured
    here), ``calibrate``'s jobs through ``FeSettings.model_of`` (only when not the default, so
    the records of default runs are unchanged) and ``FemJob``; with the facet contact it is
    refused in one line before any work."""
    import argparse

    from conftest import fe_setting_reaching_the_run

    from geocontact.cli import main
    from geocontact.fem.campaign import FemJob
    from geocontact.fem.settings import FeSettings

    seen = fe_setting_reaching_the_run(monkeypatch, tmp_path, "kernels", ["--kernels", "numpy"])
    history = tmp_path / "h.toml"  # written by the helper
    assert seen == ["numpy", "numpy"]
    parser = argparse.ArgumentParser()
    FeSettings.add_model_flags(parser)
    assert "kernels" not in FeSettings.model_of(parser.parse_args([]))
    model = FeSettings.model_of(parser.parse_args(["--kernels", "numpy"]))
    assert model["kernels"] == "numpy"
    job = FemJob(preset("reference"), (0.0, 10.0), **model)
    assert job.identity().inputs()["kernels"] == "numpy"
    assert FemJob(preset("reference"), (0.0, 10.0)).settings().kernels == "compiled"
    assert FemJob.of_inputs(job.identity().inputs()).key() == job.key()
    monkeypatch.undo()
    code = main(["fem", "--material", "reference", "--history", str(history), "--out",
                 str(tmp_path / "x"), "--kernels", "compiled", "--contact", "facet"])
    err = capsys.readouterr().err.strip()
    assert code != 0 and err.count("\n") == 0 and "kernels" in err and "facet" in err
    assert not (tmp_path / "x").exists()
