"""The universal law (issue 12, docs/universal.md) on a slice of the shipped dataset: the
interpolation reproduces its nodes, a material outside the range is refused, the parameter file
is a valid geocontact.law/1 document that both readers take, and the law's physical guarantees
(Hertz below yield, never tensile, no energy created) hold for it."""

import json
import math
import time

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from geocontact import schema
from geocontact.cli import main
from geocontact.errors import InputError
from geocontact.law import Contact, ContactArrays, load_params
from geocontact.universal import dataset, design, for_material
from geocontact.universal.interpolate import (
    FITS_FILE,
    build_surfaces,
    read_fits,
    row_key,
    universal_params,
)

SLICE = 10  # rows of the shipped dataset used here (the centre, 8 corners, 1 interior point)


@pytest.fixture(scope="module")
def slice_dir(tmp_path_factory):
    data = dataset.read_points()
    assert data["index"].size >= SLICE, "the shipped dataset is missing or too small"
    rows = dataset.rows_of(data)[:SLICE]
    folder = tmp_path_factory.mktemp("universal")
    (folder / "points.csv").write_text(dataset.format_points(rows))
    fits = dataset.default_directory() / FITS_FILE
    if fits.exists():  # the nodes' saturating fits: warm starts of the law's fit
        (folder / FITS_FILE).write_text(fits.read_text())
    return folder


@pytest.fixture(scope="module")
def slice_data(slice_dir):
    return dataset.read_points(slice_dir)


def inside_material(slice_data, fraction=0.37, modulus=3e10, radius=2e-3):
    """A material inside the box, between the slice's nodes."""
    nodes = np.column_stack([slice_data[n] for n in design.AXIS_NAMES])
    coords = fraction * nodes.min(axis=0) + (1 - fraction) * nodes.max(axis=0)
    return design.material_at(coords, modulus=modulus, radius=radius)


def test_interpolation_reproduces_its_nodes(slice_data):
    table = build_surfaces(slice_data)
    nodes = np.column_stack([slice_data[n] for n in design.AXIS_NAMES])
    for i in range(nodes.shape[0]):
        values = table(nodes[i])
        for column in dataset.law_columns():
            assert values[column] == pytest.approx(slice_data[column][i], rel=1e-7, abs=1e-9)
        # at a node the expected error is the node's own leave-one-out error
        assert all(math.isfinite(v) for v in table.expected_error(nodes[i]).values())


def test_leave_one_out_is_the_error_of_the_surface_without_the_node(slice_data):
    """The recorded LOO error of a node is |surface of the others - value| (recomputed here
    independently, with the same kernel)."""
    from scipy.interpolate import RBFInterpolator

    table = build_surfaces(slice_data)
    j = table.columns.index("residual_3")
    nodes, values = table.nodes, table.values[:, j]
    keep = np.arange(nodes.shape[0]) != 5
    rbf = RBFInterpolator(nodes[keep], values[keep], kernel=table.kernels[j], degree=1)
    assert table.loo_error[5, j] == pytest.approx(abs(rbf(nodes[5:6])[0] - values[5]),
                                                  rel=1e-9)


def test_warm_started_fit_at_a_node_is_the_full_fit(slice_dir, slice_data):
    """fits.json holds each node's saturating fits by the full 30-start grid of
    calibrate.fit; the law at a node (interpolation exact there, fit warm-started from the
    nearest nodes) lands on the same parameters."""
    fits = read_fits(slice_dir)
    checked = 0
    for i in (0, 5, 9):
        entry = fits.get(str(int(slice_data["index"][i])))
        if entry is None or "residual" not in entry or entry["row"] != row_key(slice_data, i):
            continue
        coords = [slice_data[n][i] for n in design.AXIS_NAMES]
        params = universal_params(design.material_at(coords), directory=slice_dir)
        assert params.provenance["universal"]["saturating_fit_start"].startswith("the fits")
        got = [params.residual_limit, params.residual_power, params.residual_transition,
               params.residual_log_power]
        assert got == pytest.approx(entry["residual"], rel=1e-4, abs=1e-6)
        got = [params.plastic_work_limit, params.plastic_work_power,
               params.plastic_work_transition, params.plastic_work_log_power]
        assert got == pytest.approx(entry["plastic_work"], rel=1e-4, abs=1e-6)
        checked += 1
    assert checked >= 2, "fits.json is stale: python -m geocontact.universal.interpolate --prepare"


def test_design_sequence_is_one_deterministic_list():
    head = design.design_points(40)
    assert design.design_points(20) == head[:20]
    assert head[0].coordinates == (27.5, 0.25, 0.15, 3.0)
    box = [(a[1], a[2]) for a in design.AXES]
    for p in head:
        assert all(lo <= c <= hi for c, (lo, hi) in zip(p.coordinates, box, strict=True))
    assert len({p.coordinates for p in head}) == 40
    # the top level keeps the contact radius within the FE mesh's R/2 everywhere in the box
    assert design.largest_contact_over_radius() <= 0.5


@pytest.mark.parametrize("field, value, message", [
    ("friction_angle_deg", 57.0, "friction_angle_deg: 57 is outside the universal law's range "
                                 "[0, 55]"),
    ("poissons_ratio", 0.14, "poissons_ratio: 0.14 is outside the universal law's range"),
    ("hardening_ratio", 0.31, "hardening_ratio: 0.31 is outside"),
    ("compressive_yield_stress", 1.25e8, "youngs_modulus / compressive_yield_stress: 80 is "
                                         "outside the universal law's range [100, 10000]"),
])
def test_outside_the_range_is_refused_in_one_line(slice_dir, slice_data, field, value,
                                                  message):
    material = inside_material(slice_data, modulus=1e10).with_(**{field: value})
    with pytest.raises(InputError) as err:
        universal_params(material, directory=slice_dir)
    assert message in str(err.value) and "\n" not in str(err.value)
    params = universal_params(material, extrapolate=True, directory=slice_dir)
    u = params.provenance["universal"]
    assert u["inside_range"] is False and "OUTSIDE" in u["expected_error_note"]


def test_params_command_writes_a_valid_law_file_quickly(slice_dir, slice_data, tmp_path,
                                                        capsys):
    material = inside_material(slice_data)
    toml = tmp_path / "m.toml"
    keys = ("youngs_modulus", "poissons_ratio", "compressive_yield_stress",
            "friction_angle_deg", "hardening_ratio")
    toml.write_text("[material]\n" + "".join(f"{k} = {getattr(material, k)!r}\n" for k in keys)
                    + f"[geometry]\nradius = {material.radius!r}\n")
    out = tmp_path / "P.json"
    started = time.process_time()
    assert main(["params", "--material", str(toml), "--out", str(out), "--dataset",
                 str(slice_dir), "--json"]) == 0
    cpu = time.process_time() - started
    summary = json.loads(capsys.readouterr().out)
    document = json.loads(out.read_text())
    schema.validate(document)  # the table both readers validate from
    params = load_params(out)
    assert params.material == material
    assert document["provenance"]["universal"]["points"] == SLICE
    assert document["provenance"]["universal"]["dataset_sha256"] == \
        dataset.dataset_hash(slice_dir)
    assert summary["inside_range"] is True and summary["dataset_points"] == SLICE
    # CPU time (the machine may be loaded): < 1 s measured (docs/universal.md); slack here
    assert cpu < 2.0
    # the compiled core (the C++ header the LAMMPS plugin uses) reads the same file
    path = np.concatenate([np.linspace(0, 40, 200), np.linspace(40, 5, 100),
                           np.linspace(5, 60, 200), np.linspace(60, 0, 200)]) \
        * params.yield_approach
    many = ContactArrays(params, 1)
    contact = Contact(params)
    for d in path:
        f_core, _ = many.step(np.array([d]))
        f_ref, _ = contact.update(float(d))
        assert f_core[0] == pytest.approx(f_ref, rel=1e-9, abs=1e-12 * params.yield_force)


def test_params_never_overwrites_a_file_it_did_not_write(slice_dir, slice_data, tmp_path,
                                                         capsys):
    mine = tmp_path / "P.json"
    mine.write_text('{"my": "notes"}\n')
    assert main(["params", "--material", "reference", "--out", str(mine), "--dataset",
                 str(slice_dir)]) != 0
    err = capsys.readouterr().err.strip()
    assert "refusing to replace" in err and "\n" not in err
    assert mine.read_text() == '{"my": "notes"}\n'


def test_for_material_matches_the_command_path(slice_dir, slice_data):
    material = inside_material(slice_data, fraction=0.6)
    a = universal_params(material, directory=slice_dir)
    b = universal_params(material.with_(radius=material.radius * 7.0), directory=slice_dir)
    # similarity: the radius scales out exactly (docs/model.md §10)
    assert b.yield_approach == pytest.approx(7.0 * a.yield_approach, rel=1e-9)
    for name in ("elastic_plastic_exponent", "fully_plastic_approach_ratio",
                 "unloading_power", "residual_limit", "plastic_work_limit"):
        assert getattr(b, name) == pytest.approx(getattr(a, name), rel=1e-6)
    with pytest.raises(InputError, match="material: expected"):
        for_material("reference")


@pytest.fixture(scope="module")
def universal_law(slice_dir, slice_data):
    return universal_params(inside_material(slice_data, fraction=0.45), directory=slice_dir)


@settings(max_examples=40, deadline=None)
@given(st.lists(st.floats(min_value=-1.0, max_value=1.0), min_size=1, max_size=20))
def test_universal_law_is_hertz_below_yield(universal_law, xs):
    params = universal_law
    contact = Contact(params)
    for x in xs:
        d = x * params.yield_approach
        f, _ = contact.update(d)
        assert f == pytest.approx(params.hertz_coefficient * max(d, 0.0) ** 1.5, rel=1e-12,
                                  abs=0.0)


@settings(max_examples=40, deadline=None)
@given(st.lists(st.floats(min_value=-3.0, max_value=400.0), min_size=1, max_size=15))
def test_universal_law_never_tensile_and_creates_no_energy(universal_law, xs):
    params = universal_law
    dy = params.yield_approach
    path = [0.0, *[x * dy for x in xs], -dy]
    dense = [path[0]]
    for a, b in zip(path[:-1], path[1:], strict=True):
        dense += list(np.linspace(a, b, 101)[1:])
    contact = Contact(params)
    forces, dissipated = [], 0.0
    scale = params.yield_force * dy
    for d in dense:
        f, k = contact.update(d)
        assert f >= 0.0 and k >= 0.0
        forces.append(f)
        assert contact.dissipated_energy >= dissipated - 1e-9 * scale
        dissipated = contact.dissipated_energy
    assert contact.state.force == 0.0
    loop = contact.state.work  # the law's exact work over the path, apart to apart
    assert loop >= -1e-9 * scale
    trapezoid = float(np.sum(0.5 * (np.array(forces[1:]) + forces[:-1]) * np.diff(dense)))
    reach = max(1.0, max(xs)) ** 2.5  # F dmax in units of Fy dy
    assert trapezoid == pytest.approx(loop, rel=2e-3, abs=1e-3 * scale * reach)
