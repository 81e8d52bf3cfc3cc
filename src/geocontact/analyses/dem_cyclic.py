"""Strain-controlled cyclic simple shear of a DEM sample in LAMMPS
(``examples/lammps/in.cyclicshear``): the modulus reduction G/Gmax(γ) and damping ratio D(γ)
curves of geotechnical engineering, per contact law, mean stress and sample (docs/sample-study.md).

Each run (law, consolidation stress, seed) is one LAMMPS process: the sample is generated,
consolidated and sheared through every amplitude in turn. A finished run is committed to
``DIR/runs/NAME/`` (its own result folder, with the inputs that made it) and skipped on a rerun
with the same inputs, so an interrupted study resumes where it stopped. From the last cycle of
each amplitude: the secant shear modulus G = (τ(γmax) − τ(γmin)) / (γmax − γmin), the damping
ratio D = W_loop / (4π W_peak) with W_loop = ∮ τ dγ and W_peak = G γa² / 2 (Kramer 1996,
Geotechnical Earthquake Engineering, §6.4.2), Gmax the G of the smallest amplitude, and the
change of mean stress over the cycle (the cycles are at constant volume, so the volume does not
change: the sample's tendency to contract or dilate shows as a fall or rise of mean stress).
"""

from __future__ import annotations

import hashlib
import math
import shutil
from collections.abc import Callable
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path

import numpy as np

from ..errors import GeocontactError, InputError
from ..files import (
    atomic_directory,
    check_replaceable,
    provenance,
    read_manifest,
    verify_manifest,
    write_csv,
    write_json_atomic,
    write_manifest,
)
from .dem import MAX_RANKS, check_sample, find_script, read_run, read_table, run_lammps
from .restitution import restitution_of_damping

SCHEMA = "geocontact.dem-cyclic/1"
COMMAND = "dem-cyclic-shear"
RUN_COMMAND = "dem-cyclic-shear-run"
TEST = "cyclicshear"
# 1e-6 ... 1e-2, two per decade: nine amplitudes, log-spaced
DEFAULT_AMPLITUDES = tuple(float(f"{a:.3g}") for a in np.logspace(-6, -2, 9))
# the baseline beside the law: "elastic", the grain's elastic law file through the same pair
# style (law.elastic: like for like, the normal law alone differs); "granular", LAMMPS's pair
# granular hertz/material + Mindlin + Tsuji (a cross-check); "none": the law alone
BASELINES = ("elastic", "granular", "none")
CYCLIC_EXTENSION = ("file", "off")  # CyclicSettings.cyclic_extension
MIN_AMPLITUDE, MAX_AMPLITUDE = 1e-8, 0.05  # below: round-off of the tilt; above: not a cycle
MAX_AMPLITUDES = 30
MAX_CYCLES = 20
MAX_SEEDS = 50


@dataclass
class CyclicSettings:
    """Inputs of a cyclic simple shear study (the LAMMPS script's variables of the same
    meaning, and the study's loops over laws, stresses and seeds)."""

    grains: int = 1000
    radius: float = 1e-3  # median grain radius, m
    spread: float = 0.3  # standard deviation of ln(radius)
    stresses: tuple[float, ...] = (1e5,)  # mean stress of consolidation, Pa
    amplitudes: tuple[float, ...] = DEFAULT_AMPLITUDES
    cycles: int = 3
    seeds: int = 3
    seed: int = 4821  # the first sample's; the others follow it
    inertia: float = 1e-3  # the largest inertia number of the cycles
    friction: float = 0.5
    damping: float = 0.5
    baseline: str = "elastic"
    # drained between cycles: after each cycle a servo on lz restores the vertical stress (the
    # volumetric strain per cycle); False: every cycle and the time between at constant volume
    drained: bool = False
    # the law file's cyclic (ratchet) extension: "file" as the file has it, or "off" (the file
    # with cyclic.enabled false, written beside each geocontact run): the extension counts
    # micro-cycles of any amplitude (docs/sample-study.md), so small-strain curves are measured
    # without it until a threshold is settled
    cyclic_extension: str = "file"
    extra: dict[str, str] = field(default_factory=dict)  # other script variables (-var k v)

    @property
    def stress(self) -> float:  # check_sample's single stress
        return min(self.stresses)

    @property
    def restitution(self) -> None:  # check_sample's: damping here is `damping` (no restitution)
        return None

    def check(self) -> None:
        check_sample(self, "amplitude")
        if not self.stresses or len(self.stresses) > 10:
            raise InputError(f"stress: 1 to 10 mean stresses, got {len(self.stresses)}")
        for s in self.stresses:
            if not (math.isfinite(s) and 1.0 <= s <= 1e9):
                raise InputError(f"stress: must be in [1, 1e+09] Pa, got {s:g}")
        if len(set(self.stresses)) != len(self.stresses):
            raise InputError("stress: each mean stress once")
        amps = self.amplitudes
        if not 2 <= len(amps) <= MAX_AMPLITUDES:
            raise InputError(f"amplitudes: 2 to {MAX_AMPLITUDES} shear strain amplitudes (the "
                             f"smallest gives Gmax), got {len(amps)}")
        for a in amps:
            if not (math.isfinite(a) and MIN_AMPLITUDE <= a <= MAX_AMPLITUDE):
                raise InputError(f"amplitudes: each must be in [{MIN_AMPLITUDE:g}, "
                                 f"{MAX_AMPLITUDE:g}], got {a:g}")
        if any(b <= a for a, b in zip(amps, amps[1:], strict=False)):
            raise InputError("amplitudes: must increase strictly (the sample is sheared from "
                             "the smallest up)")
        if not 2 <= self.cycles <= MAX_CYCLES:
            raise InputError(f"cycles: must be in [2, {MAX_CYCLES}] per amplitude (the last "
                             f"is measured after the first), got {self.cycles}")
        if not 1 <= self.seeds <= MAX_SEEDS:
            raise InputError(f"seeds: must be in [1, {MAX_SEEDS}], got {self.seeds}")
        if self.seed + self.seeds > 2**31 - 2:
            raise InputError(f"seed: must be at most {2**31 - 2 - self.seeds}, got {self.seed}")
        if self.cyclic_extension not in CYCLIC_EXTENSION:
            raise InputError(f"cyclic_extension: must be file (as the law file has it) or off, "
                             f"got {self.cyclic_extension!r}")
        if self.baseline not in BASELINES:
            raise InputError(f"baseline: must be elastic (the grain's elastic law through pair "
                             f"geocontact), granular (pair granular hertz/material + Mindlin) "
                             f"or none, got {self.baseline!r}")


@dataclass(frozen=True)
class Run:
    law: str  # geocontact | elastic | granular
    stress: float
    seed: int

    @property
    def name(self) -> str:
        return f"{self.law}-p{self.stress:.6g}-s{self.seed}"


def plan(settings: CyclicSettings) -> list[Run]:
    laws = ("geocontact",) + (() if settings.baseline == "none" else (settings.baseline,))
    return [Run(law, stress, settings.seed + k) for law in laws for stress in settings.stresses
            for k in range(settings.seeds)]


def run_inputs(run: Run, settings: CyclicSettings, law: Path) -> dict:
    """What makes a run: a finished run is reused only if these are equal."""
    s = asdict(settings)
    for key in ("stresses", "seeds", "seed", "baseline"):
        s.pop(key)
    if run.law != "geocontact":  # the baselines have no cyclic extension
        s.pop("cyclic_extension")
    # the file by name and content, not by its place: a study committed in the repository is
    # reused from any checkout (the quartz-like file is made into the study's own folder)
    # and the LAMMPS script by content: a finished run of another script is not reused
    script = find_script(TEST)
    return {"law_file": law.name, "law_sha256": hashlib.sha256(law.read_bytes()).hexdigest(),
            "script_sha256": hashlib.sha256(script.read_bytes()).hexdigest(),
            "contact": run.law, "stress": run.stress, "seed": run.seed,
            **s, "amplitudes": list(settings.amplitudes)}


def script_variables(run: Run, settings: CyclicSettings, law: Path, out: Path) -> list[str]:
    """The script's -var arguments; ``law`` the file the run's contact reads (for elastic, the
    grain's elastic law file, run through pair geocontact)."""
    from .lammps_plugin import plugin_path

    values = {"N": settings.grains, "rmed": repr(settings.radius),
              "spread": repr(settings.spread), "stress": repr(run.stress),
              "cycles": settings.cycles, "inertia": repr(settings.inertia),
              "friction": repr(settings.friction), "damping": repr(settings.damping),
              # granular's Tsuji e: the restitution the plugin's damping gives (like for like)
              "etsuji": repr(restitution_of_damping(settings.damping)),
              "seed": run.seed, "params": str(law),
              "contact": "granular" if run.law == "granular" else "geocontact",
              "drainfactor": 10 if settings.drained else 0,
              "plugin": str(plugin_path()), "out": str(out), **settings.extra}
    args: list[str] = []
    for name, value in values.items():
        args += ["-var", name, str(value)]
    return args + ["-var", "amplitudes", *(repr(float(a)) for a in settings.amplitudes)]


def _report_segments(folder: Path, reported: int, contact: str,
                     progress: Callable[[str], None] | None) -> int:
    """Progress: one line per finished amplitude (its last segment written)."""
    path = folder / "segments.txt"
    if progress is None or not path.is_file():
        return reported
    rows = [r.split() for r in path.read_text().splitlines() if r.strip() and r[0] != "#"]
    done = [r for r in rows if len(r) == 7 and r[2] == "3"]
    finished = {int(r[0]): int(r[6]) for r in done if int(r[1]) == max(int(x[1]) for x in done)}
    for k in sorted(finished)[reported:]:
        progress(f"{contact}: amplitude {k} done at step {finished[k]}")
    return max(reported, len(finished))


# --- the loops and the curves ----------------------------------------------------------------

def read_amplitude(folder: Path, k: int) -> dict[str, np.ndarray]:
    names, rows = read_table_titled(folder / f"amp-{k}.txt")
    return {n: np.array([float(r[i]) for r in rows]) for i, n in enumerate(names)}


def read_table_titled(path: Path) -> tuple[list[str], list[list[str]]]:
    """fix ave/time's file: '#' title lines, the last of them the column names."""
    if not path.is_file():
        raise GeocontactError(f"{path}: missing (the LAMMPS run stopped before writing it)")
    lines = path.read_text().splitlines()
    titles = [line for line in lines if line.startswith("#")]
    names = titles[-1].lstrip("#").split() if titles else []
    return names, [line.split() for line in lines if line.strip() and not line.startswith("#")]


def loop_measures(strain: np.ndarray, stress: np.ndarray) -> dict[str, float]:
    """Secant modulus, loop area and damping ratio of one closed cycle of (γ, τ) samples in
    their order: W_loop = ∮ τ dγ (trapezoids, closed from the last sample to the first),
    G = (τ(γmax) − τ(γmin)) / (γmax − γmin), W_peak = G γa² / 2, D = W_loop / (4π W_peak)."""
    g = np.append(strain, strain[0])
    t = np.append(stress, stress[0])
    w_loop = float(np.sum(0.5 * (t[1:] + t[:-1]) * np.diff(g)))
    i, j = int(np.argmax(strain)), int(np.argmin(strain))
    gamma_a = 0.5 * (strain[i] - strain[j])
    modulus = float((stress[i] - stress[j]) / (strain[i] - strain[j]))
    w_peak = 0.5 * modulus * gamma_a**2
    return {"G_Pa": modulus, "strain_amplitude": float(gamma_a), "loop_work_J_m3": w_loop,
            "peak_energy_J_m3": w_peak, "damping_ratio": w_loop / (4 * math.pi * w_peak)}


def parse_run(folder: Path, run: Run, settings: CyclicSettings, material: str) -> dict:
    """The loops (every cycle of every amplitude) and the per-amplitude measures of the last
    cycle of one finished LAMMPS run folder."""
    info = read_run(folder / "run.txt")
    _, run_rows = read_table(folder / "run.txt")
    schedule = {r[0]: [float(v) for v in r[1:]] for r in run_rows if r[0].startswith("amplit")}
    if info.get("done") is None:
        raise GeocontactError(f"{folder}: the LAMMPS run did not finish (no 'done' in run.txt)")
    reached = float(info["consolidated_mean_stress_Pa"])
    if not abs(reached / run.stress - 1) <= CONSOLIDATION_TOLERANCE:
        raise GeocontactError(
            f"{run.name}: the sample did not consolidate to its mean stress ({reached:.4g} Pa "
            f"of {run.stress:.4g} Pa, more than {CONSOLIDATION_TOLERANCE:.0%} off); its moduli "
            "would be those of a loose heap, not of the sample asked for")
    _, seg_rows = read_table(folder / "segments.txt")
    segments = [[int(r[0]), int(r[1]), int(r[2]), float(r[3]), int(r[4]), int(r[5]), int(r[6])]
                for r in seg_rows]
    density = float(info["density_kg_m3"])
    crossing = float(info["wave_crossing_time_s"])
    v_ref = float(info["consolidated_volume_m3"])
    d = 2 * settings.radius
    loops: dict[str, list] = {k: [] for k in LOOP_COLUMNS}
    curves = []
    for k, amplitude in enumerate(settings.amplitudes, start=1):
        series = read_amplitude(folder, k)
        _, nq, _, rate, _ = schedule[f"amplitude_{k}"]
        step = series["step"]
        strain = series["shear_strain"]
        tau = -series["pxz_Pa"]  # LAMMPS's pressure is compression positive
        mean = (series["pxx_Pa"] + series["pyy_Pa"] + series["pzz_Pa"]) / 3
        volume = series["volume_m3"]
        cycle = np.zeros(len(step), dtype=int)
        for a, c, _, _, _, first, last in segments:
            if a == k:
                cycle[(step >= first) & (step <= last)] = c
        keep = cycle > 0
        columns = {"law": run.law, "material": material, "seed": run.seed,
                   "consolidation_stress_Pa": run.stress, "amplitude": amplitude}
        for name, value in columns.items():
            loops[name] += [value] * int(keep.sum())
        for name, values in (("cycle", cycle), ("step", step), ("time_s", series["time_s"]),
                             ("shear_strain", strain), ("shear_stress_Pa", tau),
                             ("mean_stress_Pa", mean), ("vertical_stress_Pa", series["pzz_Pa"]),
                             ("volumetric_strain", (v_ref - volume) / v_ref),
                             ("law_dissipated_J", series["law_dissipated_J"]),
                             ("ledger_dissipated_J", series["ledger_dissipated_J"]),
                             ("ledger_stored_J", series["ledger_stored_J"]),
                             ("kinetic_J", series["kinetic_J"]),
                             ("contacts_per_grain", series["contacts_per_grain"]),
                             ("sliding_dissipated_J", series["sliding_dissipated_J"]),
                             ("viscous_dissipated_J", series["viscous_dissipated_J"])):
            loops[name] += values[keep].tolist()
        last = cycle == settings.cycles
        # the row before the measured cycle: the end of the previous cycle's drainage; the last
        # row of the amplitude: the end of this cycle's drainage (the vertical stress restored)
        before = int(np.flatnonzero(last)[0]) - 1
        m = loop_measures(strain[last], tau[last])
        p_start, p_end = mean[before], mean[last][-1]
        v_start, v_end = volume[before], volume[-1]
        mean_volume = float(np.mean(volume[last]))
        # the ledger over the last cycle, per unit volume, as damping ratios (4π W_peak):
        # W_loop = dissipated + change of stored + change of kinetic (the balance)
        scale = 4 * math.pi * m["peak_energy_J_m3"] * mean_volume
        change = {k: (series[k][last][-1] - series[k][before]) / scale
                  for k in ("law_dissipated_J", "ledger_dissipated_J", "ledger_stored_J",
                            "kinetic_J", "sliding_dissipated_J", "viscous_dissipated_J")}
        ledger = run.law != "granular"  # pair granular has no ledger
        curves.append({
            "law": run.law, "material": material, "seed": run.seed,
            "consolidation_stress_Pa": run.stress, "amplitude": amplitude, **m,
            # compression positive, over the cycle and the drainage after it
            "volumetric_strain_per_cycle": float((v_start - v_end) / v_start),
            # within the cycle (constant volume), before the drainage restores it
            "mean_stress_change_per_cycle_Pa": float(p_end - p_start),
            "mean_stress_Pa": float(np.mean(mean[last])),
            # geocontact only (pair granular has no ledger): every dissipated channel, the
            # normal law's own share, and the stored and kinetic energies' changes
            "damping_ratio_ledger": change["ledger_dissipated_J"] if ledger else math.nan,
            "damping_ratio_normal_law": change["law_dissipated_J"] if ledger else math.nan,
            # Coulomb sliding [7] and the normal and tangential dashpots [8] + [9]: with the
            # law's share, every dissipated channel the study's contacts have (no rolling or
            # twisting resistance)
            "damping_ratio_sliding": change["sliding_dissipated_J"] if ledger else math.nan,
            "damping_ratio_viscous": change["viscous_dissipated_J"] if ledger else math.nan,
            "stored_energy_change_ratio": change["ledger_stored_J"] if ledger else math.nan,
            "kinetic_energy_change_ratio": change["kinetic_J"],
            "strain_rate_1_s": rate, "steps_per_cycle": int(4 * nq),
            "period_over_wave_crossing": 4 * nq * float(info["timestep_s"]) / crossing,
            "inertia_number": rate * d * math.sqrt(density / run.stress),
            "contacts_per_grain": float(np.mean(series["contacts_per_grain"][last])),
        })
        curves[-1].update(balance_check(curves[-1]))
    gmax = curves[0]["G_Pa"]
    if not gmax > 0:
        raise GeocontactError(f"{run.name}: no shear modulus at the smallest amplitude "
                              f"(G = {gmax:.4g} Pa): the sample carries no shear")
    for c in curves:
        c["G_over_Gmax"] = c["G_Pa"] / gmax
    summary = {"run": run.name, "law": run.law, "seed": run.seed,
               "consolidation_stress_Pa": run.stress, "grains": int(info["grains"]),
               "timestep_s": float(info["timestep_s"]), "steps": int(info["steps_total"]),
               "consolidated_mean_stress_Pa": float(info["consolidated_mean_stress_Pa"]),
               "consolidated_vertical_stress_Pa": float(info["consolidated_vertical_stress_Pa"]),
               "packing_fraction": (float(info["solid_volume_m3"])
                                    / float(info["consolidated_volume_m3"])),
               "contacts_per_grain": float(info["contacts_per_grain"]),
               "critical_timestep_min_s": _finite(float(info.get("critical_timestep_min_s",
                                                                 "inf"))),
               "timestep_warning_step": (int(info["timestep_warning_step"])
                                         if "timestep_warning_step" in info else None),
               "wave_crossing_time_s": crossing, "Gmax_Pa": gmax,
               # geocontact: contacts the law extrapolated for (beyond its calibrated range)
               "beyond_range_contacts": (int(float(info["beyond_range_contacts"]))
                                         if "beyond_range_contacts" in info else None),
               "beyond_range_max_depth": (float(info["beyond_range_max_depth"])
                                          if "beyond_range_max_depth" in info else None)}
    return {"summary": summary, "loops": loops, "curves": curves}


def balance_check(curve: dict) -> dict:
    """Whether an amplitude's loop is a quasi-static loop of the contacts: the work of the
    cycle the contact stress's loop measures, W_loop V, must equal what the contacts' ledger
    says became of it, ΔD + ΔU + ΔK (docs/sample-study.md, "What is measured"). In a
    quasi-static cycle it does, to the ledger's rounding. When it does not, energy reached the
    grains by a way the contact stress does not see -- the velocity the sheared periodic images
    give a grain crossing the box (`fix deform ... remap v`) -- and the grains are thrown about:
    the point is not a modulus reduction or damping point. ``energy_balance_residual``:
    (D − D_ledger − ΔU − ΔK) over the sum of their magnitudes; ``quasi_static``: within
    ``BALANCE_TOLERANCE``; None without a ledger (pair granular)."""
    terms = [float(curve[k]) for k in BALANCE_TERMS]
    if not all(math.isfinite(t) for t in terms):
        return {"energy_balance_residual": math.nan, "quasi_static": None}
    residual = (terms[0] - sum(terms[1:])) / max(sum(abs(t) for t in terms), 1e-300)
    return {"energy_balance_residual": residual,
            "quasi_static": abs(residual) <= BALANCE_TOLERANCE}


def _finite(value: float) -> float | None:
    return value if value < 1e300 else None


# the energy balance of a quasi-static cycle closes to the ledger's rounding: measured in the
# study's first 16 runs (500 grains), within 0.6 % of the terms' magnitudes at every amplitude
# but the loose reference sample's (100 Pa) above 10⁻³, off by 16–99.6 % (docs/sample-study.md)
BALANCE_TOLERANCE = 0.02
# W_loop V = ΔD + ΔU + ΔK in units of 4π W_peak V: the loop's D, the ledger's, the stored and
# the kinetic energies' changes
BALANCE_TERMS = ("damping_ratio", "damping_ratio_ledger", "stored_energy_change_ratio",
                 "kinetic_energy_change_ratio")

# the script consolidates to 1 % (in.cyclicshear `ctol`); the hold and the settling at fixed box
# move it a little (measured: within 0.01 %); beyond this the run is refused
CONSOLIDATION_TOLERANCE = 0.05

LOOP_COLUMNS = ("law", "material", "seed", "consolidation_stress_Pa", "amplitude", "cycle",
                "step", "time_s", "shear_strain", "shear_stress_Pa", "mean_stress_Pa",
                "vertical_stress_Pa", "volumetric_strain", "law_dissipated_J",
                "ledger_dissipated_J", "ledger_stored_J", "kinetic_J", "contacts_per_grain",
                "sliding_dissipated_J", "viscous_dissipated_J")
CURVE_COLUMNS = ("law", "material", "seed", "consolidation_stress_Pa", "amplitude", "G_Pa",
                 "G_over_Gmax", "damping_ratio", "damping_ratio_ledger",
                 "volumetric_strain_per_cycle", "mean_stress_change_per_cycle_Pa",
                 "damping_ratio_normal_law", "damping_ratio_sliding", "damping_ratio_viscous",
                 "stored_energy_change_ratio", "kinetic_energy_change_ratio", "strain_amplitude",
                 "loop_work_J_m3", "peak_energy_J_m3", "mean_stress_Pa", "strain_rate_1_s",
                 "inertia_number", "steps_per_cycle", "period_over_wave_crossing",
                 "contacts_per_grain", "energy_balance_residual", "quasi_static")


# --- the command -------------------------------------------------------------------------------

def _cell(value):
    """A curve's value as a CSV number: a flag as 1 / 0, an unknown one (None) as NaN."""
    return math.nan if value is None else float(value) if isinstance(value, bool) else value


def _finished(folder: Path, inputs: dict) -> bool | None:
    """True: a finished run of these inputs; False: none; None: a finished run of others."""
    manifest = read_manifest(folder)
    if manifest is None or manifest.get("command") != RUN_COMMAND or verify_manifest(folder):
        return False
    from ..files import json_safe

    return True if manifest.get("inputs") == json_safe(inputs) else None


def run_cyclic_shear(law: str | Path, settings: CyclicSettings, *, out: str | Path,
                     ranks: int = 1, overwrite: bool = False,
                     progress: Callable[[str], None] | None = None) -> dict:
    """Every run of the study into ``out``: ``runs/NAME/`` (committed when finished, reused on a
    rerun with the same inputs), ``loops/NAME.csv``, ``curves.csv`` and ``summary.json``."""
    from ..law import load_params

    if not 1 <= ranks <= MAX_RANKS:
        raise InputError(f"ranks: must be in [1, {MAX_RANKS}], got {ranks}")
    settings.check()
    given = str(law)  # recorded as the user gave it (relative paths stay relative)
    law = Path(law).resolve()
    try:
        params = load_params(law)
    except InputError as exc:
        raise InputError(f"law: {str(exc).removeprefix('params: ')}") from None
    settings.extra.setdefault("E", repr(params.material.youngs_modulus))
    settings.extra.setdefault("nu", repr(params.material.poissons_ratio))
    material = law.stem  # the law file names the material (its label says how it was made)
    out = Path(out)
    check_replaceable(out, COMMAND, overwrite=overwrite)  # a partial study of ours resumes
    runs = plan(settings)
    inputs = {"law": given, "ranks": ranks, **asdict(settings)}
    stale = [r for r in runs
             if _finished(out / "runs" / r.name, run_inputs(r, settings, law)) is None]
    if stale and not overwrite:
        raise InputError(f"out: {out / 'runs' / stale[0].name} was made with other inputs; "
                         "choose another folder or pass --force to run it again")
    out.mkdir(parents=True, exist_ok=True)
    write_manifest(out, COMMAND, inputs)  # a partial study is ours: resumable, replaceable
    documents = []
    for n, run in enumerate(runs, start=1):
        folder = out / "runs" / run.name
        what = f"[{n}/{len(runs)}] {run.name}"
        inputs_run = run_inputs(run, settings, law)
        if not _finished(folder, inputs_run):
            if progress:
                progress(f"{what}: {settings.grains} grains, {len(settings.amplitudes)} "
                         f"amplitudes x {settings.cycles} cycles")
            parsed = run_one(run, settings, law, material, folder, ranks, progress)
            wall = parsed["summary"]["runtime_s"]
            if progress:
                progress(f"{what}: done in {wall:.1f} s, Gmax "
                         f"{parsed['summary']['Gmax_Pa']:.4g} Pa")
        elif progress:
            progress(f"{what}: finished before, reused")
        documents.append(_write_loops(out, folder, run, settings, material))
        # the run and its loops listed as ours at once: a study stopped at any point resumes
        # (its loops file unlisted, the next call refused the folder as not ours)
        write_manifest(out, COMMAND, inputs)
    curves = [c for d in documents for c in d["curves"]]
    write_csv(out / "curves.csv", {k: np.array([_cell(c[k]) for c in curves])
                                   for k in CURVE_COLUMNS})
    document = {"schema": SCHEMA, "test": "cyclic-shear", "law": given,
                "law_label": params.label, "material": material, "ranks": ranks,
                "calibrated_max_depth": params.calibrated_depth,
                "runs": [d["summary"] for d in documents], "curves": curves,
                "provenance": provenance(COMMAND, inputs)}
    write_json_atomic(out / "summary.json", document)
    write_manifest(out, COMMAND, inputs)
    return document


def without_cyclic_extension(law: Path, path: Path) -> Path:
    """The law file at ``law`` with its cyclic extension off, saved at ``path`` (the run's own
    copy: what the run read is kept beside its results)."""
    from ..law import load_params

    params = load_params(law)
    replace(params, cyclic=replace(params.cyclic, enabled=False)).save(path)
    return path


def run_one(run: Run, settings: CyclicSettings, law: Path, material: str, folder: Path,
            ranks: int = 1, progress: Callable[[str], None] | None = None) -> dict:
    """One LAMMPS run committed to ``folder`` (a result of its own: ``lammps/`` with the
    script's outputs, ``run.json``); its parsed loops and curves."""
    with atomic_directory(folder, RUN_COMMAND, overwrite=True,
                          inputs=run_inputs(run, settings, law)) as tmp:
        lammps = tmp / "lammps"
        contact_law = law
        if run.law == "geocontact" and settings.cyclic_extension == "off":
            contact_law = without_cyclic_extension(law, tmp / "law-no-cyclic-extension.json")
        if run.law == "elastic":  # the grain's elastic law, kept beside the run
            from ..law import load_params
            from ..law.elastic import elastic_law

            contact_law = tmp / "law-elastic.json"
            elastic_law(load_params(law)).save(contact_law)
        wall = run_lammps(TEST, script_variables(run, settings, contact_law, lammps), run.law,
                          ranks, lammps, progress, reporter=_report_segments)
        for suffix in (".log", ".stderr"):
            shutil.move(tmp / f"lammps{suffix}", lammps / f"lammps{suffix}")
        parsed = parse_run(lammps, run, settings, material)
        parsed["summary"]["runtime_s"] = wall
        write_json_atomic(tmp / "run.json", {"summary": parsed["summary"],
                                             "curves": parsed["curves"]})
    return parsed


def _write_loops(out: Path, folder: Path, run: Run, settings: CyclicSettings,
                 material: str) -> dict:
    """``loops/NAME.csv`` of a finished run (parsed again from its LAMMPS outputs)."""
    import json

    parsed = parse_run(folder / "lammps", run, settings, material)
    (out / "loops").mkdir(exist_ok=True)
    write_csv(out / "loops" / f"{run.name}.csv",
              {k: np.array(parsed["loops"][k]) for k in LOOP_COLUMNS})
    summary = json.loads((folder / "run.json").read_text())["summary"]
    return {"summary": summary, "curves": parsed["curves"]}
