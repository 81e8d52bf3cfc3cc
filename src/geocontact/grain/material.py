"""Material and geometry of two identical Drucker-Prager spheres (docs/model.md §2-3, 9).

The input format is the TOML of docs/interfaces.md::

    [material]
    youngs_modulus = 10e9
    poissons_ratio = 0.25
    compressive_yield_stress = 10e6
    friction_angle_deg = 30.0
    hardening_ratio = 0.0
    [geometry]
    radius = 0.1

Presets live in ``geocontact/data/presets/*.toml`` (data, not code).
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import asdict, dataclass, replace
from importlib import resources
from pathlib import Path
from typing import Any

from .. import schema
from ..errors import InputError
from ..files import read_text_input

MATERIAL_KEYS = (
    "youngs_modulus",
    "poissons_ratio",
    "compressive_yield_stress",
    "friction_angle_deg",
    "hardening_ratio",
)
GEOMETRY_KEYS = ("radius",)
# The allowed ranges (and why) are those of the law's parameter file, data/law-schema.json:
# E in [1e3, 1e13] Pa, sigma_c / E in [1e-8, 1e6], tan(beta) < 3, R in [1e-9, 1e3] m.


@dataclass(frozen=True)
class Material:
    """Elastic-plastic Drucker-Prager material of two identical spheres of radius ``radius``."""

    youngs_modulus: float
    poissons_ratio: float
    compressive_yield_stress: float
    friction_angle_deg: float
    hardening_ratio: float
    radius: float

    def __post_init__(self) -> None:
        # Each field as the schema of the parameter file has it; the messages name the field
        # alone (the same material comes from a TOML file, a parameter file or a call).
        for key in (*MATERIAL_KEYS, *GEOMETRY_KEYS):
            spec = schema.field(f"material.{key}")
            scale = getattr(self, spec["relative_to"].rpartition(".")[2]) \
                if "relative_to" in spec else 1.0
            object.__setattr__(self, key, schema.check_number(key, getattr(self, key), spec,
                                                              scale))

    # --- derived quantities (docs/model.md §2-3) -------------------------------------------
    @property
    def tan_beta(self) -> float:
        return math.tan(math.radians(self.friction_angle_deg))

    @property
    def cohesion_factor(self) -> float:
        """d / sigma_c = 1 - tan(beta)/3 for the ABAQUS linear Drucker-Prager cone (K = 1)."""
        return 1.0 - self.tan_beta / 3.0

    @property
    def hardening_modulus(self) -> float:
        """H = m E / (1 - m): slope of sigma_c against equivalent plastic strain."""
        m = self.hardening_ratio
        return m * self.youngs_modulus / (1.0 - m)

    @property
    def shear_modulus(self) -> float:
        return self.youngs_modulus / (2.0 * (1.0 + self.poissons_ratio))

    @property
    def bulk_modulus(self) -> float:
        return self.youngs_modulus / (3.0 * (1.0 - 2.0 * self.poissons_ratio))

    @property
    def effective_modulus(self) -> float:
        """E* = E / (2 (1 - nu^2)) for two identical spheres."""
        return self.youngs_modulus / (2.0 * (1.0 - self.poissons_ratio**2))

    @property
    def effective_radius(self) -> float:
        """R* = R / 2 for two identical spheres."""
        return self.radius / 2.0

    @property
    def tensile_yield_stress(self) -> float:
        """Uniaxial tensile strength of the cone: q = sigma, p = -sigma/3 on F = 0."""
        return self.cohesion_factor * self.compressive_yield_stress / (1.0 + self.tan_beta / 3.0)

    # --- conversions ----------------------------------------------------------------------
    def to_dict(self) -> dict[str, float]:
        return asdict(self)

    def to_toml_dict(self) -> dict[str, dict[str, float]]:
        d = self.to_dict()
        return {
            "material": {k: d[k] for k in MATERIAL_KEYS},
            "geometry": {k: d[k] for k in GEOMETRY_KEYS},
        }

    def to_toml(self) -> str:
        lines = []
        for section, values in self.to_toml_dict().items():
            lines.append(f"[{section}]")
            lines += [f"{k} = {v!r}" for k, v in values.items()]
            lines.append("")
        return "\n".join(lines)

    def with_(self, **changes: float) -> Material:
        """A copy with some fields changed (validated again)."""
        return replace(self, **changes)

    @classmethod
    def from_dict(cls, data: dict[str, Any], *, source: str = "material") -> Material:
        """From the nested TOML form ({material: {...}, geometry: {...}}) or a flat mapping."""
        if "material" in data and isinstance(data["material"], dict):
            unknown_sections = set(data) - {"material", "geometry"}
            if unknown_sections:
                raise InputError(
                    f"{source}: unknown section {sorted(unknown_sections)[0]!r} "
                    "(allowed: material, geometry)"
                )
            flat = dict(data["material"])
            geometry = data.get("geometry", {})
            if not isinstance(geometry, dict):
                raise InputError(f"{source}: [geometry] must be a table")
            for key, value in geometry.items():
                if key not in GEOMETRY_KEYS:
                    raise InputError(f"geometry.{key}: unknown key (allowed: radius)")
                flat[key] = value
            section = "material."
        else:
            flat = dict(data)
            section = ""
        allowed = (*MATERIAL_KEYS, *GEOMETRY_KEYS)
        for key in flat:
            if key not in allowed:
                raise InputError(
                    f"{section}{key}: unknown key (allowed: {', '.join(allowed)})"
                )
        for key in allowed:
            if key not in flat:
                where = "geometry." if key in GEOMETRY_KEYS else section
                raise InputError(f"{where}{key}: missing")
        return cls(**{k: flat[k] for k in allowed})


def load_material(path: str | Path) -> Material:
    """Read and validate a material TOML file, or a preset name (see ``list_presets``)."""
    p = Path(path)
    if not p.exists():
        if str(path) in list_presets():
            return preset(str(path))
        raise InputError(f"material: file not found: {path}")
    try:
        data = tomllib.loads(read_text_input(p, "material"))
    except tomllib.TOMLDecodeError as exc:
        raise InputError(f"material: malformed TOML in {path}: {exc}") from None
    except RecursionError:
        raise InputError(f"material: malformed TOML in {path}: nested too deeply") from None
    return Material.from_dict(data, source=str(path))


def _preset_dir():
    return resources.files("geocontact") / "data" / "presets"


def list_presets() -> list[str]:
    return sorted(p.name[:-5] for p in _preset_dir().iterdir() if p.name.endswith(".toml"))


def preset(name: str) -> Material:
    """A named preset material shipped with the package (e.g. ``reference``)."""
    names = list_presets()
    if name not in names:
        raise InputError(f"preset: unknown name {name!r} (allowed: {', '.join(names)})")
    data = tomllib.loads((_preset_dir() / f"{name}.toml").read_text())
    data.pop("description", None)
    return Material.from_dict(data, source=f"preset {name}")


def preset_description(name: str) -> str:
    data = tomllib.loads((_preset_dir() / f"{name}.toml").read_text())
    return str(data.get("description", ""))
