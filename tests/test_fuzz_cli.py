"""Fuzzing the command line with bad files and arguments (issue 16).

Valid material, history, parameter, approach and record files are mutated (wrong types, NaN,
inf, negative, huge and tiny numbers, bools, missing and unknown keys, truncated text) and fed to
``geocontact.cli.main`` in-process. Whatever the input, the command must exit with 0 or 2, and
on failure print exactly one line on stderr (``error: ...``), no traceback and no warning, and
leave nothing at --out. The expensive part of a valid run is replaced by a stub that stops the
command where the work would start (the FE mesh, the column's time integration), so every
example checks validation only and the module stays well under a minute.
"""

from __future__ import annotations

import contextlib
import copy
import json
import math
import os
import re
import tempfile
import warnings
from pathlib import Path

import numpy as np
import pytest
from conftest import Reached
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from geocontact import preset
from geocontact.cli import main

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
PARAMS = json.loads((EXAMPLES / "params-illustrative.json").read_text())
MATERIAL = preset("reference").to_toml_dict()
HISTORIES = [{"history": {"forces": [0.0, 300.0, 0.0, 300.0, 0.0]}},
             {"history": {"preset": "repeated", "peak_force": 300.0}}]

# Deterministic, so the shared suite does not turn red at random. To hunt for more defects,
# GEOCONTACT_FUZZ=N runs N times as many examples with fresh random ones.
HUNT = int(os.environ.get("GEOCONTACT_FUZZ", "0"))
FUZZ = settings(deadline=None, derandomize=not HUNT, database=None,
                suppress_health_check=[HealthCheck.function_scoped_fixture,
                                       HealthCheck.too_slow])
OUTCOMES: dict[str, int] = {}  # hunting mode: exit codes by command, in the temp folder


def fuzz(examples: int):
    return settings(FUZZ, max_examples=examples * max(HUNT, 1))


# --- values and mutations ---------------------------------------------------------------------
BAD_NUMBERS = [0, -1, -1.0, 0.5, 1, 3, 1e-300, 5e-324, 1e308, -1e308, 10**400, -10**400, 2**63,
               math.nan, math.inf, -math.inf, 1e9, 1e20]
WEIRD = st.one_of(
    st.sampled_from(BAD_NUMBERS),
    st.sampled_from([True, False, "", "abc", "1e3", "nan", [], [1.0], [True], {}, {"a": 1}]),
    st.floats(allow_nan=True, allow_infinity=True),
    st.integers(min_value=-10**30, max_value=10**30),
    st.text(max_size=6),
)
KEY = st.text(alphabet="abcdefghijklmnopqrstuvwxyz_", min_size=1, max_size=8)


def paths(node, prefix=()):
    """Every place in a nested document (dict keys, list indices), containers included."""
    out = [prefix] if prefix else []
    if isinstance(node, dict):
        for k, v in node.items():
            out += paths(v, (*prefix, k))
    elif isinstance(node, list):
        for i, v in enumerate(node):
            out += paths(v, (*prefix, i))
    return out


def mutate(data, doc, json_values: bool):
    """0-3 mutations of a copy of ``doc``: scale a number (the edges of the valid ranges), set a
    value to something weird, delete it, or add an unknown key or list item."""
    doc = copy.deepcopy(doc)
    for _ in range(data.draw(st.integers(0, 3))):
        places = paths(doc)
        if not places:
            break
        where = data.draw(st.sampled_from(places))
        parent = doc
        for step in where[:-1]:
            parent = parent[step]
        key = where[-1]
        action = data.draw(st.sampled_from(["scale", "scale", "set", "set", "delete",
                                            "unknown"]))
        if action == "scale" and isinstance(parent[key], (int, float)) and not isinstance(
                parent[key], bool) and abs(parent[key]) < 1e300:
            parent[key] = parent[key] * data.draw(st.sampled_from(
                [0.0, -1.0, 1e-9, 1e-3, 0.5, 0.999, 1.001, 2.0, 10.0, 1e3, 1e9]))
            continue
        # a copy: sampled lists and tables are shared between examples
        value = copy.deepcopy(data.draw(st.one_of(WEIRD, st.none()) if json_values else WEIRD))
        if action == "set":
            parent[key] = value
        elif action == "delete":
            del parent[key]
        elif isinstance(parent, dict):
            parent[data.draw(KEY)] = value
        else:
            parent.append(value)
    return doc


def toml_value(value) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        return "nan" if math.isnan(value) else ("inf" if value > 0 else "-inf") if math.isinf(
            value) else repr(value)
    if isinstance(value, str):
        return json.dumps(value)
    if isinstance(value, list):
        return "[" + ", ".join(toml_value(v) for v in value) + "]"
    return "{" + ", ".join(f"{json.dumps(k)} = {toml_value(v)}" for k, v in value.items()) + "}"


def toml_text(doc: dict) -> str:
    """TOML with every table inline (``material = {...}``), the same document as [material]."""
    return "".join(f"{json.dumps(k)} = {toml_value(v)}\n" for k, v in doc.items())


def damaged(data, text: str) -> str:
    """Sometimes the file text itself is damaged: cut short or with a stray character."""
    kind = data.draw(st.sampled_from(["as is"] * 8 + ["truncated", "stray"]))
    if kind == "as is" or not text:
        return text
    at = data.draw(st.integers(0, len(text) - 1))
    if kind == "truncated":
        return text[:at]
    return text[:at] + data.draw(st.sampled_from(["\x00", "[", "{", '"', "=", "\n", "é", ","])) \
        + text[at:]


# --- running a command ------------------------------------------------------------------------
def run_cli(capsys, argv: list[str], out: Path | None = None, command=main) -> int | None:
    """Run ``geocontact argv``; check the exit code and stderr, and that a success prints no
    NaN or infinity (a silent wrong answer; --json writes them as null). None: the stub was
    reached."""
    capsys.readouterr()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            code = command(argv)
        except Reached:
            code = None
    captured = capsys.readouterr()
    if HUNT:
        key = f"{argv[0] if command is main else command.__module__} {code}"
        OUTCOMES[key] = OUTCOMES.get(key, 0) + 1
        (Path(tempfile.gettempdir()) / "geocontact-fuzz-outcomes.json").write_text(
            json.dumps(OUTCOMES))
    assert "Traceback" not in captured.err
    assert not [str(w.message) for w in caught], f"warnings for {argv}"
    if code is None:
        return None
    assert code in (0, 2), f"exit {code} for {argv}: {captured.err}"
    if code == 2:
        assert captured.err.startswith("error: ") and captured.err.count("\n") == 1, (
            f"{argv}: {captured.err!r}")
        if out is not None:
            assert not out.exists(), f"{out} left behind by a failed {argv}"
    else:
        printed = re.sub(r"\S*geocontact-fuzz-\S*", "", captured.out.lower())  # the paths
        assert not re.search(r"\b(nan|inf|infinity|null)\b", printed), (argv, printed)
    return code


@contextlib.contextmanager
def folder():
    with tempfile.TemporaryDirectory(prefix="geocontact-fuzz-") as name:
        yield Path(name)


def number_text(data) -> str:
    """A command-line number: fine, out of range, not finite, or not a number at all."""
    return data.draw(st.one_of(
        st.sampled_from(["0", "-1", "1", "0.5", "2", "1e-300", "1e400", "nan", "inf", "-inf",
                         "abc", "", "1e9", "3000"]),
        st.floats(allow_nan=True, allow_infinity=True).map(repr),
        st.integers(-10**6, 10**6).map(str)))


# --- the commands -----------------------------------------------------------------------------
@fuzz(150)
@given(data=st.data())
def test_yield_and_illustrative_law_on_mutated_material_files(capsys, data):
    with folder() as tmp:
        path = tmp / "m.toml"
        path.write_text(damaged(data, toml_text(mutate(data, MATERIAL, json_values=False))))
        if data.draw(st.booleans()):
            run_cli(capsys, ["yield", "--material", str(path), *data.draw(
                st.sampled_from([[], ["--json"]]))])
        else:  # python scripts/make_illustrative_params.py, with the CLI's error reporting
            import make_illustrative_params as illustrative

            out = tmp / "P.json"
            run_cli(capsys, ["--material", str(path), "--out", str(out)], out=out,
                    command=illustrative.main)


@fuzz(400)
@given(data=st.data())
def test_law_on_mutated_parameter_and_approach_files(capsys, data):
    with folder() as tmp:
        params = tmp / "p.json"
        document = mutate(data, PARAMS, json_values=True) if data.draw(st.booleans()) else PARAMS
        params.write_text(damaged(data, json.dumps(document)))
        fine = st.floats(-1e-3, 1e-3)
        approaches = data.draw(st.lists(fine if data.draw(st.booleans()) else st.one_of(
            fine, st.sampled_from(BAD_NUMBERS), st.sampled_from(["abc", ""])),
            min_size=0, max_size=8))
        header = data.draw(st.sampled_from(["approach_m"] * 4 + ["approach_m,force_N",
                                                                 "force_N", ""]))
        rows = "".join(f"{a}\n" if header != "approach_m,force_N" else f"{a},1\n"
                       for a in approaches)
        approach = tmp / "a.csv"
        approach.write_text(damaged(data, f"{header}\n{rows}"))
        out = tmp / data.draw(st.sampled_from(["f.csv", "new/f.csv", "p.json/f.csv", "."]))
        code = run_cli(capsys, ["law", "--params", str(params), "--approach", str(approach),
                                "--out", str(out)], out=out if out.name == "f.csv" else None)
        if code == 0:
            table = out.read_text().lower()
            assert "nan" not in table and "inf" not in table, table


@fuzz(300)
@given(data=st.data())
def test_fem_and_cycles_on_mutated_material_and_history_files(capsys, no_work, data):
    with folder() as tmp:
        material = tmp / "m.toml"
        material.write_text(toml_text(mutate(data, MATERIAL, json_values=False))
                            if data.draw(st.booleans()) else toml_text(MATERIAL))
        history = tmp / "h.toml"
        history.write_text(damaged(data, toml_text(mutate(
            data, data.draw(st.sampled_from(HISTORIES)), json_values=False))))
        command = data.draw(st.sampled_from(["fem", "cycles"]))
        extra = data.draw(st.sampled_from([[], ["--steps", "0"], ["--steps", "20000"],
                                           ["--steps", "5"], ["--mesh", "coarse"]]))
        if command == "cycles" and data.draw(st.booleans()):
            extra += ["--tolerance", number_text(data)]
        out = tmp / "run"
        run_cli(capsys, [command, "--material", str(material), "--history", str(history),
                         "--out", str(out), *extra], out=out)


@fuzz(150)
@given(data=st.data())
def test_calibrate_arguments(capsys, no_work, data):
    with folder() as tmp:
        out = tmp / "P.json"
        options = data.draw(st.lists(st.sampled_from(
            ["--levels", "--max-force", "--peak-forces", "--steps", "--workers"]),
            max_size=3, unique=True))
        argv = ["calibrate", "--material", "reference", "--mesh", "coarse", "--cache",
                str(tmp / "cache"), "--out", str(out)]
        for option in options:
            value = (",".join(number_text(data) for _ in range(data.draw(st.integers(0, 5))))
                     if option == "--peak-forces" else number_text(data))
            argv += [option, value]
        run_cli(capsys, argv, out=out)


def _record_text(data) -> tuple[str, str]:
    """A small record, as a two-column CSV or a PEER AT2 file, perhaps damaged."""
    npts = data.draw(st.integers(0, 120))
    dt = data.draw(st.sampled_from([0.01, 0.01, 0.0, -0.01, 1e-9, math.nan, 0.02]))
    t = np.arange(npts) * 0.01
    acc = 0.2 * np.sin(2 * np.pi * 2.0 * t) * np.exp(-((t - 0.4) / 0.2) ** 2)
    values = [repr(float(a)) for a in acc]
    if values and data.draw(st.booleans()):
        i = data.draw(st.integers(0, len(values) - 1))
        values[i] = data.draw(st.sampled_from(["nan", "inf", "abc", "1e400", "0", "", "1,2"]))
    if data.draw(st.booleans()):
        unit = data.draw(st.sampled_from(["G", "CM/S2", "FURLONGS", ""]))
        npts_given = npts + data.draw(st.sampled_from([0, 0, 0, 1, -1]))
        lines = ["PEER NGA STRONG MOTION DATABASE RECORD", "Fuzz, 1/1/2000, X, 000",
                 f"ACCELERATION TIME SERIES IN UNITS OF {unit}",
                 f"NPTS=  {npts_given}, DT=   {dt} SEC"]
        lines += [" ".join(values[i:i + 5]) for i in range(0, len(values), 5)]
        return "rec.AT2", damaged(data, "\n".join(lines) + "\n")
    header = data.draw(st.sampled_from(["time_s,acceleration_g", "time_s,acceleration_m_s2",
                                        "# units: cm/s^2", "time,acc", ""]))
    rows = [f"{i * dt!r},{v}" for i, v in enumerate(values)]
    return "rec.csv", damaged(data, header + "\n" + "\n".join(rows) + "\n")


@fuzz(300)
@given(data=st.data())
def test_seismic_on_mutated_records_parameters_and_arguments(capsys, no_work, data):
    pytest.importorskip("eqsig")
    with folder() as tmp:
        name, text = _record_text(data)
        record = tmp / name
        record.write_text(text)
        params = tmp / "p.json"
        params.write_text(json.dumps(mutate(data, PARAMS, json_values=True)
                                     if data.draw(st.integers(0, 3)) == 0 else PARAMS))
        out = tmp / "quake"
        argv = ["seismic", str(record), "--params", str(params), "--out", str(out),
                "--no-figures"]
        options = data.draw(st.lists(st.sampled_from(
            ["--pga", "--column", "--surcharge", "--density", "--damping", "--time-step",
             "--time-step-safety", "--output-interval", "--gap", "--aftershock-pga", "--unit",
             "--baseline", "--aftershock"]), max_size=3, unique=True))
        for option in options:
            if option == "--unit":
                value = data.draw(st.sampled_from(["g", "m/s2", "cm/s^2", "gal", "furlongs"]))
            elif option == "--baseline":
                value = data.draw(st.sampled_from(["none", "mean", "linear", "cubic"]))
            elif option == "--aftershock":
                value = f"{record}@{number_text(data)}"
            elif option == "--column":
                value = data.draw(st.sampled_from(["0", "1", "3", "101", "-2", "x"]))
            else:
                value = number_text(data)
            argv += [option, value]
        run_cli(capsys, argv, out=out)


@fuzz(10)
@given(data=st.data())
def test_seismic_short_real_runs(capsys, data):
    """A few whole runs on a 0.2 s record (about 1 s each): the integration, classification and
    outputs with odd but accepted settings."""
    pytest.importorskip("eqsig")
    with folder() as tmp:
        t = np.arange(41) * 0.005
        acc = 0.2 * np.sin(2 * np.pi * 5.0 * t)
        record = tmp / "rec.csv"
        record.write_text("time_s,acceleration_g\n" + "".join(
            f"{float(a)!r},{float(b)!r}\n" for a, b in zip(t, acc, strict=True)))
        params = tmp / "p.json"
        params.write_text(json.dumps(PARAMS))
        out = tmp / "quake"
        argv = ["seismic", str(record), "--params", str(params), "--out", str(out),
                "--no-figures", "--gap", data.draw(st.sampled_from(["0", "0.01"])),
                "--column", data.draw(st.sampled_from(["1", "2", "5"]))]
        choices = {"--pga": ["0.001", "3", "30", "1e4"], "--damping": ["0", "0.05", "1", "50"],
                   "--surcharge": ["0", "1", "1e5"], "--density": ["1", "2650", "1e5"],
                   "--time-step-safety": ["1e-3", "0.5", "1"],
                   "--output-interval": ["1e-9", "0.01", "1"],
                   "--baseline": ["none", "mean", "quadratic"],
                   "--aftershock": [f"{record}@0.5", str(record)]}
        for option in data.draw(st.lists(st.sampled_from(sorted(choices)), max_size=3,
                                         unique=True)):
            argv += [option, data.draw(st.sampled_from(choices[option]))]
        run_cli(capsys, argv, out=out)
