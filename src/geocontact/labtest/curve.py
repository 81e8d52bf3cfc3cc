"""A measured single-grain force-displacement test: reading, units, set-up, contact point and
segmentation into load-unload cycles.

    record = read_test("curve.csv")                  # SI units, checked
    test = condition(record, setup="platens", radius=4e-3, machine_stiffness=2e7)
    test.approach, test.force                         # pair approach (m), force (N), from contact
    test.cycles                                       # per cycle: loading, unloading, reloading

Set-ups (docs/model.md §10; the FE half model is one sphere on a frictionless rigid plane at
interference
w = delta / 2):

* ``pair``: two identical grains; the displacement is the ball-ball approach delta;
* ``platens``: one grain between two rigid platens, two sphere-flat contacts in series each at
  w, so the platen displacement 2 w is the approach delta of the equivalent pair at the same
  force: delta = displacement;
* ``flat``: one grain on one rigid flat, displacement w: delta = 2 x displacement.

The machine's own compliance (platens, load cell, frame: ``machine_stiffness`` in N/m, measured
by the lab with the platens in contact) is subtracted first: u = displacement - F / k.

Contact point: the machine zero is never the contact. The contact point u0 and the load-cell
offset f0 are parameters of one least-squares fit of every branch of the record (loading,
unloading, reloading; ``labtest.contact``): the virgin envelope with its Hertz onset
F = f0 + K (u - u0)_+^1.5, and the unloadings and reloadings of every cycle from their peaks on
that envelope to residual approaches at or after u0. The force noise (sigma, from the residual
of a Savitzky-Golay smoothing, median absolute deviation) sets the robust loss's scale.

Segmentation: the press drives the displacement, so the turning points are found on it (a
zig-zag with a hysteresis of ``TURN_SHARE`` of the displacement range on the smoothed signal,
immune to noise below it); a valley where the force has fallen below ``CLOSED_SHARE`` of the
cycle's peak closes the cycle, and the cycles are ``force_history.cycle_windows`` of those
waypoints. Each cycle's loading splits into reloading (up to the previous largest approach) and
virgin loading (beyond it); points at zero force after lift-off (the platen backed off past the
residual approach) are the gap until re-contact.
"""

from __future__ import annotations

import csv
import hashlib
import math
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from scipy.signal import savgol_filter

from ..errors import InputError
from ..grain.force_history import cycle_peak, cycle_windows
from ..schema import finite_number
from .contact import fit_contact

LENGTH_UNITS = {"m": 1.0, "mm": 1e-3, "um": 1e-6, "µm": 1e-6, "nm": 1e-9}
FORCE_UNITS = {"N": 1.0, "kN": 1e3, "mN": 1e-3}
TIME_UNITS = {"s": 1.0, "ms": 1e-3, "min": 60.0}
KINDS = {"displacement": LENGTH_UNITS, "force": FORCE_UNITS, "time": TIME_UNITS}
SETUPS = ("pair", "platens", "flat")

MIN_POINTS = 50           # fewer points cannot resolve a contact point and three cycles
SMOOTH_WINDOW = 11        # Savitzky-Golay window (points) for the noise estimate and turns
TURN_SHARE = 0.02         # hysteresis of a turning point, share of the displacement range
CLOSED_SHARE = 0.10       # a cycle is closed when the force falls below this share of its peak
TENSION_SIGMAS = 8.0      # a force below -TENSION_SIGMAS x sigma (after the offset) is tension


@dataclass
class Record:
    """A test as read: SI units, in the file's order."""

    displacement: np.ndarray  # m, machine reading
    force: np.ndarray  # N
    time: np.ndarray | None  # s
    source: str
    columns: dict[str, str]  # kind -> column name used
    sha256: str = ""


def _column_spec(columns: str | dict | None) -> dict[str, tuple[str, float]]:
    """``--columns``: ``displacement=NAME:UNIT,force=NAME:UNIT[,time=NAME:UNIT]``."""
    if columns is None:
        return {}
    if isinstance(columns, str):
        items = [c for c in columns.split(",") if c.strip()]
        pairs = {}
        for item in items:
            kind, eq, rest = item.partition("=")
            if not eq:
                raise InputError(f"columns: expected KIND=NAME:UNIT, got {item!r}")
            pairs[kind.strip()] = rest.strip()
        columns = pairs
    spec = {}
    for kind, text in columns.items():
        if kind not in KINDS:
            raise InputError(f"columns: unknown kind {kind!r} (allowed: displacement, force, "
                             "time)")
        name, colon, unit = str(text).rpartition(":")
        if not colon or not name:
            raise InputError(f"columns: {kind}={text!r} needs NAME:UNIT (units: "
                             f"{', '.join(KINDS[kind])})")
        if unit not in KINDS[kind]:
            raise InputError(f"columns: unknown {kind} unit {unit!r} (allowed: "
                             f"{', '.join(KINDS[kind])})")
        spec[kind] = (name, KINDS[kind][unit])
    return spec


_SUFFIXED = re.compile(r"^(displacement|force|time)_(.+)$")


def _find_columns(header: list[str], given: dict) -> dict[str, tuple[int, float, str]]:
    found: dict[str, tuple[int, float, str]] = {}
    names = [h.strip() for h in header]
    for kind, (name, scale) in given.items():
        if name not in names:
            raise InputError(f"columns: no column {name!r} in the test (found: "
                             f"{', '.join(names)})")
        found[kind] = (names.index(name), scale, name)
    for i, name in enumerate(names):
        match = _SUFFIXED.match(name)
        if not match or match.group(1) in found:
            continue
        kind, unit = match.group(1), match.group(2)
        if unit not in KINDS[kind]:
            raise InputError(f"{name}: unknown unit {unit!r} (allowed: "
                             f"{', '.join(f'{kind}_{u}' for u in KINDS[kind])}; or name the "
                             "column with --columns KIND=NAME:UNIT)")
        found[kind] = (i, KINDS[kind][unit], name)
    for kind in ("displacement", "force"):
        if kind not in found:
            allowed = ", ".join(f"{kind}_{u}" for u in KINDS[kind])
            raise InputError(f"{kind}: no {kind} column (expected one of {allowed}, or "
                             f"--columns {kind}=NAME:UNIT); found: {', '.join(names)}")
    return found


def read_test(path: str | Path, columns: str | dict | None = None) -> Record:
    """Read a test CSV (``#`` comment lines allowed): unit-suffixed columns or ``columns``;
    one-line errors for a missing file, unknown units, non-numbers, NaN, too few points and
    time that does not increase."""
    path = Path(path)
    if not path.is_file():
        raise InputError(f"curve: file not found: {path}" if not path.exists()
                         else f"curve: {path} is not a file")
    raw = path.read_bytes()
    try:
        text = raw.decode()
    except UnicodeDecodeError:
        raise InputError(f"curve: {path} is not a UTF-8 text file") from None
    lines = [line for line in text.splitlines() if line.strip() and not line.startswith("#")]
    if not lines:
        raise InputError(f"curve: {path} has no header and no data")
    try:
        rows = list(csv.reader(lines))
    except csv.Error as exc:
        raise InputError(f"curve: {path}: malformed CSV: {exc}") from None
    found = _find_columns(rows[0], _column_spec(columns))
    data = {kind: [] for kind in found}
    for line, row in enumerate(rows[1:], start=2):
        for kind, (i, scale, name) in found.items():
            cell = row[i].strip() if i < len(row) else ""
            try:
                value = float(cell)
            except ValueError:
                raise InputError(f"{name}: row {line} is not a number: {cell!r}") from None
            if math.isnan(value):
                raise InputError(f"{name}: row {line} is NaN; remove or fill the gaps in the "
                                 "record first")
            if not math.isfinite(value):
                raise InputError(f"{name}: row {line} is infinite ({cell})")
            data[kind].append(value * scale)
    n = len(data["force"])
    if n < MIN_POINTS:
        raise InputError(f"curve: {n} data points; need >= {MIN_POINTS} (a contact point and "
                         "three load-unload cycles)")
    time = np.asarray(data["time"]) if "time" in data else None
    if time is not None:
        bad = np.flatnonzero(np.diff(time) <= 0.0)
        if bad.size:
            name = found["time"][2]
            raise InputError(f"{name}: time must increase; row {bad[0] + 3} "
                             f"({time[bad[0] + 1]:g} s) is not after row {bad[0] + 2} "
                             f"({time[bad[0]]:g} s)")
    return Record(displacement=np.asarray(data["displacement"]),
                  force=np.asarray(data["force"]), time=time, source=str(path),
                  columns={k: v[2] for k, v in found.items()},
                  sha256=hashlib.sha256(raw).hexdigest())


def check_setup(setup: str) -> str:
    if setup not in SETUPS:
        raise InputError(f"setup: unknown set-up {setup!r} (allowed: {', '.join(SETUPS)})")
    return setup


def approach_of(displacement, setup: str):
    """The pair approach delta of a set-up's displacement (docs/model.md §10, module docstring)."""
    check_setup(setup)
    return 2.0 * np.asarray(displacement) if setup == "flat" else np.asarray(displacement)


def displacement_of(approach, setup: str):
    """Inverse of ``approach_of``."""
    check_setup(setup)
    return 0.5 * np.asarray(approach) if setup == "flat" else np.asarray(approach)


def local_smoothing(force, time=None) -> tuple[np.ndarray, np.ndarray]:
    """The force smoothed by a local quadratic over SMOOTH_WINDOW points, in time when the
    record has it, and each point's leverage h (the share of its own value in the smoothed one:
    the residual of white noise has the variance (1 - h) sigma^2). On an evenly sampled record
    this is the Savitzky-Golay filter (scipy.signal, mode "interp"). A logger's uneven intervals
    are why it is in time: the press drives the displacement at a constant speed, so the force
    is smooth in time, not in the point index; in the index a jittered interval is a kink of
    the size slope x jitter, which a smoothing in the index takes for noise (the flat test's
    record, intervals 0.3-1.7 x the mean: 4.1e-4 of the peak force against the 3e-4 it was
    made with: docs/fit.md, "The contact point and the master curve")."""
    f = np.asarray(force, dtype=float)
    window = min(SMOOTH_WINDOW, f.size - (1 - f.size % 2))
    t = np.arange(f.size, dtype=float) if time is None else np.asarray(time, dtype=float)
    half = window // 2
    # each point's window: centred, or the first / last full window at the ends
    start = np.clip(np.arange(f.size) - half, 0, f.size - window)
    idx = start[:, None] + np.arange(window)[None, :]
    span = t[idx[:, -1]] - t[idx[:, 0]]
    tau = (t[idx] - t[:, None]) / span[:, None]  # conditioned: the window in [-1, 1]
    x = np.stack([np.ones_like(tau), tau, tau**2], axis=-1)  # (points, window, 3)
    inverse = np.linalg.inv(np.einsum("nwi,nwj->nij", x, x))
    coef = np.einsum("nij,nwj,nw->ni", inverse, x, f[idx])
    # the point itself sits at tau = 0 of its own window: the fit's value there is coef[0]
    return coef[:, 0], inverse[:, 0, 0]


def force_noise(force, time=None) -> float:
    """Standard deviation of the force noise: median absolute deviation of the residual of a
    local quadratic smoothing (``local_smoothing``, in time when given; robust to turning
    points), each residual divided by sqrt(1 - h), the share of white noise it keeps, and
    scaled to a normal's sigma."""
    f = np.asarray(force, dtype=float)
    smooth, leverage = local_smoothing(f, time)
    r = (f - smooth) / np.sqrt(1.0 - leverage)
    return float(1.4826 * np.median(np.abs(r - np.median(r))))


def turning_points(u) -> list[int]:
    """Alternating extrema of a driven displacement (zig-zag with a hysteresis of TURN_SHARE of
    its range, on the smoothed signal): [peak, valley, peak, ...] indices after the start."""
    u = np.asarray(u, dtype=float)
    window = min(SMOOTH_WINDOW, u.size - (1 - u.size % 2))
    s = savgol_filter(u, window, 2)
    h = TURN_SHARE * float(s.max() - s.min())
    turns, rising, best = [], True, 0
    for i in range(1, s.size):
        if rising:
            if s[i] > s[best]:
                best = i
            elif s[i] < s[best] - h:
                turns.append(best)
                rising, best = False, i
        else:
            if s[i] < s[best]:
                best = i
            elif s[i] > s[best] + h:
                turns.append(best)
                rising, best = True, i
    if not rising:  # the record ends on an unloading: its lowest point is the last valley
        turns.append(best)
    return turns


@dataclass
class Cycle:
    """One load-unload cycle of the conditioned test (indices into ``LabTest`` arrays)."""

    start: int  # valley before (or the contact point)
    peak: int
    end: int  # valley after
    closed: bool  # the force fell below CLOSED_SHARE of the peak
    previous_max_approach: float  # largest approach before this cycle (0 for the first)

    def loading(self) -> slice:
        return slice(self.start, self.peak + 1)

    def unloading(self) -> slice:
        return slice(self.peak, self.end + 1)


@dataclass
class LabTest:
    """A conditioned test: pair approach and force from the contact point, and its cycles."""

    record: Record
    setup: str
    radius: float
    machine_stiffness: float | None
    approach: np.ndarray  # m, pair approach, zero at the contact point (negative before)
    force: np.ndarray  # N, offset removed
    noise: float  # N, force noise sigma
    contact: dict
    cycles: list[Cycle] = field(default_factory=list)
    first_contact: int = 0  # index of the first point past the contact point

    @property
    def peak_force(self) -> float:
        return float(self.force.max())

    def inputs(self) -> dict:
        return {"curve": self.record.source, "curve_sha256": self.record.sha256,
                "columns": self.record.columns, "setup": self.setup, "radius_m": self.radius,
                "machine_stiffness_N_per_m": self.machine_stiffness,
                "points": int(self.force.size)}


def condition(record: Record, setup: str, radius: float,
              machine_stiffness: float | None = None, *,
              force: np.ndarray | None = None, contact: dict | None = None) -> LabTest:
    """Compliance, contact point, offset, set-up mapping and cycles of a read test.
    ``force``: a replacement force series (the bootstrap's); ``contact``: a contact point
    (``contact_displacement_m``, ``offset_N``) already found (``labtest.fit.prepare``'s
    refinement on the Hertz onset), instead of the whole-record fit."""
    check_setup(setup)
    radius = finite_number("radius", radius)
    if not radius > 0:
        raise InputError(f"radius: must be > 0 m, got {radius:g}")
    if machine_stiffness is not None:
        machine_stiffness = finite_number("machine_stiffness", machine_stiffness)
        if not machine_stiffness > 0:
            raise InputError(f"machine_stiffness: must be > 0 N/m, got {machine_stiffness:g}")
    f = np.asarray(record.force if force is None else force, dtype=float)
    u = np.asarray(record.displacement, dtype=float)
    if machine_stiffness:
        u = u - f / machine_stiffness
    sigma = force_noise(f, record.time)
    # orient: the press pushes, so the displacement grows into the grain
    if np.median(u[-max(5, u.size // 20):]) < u[0] and u.max() - u[0] < u[0] - u.min():
        u = -u
    turns = turning_points(u)
    peaks = turns[0::2]
    if not peaks or len(turns) < 2:
        raise InputError("curve: no unloading found (the displacement never reverses by "
                         f"{100 * TURN_SHARE:g} % of its range); fit needs load-unload cycles")
    base = float(np.median(f[: max(5, f.size // 50)]))
    if float(f.max()) - base < 10.0 * max(sigma, 1e-300):
        raise InputError(f"curve: the force never rises above the load-cell noise (peak "
                         f"{float(f.max()) - base:.3g} N, noise {sigma:.3g} N): the "
                         "displacement never closes the gap to the grain")
    if contact is None:
        contact = fit_contact(u, f, sigma, turns, SMOOTH_WINDOW)
    f = f - contact["offset_N"]
    tension = np.flatnonzero(f < -max(TENSION_SIGMAS * sigma, 1e-3 * float(f.max())))
    if tension.size:
        i = int(tension[0])
        raise InputError(f"force: {f[i]:.4g} N at row {i + 2} is tension beyond the load-cell "
                         f"noise ({sigma:.3g} N); a grain test is compressive: check the sign "
                         "and the zero of the force column")
    delta = approach_of(u - contact["contact_displacement_m"], setup)
    contact = {**contact, "noise_N": sigma}
    first = int(np.argmax(delta > 0.0))
    test = LabTest(record=record, setup=setup, radius=radius,
                   machine_stiffness=machine_stiffness, approach=delta, force=f, noise=sigma,
                   contact=contact, first_contact=first)
    test.cycles = _cycles(test, turns)
    return test


def _cycles(test: LabTest, turns: list[int]) -> list[Cycle]:
    """Cycles between the valleys where the force fell below CLOSED_SHARE of the peak
    (``force_history.cycle_windows`` over those waypoints)."""
    d, f = test.approach, test.force
    marks = [test.first_contact] + list(turns)
    waypoints = [0.0]
    for k, i in enumerate(turns):
        if k % 2 == 0:
            waypoints.append(float(f[i]))
        else:
            prior_peak = waypoints[-1]
            # the valley's force over a few points: one noisy reading must not keep a small
            # cycle open (0.4 % noise against a first peak at 6 % of the largest, issue 37)
            low = float(np.median(f[max(0, i - SMOOTH_WINDOW // 2):i + SMOOTH_WINDOW // 2 + 1]))
            waypoints.append(0.0 if low < CLOSED_SHARE * prior_peak else low)
    if marks[-1] < f.size - 1 and len(turns) % 2 == 1:  # loading to the end: open
        marks.append(f.size - 1)
        waypoints.append(float(f[-1]))
    cycles, largest = [], 0.0
    for a, b in cycle_windows(waypoints, marks):
        peak_force, _ = cycle_peak(f, d, (a, b))
        k = a + int(np.argmax(f[a:b + 1]))
        closed = float(np.min(f[k:b + 1])) < CLOSED_SHARE * peak_force
        cycles.append(Cycle(start=a, peak=k, end=b, closed=closed,
                            previous_max_approach=largest))
        largest = max(largest, float(np.max(d[a:b + 1])))
    return cycles
