"""The table of every field of a ``geocontact.law/1`` parameter file: type, required or
optional, default, allowed range and the one-line message (``data/law-schema.json``).

The Python loader (``geocontact.law.params``, and ``geocontact.grain.material`` for the material's
ranges) and the C++ reader (``plugins/lammps/include/geocontact/params.hpp``, which embeds the
same file at build time) both validate from it, with the same messages; the bad documents of
``tests/data/bad-law-params/`` hold the two to it. Rules between fields (a deep regime beyond
the fully plastic one, the cycle-2 ratio, Hertz at yield, the energy check) are code on each
side (``LawParams``), in that corpus too. How to add a field: docs/law.md.
"""

from __future__ import annotations

import json
import math
import numbers
from functools import cache
from importlib import resources
from typing import Any

from .errors import InputError

SCHEMA_FILE = "law-schema.json"


@cache
def law_schema() -> dict[str, Any]:
    """The parsed schema file, as shipped in the package."""
    return json.loads((resources.files("geocontact") / "data" / SCHEMA_FILE).read_text())


@cache
def fields() -> dict[str, dict[str, Any]]:
    """Every field by its dotted path, in the order they are checked."""
    return {f["path"]: f for f in law_schema()["fields"]}


def field(path: str) -> dict[str, Any]:
    return fields()[path]


def default(spec: dict[str, Any]) -> Any:
    """A field's default value (``"inf"`` in the file stands for infinity)."""
    value = spec.get("default")
    return math.inf if value == "inf" else value


@cache
def _children(path: str) -> tuple[dict[str, Any], ...]:
    """The fields one level below ``path`` ("" for the document), in schema order."""
    return tuple(f for p, f in fields().items() if p.rpartition(".")[0] == path)


def _key(spec: dict[str, Any]) -> str:
    return spec["path"].rpartition(".")[2]


def kind_name(value: Any) -> str:
    """What a JSON value is, in the words of the messages (the C++ reader's json::kind_name)."""
    if value is None:
        return "null"
    if isinstance(value, bool):
        return "true/false"
    if isinstance(value, numbers.Real):
        return "a number"
    if isinstance(value, str):
        return "a string"
    if isinstance(value, (list, tuple)):
        return "an array"
    return "an object"


def bounds(spec: dict[str, Any], scale: float = 1.0) -> tuple[float | None, bool, float | None,
                                                              bool]:
    """(low, low open, high, high open) of a number field, times ``scale`` (None: unbounded)."""
    lo_open = "exclusiveMinimum" in spec
    hi_open = "exclusiveMaximum" in spec
    lo = spec.get("exclusiveMinimum", spec.get("minimum"))
    hi = spec.get("exclusiveMaximum", spec.get("maximum"))
    return (None if lo is None else lo * scale, lo_open, None if hi is None else hi * scale,
            hi_open)


def finite_number(field: str, value: Any) -> float:
    """``value`` as a float, or a one-line InputError naming ``field``: the one check of a
    number read from a file (material, history, law parameters). A TOML/JSON ``true`` is not
    a number (Python's bool is an int: it would silently read as 1)."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise InputError(f"{field}: expected a number, got {value!r}"[:200])
    try:
        number = float(value)
    except OverflowError:  # an integer of hundreds of digits
        number = math.inf
    if not math.isfinite(number):
        raise InputError(f"{field}: must be a finite number, got {number}")
    return number


def check_number(where: str, value: Any, spec: dict[str, Any], scale: float = 1.0) -> float:
    """``value`` as a float inside the field's range, or the one-line InputError naming
    ``where``. ``scale``: the value of the field's ``relative_to`` field, if it has one."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        # what the value is rather than its repr: the C++ reader says the same
        raise InputError(f"{where}: expected a number, got {kind_name(value)}")
    number = finite_number(where, value)
    lo, lo_open, hi, hi_open = bounds(spec, scale)
    bad_lo = lo is not None and (number <= lo if lo_open else number < lo)
    bad_hi = hi is not None and (number >= hi if hi_open else number > hi)
    if bad_lo or bad_hi:
        # an unbounded side reads as open: (0, inf)
        rng = (f"{'(' if lo_open or lo is None else '['}"
               f"{'-inf' if lo is None else format(lo, 'g')}, "
               f"{'inf' if hi is None else format(hi, 'g')}"
               f"{')' if hi_open or hi is None else ']'}")
        unit = f" {spec['unit']}" if "unit" in spec else ""
        if "relative_to" in spec:
            low, _, high, _ = bounds(spec)
            unit += (f" ({'-inf' if low is None else format(low, 'g')} to "
                     f"{'inf' if high is None else format(high, 'g')} x "
                     f"{spec['relative_to'].rpartition('.')[2]})")
        raise InputError(f"{where}: must be in {rng}{unit}, got {number:g}")
    return number


def check_array(where: str, value: Any, spec: dict[str, Any],
                values: dict[str, Any] | None = None) -> tuple[float, ...]:
    """``value`` as a tuple of floats: an array of ``minItems`` to ``maxItems`` numbers (as
    many as its ``same_length_as`` field in ``values``), each inside the field's range
    (named ``where[i]``, from 0) and, if ``increasing``, strictly above the one before; or the
    one-line InputError."""
    if not isinstance(value, (list, tuple)):
        raise InputError(f"{where}: must be an array of numbers, got {kind_name(value)}")
    low, high = spec["minItems"], spec["maxItems"]
    if not low <= len(value) <= high:
        raise InputError(f"{where}: must have {low} to {high} entries, got {len(value)}")
    other = spec.get("same_length_as")
    if other is not None and values is not None and len(value) != len(values[other]):
        raise InputError(f"{where}: must have as many entries as {other} "
                         f"({len(values[other])}), got {len(value)}")
    out: list[float] = []
    for i, item in enumerate(value):
        number = check_number(f"{where}[{i}]", item, spec)
        if spec.get("increasing") and out and number <= out[-1]:
            raise InputError(f"{where}[{i}]: must be above {where}[{i - 1}] = {out[-1]:g} "
                             f"(strictly increasing), got {number:g}")
        out.append(number)
    return tuple(out)


def validate(document: Any) -> dict[str, Any]:
    """Every field of a ``geocontact.law/1`` document checked against the schema, in its order.

    Returns the value of each field by path: given, or its default (numbers as floats; an
    open object's extra keys under ``PATH.*`` as a dict). Rules between fields are not checked
    here (``LawParams.from_dict``)."""
    if not isinstance(document, dict):
        raise InputError("params: must hold a JSON object")
    values: dict[str, Any] = {}
    _check_object("", document, values)
    return values


def _check_object(path: str, data: dict[str, Any], values: dict[str, Any]) -> None:
    children = _children(path)
    known = {_key(c): c for c in children}
    spec = fields().get(path, {"keys": "closed"})
    if spec.get("keys") == "closed":
        for key in data:
            if key not in known:
                where = f"{path}.{key}" if path else key
                raise InputError(f"{where}: unknown key (allowed: {', '.join(known)})")
    else:
        values[f"{path}.*"] = {k: v for k, v in data.items() if k not in known}
    for key, child in known.items():
        _check_field(child, data, key in data, data.get(key), values)


def _check_field(spec: dict[str, Any], parent: dict[str, Any] | None, present: bool, value: Any,
                 values: dict[str, Any]) -> None:
    path, kind = spec["path"], spec["type"]
    excluded = spec.get("without") in (parent or {})
    if present and excluded:
        raise InputError(f"{path}: must be left out beside {path.rpartition('.')[0]}."
                         f"{spec['without']}")
    if not present:
        # beside its "without" sibling a field is neither required nor needed by a "with"
        needed = not excluded and (spec.get("required") or spec.get("with") in (parent or {}))
        if parent is not None and needed:
            raise InputError(f"{path}: missing")
        if kind == "object":
            if "name" in spec:
                values[path] = {}
            for child in _children(path):
                _check_field(child, None, False, None, values)
        elif "default" in spec:
            values[path] = tuple(default(spec)) if kind == "array" else default(spec)
        return
    if kind == "number":
        scale = values[spec["relative_to"]] if "relative_to" in spec else 1.0
        values[path] = check_number(path, value, spec, scale)
    elif kind == "array":
        values[path] = check_array(path, value, spec, values)
    elif kind == "bool":
        if not isinstance(value, bool):
            raise InputError(f"{path}: must be true or false, got {kind_name(value)}")
        values[path] = value
    elif kind == "string":
        if not isinstance(value, str):
            raise InputError(f"{path}: must be a string, got {kind_name(value)}")
        if "const" in spec and value != spec["const"]:
            raise InputError(f"{path}: expected {spec['const']!r}, got {_short(value)}")
        if "enum" in spec and value not in spec["enum"]:
            raise InputError(f"{path}: must be one of {', '.join(spec['enum'])}, "
                             f"got {_short(value)}")
        values[path] = value
    elif kind == "object":
        if not isinstance(value, dict):
            raise InputError(f"{path}: must be a JSON object, got {kind_name(value)}")
        if "name" in spec:
            values[path] = dict(value)
        _check_object(path, value, values)


def _short(text: str) -> str:
    """A string echoed in a message: quoted if short printable ASCII (what the C++ reader can
    echo alike), else only its length."""
    if len(text) <= 40 and all(" " <= c <= "~" and c not in "\\\"" for c in text):
        return f'"{text}"'
    return f"a string of {len(text)} characters"


def named_values(values: dict[str, Any]) -> dict[str, Any]:
    """The validated values by their ``name`` (``group.attribute`` or ``attribute``)."""
    return {f["name"]: values[p] for p, f in fields().items() if "name" in f and p in values}
