"""Small, shared file helpers: atomic writes, CSV columns in and out, provenance records."""

from __future__ import annotations

import csv
import json
import math
import os
import platform
import shutil
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import numpy as np

from .errors import InputError


def provenance(command: str, inputs: dict[str, Any]) -> dict[str, Any]:
    """What every result file records: the version and the inputs that made it."""
    from . import __version__

    return {
        "geocontact_version": __version__,
        "command": command,
        "inputs": inputs,
        "created_utc": datetime.now(UTC).isoformat(timespec="seconds"),
        "python": platform.python_version(),
    }


def check_output_file(path: str | Path, what: str) -> Path:
    """``path`` as a file to (over)write: not an existing folder, not below a file. Commands
    call it before their work, so a bad --out fails at once; ``atomic_path`` calls it too."""
    path = Path(path)
    if path.is_dir():
        raise InputError(f"{what}: {path} is an existing folder; expected a file name")
    for parent in path.parents:
        if parent.exists():
            if not parent.is_dir():
                raise InputError(f"{what}: {parent} is a file, so {path} cannot be written")
            break
    return path


@contextmanager
def atomic_path(path: str | Path, what: str = "output") -> Iterator[Path]:
    """A temporary path beside ``path`` (same suffix, so writers infer the format) that is
    renamed onto ``path`` when the block succeeds and removed when it fails: a reader never
    sees a half-written file."""
    path = check_output_file(path, what)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=path.suffix, dir=path.parent)
    os.close(fd)
    try:
        yield Path(tmp)
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)  # mkstemp makes 0600; results are for everyone to read
        os.replace(tmp, path)
    finally:
        Path(tmp).unlink(missing_ok=True)


@contextmanager
def atomic_directory(path: str | Path) -> Iterator[Path]:
    """A temporary folder beside ``path``, swapped into place when the block succeeds (an older
    ``path`` is replaced) and removed when it fails: a result directory is never half-written."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(dir=path.parent, prefix=f".{path.name}.tmp-"))
    tmp.chmod(0o755)
    try:
        yield tmp
        old = None
        if path.exists():
            old = path.parent / f".{path.name}.old-{os.getpid()}"
            os.replace(path, old)
        os.replace(tmp, path)
        if old is not None:
            shutil.rmtree(old, ignore_errors=True)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def write_text_atomic(path: str | Path, text: str) -> None:
    with atomic_path(path) as tmp:
        tmp.write_text(text)


def json_safe(value: Any) -> Any:
    """JSON-ready copy: numpy scalars and arrays to Python, NaN and inf to null."""
    if isinstance(value, (float, np.floating)):
        return float(value) if math.isfinite(value) else None
    if isinstance(value, np.integer):
        return int(value)
    if isinstance(value, np.ndarray):
        return [json_safe(v) for v in value.tolist()]
    if isinstance(value, dict):
        return {str(k): json_safe(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [json_safe(v) for v in value]
    return value


def write_json_atomic(path: str | Path, document: dict[str, Any]) -> None:
    write_text_atomic(path, json.dumps(json_safe(document), indent=2) + "\n")


def read_text_input(path: str | Path, what: str) -> str:
    """The text of an input file; a missing file, a directory or non-UTF-8 bytes give a
    one-line InputError naming ``what`` (the field the file was given for)."""
    path = Path(path)
    if not path.exists():
        raise InputError(f"{what}: file not found: {path}")
    if path.is_dir():
        raise InputError(f"{what}: {path} is a directory, expected a file")
    try:
        return path.read_text()
    except UnicodeDecodeError:
        raise InputError(f"{what}: {path} is not a UTF-8 text file") from None


def read_csv_column(path: str | Path, column: str, ragged: bool = False) -> np.ndarray:
    """One numeric column of a CSV file with a header; one-line errors on any defect.
    ``ragged``: the column may end before the file does (blank cells, as ``write_csv`` writes
    columns of different lengths)."""
    p = Path(path)
    if not p.exists():
        raise InputError(f"{column}: file not found: {path}")
    try:
        with p.open(newline="") as handle:
            reader = csv.DictReader(row for row in handle if not row.startswith("#"))
            if reader.fieldnames is None or column not in [f.strip() for f in reader.fieldnames]:
                raise InputError(f"{path}: no column {column!r} (found: {reader.fieldnames})")
            key = next(f for f in reader.fieldnames if f.strip() == column)
            values = []
            for line, row in enumerate(reader, start=2):
                text = (row.get(key) or "").strip()
                if ragged and not text:
                    continue
                try:
                    value = float(text)
                except ValueError:
                    raise InputError(
                        f"{path}:{line}: {column} must be a number, got {text!r}"
                    ) from None
                if not math.isfinite(value):
                    raise InputError(f"{path}:{line}: {column} must be finite, got {text}")
                values.append(value)
    except UnicodeDecodeError:
        raise InputError(f"{path}: not a UTF-8 text file") from None
    except csv.Error as exc:
        raise InputError(f"{path}: malformed CSV: {exc}") from None
    if not values:
        raise InputError(f"{path}: column {column!r} has no rows")
    return np.asarray(values)


def write_csv(path: str | Path, columns: dict[str, np.ndarray]) -> None:
    """Columns of possibly different lengths (a figure's curves); short ones end in blanks."""
    names = list(columns)
    values = [np.asarray(columns[n]).tolist() for n in names]
    length = max((len(v) for v in values), default=0)

    def cell(column, row):
        if row >= len(column):
            return ""
        v = column[row]
        return repr(v) if isinstance(v, float) else str(v)

    lines = [",".join(names)] + [",".join(cell(c, r) for c in values) for r in range(length)]
    write_text_atomic(path, "\n".join(lines) + "\n")
