"""Material validation and presets (docs/model.md §3 and 9, docs/interfaces.md M.toml)."""

from __future__ import annotations

import math

import pytest

from geocontact.errors import InputError
from geocontact.grain.material import (
    MATERIAL_KEYS,
    Material,
    list_presets,
    load_material,
    preset,
    preset_description,
)

REFERENCE = {
    "youngs_modulus": 10e9,
    "poissons_ratio": 0.25,
    "compressive_yield_stress": 10e6,
    "friction_angle_deg": 30.0,
    "hardening_ratio": 0.0,
    "radius": 0.1,
}


def assert_one_line_error(excinfo, field: str) -> None:
    message = str(excinfo.value)
    assert field in message
    assert "\n" not in message


@pytest.mark.parametrize(
    "field, value",
    [
        ("youngs_modulus", -1e9),
        ("youngs_modulus", 0.0),
        ("poissons_ratio", 0.5),
        ("poissons_ratio", 0.7),
        ("poissons_ratio", -1.0),
        ("poissons_ratio", -1.5),
        ("compressive_yield_stress", 0.0),
        ("friction_angle_deg", math.degrees(math.atan(3.0))),  # tan beta = 3
        ("friction_angle_deg", 80.0),
        ("friction_angle_deg", -1.0),
        ("hardening_ratio", -0.1),
        ("hardening_ratio", 1.0),
        ("radius", 0.0),
        ("radius", -0.1),
        ("youngs_modulus", math.nan),
        ("radius", math.inf),
        ("poissons_ratio", "0.25"),
        ("hardening_ratio", True),
    ],
)
def test_out_of_range_values_are_rejected(field, value):
    with pytest.raises(InputError) as excinfo:
        Material(**{**REFERENCE, field: value})
    assert_one_line_error(excinfo, field)


def test_valid_edges_are_accepted():
    Material(**{**REFERENCE, "poissons_ratio": -0.99, "friction_angle_deg": 0.0})
    Material(**{**REFERENCE, "poissons_ratio": 0.499, "friction_angle_deg": 71.5,
                "hardening_ratio": 0.99})


def test_derived_quantities():
    material = Material(**REFERENCE)
    nu, E = 0.25, 10e9
    assert material.effective_modulus == pytest.approx(E / (2 * (1 - nu**2)), rel=1e-15)
    assert material.effective_radius == 0.05
    assert material.tan_beta == pytest.approx(1 / math.sqrt(3), rel=1e-14)
    assert material.cohesion_factor == pytest.approx(1 - 1 / (3 * math.sqrt(3)), rel=1e-14)
    assert material.hardening_modulus == 0.0
    # on the cone in uniaxial tension: q = sigma_t, p = -sigma_t / 3
    sigma_t = material.tensile_yield_stress
    assert sigma_t + sigma_t / 3 * material.tan_beta == pytest.approx(
        material.cohesion_factor * 10e6, rel=1e-14
    )


def write(tmp_path, text: str):
    path = tmp_path / "material.toml"
    path.write_text(text)
    return path


def test_toml_round_trip(tmp_path):
    material = Material(**REFERENCE)
    assert load_material(write(tmp_path, material.to_toml())) == material


@pytest.mark.parametrize(
    "text, field",
    [
        ("[material]\nyoungs_modulus = \n", "malformed TOML"),
        ("not toml at all [[[", "malformed TOML"),
        (Material(**REFERENCE).to_toml() + "\n[extra]\nx = 1\n", "extra"),
        (Material(**REFERENCE).to_toml().replace("hardening_ratio", "hardening"), "hardening"),
        (Material(**REFERENCE).to_toml().replace("radius = 0.1", "diameter = 0.2"), "diameter"),
        (Material(**REFERENCE).to_toml().replace("radius = 0.1", ""), "geometry.radius"),
        (Material(**REFERENCE).to_toml().replace("poissons_ratio = 0.25", ""),
         "material.poissons_ratio"),
        (Material(**REFERENCE).to_toml().replace("10000000000.0", "nan"), "youngs_modulus"),
        (Material(**REFERENCE).to_toml().replace("10000000000.0", '"10 GPa"'), "youngs_modulus"),
    ],
)
def test_bad_files_give_one_line_input_error(tmp_path, text, field):
    with pytest.raises(InputError) as excinfo:
        load_material(write(tmp_path, text))
    assert_one_line_error(excinfo, field)


def test_missing_file_and_binary_file(tmp_path):
    with pytest.raises(InputError) as excinfo:
        load_material(tmp_path / "nope.toml")
    assert_one_line_error(excinfo, "not found")
    path = tmp_path / "binary.toml"
    path.write_bytes(b"\xff\xfe\x00\x01")
    with pytest.raises(InputError) as excinfo:
        load_material(path)
    assert_one_line_error(excinfo, "material")


def test_flat_mapping():
    assert Material.from_dict(REFERENCE) == Material(**REFERENCE)
    with pytest.raises(InputError, match="friction_angle"):
        Material.from_dict({k: v for k, v in REFERENCE.items() if k != "friction_angle_deg"})


def test_presets_load():
    names = list_presets()
    assert {"reference", "reference-weak", "von-mises"} <= set(names)
    for name in names:
        material = preset(name)
        assert isinstance(material, Material)
        assert preset_description(name)
        assert load_material(name) == material  # a preset name works where a path does


def test_reference_presets_match_spec():
    assert preset("reference") == Material(**REFERENCE)
    weak = preset("reference-weak")
    assert weak.compressive_yield_stress == 1e6
    assert {k: getattr(weak, k) for k in MATERIAL_KEYS if k != "compressive_yield_stress"} == {
        k: REFERENCE[k] for k in MATERIAL_KEYS if k != "compressive_yield_stress"
    }
    von_mises = preset("von-mises")
    assert von_mises.friction_angle_deg == 0.0 and von_mises.poissons_ratio == 0.3


def test_unknown_preset():
    with pytest.raises(InputError) as excinfo:
        preset("granite-from-mars")
    assert_one_line_error(excinfo, "preset")
