"""Helpers shared by the sub-commands."""

from __future__ import annotations

import json
import sys
import tomllib
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ..errors import InputError
from ..files import json_safe

if TYPE_CHECKING:
    from ..grain.material import Material


def print_json(document: dict[str, Any]) -> None:
    json.dump(json_safe(document), sys.stdout, indent=2)
    sys.stdout.write("\n")


def add_force_flag(parser, kind: str = "folder") -> None:
    """``--force``: replace an output that geocontact did not write (files.claim)."""
    parser.add_argument("--force", action="store_true", help=(
        "replace the output folder even if it holds files geocontact did not write, files "
        "changed since, or another command's result (without it: refused)" if kind == "folder"
        else "replace the output file even if geocontact did not write it or it was changed "
             "since (without it: refused)"))


def fe_model_of(args) -> dict:
    """The FE model the flags of ``add_fe_model_flags`` chose, as FemJob keywords
    (``fem.settings.FeSettings.model_of``)."""
    from ..fem.settings import FeSettings

    return FeSettings.model_of(args)


def add_fe_model_flags(p) -> None:
    """The FE engine's model flags, --kinematics to --resolve-from
    (``fem.settings.FeSettings.add_model_flags``; docs/fem.md)."""
    from ..fem.settings import FeSettings

    FeSettings.add_model_flags(p)


def _toml_document(path: Path, field: str) -> dict:
    from ..files import read_text_input

    try:
        return tomllib.loads(read_text_input(path, field))
    except tomllib.TOMLDecodeError as exc:
        raise InputError(f"{field}: malformed TOML in {path}: {exc}") from None
    except RecursionError:
        raise InputError(f"{field}: malformed TOML in {path}: nested too deeply") from None


def load_material_arg(path: str) -> Material:
    """``--material``: a preset name or a material TOML file, which may be written like the
    shipped presets (a top-level ``description`` string beside [material] and [geometry]), so
    ``geocontact presets`` output and data/presets/*.toml are templates. Other top-level
    values are unknown keys (tables are unknown sections, ``Material.from_dict``)."""
    from ..grain.material import Material, load_material

    p = Path(path)
    if not p.is_file():  # a preset, or a missing path or a folder: load_material's messages
        return load_material(path)
    data = _toml_document(p, "material")
    description = data.pop("description", "")
    if not isinstance(description, str):
        raise InputError(f"description: must be a string (a note on the material), got "
                         f"{type(description).__name__}")
    for key, value in data.items():
        if not isinstance(value, dict):
            raise InputError(f"{key}: unknown key at the top of {path} (allowed: description, "
                             "and the tables [material] and [geometry])")
    return Material.from_dict(data, source=str(path))


def load_history_arg(path: str) -> list[float]:
    """``--history``: ``load_history``, with a preset's ``peak_force`` required (the library's
    default of 3000 N is the paper's; on the command line a history is what the file says)."""
    from ..grain.force_history import load_history

    forces = load_history(path)
    table = _toml_document(Path(path), "history")["history"]
    if "preset" in table and "peak_force" not in table:
        raise InputError(f"history.peak_force: missing (the peak force of preset "
                         f"{table['preset']!r} in N, e.g. peak_force = 3000.0)")
    return forces
