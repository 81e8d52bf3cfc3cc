"""Loading-history class and shakedown state of a contact, and the paper's peak-time rule.

The paper (section "Seismic loading") sorts records by **when their peak comes**: a peak early in
the record (El Centro < 7 %, Kobe < 19 % of the record length) makes the record an *extended
monotonically decreasing* history (docs/model.md §8: the first, largest load does the plastic work,
later smaller cycles are elastic - elastic shakedown); a later peak (Wenchuan, about 25 %) gives it
*repeated / monotonically increasing* character (limited hardening, ratchetting possible).
:func:`peak_time_rule` is that rule.

:func:`history_class` decides the same question from a contact-force history itself: the cycles
come from rainflow counting (ASTM E1049, the maintained ``rainflow`` package); each significant
cycle contributes its upper force and the time it is reached, and the sequence of those peaks is
classified:

* ``single``: one significant cycle;
* ``repeated``: several cycles reach the top level (within ``tolerance`` of the force range);
* ``extended monotonically decreasing``: the top is reached within the first ``early_fraction``
  of the significant cycles and never again;
* ``monotonically increasing``: the top comes later, after a staircase of rising maxima;
* otherwise (late top, no staircase) ``repeated``.

:func:`shakedown_state` reads what the law did rather than what the force did: the growth of the
residual approach and of the dissipated energy in the second half of the significant cycles,
relative to their growth over the whole history, by the rule of ``geocontact.calibrate.cyclic_fit``
(:func:`calibrate.cyclic_fit.shakedown_rule`; docs/model.md §6: elastic shakedown when both stop,
plastic shakedown when only the residual approach stops, ratchetting when it keeps growing).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

# The shakedown states and their rule are shared with the cyclic-history analysis.
from ...calibrate.cyclic_fit import (
    ELASTIC,
    ELASTIC_SHAKEDOWN,
    RATCHETTING,
    shakedown_rule,
)
from ...errors import InputError

DECREASING = "extended monotonically decreasing"
REPEATED = "repeated"
INCREASING = "monotonically increasing"
SINGLE = "single"
NO_LOADING = "none"
REPEATED_OR_INCREASING = "repeated/monotonically increasing"


# The paper's records: El Centro 7 % and Kobe 19 % behave as decreasing, Wenchuan 25 % does not.
PAPER_EARLY_PEAK_FRACTION = 0.20


@dataclass(frozen=True)
class Cycle:
    """A rainflow cycle: range, mean, count (1 or 0.5) and the sample where its top is reached."""

    range: float
    mean: float
    count: float
    peak_index: int

    @property
    def peak(self) -> float:
        return self.mean + 0.5 * self.range


def rainflow_cycles(history: np.ndarray) -> list[Cycle]:
    """Rainflow cycles of a history, each with the index of its upper reversal."""
    import rainflow

    values = np.asarray(history, dtype=float)
    if values.ndim != 1 or not np.all(np.isfinite(values)):
        raise InputError("history: must be a one-dimensional array of finite numbers")
    cycles = []
    for rng, mean, count, i_start, i_end in rainflow.extract_cycles(values):
        top = i_start if values[i_start] >= values[i_end] else i_end
        cycles.append(Cycle(float(rng), float(mean), float(count), int(top)))
    return cycles


@dataclass(frozen=True)
class HistoryClass:
    """The loading-history class of one force history and the numbers it was decided on."""

    history_class: str
    significant_cycles: float  # rainflow count (half cycles count 0.5)
    significant_peaks: int  # distinct upper reversals of the significant cycles
    top_force: float
    top_time_index: int
    peaks_before_top_fraction: float
    peaks_near_top: int
    rising_maxima: int

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


def significant_peaks(history: np.ndarray, significance: float = 0.05
                      ) -> tuple[np.ndarray, np.ndarray, float]:
    """Indices and forces of the distinct tops of the rainflow cycles whose range is at least
    ``significance`` times the range of the history, in time order; and their rainflow count."""
    values = np.asarray(history, dtype=float)
    span = float(np.ptp(values)) if values.size else 0.0
    cycles = [c for c in rainflow_cycles(values) if span > 0 and c.range >= significance * span]
    index = np.array(sorted({c.peak_index for c in cycles}), dtype=int)
    return index, values[index], float(sum(c.count for c in cycles))


def history_class(force: np.ndarray, *, significance: float = 0.05, tolerance: float = 0.05,
                  early_fraction: float = PAPER_EARLY_PEAK_FRACTION, min_repeats: int = 3,
                  min_rises: int = 3) -> HistoryClass:
    """Loading-history class (docs/model.md §8) of a compressive force history, from rainflow.

    ``significance``: a cycle counts if its range is at least this fraction of the history's
    range. ``tolerance``: a peak is "at the top" if within this fraction of the range below the
    highest peak, and a new maximum "rises" if it beats the previous one by more than that.
    """
    values = np.asarray(force, dtype=float)
    span = float(np.ptp(values)) if values.size else 0.0
    index, peaks, count = significant_peaks(values, significance)
    if span <= 0 or peaks.size == 0:
        return HistoryClass(NO_LOADING, 0.0, 0, float(values.max(initial=0.0)), 0, 0.0, 0, 0)
    top = float(peaks.max())
    near = peaks >= top - tolerance * span
    first_top = int(np.argmax(near))
    running = -np.inf
    rises = 0
    for p in peaks:
        if p > running + tolerance * span:
            rises += 1
            running = p
        else:
            running = max(running, p)
    before = first_top / peaks.size
    n_near = int(near.sum())
    if peaks.size == 1:
        cls = SINGLE
    elif n_near >= min_repeats:
        cls = REPEATED
    elif before <= early_fraction:
        cls = DECREASING
    elif rises >= min_rises:
        cls = INCREASING
    else:
        cls = REPEATED
    return HistoryClass(
        history_class=cls,
        significant_cycles=count,
        significant_peaks=int(peaks.size),
        top_force=top,
        top_time_index=int(index[first_top]),
        peaks_before_top_fraction=float(before),
        peaks_near_top=n_near,
        rising_maxima=rises,
    )


def peak_time_rule(peak_time_fraction: float,
                   early_fraction: float = PAPER_EARLY_PEAK_FRACTION) -> str:
    """The paper's rule: an early peak makes the record an extended monotonically decreasing
    history, a later one gives it repeated / monotonically increasing character."""
    if not 0.0 <= peak_time_fraction <= 1.0:
        raise InputError(f"peak_time_fraction: must be in [0, 1], got {peak_time_fraction:g}")
    return DECREASING if peak_time_fraction <= early_fraction else REPEATED_OR_INCREASING


def agrees_with_paper_rule(history: str, rule: str) -> bool:
    """Whether a rainflow history class falls in the paper rule's category."""
    if rule == DECREASING:
        return history in (DECREASING, SINGLE)
    return history in (REPEATED, INCREASING)


@dataclass(frozen=True)
class ShakedownState:
    state: str
    residual_growth: float  # m, over the whole history
    residual_growth_late: float  # m, over the second half of the significant cycles
    dissipation: float  # J, over the whole history
    dissipation_late: float  # J, over the second half
    shakedown_cycle: int | None  # significant peaks until the residual approach has settled

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


def shakedown_state(force: np.ndarray, residual_approach: np.ndarray,
                    dissipated_energy: np.ndarray, *, approach_scale: float,
                    energy_scale: float, significance: float = 0.05,
                    tolerance: float = 0.05) -> ShakedownState:
    """Shakedown state of one contact from the law's residual approach and dissipated energy
    sampled with its force history.

    ``approach_scale`` and ``energy_scale`` set what counts as no growth at all (a purely
    elastic history): growth below 1e-9 of them.
    """
    force = np.asarray(force, dtype=float)
    residual = np.asarray(residual_approach, dtype=float)
    dissipated = np.asarray(dissipated_energy, dtype=float)
    if not (force.shape == residual.shape == dissipated.shape) or force.ndim != 1:
        raise InputError("shakedown: force, residual approach and dissipation must be equal-length")
    dr = float(residual[-1] - residual[0])
    dd = float(dissipated[-1] - dissipated[0])
    index, _, _ = significant_peaks(force, significance)
    if dr <= 1e-9 * approach_scale and dd <= 1e-9 * energy_scale:
        return ShakedownState(ELASTIC, dr, 0.0, dd, 0.0, 0)
    if index.size < 2:
        # one loading: it did its plastic work and nothing follows
        return ShakedownState(ELASTIC_SHAKEDOWN, dr, 0.0, dd, 0.0, int(index.size))
    half = int(index[index.size // 2])
    dr_late = float(residual[-1] - residual[half])
    dd_late = float(dissipated[-1] - dissipated[half])
    settled = residual[index] >= residual[-1] - tolerance * max(dr, 0.0)
    # first significant peak from which the residual approach stays within tolerance of its end
    unsettled = np.flatnonzero(~settled)
    cycle = int(unsettled[-1] + 2) if unsettled.size else 1
    state = shakedown_rule(dr_late, dr, dd_late, dd, tolerance)
    if state == RATCHETTING:
        cycle = None
    return ShakedownState(state, dr, dr_late, dd, dd_late, cycle)
