"""The CalculiX peer model (geocontact.verification.ccx): deck, .dat reader, residual approach; one
coarse ccx run when the ``ccx`` executable is installed (``make ccx``)."""

import numpy as np
import pytest

from geocontact.errors import InputError
from geocontact.fem.run import history_mesh
from geocontact.grain import hertz
from geocontact.grain.material import preset
from geocontact.verification.ccx import (
    SECTORS,
    AxisymmetricMesh,
    branches,
    ccx_executable,
    force_difference,
    loading_work_at,
    read_dat,
    residual_approach,
    run_ccx,
    smoothed_force_at,
    sphere_faces,
    unloading_exponent,
    unloading_shape,
    write_deck,
)

VON_MISES = preset("von-mises")


@pytest.fixture(scope="module")
def mesh():
    return AxisymmetricMesh.from_skfem(history_mesh(VON_MISES, 1000.0, "coarse"))


def _keyword_block(lines, keyword):
    start = next(i for i, line in enumerate(lines) if line.upper().startswith(keyword))
    block = []
    for line in lines[start + 1:]:
        if line.startswith("*"):
            break
        block.append(line)
    return block


def test_mesh_export_keeps_the_quadratic_triangles(mesh):
    p, t = mesh.points, mesh.triangles
    # mid-edge nodes on the straight edges sit half-way; vertices counter-clockwise
    e1, e2 = p[t[:, 1]] - p[t[:, 0]], p[t[:, 2]] - p[t[:, 0]]
    assert np.all(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0] > 0)
    for mid, (a, b) in zip((3, 4, 5), ((0, 1), (1, 2), (2, 0)), strict=True):
        gap = np.linalg.norm(p[t[:, mid]] - 0.5 * (p[t[:, a]] + p[t[:, b]]), axis=1)
        edge = np.linalg.norm(p[t[:, a]] - p[t[:, b]], axis=1)
        assert np.all(gap < 0.05 * edge)  # only the curved sphere edges bulge, slightly


def test_deck_contact_surface_load_steps_and_field_width(tmp_path, mesh):
    radius = VON_MISES.radius
    info = write_deck(tmp_path / "d.inp", VON_MISES, mesh, [1e-5, 0.0], [20, 10])
    text = (tmp_path / "d.inp").read_text()
    lines = text.splitlines()
    assert info["elements"] == len(mesh.triangles)
    assert len(_keyword_block(lines, "*ELEMENT, TYPE=CAX6")) == len(mesh.triangles)
    # every slave face is an edge on the sphere inside the contact zone, ending at the tip
    faces = sphere_faces(mesh, radius)
    assert [line for line in _keyword_block(lines, "*SURFACE, NAME=SPHERESURF")] == \
        [f"{e + 1}, S{f}" for e, f in faces]
    nodes = {0: (0, 1, 3), 1: (1, 2, 4), 2: (2, 0, 5)}
    face_nodes = np.array([mesh.triangles[e, nodes[f - 1]] for e, f in faces]).ravel()
    xy = mesh.points[face_nodes]
    assert np.allclose(np.hypot(xy[:, 0], xy[:, 1] - radius), radius, rtol=1e-9)
    assert xy[:, 1].max() < 0.3 * radius and np.min(np.abs(xy).sum(axis=1)) == 0.0
    # von Mises, perfectly plastic, frictionless penalty contact, no NLGEOM
    assert _keyword_block(lines, "*PLASTIC") == [f"{VON_MISES.compressive_yield_stress:.12e}, 0.0"]
    assert "*FRICTION" not in text and "NLGEOM" not in text
    assert float(_keyword_block(lines, "*SURFACE BEHAVIOR")[0]) == pytest.approx(
        info["penalty_slope_Pa_per_m"])
    # one step per waypoint, top displacement = -interference, CalculiX's 20-character fields
    steps = [i for i, line in enumerate(lines) if line == "*STEP, INC=100000"]
    assert len(steps) == 2
    assert [_keyword_block(lines[s:], "*BOUNDARY")[0] for s in steps] == [
        "TOP, 2, 2, -1.000000000000e-05", "TOP, 2, 2, -0.000000000000e+00"]
    assert [float(_keyword_block(lines[s:], "*STATIC")[0].split(",")[0]) for s in steps] == \
        [pytest.approx(0.05), pytest.approx(0.1)]
    data = [line for line in lines if not line.startswith("*")]
    assert max(len(field.strip()) for line in data for field in line.split(",")) <= 20


def test_deck_refuses_a_friction_angle(tmp_path, mesh):
    with pytest.raises(InputError, match="friction_angle"):
        write_deck(tmp_path / "d.inp", preset("reference"), mesh, [1e-5], [4])


def test_read_dat_scales_the_sector_force_to_the_whole_circumference(tmp_path):
    block = ("\n total force (fx,fy,fz) for set TOP and time  {t:.7E}\n\n"
             "       -2.366413E-04 {f:.6E} -3.663881E-14\n")
    (tmp_path / "s.dat").write_text(block.format(t=0.5, f=-8.292722e-3)
                                    + block.format(t=1.0, f=-2.444781e-2))
    times, force = read_dat(tmp_path / "s.dat")
    assert times.tolist() == [0.5, 1.0]
    assert force == pytest.approx(SECTORS * np.array([8.292722e-3, 2.444781e-2]))


def test_residual_approach_is_exact_for_a_power_law_unloading():
    approach = np.linspace(10.0, 0.0, 21)
    force = np.where(approach > 3.3, 7.0 * np.clip(approach - 3.3, 0, None) ** 1.45, 0.0)
    assert residual_approach(approach, force, 1e-12) == pytest.approx(3.3, rel=1e-9)
    assert residual_approach(approach, np.ones_like(approach), 1e-12) is None  # never opens


def test_deck_nlgeom_makes_every_step_geometrically_nonlinear(tmp_path, mesh):
    write_deck(tmp_path / "d.inp", VON_MISES, mesh, [1e-5, 0.0], [4, 4], nlgeom=True)
    steps = [line for line in (tmp_path / "d.inp").read_text().splitlines()
             if line.startswith("*STEP")]
    assert steps == ["*STEP, NLGEOM, INC=100000"] * 2


def test_branches_and_force_difference_at_equal_approach():
    # loading F = d^1.5 to d = 2, unloading F = F_max ((d - 1)/(2 - 1))^1.5 down to d = 1
    up = np.linspace(0.0, 2.0, 21)
    down = np.linspace(2.0, 0.8, 13)[1:]
    approach = np.concatenate([up, down])
    force = np.concatenate([up**1.5, 2**1.5 * np.clip(down - 1.0, 0.0, None) ** 1.5])
    (dl, fl), (du, fu) = branches(approach, force)
    assert dl[-1] == du[-1] == 2.0 and np.all(np.diff(dl) > 0) and np.all(np.diff(du) > 0)
    assert du[0] == pytest.approx(1.1) and np.all(fu > 0)  # only the points still in contact
    # the same curves 3 % higher differ by 3 % of the peak at the peak, less below it
    diff = force_difference((approach, 1.03 * force), (approach, force), force.max())
    assert diff["loading"] == pytest.approx(0.03) and diff["unloading"] == pytest.approx(0.03)
    shifted = force_difference((approach, force), (approach + 0.1, force), force.max())
    assert 0.05 < shifted["loading"] < 0.2  # a shift in approach shows as a force difference


def _cycle(n_unload: float = 1.4, scatter: float = 0.0) -> dict:
    """Loading F = 3 d^1.2 to d = 2 (with an alternating scatter), unloading
    F = F_max t^n, t = (d - 1.5)/(2 - 1.5), down to d = 1."""
    up = np.linspace(0.0, 2.0, 41)
    wobble = 1.0 + scatter * (-1.0) ** np.arange(41)
    down = np.linspace(2.0, 1.0, 41)[1:]
    f_max = 3.0 * 2.0**1.2 * wobble[-1]
    force = np.concatenate([3.0 * up**1.2 * wobble,
                            f_max * np.clip((down - 1.5) / 0.5, 0.0, None) ** n_unload])
    return {"approach": np.concatenate([up, down]), "force": force, "max_approach_m": 2.0,
            "residual_approach_m": 1.5, "max_force_N": f_max}


def test_curve_measures_smoothed_force_work_and_unloading_shape():
    run = _cycle()
    at = np.array([0.5, 1.0, 2.0])
    assert smoothed_force_at(run, at) == pytest.approx(3.0 * at**1.2, rel=1e-12)
    assert loading_work_at(run, at) == pytest.approx(3.0 * at**2.2 / 2.2, rel=2e-3)
    assert unloading_exponent(run) == pytest.approx(1.4, rel=1e-9)
    t = np.linspace(0.0, 1.0, 11)
    assert unloading_shape(run, t) == pytest.approx(t**1.4, abs=2e-3)
    # a +/- 3 % scatter from point to point (a contact edge crossing nodes) leaves the smoothed
    # force within 1 % (an odd number of points in the window) and the work within 0.1 %
    noisy = _cycle(scatter=0.03)
    assert np.max(np.abs(smoothed_force_at(noisy, at[:2]) / (3.0 * at[:2]**1.2) - 1)) < 1e-2
    assert np.max(np.abs(loading_work_at(noisy, at) / loading_work_at(run, at) - 1)) < 1e-3
    assert np.isnan(smoothed_force_at(run, [2.5])[0])  # beyond the branch


@pytest.mark.slow
@pytest.mark.skipif(ccx_executable() is None, reason="CalculiX 'ccx' not installed (make ccx)")
def test_finite_strain_unloads_like_calculix_nlgeom():
    """At a/R = 0.15 (preset von-mises-large, 0 -> 100 omega_c -> 0, coarse mesh) the shape of
    the unloading curve is where small and finite strain differ (docs/verification.md item 15):
    our finite strain must follow CalculiX NLGEOM better than our small strain does, by a factor
    two (measured 3.4 x on this mesh with 24 increments). ~1 min (one CalculiX run)."""
    from geocontact.fem.run import run_history
    from geocontact.verification import published_fits as fits

    material = preset("von-mises-large")
    jg = fits.jackson_green_critical(material)
    peak = float(fits.jackson_green_load(material, 100.0)) * jg.force
    fe_mesh = AxisymmetricMesh.from_skfem(history_mesh(material, peak, "coarse"))
    ours = {}
    for kinematics in ("small", "finite"):
        r = run_history(material, [0.0, peak, 0.0], mesh="coarse", write_fields=False,
                        kinematics=kinematics)
        ours[kinematics] = {"approach": r.curve["approach_m"], "force": r.curve["force_N"],
                            **{k: r.summary["cycles"][0][k] for k in
                               ("max_approach_m", "residual_approach_m", "max_force_N")}}
        assert r.summary["mesh"]["elements"] == len(fe_mesh.triangles)
    d_max = ours["finite"]["max_approach_m"]
    # unload to 0.7 d_max, just past the residual approach (~0.75 d_max): the 12 unloading
    # increments all fall on the branch in contact
    c = run_ccx(material, fe_mesh, [d_max, 0.7 * d_max], [12, 12], nlgeom=True)
    nlgeom = {"approach": c.curve["approach_m"], "force": c.curve["force_N"],
              **{k: c.summary[k] for k in ("max_approach_m", "residual_approach_m",
                                           "max_force_N")}}
    t = np.linspace(0.0, 1.0, 51)

    def gap(run):
        return float(np.max(np.abs(unloading_shape(run, t) - unloading_shape(nlgeom, t))))

    assert gap(ours["finite"]) < 0.5 * gap(ours["small"])
    n = {k: unloading_exponent(r) for k, r in ours.items()}
    n_nlgeom = unloading_exponent(nlgeom)
    assert abs(n["finite"] - n_nlgeom) < 0.5 * abs(n["small"] - n_nlgeom)
    assert n["finite"] < n["small"]  # finite strain unloads with the smaller exponent


@pytest.mark.skipif(ccx_executable() is None, reason="CalculiX 'ccx' not installed (make ccx)")
@pytest.mark.parametrize("nlgeom", [False, True], ids=["small", "nlgeom"])
def test_ccx_elastic_contact_matches_hertz(mesh, nlgeom):
    """Below yield the peer must give Hertz (within the coarse mesh's and the penalty's error),
    with and without NLGEOM (strains of 1e-3: geometric effects far below 1 %): checks the
    deck, the force scaling from CalculiX's 2 degree sector and the reader."""
    approach = float(hertz.hertz_approach(VON_MISES, 0.5 * hertz.incipient_yield(VON_MISES).force))
    result = run_ccx(VON_MISES, mesh, [approach], [3], nlgeom=nlgeom)
    d, f = result.curve["approach_m"], result.curve["force_N"]
    # at 0.5 Fy (contact radius resolved by the coarse mesh): 0.5 % under Hertz when written;
    # the smaller contacts of the first increments are under-resolved (4 % low at 1/3)
    assert f[-1] == pytest.approx(hertz.hertz_force(VON_MISES, d[-1]), rel=0.01)
    assert np.all(np.diff(f) > 0)
    assert result.summary["cpu_time_s"] > 0 and result.summary["increments"] == 3
