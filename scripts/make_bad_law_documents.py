"""The corpus of bad ``geocontact.law/1`` documents that the Python loader and the C++ reader
must reject with the same one-line message (``tests/data/bad-law-params/``).

Generated from the schema (``data/law-schema.json``): for every field, each of its bounds
just crossed (open bounds at the bound itself), a value of the wrong type, and missing where it
is required; for every closed object an unknown key; plus the rules between fields, written
here by hand. Each bad document is the base document (a valid one with every optional field
set, ``base.json``; the reference file's, with a ``contact_radius`` block added) with one
change. The expected message is the Python loader's, checked here
to name the field on one line. The fields of the tabulated residual form change a second
base, ``base-table.json`` (the base with ``residual_approach`` a table of its own closed form at
a few depths), those of the loading segments a third, ``base-segments.json`` (the base's virgin
curve written as segments). ``tests/test_law_schema.py`` replays the corpus through both
readers and checks that the committed corpus is what this writes. Regenerate with::

    python scripts/make_bad_law_documents.py --out tests/data/bad-law-params

Never edit the output by hand.
"""

from __future__ import annotations

import copy
import json
import re
from pathlib import Path
from typing import Any

from geocontact import schema
from geocontact.errors import ArgumentParser, InputError, run_reporting_errors
from geocontact.files import write_text_atomic
from geocontact.law.params import LawParams, load_params

CORPUS_SCHEMA = "geocontact.bad-law-params/1"
INDEX = "index.json"
# relative to the working directory (the repository root), as the golden vectors' default:
# the calibrated reference file sets every optional field (deep regime, transition depths, log
# powers, plastic work, cyclic laws, yield.force_N)
DEFAULT_BASE = Path("examples") / "params-reference.json"
# a JSON number that reads as infinity on both sides (JSON has no literal for it)
_INFINITE = 1e400
# the depths of the table base's knots (its ratios: the base's closed form there)
TABLE_DEPTHS = (1.5, 4.0, 20.0, 200.0, 5000.0)
TABLE_BASE = "base-table.json"
# the optional contact-radius fit the reference file does not carry, set in the base so that its
# fields are covered too: the weak grain's fit (examples/params-reference-weak.json) at four of
# its knots, rounded
RADIUS_BASE = {"depth": [3.5, 98.0, 3964.0, 160708.0],
               "envelope_ratio": [1.02, 1.25, 1.81, 1.94],
               "unloading_offset": [0.84, 0.60, 0.24, 0.11],
               "unloading_power": [0.32, 0.24, 0.44, 0.51]}
SEGMENTS_BASE = "base-segments.json"


def table_base(base: dict) -> dict:
    """``base`` with its residual approach tabulated: knots of its own closed form."""
    document = copy.deepcopy(base)
    ratio = LawParams.from_dict(base).residual_ratio(list(TABLE_DEPTHS))
    document["residual_approach"] = {"table": {"depth": list(TABLE_DEPTHS),
                                               "ratio": [float(r) for r in ratio]}}
    return document


def segments_base(base: dict) -> dict:
    """``base`` with its virgin curve written as ``loading.segments``: its regimes, the last one
    split in two at twice its start (the same curve, four segments)."""
    document = copy.deepcopy(base)
    loading = base["loading"]
    depth = [1.0, loading["fully_plastic_approach_ratio"]]
    exponent = [loading["elastic_plastic_exponent"], loading["fully_plastic_exponent"]]
    if "deep_plastic_approach_ratio" in loading:
        depth.append(loading["deep_plastic_approach_ratio"])
        exponent.append(loading["deep_plastic_exponent"])
    depth.append(2.0 * depth[-1])
    exponent.append(exponent[-1])
    document["loading"] = {"segments": {"depth": depth, "exponent": exponent}}
    return document


def _present(document: dict, path: str) -> bool:
    node = document
    for key in path.split("."):
        if not isinstance(node, dict) or key not in node:
            return False
        node = node[key]
    return True


def _get(document: dict, path: str) -> tuple[dict, str]:
    *parents, key = path.split(".")
    node = document
    for p in parents:
        node = node[p]
    return node, key


def _with(base: dict, path: str, value: Any = None, *, remove: bool = False) -> dict:
    document = copy.deepcopy(base)
    node, key = _get(document, path)
    if remove:
        del node[key]
    else:
        node[key] = value
    return document


def _outside(bound: float, closed: bool, below: bool) -> float:
    """A value just beyond a bound: the bound itself when it is open."""
    if not closed:
        return bound
    step = 0.5 * abs(bound) if bound else 0.5
    return bound - step if below else bound + step


def _field_cases(base: dict, alternates: list[dict]) -> list[tuple[str, str, Any]]:
    """(name, field path, bad document) from the schema's table: each field changed in the
    base that holds it (one of ``alternates`` for the fields of the residual table and of the
    loading segments)."""
    cases = []
    for path, spec in schema.fields().items():
        kind = spec["type"]
        if kind == "any":
            continue
        slug = path
        doc = next((alt for alt in alternates
                    if _present(alt, path) and not _present(base, path)), base)
        if "without" in spec:
            # given beside the sibling that excludes it (its value from the base), in the
            # alternate base that holds that sibling
            node, key = _get(base, path)
            sibling = f"{path.rpartition('.')[0]}.{spec['without']}"
            holder = next(alt for alt in alternates if _present(alt, sibling))
            if key in node:
                cases.append((f"{slug}--beside-{spec['without']}", path,
                              _with(holder, path, node[key])))
        node, key = _get(doc, path) if path.split(".")[0] in doc else (None, None)
        if spec.get("required") or (spec.get("with") and node is not None
                                    and spec["with"] in node):
            cases.append((f"{slug}--missing", path, _with(doc, path, remove=True)))
        if kind == "number":
            scale = 1.0
            if "relative_to" in spec:
                scale = _get(doc, spec["relative_to"])[0][spec["relative_to"].split(".")[-1]]
            lo, lo_open, hi, hi_open = schema.bounds(spec, scale)
            if lo is not None:
                cases.append((f"{slug}--below-{'open' if lo_open else 'closed'}-minimum", path,
                              _with(doc, path, _outside(lo, not lo_open, True))))
            if hi is not None:
                cases.append((f"{slug}--above-{'open' if hi_open else 'closed'}-maximum", path,
                              _with(doc, path, _outside(hi, not hi_open, False))))
            cases.append((f"{slug}--string", path, _with(doc, path, "1.0")))
            cases.append((f"{slug}--bool", path, _with(doc, path, True)))
        elif kind == "array":
            cases += _array_cases(path, spec, doc)
        elif kind == "bool":
            cases.append((f"{slug}--number", path, _with(doc, path, 0)))
        elif kind == "string":
            cases.append((f"{slug}--number", path, _with(doc, path, 3)))
        elif kind == "object":
            cases.append((f"{slug}--array", path, _with(doc, path, [1, 2])))
            if spec.get("keys") == "closed":
                cases.append((f"{slug}--unknown-key", f"{path}.colour",
                              _with(doc, f"{path}.colour", 1)))
        if "enum" in spec:
            cases.append((f"{slug}--not-allowed", path, _with(doc, path, "bogus")))
        if "const" in spec:
            cases.append((f"{slug}--other-version", path, _with(doc, path, "geocontact.law/9")))
            cases.append((f"{slug}--long-non-ascii", path,
                          _with(doc, path, "g\u00e9ocontact.law/1 " + "x" * 40)))
    cases.append(("unknown-section", "colour", _with(base, "colour", 1)))
    return cases


def _array_cases(path: str, spec: dict, doc: dict) -> list[tuple[str, str, Any]]:
    """An array field of ``doc``: of the wrong type, too short, too long, as long as its
    ``same_length_as`` field but one, an entry of the wrong type, beyond each bound (the
    first entry below, the last above) or infinite, and not increasing."""
    node, key = _get(doc, path)
    good = list(node[key])
    last = len(good) - 1

    def entry(i: int, value: Any) -> dict:
        return _with(doc, path, [value if j == i else g for j, g in enumerate(good)])

    cases = [
        (f"{path}--number", path, _with(doc, path, 3)),
        (f"{path}--too-few", path, _with(doc, path, good[:spec["minItems"] - 1])),
        (f"{path}--too-many", path, _with(doc, path, good + [good[-1]] * (spec["maxItems"]
                                                                        + 1 - len(good)))),
        (f"{path}--entry-string", f"{path}[1]", entry(1, "1.0")),
        (f"{path}--entry-infinite", f"{path}[{last}]", entry(last, _INFINITE)),
    ]
    if "same_length_as" in spec:
        cases.append((f"{path}--length-differs", path, _with(doc, path, good[:-1])))
    lo, lo_open, hi, hi_open = schema.bounds(spec)
    if lo is not None:
        cases.append((f"{path}--below-{'open' if lo_open else 'closed'}-minimum", f"{path}[0]",
                      entry(0, _outside(lo, not lo_open, True))))
    if hi is not None:
        cases.append((f"{path}--above-{'open' if hi_open else 'closed'}-maximum",
                      f"{path}[{last}]", entry(last, _outside(hi, not hi_open, False))))
    if spec.get("increasing"):
        cases.append((f"{path}--not-increasing", f"{path}[2]", entry(2, good[1])))
    return cases


def _cross_field_cases(base: dict, tabulated: dict,
                       segmented: dict) -> list[tuple[str, str, Any]]:
    """The rules between fields (code on both sides, LawParams.from_dict and params.hpp)."""
    table = tabulated["residual_approach"]["table"]
    low_table = {"depth": table["depth"], "ratio": [0.01 * r for r in table["ratio"]]}
    loading = base["loading"]
    cases = [
        ("loading.deep_plastic_approach_ratio--not-beyond-fully-plastic",
         "loading.deep_plastic_approach_ratio",
         _with(base, "loading.deep_plastic_approach_ratio",
               0.5 * (1.0 + loading["fully_plastic_approach_ratio"]))),
        ("yield.force_N--disagrees-with-hertz", "yield.force_N",
         _with(base, "yield.force_N", 1.01 * base["yield"]["force_N"])),
        ("unloading--creates-energy", "unloading/residual_approach",
         _with(_with(base, "residual_approach.limit", 0.0), "loading.elastic_plastic_exponent",
               3.0)),
        ("unloading--creates-energy-with-table", "unloading/residual_approach",
         _with(_with(tabulated, "residual_approach.table", low_table),
               "loading.elastic_plastic_exponent", 3.0)),
        ("loading.segments.depth--first-not-at-yield", "loading.segments.depth[0]",
         _with(segmented, "loading.segments.depth",
               [1.5, *segmented["loading"]["segments"]["depth"][1:]])),
        ("unloading--creates-energy-with-segments", "unloading/residual_approach",
         _with(_with(segmented, "residual_approach.limit", 0.0), "loading.segments.exponent",
               [3.0, *segmented["loading"]["segments"]["exponent"][1:]])),
        ("residual_approach.limit--infinite", "residual_approach.limit",
         _with(base, "residual_approach.limit", _INFINITE)),
        ("residual_approach.power--huge-integer", "residual_approach.power",
         _with(base, "residual_approach.power", 10**400)),
    ]
    for ratio in ("residual_ratio", "plastic_work_ratio"):
        # c 2^-p just above 1: c = 2^p * 1.01
        power = base["cyclic"][ratio]["power"]
        cases.append((f"cyclic.{ratio}--cycle-2-ratio-above-1", f"cyclic.{ratio}",
                      _with(base, f"cyclic.{ratio}.coefficient", 1.01 * 2.0**power)))
    return cases


def _text(document: Any) -> str:
    # Infinity (not JSON) as a number that reads as infinity, as a value or an array entry
    text = json.dumps(document, indent=2)
    return re.sub(r'(?m)^(\s*(?:"[^"\n]*": )?)Infinity', r"\g<1>1e400", text) + "\n"


def generate(base_path: str | Path = DEFAULT_BASE) -> dict[str, str]:
    """Every file of the corpus by name: the base document, the bad ones, and ``index.json``
    (each bad document's file, the field it names and its expected one-line message)."""
    base = json.loads(Path(base_path).read_text())
    base.pop("provenance", None)  # what made the base is not the point of the corpus
    base.pop("fit_errors", None)
    base.setdefault("contact_radius", copy.deepcopy(RADIUS_BASE))
    LawParams.from_dict(base)  # the base itself is valid
    files = {"base.json": _text(base)}
    index = []
    tabulated = table_base(base)
    LawParams.from_dict(tabulated)
    files[TABLE_BASE] = _text(tabulated)
    segmented = segments_base(base)
    LawParams.from_dict(segmented)
    files[SEGMENTS_BASE] = _text(segmented)
    cases = [*_field_cases(base, [tabulated, segmented]),
             *_cross_field_cases(base, tabulated, segmented)]
    cases.append(("document--not-an-object", "params", [base]))
    for name, path, document in cases:
        text = _text(document)
        try:
            LawParams.from_dict(json.loads(text))
        except InputError as exc:
            message = str(exc)
        else:
            raise AssertionError(f"bad-document case {name} was accepted")
        if not message.startswith(f"{path}:") or "\n" in message:
            raise AssertionError(f"bad-document case {name}: the message does not name "
                                 f"{path} on one line: {message}")
        file = f"{name}.json"
        files[file] = text
        index.append({"file": file, "field": path, "message": message})
    files[INDEX] = json.dumps({"schema": CORPUS_SCHEMA, "base": "base.json",
                               "table_base": TABLE_BASE, "segments_base": SEGMENTS_BASE,
                               "cases": index}, indent=2) + "\n"
    return files


def _earlier_corpus(out: Path) -> list[dict]:
    """The cases of the corpus already in ``out`` (none for a new or empty folder). A folder
    holding anything else is not ours to write into: refused."""
    if not out.exists():
        return []
    if not out.is_dir():
        raise InputError(f"--out: {out} is a file; expected a corpus folder")
    index = out / INDEX
    if not index.is_file():
        if any(out.iterdir()):
            raise InputError(f"--out: {out} holds files but no {INDEX} of a bad-document "
                             "corpus; refusing to write into it: choose another folder")
        return []
    try:
        doc = json.loads(index.read_text())
    except (OSError, ValueError):
        doc = None
    if not isinstance(doc, dict) or doc.get("schema") != CORPUS_SCHEMA:
        raise InputError(f"--out: {index} is not the index of a bad-document corpus "
                         f"({CORPUS_SCHEMA}); refusing to write into {out}")
    return [c for c in doc.get("cases", []) if isinstance(c, dict)]


def write(out: str | Path, base_path: str | Path = DEFAULT_BASE) -> int:
    """Write the corpus into ``out``; a case file of an earlier corpus (named in its index)
    that is no longer generated is removed, any other file is left alone."""
    out = Path(out)
    files = generate(base_path)
    earlier = _earlier_corpus(out)
    out.mkdir(parents=True, exist_ok=True)
    for case in earlier:
        # only plain file names of an index this generator wrote: never a path elsewhere
        name = str(case.get("file", ""))
        stale = out / name
        if (name not in files and Path(name).name == name and name.endswith(".json")
                and stale.is_file()):
            stale.unlink()
    for name, text in files.items():
        write_text_atomic(out / name, text)
    return len(files) - 3  # the bases and the index


def main(argv: list[str] | None = None) -> int:
    parser = ArgumentParser(prog="python scripts/make_bad_law_documents.py",
                            description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", required=True, help="corpus folder")
    parser.add_argument("--base", default=str(DEFAULT_BASE),
                        help="a valid parameter file with every optional field set")

    def run() -> None:
        args = parser.parse_args(argv)  # a bad flag is one line, not a traceback
        if not Path(args.base).exists():
            raise InputError(f"--base: file not found: {args.base}")
        load_params(args.base)
        print(f"{write(args.out, args.base)} bad documents in {args.out}")

    return run_reporting_errors(run)


if __name__ == "__main__":
    raise SystemExit(main())
