"""Seismic and aftershock analysis: records -> column -> classification -> outputs.

:func:`run_seismic` runs a main shock and any aftershocks back to back on one column (the
contacts remember every event; a quiet gap separates events), then classifies every contact's
force history per event (rainflow) and compares it with the paper's peak-time-fraction rule for
the record. :func:`write_outputs` writes CSV histories, summary.json and figures atomically.
"""

from __future__ import annotations

import math
import time
import tomllib
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from ...errors import InputError
from ...fem.roundoff import Resolution, seismic_energy
from ...files import atomic_directory, provenance, write_json_atomic, write_text_atomic
from ...law import calibrated_range
from . import classify
from .column import Column, ColumnModel, law_contacts
from .records import ProcessedRecord, load_record, process


def defaults() -> dict[str, dict[str, Any]]:
    """The defaults of data/seismic.toml."""
    text = (resources.files("geocontact") / "data" / "seismic.toml").read_text()
    return tomllib.loads(text)


@dataclass(frozen=True)
class Settings:
    """Every knob of a seismic run; ``Settings.from_defaults()`` reads data/seismic.toml."""

    target_pga: float
    baseline: str
    early_peak_fraction: float
    spheres: int
    density: float
    surcharge: float
    damping_ratio: float
    time_step_safety: float
    stiffness_probe_force_factor: float
    output_interval: float
    gap: float
    settle_window: float
    significance: float
    tolerance: float
    unit: str | None = None
    time_step: float | None = None

    @classmethod
    def from_defaults(cls, **changes: Any) -> Settings:
        d = defaults()
        base = cls(
            target_pga=d["record"]["target_pga_m_s2"],
            baseline=d["record"]["baseline"],
            early_peak_fraction=d["record"]["early_peak_fraction"],
            spheres=d["column"]["spheres"],
            density=d["column"]["density_kg_m3"],
            surcharge=d["column"]["surcharge_N"],
            damping_ratio=d["column"]["damping_ratio"],
            time_step_safety=d["column"]["time_step_safety"],
            stiffness_probe_force_factor=d["column"]["stiffness_probe_force_factor"],
            output_interval=d["column"]["output_interval_s"],
            gap=d["aftershocks"]["gap_s"],
            settle_window=d["aftershocks"]["settle_window_s"],
            significance=d["classification"]["significance"],
            tolerance=d["classification"]["tolerance"],
        )
        return replace(base, **{k: v for k, v in changes.items() if v is not None})

    def __post_init__(self) -> None:
        for name in ("gap", "settle_window"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0):
                raise InputError(f"{name}: must be a finite number >= 0 s, got {value:g}")
        if not 0 < self.early_peak_fraction < 1:
            raise InputError(f"early_peak_fraction: must be in (0, 1), got "
                             f"{self.early_peak_fraction:g}")


@dataclass(frozen=True)
class EventSpec:
    """One event of a sequence: a record and the PGA it is scaled to (m/s^2)."""

    record: str
    pga: float | None = None

    @classmethod
    def parse(cls, text: str, default_pga: float) -> EventSpec:
        """``RECORD`` or ``RECORD@PGA`` (PGA in m/s^2)."""
        record, sep, pga = text.rpartition("@")
        if not sep:
            return cls(text, default_pga)
        try:
            value = float(pga)
        except ValueError:
            raise InputError(f"aftershock: expected RECORD@PGA with PGA in m/s^2, got {text!r}"
                             ) from None
        if not (math.isfinite(value) and value > 0):
            raise InputError(f"aftershock: PGA must be > 0 m/s^2, got {pga!r}")
        return cls(record, value)


@dataclass
class EventResult:
    label: str
    spec: EventSpec
    record: ProcessedRecord
    start: float  # column time (s) at which the base starts moving with this record
    end: float  # end of the record
    window_end: float  # end of the quiet gap after it
    paper_rule: str = ""
    record_class: classify.HistoryClass | None = None
    contacts: list[dict[str, Any]] = field(default_factory=list)
    settlement: float = float("nan")

    def summary(self) -> dict[str, Any]:
        contact_classes = [c["history_class"] for c in self.contacts]
        agree = [c["agrees_with_paper_rule"] for c in self.contacts]
        return {
            "label": self.label,
            "record": self.record.summary(),
            "start_s": self.start,
            "end_s": self.end,
            "window_end_s": self.window_end,
            "paper_rule": {
                "peak_time_fraction": self.record.peak_time_fraction,
                "early_peak_fraction": None,  # filled by SeismicResult.summary
                "history_class": self.paper_rule,
            },
            "record_rainflow": self.record_class.to_dict() if self.record_class else None,
            "contact_history_classes": contact_classes,
            "contacts_agreeing_with_paper_rule": int(sum(agree)),
            "settlement_m": self.settlement,
            "contacts": self.contacts,
        }


@dataclass
class SeismicResult:
    settings: Settings
    params_source: str
    column: Column
    events: list[EventResult]
    history: dict[str, np.ndarray]
    wall_time: float

    def contact_summary(self) -> list[dict[str, Any]]:
        c = self.column
        h = self.history
        clean = energy_resolution(c).clean
        rows = []
        for k in range(c.model.spheres):
            rows.append({
                "contact": k,
                "static_force_N": float(c.static_force[k]),
                "static_approach_m": float(c.static_approach[k]),
                "max_force_N": float(c.max_force[k]),
                "max_approach_m": float(c.contacts.max_approach[k]),
                "residual_approach_m": float(c.contacts.residual_approach[k]),
                "seismic_residual_approach_m": float(h["residual_approach"][-1, k]
                                                     - h["residual_approach"][0, k]),
                "dissipated_energy_J": clean(float(h["dissipated_energy"][-1, k]
                                                   - h["dissipated_energy"][0, k])),
                "total_dissipated_energy_J": clean(float(c.contacts.dissipated_energy[k])),
            })
        return rows

    def summary(self) -> dict[str, Any]:

        c = self.column
        s = self.settings
        events = [e.summary() for e in self.events]
        for e in events:
            e["paper_rule"]["early_peak_fraction"] = s.early_peak_fraction
        main = self.events[0]
        return {
            "provenance": provenance("seismic", {
                "record": main.spec.record,
                "params": self.params_source,
                "aftershocks": [{"record": e.spec.record, "pga_m_s2": e.spec.pga}
                                for e in self.events[1:]],
                "settings": {k: v for k, v in s.__dict__.items()},
            }),
            "scaled_pga_m_s2": main.record.pga,
            "peak_time_fraction": main.record.peak_time_fraction,
            "classification": {
                "paper_rule": main.paper_rule,
                "record_rainflow": main.record_class.history_class if main.record_class else None,
                "contacts": [
                    {"contact": r["contact"], "history_class": r["history_class"],
                     "shakedown_state": r["shakedown_state"],
                     "agrees_with_paper_rule": r["agrees_with_paper_rule"]}
                    for r in main.contacts
                ],
            },
            "contacts": [
                {**row, "history_class": main.contacts[row["contact"]]["history_class"],
                 "shakedown_state": main.contacts[row["contact"]]["shakedown_state"]}
                for row in self.contact_summary()
            ],
            "settlement_m": self.events[-1].settlement,
            "static_settlement_m": float(-c.static_top),
            "column": {
                "spheres": c.model.spheres,
                "radius_m": c.model.radius,
                "density_kg_m3": c.model.density,
                "sphere_mass_kg": c.mass,
                "gravity_m_s2": c.model.gravity,
                "surcharge_N": c.model.surcharge,
                "contact_damping_ratio": c.model.damping_ratio,
                "contact_damping": ("none" if c.model.damping_ratio == 0 else
                                    "viscous normal, c = 2 zeta sqrt(m_eff k_tangent)"),
                "base": "an identical grain fixed to the base (ball-ball contact)",
                "excitation": "record applied as vertical base acceleration (positive up)",
            },
            "integration": {
                "scheme": "velocity Verlet",
                "time_step_s": c.dt,
                "time_step_safety": s.time_step_safety if s.time_step is None else None,
                "stiffness_estimate_N_per_m": c.stiffness_estimate,
                "max_stiffness_seen_N_per_m": c.max_stiffness_seen,
                "stability_ratio": c.stability_ratio,
                "steps": c.steps,
                "output_interval_s": c.dt * c.stride,
                "wall_time_s": self.wall_time,
            },
            "energy_J": {
                "base_input": c.base_work,
                "contact_work": c.contact_work,
                "damping_loss": c.damping_loss,
                "dissipated_by_law": energy_resolution(c).clean(float(np.sum(
                    self.history["dissipated_energy"][-1] - self.history["dissipated_energy"][0]))),
                "balance_error": c.energy_error(),  # as computed: it measures the integration
            },
            "resolution": {"energy": energy_resolution(c).to_dict(),
                           "applies_to": "dissipated energies of contacts, events and the law "
                                         "(0.0 when below; history.csv keeps the raw values)"},
            "events": events,
        }


def energy_resolution(column: Column) -> Resolution:
    """The run's energy resolution (``geocontact.fem.roundoff``): dissipations below it are
    round-off of differences of cumulative energies (a contact reloaded inside its envelope)."""
    return seismic_energy(column.base_work, column.contact_work,
                          float(np.max(np.abs(column.contacts.dissipated_energy), initial=0.0)))


def _classify_window(column: Column, history: dict[str, np.ndarray], event: EventResult,
                     settings: Settings) -> None:
    t = history["time"]
    window = (t >= event.start) & (t <= event.window_end + 1e-12)
    # include the sample just before the event, the state it starts from
    first = max(int(np.argmax(window)) - 1, 0)
    window[first] = True
    event.paper_rule = classify.peak_time_rule(event.record.peak_time_fraction,
                                               settings.early_peak_fraction)
    event.record_class = classify.history_class(
        event.record.acceleration, significance=settings.significance,
        tolerance=settings.tolerance, early_fraction=settings.early_peak_fraction)
    clean = energy_resolution(column).clean
    for k in range(column.model.spheres):
        force = history["force"][window, k]
        residual = history["residual_approach"][window, k]
        dissipated = history["dissipated_energy"][window, k]
        hc = classify.history_class(force, significance=settings.significance,
                                    tolerance=settings.tolerance,
                                    early_fraction=settings.early_peak_fraction)
        sd = classify.shakedown_state(
            force, residual, dissipated, approach_scale=float(column.static_approach[k]),
            energy_scale=float(history["dissipated_energy"][-1, k] + 1e-30),
            significance=settings.significance, tolerance=settings.tolerance)
        event.contacts.append({
            "contact": k,
            "max_force_N": float(force.max()),
            "residual_approach_m": float(residual[-1]),
            "residual_approach_increment_m": float(residual[-1] - residual[0]),
            "accumulated_residual_approach_m": float(residual[-1]
                                                     - history["residual_approach"][0, k]),
            "dissipated_energy_J": clean(float(dissipated[-1] - dissipated[0])),
            "accumulated_dissipated_energy_J": clean(float(
                dissipated[-1] - history["dissipated_energy"][0, k])),
            "history_class": hc.history_class,
            "rainflow": hc.to_dict(),
            "shakedown_state": sd.state,
            "shakedown": {**sd.to_dict(), "dissipation": clean(sd.dissipation),
                          "dissipation_late": clean(sd.dissipation_late)},
            "agrees_with_paper_rule": classify.agrees_with_paper_rule(hc.history_class,
                                                                      event.paper_rule),
        })
    late = (t >= event.window_end - settings.settle_window) & window
    if not late.any():
        late = window
    # mean over the end of the quiet gap: the column is still ringing without damping
    event.settlement = float(column.static_top - np.mean(history["top_displacement"][late]))


def check_approach_bound(params, model: ColumnModel, pga: float) -> None:
    """Refuse, before the time integration, a shaking that presses the base contact past the
    approach R (the sphere radius: no contact law holds beyond, README): at rest under the peak
    base acceleration the base contact carries n m (g + PGA) + S (the column's equation of
    motion, column.py, without dynamic amplification, so a lower bound of the run's peak)."""
    radius = model.radius
    limit, _ = law_contacts(params)(1).step(np.array([radius]))  # virgin curve at approach R
    limit = float(limit[0])
    force = model.spheres * model.mass * (model.gravity + pga) + model.surcharge
    if force <= limit:
        return
    if model.static_forces()[-1] > limit:
        raise InputError(f"surcharge: the column's base contact would carry "
                         f"{model.static_forces()[-1]:.4g} N at rest, beyond the {limit:.4g} N "
                         f"at which the law's approach reaches the sphere radius {radius:g} m "
                         "(approaches <= R)")
    raise InputError(f"pga: {pga:g} m/s^2 would press the column's base contact with "
                     f"{force:.4g} N even at rest (n m (g + PGA) + surcharge), beyond the "
                     f"{limit:.4g} N at which the law's approach reaches the sphere radius "
                     f"{radius:g} m (approaches <= R); lower the PGA")


def run_seismic(params, main: EventSpec, aftershocks: list[EventSpec], settings: Settings, *,
                params_source: str = "", progress: Callable[[str], None] | None = None
                ) -> SeismicResult:
    """Main shock then aftershocks on one column of the law's contacts."""
    started = time.perf_counter()
    specs = [main, *aftershocks]
    processed = []
    for spec in specs:
        record = load_record(spec.record, settings.unit)
        processed.append(process(record, spec.pga, settings.baseline))
    model = ColumnModel(settings.spheres, params.material.radius, settings.density,
                        surcharge=settings.surcharge, damping_ratio=settings.damping_ratio)
    check_approach_bound(params, model, max(rec.pga for rec in processed))
    column = Column(model, law_contacts(params), time_step=settings.time_step,
                    safety=settings.time_step_safety,
                    probe_force_factor=settings.stiffness_probe_force_factor,
                    output_interval=settings.output_interval)
    for rec in processed:  # a time step far too small fails now, not after the first event
        column.steps_for(rec.duration + settings.gap)
    events = []
    for i, (spec, rec) in enumerate(zip(specs, processed, strict=True)):
        label = "main shock" if i == 0 else f"aftershock {i}"
        if progress:
            progress(f"{label}: {rec.record.name}, {rec.duration:.2f} s at dt = {column.dt:.3g} s "
                     f"(scale {rec.scale_factor:.4g}, PGA {rec.pga:.4g} m/s^2)")
        start = column.t
        times, acc = rec.time, rec.acceleration

        def base(t, t0=start, times=times, acc=acc):
            return np.interp(t - t0, times, acc, left=0.0, right=0.0)

        # in quarters, to report progress on long records (the state carries over exactly)
        for quarter in range(4):
            column.run(rec.duration / 4.0, base, event=i)
            if progress and quarter < 3:
                progress(f"  {25 * (quarter + 1)} % ({column.steps} steps)")
        end = column.t
        column.run(settings.gap, None, event=i)
        events.append(EventResult(label, spec, rec, start, end, column.t))
    # once, with the whole run's count and depth (after any refusal of the input)
    calibrated_range.report(column.range_excess(), calibrated_range.WARN,
                            what=params_source or "the law")
    history = column.history.arrays()
    deepest = float(np.max(history["approach"]))
    if deepest > model.radius:  # dynamic amplification beyond the quasi-static bound
        raise InputError(f"pga: the column's contacts reached an approach of {deepest:.4g} m, "
                         f"beyond the sphere radius {model.radius:g} m where no contact law "
                         "holds (approaches <= R); lower the PGA or the surcharge")
    for event in events:
        _classify_window(column, history, event, settings)
    return SeismicResult(settings, params_source, column, events, history,
                         time.perf_counter() - started)


# --- outputs -----------------------------------------------------------------------------------
def _csv_text(columns: dict[str, np.ndarray]) -> str:
    import io

    data = np.column_stack([np.asarray(v, dtype=float) for v in columns.values()])
    buffer = io.StringIO()
    np.savetxt(buffer, data, fmt="%.9g", delimiter=",", header=",".join(columns), comments="")
    return buffer.getvalue()


def write_outputs(result: SeismicResult, out_dir: str | Path, *, figures: bool = True,
                  overwrite: bool = False) -> dict[str, Any]:
    """Write the run directory as one unit (``io.atomic_directory``: an existing folder only
    if it is a seismic result of ours, unless ``overwrite``); returns the summary (also in
    summary.json)."""

    with atomic_directory(out_dir, "seismic", overwrite=overwrite) as tmp:
        return _write_outputs(result, tmp, figures)


def _write_outputs(result: SeismicResult, out: Path, figures: bool) -> dict[str, Any]:

    h = result.history
    n = result.column.model.spheres
    columns: dict[str, np.ndarray] = {
        "time_s": h["time"],
        "event": h["event"],
        "base_acceleration_m_s2": h["base_acceleration"],
        "settlement_m": result.column.static_top - h["top_displacement"],
    }
    for k in range(n):
        columns[f"force_N_c{k}"] = h["force"][:, k]
    for k in range(n):
        columns[f"approach_m_c{k}"] = h["approach"][:, k]
    for k in range(n):
        columns[f"residual_approach_m_c{k}"] = h["residual_approach"][:, k]
    for k in range(n):
        columns[f"dissipated_energy_J_c{k}"] = h["dissipated_energy"][:, k]
    write_text_atomic(out / "history.csv", _csv_text(columns))

    rec_cols: dict[str, list[np.ndarray]] = {"event": [], "time_s": [], "acceleration_m_s2": []}
    for i, e in enumerate(result.events):
        rec_cols["event"].append(np.full(e.record.record.npts, i))
        rec_cols["time_s"].append(e.record.time)
        rec_cols["acceleration_m_s2"].append(e.record.acceleration)
    write_text_atomic(out / "records.csv",
                      _csv_text({k: np.concatenate(v) for k, v in rec_cols.items()}))

    contact_rows = result.contact_summary()
    lines = ["contact,static_force_N,static_approach_m,max_force_N,residual_approach_m,"
             "seismic_residual_approach_m,dissipated_energy_J,history_class,shakedown_state"]
    main = result.events[0]
    for row in contact_rows:
        k = row["contact"]
        lines.append(",".join([
            str(k), *(f"{row[key]:.10g}" for key in (
                "static_force_N", "static_approach_m", "max_force_N", "residual_approach_m",
                "seismic_residual_approach_m", "dissipated_energy_J")),
            main.contacts[k]["history_class"], main.contacts[k]["shakedown_state"]]))
    write_text_atomic(out / "contacts.csv", "\n".join(lines) + "\n")

    lines = ["event,label,record,contact,residual_approach_increment_m,"
             "accumulated_residual_approach_m,dissipated_energy_J,accumulated_dissipated_energy_J,"
             "history_class,shakedown_state,paper_rule,settlement_m"]
    for i, e in enumerate(result.events):
        for c in e.contacts:
            lines.append(",".join([
                str(i), e.label, e.record.record.name, str(c["contact"]),
                *(f"{c[key]:.10g}" for key in (
                    "residual_approach_increment_m", "accumulated_residual_approach_m",
                    "dissipated_energy_J", "accumulated_dissipated_energy_J")),
                c["history_class"], c["shakedown_state"], e.paper_rule,
                f"{e.settlement:.10g}"]))
    write_text_atomic(out / "events.csv", "\n".join(lines) + "\n")

    summary = result.summary()
    if figures:
        from .figures import write_figures

        summary["figures"] = write_figures(result, out)
    write_json_atomic(out / "summary.json", summary)
    return summary
