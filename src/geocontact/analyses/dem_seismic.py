"""A DEM sample under a seismic record in LAMMPS (``examples/lammps/in.seismic``): the record
turned into a base displacement, the time scale, the run, and the settlement and dissipation
against time beside the paper's peak-time rule (docs/dem.md "Seismic").

The test is a drained direct simple shear: the consolidated sample (``in.oedometer``'s) between a
base and a top wall, periodic in x and y; the top wall holds the vertical stress (a servo) and
does not move sideways; the base slides along x with the record's ground displacement.

**The base displacement.** The acceleration record is baseline-corrected (eqsig, as ``geocontact
seismic``) and integrated twice (trapezoid); the constant velocity that brings the ground back
to its start at the end is removed (integration drift: a constant velocity leaves the
acceleration unchanged). That displacement, in units of its peak, times ``strain`` times the
sample height is the base's: the record is scaled to a peak shear strain of the sample, the
quantity a simple-shear element of a soil layer sees, instead of to a PGA.

**The time scale (a compression, not larger grains).** Real time would need about 10^8 steps
of 10^-7 s for a 40 s record. The number of steps for a given strain path at a given inertia
number I = (shear rate) d sqrt(rho / sigma) does not depend on the grain size (the time step and
the rate both scale with it), so larger grains would not help; the record's time is compressed
by ``timescale`` instead, chosen so that the largest inertia number of the shaking is
``inertia``. What a compression keeps: the displacement path (its waveform, the order and
relative timing of its peaks, hence the peak-time fraction), and the response of the contact law,
which is rate independent, as long as the sample stays quasi-static. Two numbers say whether it
does, both reported: the inertia number (below about 1e-3 the stresses do not depend on the
rate), and the ratio of the compressed record's displacement frequency (timescale times
max|du/dt| / max|u| / 2 pi) to the sample's first vertical resonance sqrt(M / rho_bulk) / (4 H),
given for M between the consolidation's secant modulus (a lower bound of the elastic one) and
the Voigt estimate the servo uses (an upper bound): well below 1, the
sample is loaded as a quasi-static element; near 1 or above, the base shakes only the grains
near it and the stresses are dynamic. The time compression does not keep the inertial loading of
the real event (the base acceleration in the simulation is timescale^2 times the scaled
record's).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from ..errors import GeocontactError, InputError
from ..files import atomic_directory, check_replaceable, provenance, write_csv, write_json_atomic
from .dem import (
    SCHEMA,
    check_run,
    check_sample,
    contact_law,
    critical_timestep,
    read_run,
    read_table,
    restitution,
    run_lammps,
    script_contact,
)
from .energy import ledger_change, read_ledger_table
from .lammps_plugin import plugin_path

TEST = "seismic"
MAX_SAMPLES = 20_000  # record samples: one `run` of LAMMPS each


@dataclass
class SeismicSettings:
    """Inputs of one seismic DEM test (the LAMMPS script's variables of the same meaning)."""

    grains: int = 1000
    radius: float = 1e-3  # median grain radius, m
    spread: float = 0.3  # standard deviation of ln(radius)
    stress: float = 5e3  # vertical stress, Pa
    strain: float = 2e-3  # peak base displacement / sample height
    inertia: float = 1e-3  # largest inertia number of the shaking: sets the time compression
    friction: float = 0.5
    damping: float = 0.5  # geocontact: fraction of critical
    restitution: float | None = None  # as Settings.restitution (analyses/dem.py)
    seed: int = 4821
    baseline: str = "linear"
    decimate: int = 1  # every k-th record sample (a coarser record: fewer, longer segments)
    density: float = 2650.0
    extra: dict[str, str] = field(default_factory=dict)  # other script variables (-var k v)

    def check(self) -> None:
        check_sample(self, "record", (("strain", self.strain, 1e-6, 0.2),))
        if not 1 <= self.decimate <= 1000:
            raise InputError(f"decimate: must be in [1, 1000], got {self.decimate}")


@dataclass(frozen=True)
class BaseMotion:
    """The record as the base's displacement: in units of its peak, at the record's time."""

    processed: object  # seismic.records.ProcessedRecord
    dt: float  # s, record time (after decimation)
    displacement: np.ndarray  # u / max|u|, from the start
    peak_displacement_m: float  # of the unscaled (baseline-corrected) record
    peak_velocity_ratio: float  # max|du/dt| / max|u| (1/s, record time)
    drift_velocity_m_s: float  # the constant velocity removed

    @property
    def time(self) -> np.ndarray:
        return np.arange(self.displacement.size) * self.dt

    def timescale(self, settings: SeismicSettings) -> float:
        """Record time / simulated time that gives the largest inertia number ``inertia``."""
        rate = settings.strain * self.peak_velocity_ratio  # largest shear rate, record time
        diameter = 2.0 * settings.radius
        return settings.inertia / (rate * diameter * math.sqrt(settings.density
                                                                / settings.stress))


def base_motion(record_spec: str, baseline: str = "linear", decimate: int = 1) -> BaseMotion:
    """The base displacement of a record (file or FEMA P695 / El Centro name)."""
    from scipy.integrate import cumulative_trapezoid

    from .seismic.records import load_record, process

    processed = process(load_record(record_spec), target_pga=None, baseline=baseline)
    acc = processed.acceleration
    dt = processed.dt
    velocity = cumulative_trapezoid(acc, dx=dt, initial=0.0)
    displacement = cumulative_trapezoid(velocity, dx=dt, initial=0.0)
    duration = dt * (acc.size - 1)
    drift = displacement[-1] / duration
    displacement = displacement - drift * np.arange(acc.size) * dt
    displacement = displacement[::decimate]
    if displacement.size - 1 > MAX_SAMPLES:
        raise InputError(f"record: {displacement.size} samples, at most {MAX_SAMPLES + 1} (one "
                         "LAMMPS run each); give --decimate")
    if displacement.size < 3:
        raise InputError(f"record: {displacement.size} samples after --decimate {decimate}; "
                         "at least 3")
    peak = float(np.max(np.abs(displacement)))
    if not peak > 0:
        raise InputError(f"{record_spec}: the ground does not move (zero displacement)")
    step = dt * decimate
    ratio = float(np.max(np.abs(np.diff(displacement))) / step / peak)
    return BaseMotion(processed=processed, dt=step, displacement=displacement / peak,
                      peak_displacement_m=peak, peak_velocity_ratio=ratio,
                      drift_velocity_m_s=float(drift))


def script_variables(settings: SeismicSettings, law: Path, contact: str, out: Path,
                     record_file: Path, motion: BaseMotion) -> list[str]:
    values = {"N": settings.grains, "rmed": repr(settings.radius),
              "spread": repr(settings.spread), "stress": repr(settings.stress),
              "strain": repr(settings.strain), "density": repr(settings.density),
              "friction": repr(settings.friction), "damping": repr(settings.damping),
              "restitution": repr(restitution(settings)),
              "seed": settings.seed, "params": str(law), "contact": script_contact(contact),
              "record": str(record_file), "dtrec": repr(motion.dt),
              "timescale": repr(motion.timescale(settings)),
              "plugin": str(plugin_path()), "out": str(out), **settings.extra}
    args: list[str] = []
    for name, value in values.items():
        args += ["-var", name, str(value)]
    return args


def _report_samples(folder: Path, reported: int, contact: str,
                    progress: Callable[[str], None] | None, total: int) -> int:
    path = folder / "progress.txt"
    if progress is None or not path.is_file():
        return reported
    rows = [line.split() for line in path.read_text().splitlines()
            if line.strip() and not line.startswith("#")]
    rows = [r for r in rows if len(r) == 2]
    if len(rows) > reported:
        progress(f"{contact}: record sample {rows[-1][0]} of {total} at step {rows[-1][1]}")
    return max(reported, len(rows))


# --- parsing -----------------------------------------------------------------------------------

def _fraction_reached(time: np.ndarray, value: np.ndarray, level: float) -> float | None:
    """The first record time at which ``value`` reaches ``level`` times its final value."""
    final = value[-1]
    if not final > 0:
        return None
    hit = np.nonzero(value >= level * final)[0]
    return float(time[hit[0]]) if hit.size else None


def parse_run(folder: Path, settings: SeismicSettings, motion: BaseMotion) -> dict:
    """The settlement and dissipation of one run folder against the record's time."""
    from .seismic.classify import peak_time_rule

    run = read_run(folder / "run.txt")
    if run.get("done") is None:
        raise GeocontactError(f"{folder}: the LAMMPS run did not finish (no 'done' in run.txt)")
    names, rows = read_table(folder / "series.txt")
    series = {n: np.array([float(r[k]) for r in rows]) for k, n in enumerate(names)}
    start = int(run["shaking_start_step"])
    keep = series["step"] >= start
    step = series["step"][keep]
    dt = float(run["timestep_s"])
    nprint = int(np.median(np.diff(series["step"])))
    timescale = float(run["timescale_effective"])
    record_time = (step - start) * dt * timescale
    h0 = float(run["shaking_start_height_m"])
    side = float(run["side_m"])
    area = side * side
    height = series["height_m"][keep]
    settlement = h0 - height
    power = series["base_power_W"][keep] + series["top_power_W"][keep]
    # each sample's power is the mean over the nprint steps before it: work = sum P nprint dt
    work = np.cumsum(power * nprint * dt)
    base_work = np.cumsum(series["base_power_W"][keep] * nprint * dt)
    # geocontact: the base's work from the wall fix's own force (the virial misses the wall
    # contacts' half-branches: a few per cent quasi-statically, more when dynamic)
    wall_force = series["base_wall_force_x_N"][keep]
    fix_power = series["base_power_fix_W"][keep] + series["top_power_fix_W"][keep]
    fix_work = np.cumsum(fix_power * nprint * dt) if np.any(wall_force) else None
    fix_base_work = (float(np.sum(series["base_power_fix_W"][keep]) * nprint * dt)
                     if np.any(wall_force) else None)
    law = series["law_dissipated_J"][keep] - series["law_dissipated_J"][keep][0]
    stress = series["stress_Pa"][keep]
    shear = series["shear_stress_Pa"][keep]
    base = series["base_displacement_m"][keep]
    velocity = series["base_velocity_m_s"][keep]
    diameter = 2.0 * settings.radius
    inertia = np.abs(velocity) / height * diameter * math.sqrt(settings.density
                                                               / settings.stress)
    duration = motion.dt * (motion.displacement.size - 1)
    peak_time = motion.processed.peak_time
    modulus = float(run["modulus_Pa"])
    packing = float(run["solid_volume_m3"]) / (area * h0)
    voigt = float(run["voigt_modulus_Pa"])
    resonance = math.sqrt(modulus / (packing * settings.density)) / (4.0 * h0)
    resonance_voigt = math.sqrt(voigt / (packing * settings.density)) / (4.0 * h0)
    loading = timescale * motion.peak_velocity_ratio / (2.0 * math.pi)
    fraction = motion.processed.peak_time_fraction

    def at(t: float, values: np.ndarray) -> float:
        return float(np.interp(t, record_time, values))

    final_settlement = float(settlement[-1])
    final_work = float(work[-1])
    t50, t90 = (_fraction_reached(record_time, settlement, q) for q in (0.5, 0.9))
    w50, w90 = (_fraction_reached(record_time, work, q) for q in (0.5, 0.9))
    summary = {
        "contact": run["contact"],
        "grains": int(run["grains"]),
        "steps": int(run["steps_total"]),
        "shaking_steps": int(run["steps_total"]) - start,
        "timestep_s": dt,
        "hertz_time_s": float(run["hertz_time_s"]),
        **critical_timestep(run),
        "steps_per_sample": int(run["steps_per_sample"]),
        "timescale": timescale,
        "simulated_duration_s": duration / timescale,
        "side_m": side,
        "height_m": h0,
        "packing_fraction": packing,
        "consolidation_modulus_Pa": modulus,
        "voigt_modulus_Pa": voigt,
        "resonance_hz": resonance,
        "loading_frequency_hz": loading,
        "loading_over_resonance": loading / resonance,
        "loading_over_resonance_voigt": loading / resonance_voigt,
        "stress_at_start_Pa": float(run["shaking_start_stress_Pa"]),
        "stress_mean_Pa": float(np.mean(stress)),
        "stress_std_Pa": float(np.std(stress)),
        "stress_min_Pa": float(np.min(stress)),
        "peak_shear_strain": float(np.max(np.abs(base)) / h0),
        "peak_shear_stress_Pa": float(np.max(np.abs(shear))),
        "inertia_number": {"max": float(np.max(inertia)),
                           "rms": float(np.sqrt(np.mean(inertia**2)))},
        "contacts_per_grain_at_start": float(series["contacts_per_grain"][keep][0]),
        "contacts_per_grain_at_end": float(series["contacts_per_grain"][keep][-1]),
        "settlement_m": final_settlement,
        "vertical_strain": final_settlement / h0,
        "wall_work_J": final_work,
        "base_work_J": float(base_work[-1]),
        "base_work_from_wall_force_J": fix_base_work,
        "wall_work_from_wall_forces_J": float(fix_work[-1]) if fix_work is not None else None,
        "law_dissipated_J": float(law[-1]),
        "law_share_of_wall_work": (float(law[-1] / fix_work[-1]) if fix_work is not None
                                   and fix_work[-1] > 0 else None),
        "at_peak_time": {
            "settlement_fraction": at(peak_time, settlement) / final_settlement
            if final_settlement > 0 else None,
            "wall_work_fraction": at(peak_time, work) / final_work if final_work > 0 else None,
        },
        "settlement_50_fraction_of_record": t50 / duration if t50 is not None else None,
        "settlement_90_fraction_of_record": t90 / duration if t90 is not None else None,
        "wall_work_50_fraction_of_record": w50 / duration if w50 is not None else None,
        "wall_work_90_fraction_of_record": w90 / duration if w90 is not None else None,
        "paper_rule": peak_time_rule(fraction),
    }
    ledger_file = folder / "ledger.txt"
    if ledger_file.is_file():  # geocontact pair and walls: the energy ledger of the shaking
        rows = read_ledger_table(ledger_file)
        summary["energy"] = ledger_change(rows["shaking_start"], rows["end"])
        summary["energy_whole_run"] = ledger_change(rows["start"], rows["end"])
    arrays = {"record_time_s": record_time, "time_s": series["time_s"][keep], "step": step,
              "height_m": height, "settlement_m": settlement,
              "vertical_strain": settlement / h0, "stress_Pa": stress,
              "shear_stress_Pa": shear, "base_displacement_m": base,
              "shear_strain": base / h0, "base_velocity_m_s": velocity,
              "inertia_number": inertia, "wall_work_J": work, "base_work_J": base_work,
              "wall_work_from_wall_forces_J": (fix_work if fix_work is not None
                                               else np.zeros_like(work)),
              "law_dissipated_J": law,
              "base_wall_force_x_N": series["base_wall_force_x_N"][keep],
              "kinetic_J": series["kinetic_J"][keep],
              "contacts_per_grain": series["contacts_per_grain"][keep]}
    return {"summary": summary, "series": arrays}


# --- the command -------------------------------------------------------------------------------

def run_seismic(record: str, law: str | Path, settings: SeismicSettings, *,
                contacts: tuple[str, ...], ranks: int, out: str | Path,
                overwrite: bool = False, progress: Callable[[str], None] | None = None) -> dict:
    """Run ``in.seismic`` under ``record`` for each contact model into ``out`` (one result
    folder, written as a unit): ``record.csv``, ``CONTACT/`` with the LAMMPS outputs and
    ``series.csv``, and summary.json."""
    from .seismic.classify import PAPER_EARLY_PEAK_FRACTION, peak_time_rule

    law, params = check_run(settings, law, contacts, ranks)
    motion = base_motion(record, settings.baseline, settings.decimate)
    check_replaceable(out, "dem", overwrite=overwrite)
    timescale = motion.timescale(settings)
    processed = motion.processed
    record_summary = {
        **processed.summary(),
        "decimate": settings.decimate,
        "sample_interval_s": motion.dt,
        "peak_displacement_m": motion.peak_displacement_m,
        "drift_velocity_removed_m_s": motion.drift_velocity_m_s,
        "peak_velocity_over_peak_displacement_1_s": motion.peak_velocity_ratio,
        "paper_rule": peak_time_rule(processed.peak_time_fraction),
        "paper_early_peak_fraction": PAPER_EARLY_PEAK_FRACTION,
    }
    inputs = {"test": TEST, "record": record, "law": str(law), "contacts": list(contacts),
              "ranks": ranks, **{k: v for k, v in asdict(settings).items()}}
    document = {"schema": SCHEMA, "test": TEST, "ranks": ranks, "law": str(law),
                "law_label": params.label, "restitution": restitution(settings),
                "record": record_summary,
                "timescale_target": timescale, "runs": {},
                "provenance": provenance("dem", inputs)}
    total = motion.displacement.size - 1
    with atomic_directory(out, "dem", overwrite=overwrite, inputs=inputs) as tmp:
        write_csv(tmp / "record.csv", {
            "time_s": processed.time, "acceleration_m_s2": processed.acceleration})
        write_csv(tmp / "base_motion.csv", {"time_s": motion.time,
                                            "displacement_over_peak": motion.displacement})
        record_file = tmp / "base_increments.txt"
        record_file.write_text("".join(f"{v:.17g}\n" for v in np.diff(motion.displacement)))
        for contact in contacts:
            folder = tmp / contact
            if progress:
                progress(f"{contact}: {settings.grains} grains, {ranks} rank(s), {total} record "
                         f"samples, time compressed {timescale:.4g}x")
            law_file = contact_law(contact, law, params, tmp)
            wall = run_lammps(
                "seismic",
                script_variables(settings, law_file, contact, folder, record_file, motion),
                contact, ranks, folder, progress,
                reporter=lambda f, n, c, p: _report_samples(f, n, c, p, total))
            parsed = parse_run(folder, settings, motion)
            parsed["summary"]["runtime_s"] = wall
            parsed["summary"]["ranks"] = ranks
            write_csv(folder / "series.csv", parsed["series"])
            document["runs"][contact] = parsed["summary"]
            if progress:
                progress(f"{contact}: done in {wall:.1f} s")
        write_json_atomic(tmp / "summary.json", document)
    return document
