"""Small, shared file helpers: atomic writes, CSV columns in and out, provenance records."""

from __future__ import annotations

import csv
import ctypes
import fcntl
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
from dataclasses import dataclass, replace
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import numpy as np

from ._version import __version__
from .errors import InputError, interrupts_held


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


def check_output_folder(path: str | Path, what: str) -> Path:
    """``path`` as a folder to write into (a cache): not an existing file, not below a file."""
    path = Path(path)
    for place in [path, *path.parents]:
        if place.exists():
            if not place.is_dir():
                raise InputError(f"{what}: {place} is a file, expected a folder"
                                 + ("" if place == path else f" (for {path})"))
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
        with interrupts_held():  # an interrupt comes after the file, not inside its writer
            yield Path(tmp)
            umask = os.umask(0)
            os.umask(umask)
            os.chmod(tmp, 0o666 & ~umask)  # mkstemp makes 0600; results are for everyone
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
    edited = _edited_files(path, manifest)
    if edited:  # the manifest's SHA-256 no longer holds: someone worked on the result
        extra = f" and {len(edited) - 1} more" if len(edited) > 1 else ""
        raise InputError(f"{field}: {edited[0]}{extra} in {path} changed since geocontact "
                         f"{command} wrote it; refusing to replace the folder: {_KEEP_HINT}")


def _edited_files(directory: Path, manifest: dict[str, Any]) -> list[Path]:
    """Files the manifest lists whose size or SHA-256 differ from what was written (a file
    removed since is not an edit: nothing of the user's would be lost)."""
    edited = []
    for name, entry in manifest.get("files", {}).items():
        path = directory / name
        if path.is_file() and (path.stat().st_size != entry.get("bytes")
                               or _sha256(path) != entry.get("sha256")):
            edited.append(path)
    return edited


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
    if p.is_dir():
        raise InputError(f"{column}: {path} is a directory, expected a CSV file")
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


# --- the one write path of every command -------------------------------------------------------
# Every output a command writes is claimed before its work starts (``claim``): its kind is
# checked (a file name, not a folder; a folder, not a file), it must be ours to replace, its
# folder must be writable, and a lock beside it keeps a second run away until the first ends.
#
# What is ours. A result folder: its manifest (``RESULT_MANIFEST``) names the command and every
# file with its SHA-256; anything added or changed since is the user's (``check_replaceable``).
# A single file (P.json, F.csv): the ledger ``FILES_LEDGER`` of its folder records the SHA-256 of
# every file a command wrote there; a file is replaced only if the ledger holds its present
# bytes, i.e. geocontact wrote it and nobody changed it since. Anything else -- a file of the
# user's, one geocontact wrote and the user edited, one written by a version before the ledger
# -- needs ``overwrite`` (``--force``).
FILES_LEDGER = ".geocontact-files.json"
FILES_SCHEMA = "geocontact.files/1"


@dataclass(frozen=True)
class Output:
    """One output of a command: a ``file`` (written whole by ``atomic_path``), a ``folder``
    (a result of ``command``, ``atomic_directory``) or a ``report`` folder (an existing run
    directory the command writes into). ``field`` is the option that named it."""

    path: Path
    kind: str = "file"
    field: str = "out"


def _ledger(directory: Path) -> dict[str, Any]:
    try:
        document = json.loads((directory / FILES_LEDGER).read_text())
    except (OSError, ValueError):
        return {}
    if not isinstance(document, dict) or document.get("schema") != FILES_SCHEMA:
        return {}
    files = document.get("files")
    return files if isinstance(files, dict) else {}


def written_by_us(path: str | Path) -> bool:
    """Whether ``path`` holds exactly the bytes a geocontact command last wrote there."""
    path = Path(path)
    entry = _ledger(path.parent).get(path.name)
    return (isinstance(entry, dict) and path.is_file()
            and path.stat().st_size == entry.get("bytes") and _sha256(path) == entry.get("sha256"))


def check_file_replaceable(path: str | Path, *, overwrite: bool = False,
                           field: str = "out") -> Path:
    """``path`` as a single-file output: a file name (``check_output_file``) that is missing or
    holds what geocontact wrote there (``written_by_us``); ``overwrite`` lifts the second check."""
    path = check_output_file(path, field)
    if overwrite or not os.path.lexists(path) or written_by_us(path):
        return path
    raise InputError(f"{field}: {path} exists and is not a file geocontact wrote (or it was "
                     "changed since); refusing to replace it: choose another name, move it "
                     "away, or pass overwrite=True")


def record_written(paths: list[Path], command: str) -> None:
    """Add the files a command just wrote to their folders' ledgers (under a lock on the
    folder: two commands writing beside each other keep both entries)."""
    by_folder: dict[Path, list[Path]] = {}
    for path in paths:
        if path.is_file():
            by_folder.setdefault(path.parent, []).append(path)
    for folder, files in by_folder.items():
        with folder_lock(folder):
            ledger = _ledger(folder)
            stamp = datetime.now(UTC).isoformat(timespec="seconds")
            for path in files:
                ledger[path.name] = {"bytes": path.stat().st_size, "sha256": _sha256(path),
                                     "command": command, "written_utc": stamp}
            write_text_atomic(folder / FILES_LEDGER, json.dumps(
                {"schema": FILES_SCHEMA, "files": dict(sorted(ledger.items()))}, indent=2)
                + "\n")


@contextmanager
def folder_lock(folder: str | Path) -> Iterator[None]:
    """Hold ``folder``'s lock (``fcntl.flock`` on the folder itself, waiting for another holder):
    processes that read, change and rewrite files of one folder do it one at a time, so none
    loses another's update. The system releases it when a process dies however it dies."""
    fd = os.open(folder, os.O_RDONLY)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX)
        yield
    finally:
        os.close(fd)


def _lock_path(path: Path) -> Path:
    path = Path(os.path.abspath(path))  # ``DIR/.`` and ``DIR`` are one destination
    return path.parent / f".{path.name}.lock"


def _make_parents(path: Path, field: str) -> list[Path]:
    """Create the missing folders above ``path``; returns them (outermost first) so that a run
    that fails can remove them again. A folder that cannot be made is a one-line error."""
    missing = []
    for parent in [path.parent, *path.parent.parents]:
        if os.path.lexists(parent):
            break
        missing.append(parent)
    for folder in reversed(missing):
        try:
            folder.mkdir()
        except OSError as exc:
            _remove_empty(missing)
            raise InputError(f"{field}: cannot create the folder {folder} for {path}: "
                             f"{exc.strerror}") from None
    return list(reversed(missing))


def _remove_empty(folders: list[Path]) -> None:
    for folder in sorted(folders, key=lambda f: len(f.parts), reverse=True):
        try:
            folder.rmdir()
        except OSError:
            pass


def _holder(fd: int) -> str:
    os.lseek(fd, 0, os.SEEK_SET)
    text = os.read(fd, 64).decode(errors="replace").strip()
    return f"PID {text}" if text.isdigit() else "PID unknown"


def _acquire(path: Path, field: str) -> int:
    """Hold the lock of destination ``path`` (``fcntl.flock`` on ``.NAME.lock`` beside it, so
    the system releases it when a run dies however it dies) and write our PID into it; a
    destination held by another run is a one-line error naming that run's PID. Creating the
    lock file is also the check that the destination's folder is writable."""
    lock = _lock_path(path)
    while True:
        try:
            fd = os.open(lock, os.O_RDWR | os.O_CREAT, 0o644)
        except OSError as exc:
            raise InputError(f"{field}: cannot write in {path.parent}: {exc.strerror}"
                             ) from None
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            holder = _holder(fd)
            os.close(fd)
            raise InputError(f"{field}: {path} is being written by another geocontact run "
                             f"({holder}); wait for it to end or choose another name") from None
        try:
            same = os.stat(lock).st_ino == os.fstat(fd).st_ino
        except FileNotFoundError:
            same = False
        if same:  # not a lock file its last holder removed while we waited to open it
            os.ftruncate(fd, 0)
            os.write(fd, f"{os.getpid()}\n".encode())
            return fd
        os.close(fd)


def _release(path: Path, fd: int) -> None:
    Path(_lock_path(path)).unlink(missing_ok=True)  # while held: the next run makes a new one
    os.close(fd)


def _check_writable_folder(directory: Path, field: str) -> None:
    """A folder the command writes into (``report``): try it, permissions alone do not tell
    (root ignores them; a read-only file system does not)."""
    try:
        with tempfile.TemporaryFile(dir=directory):
            pass
    except OSError as exc:
        raise InputError(f"{field}: cannot write in {directory}: {exc.strerror}") from None


@contextmanager
def claim(outputs: list[Output], command: str, *, overwrite: bool = False) -> Iterator[None]:
    """The one write path of every command: claim ``outputs`` before the work starts and keep
    them until it ends. Each is checked for its kind and that it is ours to replace
    (``check_file_replaceable``, ``check_replaceable``; ``overwrite`` lifts that), its folder is
    created and shown writable, and its lock is taken: a second run on the same destination is
    refused at once, naming the first one's PID. When the block succeeds, the single files
    written join their folder's ledger (``record_written``); when it fails, folders made for
    the outputs are removed again if they are still empty."""
    outputs = [replace(o, path=Path(o.path)) for o in outputs]
    for o in outputs:
        if o.kind == "file":
            check_file_replaceable(o.path, overwrite=overwrite, field=o.field)
        elif o.kind == "folder":
            check_replaceable(o.path, command, overwrite=overwrite, field=o.field)
        elif not o.path.is_dir():
            raise InputError(f"{o.field}: not a directory: {o.path}")
    made: list[Path] = []
    held: list[tuple[Path, int]] = []
    succeeded = False
    try:
        for o in outputs:
            made += _make_parents(o.path, o.field)
            held.append((o.path, _acquire(o.path, o.field)))
            if o.kind == "report":
                _check_writable_folder(o.path, o.field)
        yield
        succeeded = True
        record_written([o.path for o in outputs if o.kind == "file"], command)
    finally:
        for path, fd in reversed(held):
            _release(path, fd)
        if not succeeded:
            _remove_empty(made)
