"""Small, shared file helpers: atomic writes, CSV columns in and out, provenance records."""

from __future__ import annotations

import csv
import ctypes
import hashlib
import json
import math
import os
import platform
import re
import shutil
import sys
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import numpy as np

from ._version import __version__
from .errors import InputError


def provenance(command: str, inputs: dict[str, Any]) -> dict[str, Any]:
    """What every result file records: the version and the inputs that made it."""

    return {
        "geocontact_version": __version__,
        "command": command,
        "inputs": inputs,
        "created_utc": datetime.now(UTC).isoformat(timespec="seconds"),
        "python": platform.python_version(),
    }


# --- result folders and temporaries ------------------------------------------------------------
# Every folder geocontact writes as a result carries this manifest, written last: the command
# that wrote it, the version and every file it holds. A folder without one (or holding files the
# manifest does not list) is the user's and is never replaced without ``overwrite``.
RESULT_MANIFEST = ".geocontact-result.json"
RESULT_SCHEMA = "geocontact.result/1"
# Hidden temporaries beside a target: ``.NAME.tmp-PID-XXXX[.suffix]`` (a file or folder being
# written) and ``.NAME.old-PID-XXXX`` (a replaced result about to be removed). The PID says
# whether the writer still runs; those of dead writers (SIGKILL, a power cut) are swept.
_TEMP = re.compile(r"^\.(?P<name>.+)\.(?P<kind>tmp|old)-(?P<pid>\d+)-[A-Za-z0-9_]+(\.[^.]*)?$")


def _pid_alive(pid: int) -> bool:
    if pid == os.getpid():
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # alive, someone else's
        return True
    return True


def _remove(path: Path) -> None:
    if path.is_dir() and not path.is_symlink():
        shutil.rmtree(path, ignore_errors=True)
    else:
        path.unlink(missing_ok=True)


def sweep_temporaries(path: str | Path) -> list[Path]:
    """Remove the hidden temporaries that dead writers left beside ``path``; a replaced result
    stranded by an interrupt between the two renames of a swap (``path`` itself missing) is put
    back in place. Returns what was removed or recovered."""
    path = Path(path)
    if not path.parent.is_dir():
        return []
    touched = []
    for entry in sorted(path.parent.iterdir()):
        match = _TEMP.match(entry.name)
        if not match or match["name"] != path.name or _pid_alive(int(match["pid"])):
            continue
        if match["kind"] == "old" and not os.path.lexists(path):
            os.replace(entry, path)
            print(f"recovered {path} (a replaced result left by an interrupted run)",
                  file=sys.stderr)
        else:
            _remove(entry)
        touched.append(entry)
    return touched


def _temp_prefix(path: Path, kind: str) -> str:
    return f".{path.name}.{kind}-{os.getpid()}-"


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
    sweep_temporaries(path)
    fd, tmp = tempfile.mkstemp(prefix=_temp_prefix(path, "tmp"), suffix=path.suffix,
                               dir=path.parent)
    os.close(fd)
    try:
        yield Path(tmp)
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)  # mkstemp makes 0600; results are for everyone to read
        os.replace(tmp, path)
    finally:
        Path(tmp).unlink(missing_ok=True)


def read_manifest(directory: str | Path) -> dict[str, Any] | None:
    """The result manifest of ``directory``, or None if it has none (or an unreadable one)."""
    try:
        document = json.loads((Path(directory) / RESULT_MANIFEST).read_text())
    except (OSError, ValueError):
        return None
    if not isinstance(document, dict) or document.get("schema") != RESULT_SCHEMA:
        return None
    return document


def _foreign_files(directory: Path) -> list[Path]:
    """Files under ``directory`` that no manifest of ours lists (each file is judged by the
    nearest manifest above it, so nested results count as ours): what the user put there.
    Hidden temporaries of our own writers are not foreign."""
    foreign: list[Path] = []

    def walk(folder: Path, base: Path, listed: set[str]) -> None:
        manifest = read_manifest(folder)
        if manifest is not None:
            base, listed = folder, set(manifest.get("files", {}))
        for entry in sorted(folder.iterdir()):
            if entry.name == RESULT_MANIFEST or _TEMP.match(entry.name):
                continue
            if entry.is_dir() and not entry.is_symlink():
                walk(entry, base, listed)
            elif entry.relative_to(base).as_posix() not in listed:
                foreign.append(entry)

    walk(directory, directory, set())
    return foreign


_KEEP_HINT = "choose another folder, move your files out, or pass overwrite=True"


def check_replaceable(path: str | Path, command: str, *, overwrite: bool = False,
                      field: str = "out") -> None:
    """Refuse (one-line InputError) to replace ``path`` unless it is missing, an empty folder,
    or a result of ``command`` holding only files geocontact wrote; ``overwrite`` lifts the check
    on a folder (never on a file)."""
    path = Path(path)
    sweep_temporaries(path)
    if not os.path.lexists(path):
        return
    if not path.is_dir() or path.is_symlink():
        raise InputError(f"{field}: {path} exists and is not a folder; give a folder path")
    if overwrite or not any(path.iterdir()):
        return
    manifest = read_manifest(path)
    if manifest is None:
        raise InputError(f"{field}: {path} exists and is not a geocontact result (no "
                         f"{RESULT_MANIFEST}); refusing to replace it: {_KEEP_HINT}")
    if manifest.get("command") != command:
        raise InputError(f"{field}: {path} holds a geocontact {manifest.get('command')!r} "
                         f"result, not a {command!r} one; refusing to replace it: {_KEEP_HINT}")
    foreign = _foreign_files(path)
    if foreign:
        extra = f" and {len(foreign) - 1} more" if len(foreign) > 1 else ""
        raise InputError(f"{field}: {foreign[0]}{extra} in {path} was not written by geocontact "
                         f"{command}; refusing to replace the folder: {_KEEP_HINT}")


def _sha256(path: Path) -> str:
    digest = hashlib.sha256()
    with path.open("rb") as handle:
        for block in iter(lambda: handle.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def write_manifest(directory: str | Path, command: str,
                   inputs: dict[str, Any] | None = None) -> dict[str, Any]:
    """List every file under ``directory`` (size and SHA-256) in its manifest, written last."""

    directory = Path(directory)
    files = {}
    for entry in sorted(directory.rglob("*")):
        if entry.is_file() and entry.name != RESULT_MANIFEST:
            files[entry.relative_to(directory).as_posix()] = {
                "bytes": entry.stat().st_size, "sha256": _sha256(entry)}
    document = {"schema": RESULT_SCHEMA, "command": command, "geocontact_version": __version__,
                "created_utc": datetime.now(UTC).isoformat(timespec="seconds"),
                "inputs": json_safe(inputs or {}), "files": files}
    write_text_atomic(directory / RESULT_MANIFEST, json.dumps(document, indent=2) + "\n")
    return document


def add_to_manifest(directory: str | Path, names: list[str]) -> None:
    """Add files written later into a result of ours (a report) to its manifest; nothing if
    ``directory`` is not one."""
    directory = Path(directory)
    manifest = read_manifest(directory)
    if manifest is None:
        return
    for name in names:
        path = directory / name
        manifest["files"][name] = {"bytes": path.stat().st_size, "sha256": _sha256(path)}
    write_text_atomic(directory / RESULT_MANIFEST, json.dumps(manifest, indent=2) + "\n")


def verify_manifest(directory: str | Path) -> list[str]:
    """What is wrong with a result folder against its manifest (missing manifest, missing or
    changed files); empty when the folder is complete and as written."""
    directory = Path(directory)
    manifest = read_manifest(directory)
    if manifest is None:
        return [f"{directory}: no {RESULT_MANIFEST} (not a complete geocontact result)"]
    problems = []
    for name, entry in manifest.get("files", {}).items():
        path = directory / name
        if not path.is_file():
            problems.append(f"{path}: missing")
        elif path.stat().st_size != entry.get("bytes") or _sha256(path) != entry.get("sha256"):
            problems.append(f"{path}: changed since it was written")
    return problems


_RENAME_EXCHANGE = 2


def _exchange(a: Path, b: Path) -> bool:
    """Swap two paths in one atomic rename (Linux renameat2 RENAME_EXCHANGE); False where the
    system or the file system cannot."""
    if not sys.platform.startswith("linux"):
        return False
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        renameat2 = libc.renameat2
    except (OSError, AttributeError):
        return False
    at_fdcwd = -100
    if renameat2(at_fdcwd, os.fsencode(a), at_fdcwd, os.fsencode(b), _RENAME_EXCHANGE) == 0:
        return True
    return False


@contextmanager
def atomic_directory(path: str | Path, command: str, *, overwrite: bool = False,
                     inputs: dict[str, Any] | None = None) -> Iterator[Path]:
    """A temporary folder beside ``path``, swapped into place when the block succeeds and
    removed when it fails: a result directory is never half-written, and its manifest
    (``RESULT_MANIFEST``, written last) says which command wrote which files.

    An existing ``path`` is replaced only if it is a result of the same ``command`` holding
    nothing but what geocontact wrote (``check_replaceable``; ``overwrite`` lifts this). The swap is
    one atomic rename where the system has one (Linux); elsewhere an interrupt between the two
    renames leaves the old result under a dot-name, put back by the next run."""
    path = Path(path)
    check_replaceable(path, command, overwrite=overwrite)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(dir=path.parent, prefix=_temp_prefix(path, "tmp")))
    tmp.chmod(0o755)
    try:
        yield tmp
        write_manifest(tmp, command, inputs)
        if os.path.lexists(path) and _exchange(tmp, path):
            return  # ``tmp`` now holds the old result: removed below
        old = None
        if os.path.lexists(path):
            old = Path(tempfile.mkdtemp(dir=path.parent, prefix=_temp_prefix(path, "old")))
            os.replace(path, old)
        os.replace(tmp, path)
        if old is not None:
            _remove(old)
    finally:
        _remove(tmp)


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
