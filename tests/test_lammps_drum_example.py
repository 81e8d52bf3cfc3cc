"""examples/lammps/in.drum, the rotating drum of fix wall/geocontact/region, run as a user runs it
(seconds): the bed settles on the drum's wall, the turning wall drags it up on the side where the
wall rises, and the time step stays below the critical time step the wall and the pair report."""

from __future__ import annotations

import subprocess
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
# series.txt columns
TIME, COM_X, WALL_FZ, DT_PAIR, DT_WALL = 0, 1, 4, 8, 9


def run_drums(tmp_path: Path, omegas: list[float]) -> dict[float, tuple[np.ndarray, dict]]:
    """in.drum at each rotation speed, one LAMMPS process each (side by side)."""
    lmp = str(ROOT / ".venv" / "bin" / "lmp")
    env = {"LD_LIBRARY_PATH": str(ROOT / ".venv" / "lib"), "PATH": "/usr/bin:/bin",
           "OMP_NUM_THREADS": "1"}
    procs = {}
    for omega in omegas:
        out = tmp_path / f"omega{omega}"
        procs[omega] = (out, subprocess.Popen(
            [lmp, "-in", "examples/lammps/in.drum", "-log", "none", "-var", "out", str(out),
             "-var", "omega", str(omega)], cwd=ROOT, env=env, stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT, text=True))
    results = {}
    for omega, (out, proc) in procs.items():
        output, _ = proc.communicate(timeout=600)
        assert proc.returncode == 0, output[-2000:]
        series = np.loadtxt(out / "series.txt", comments="#", ndmin=2)
        run = dict(line.split() for line in (out / "run.txt").read_text().splitlines())
        results[omega] = (series, {k: float(v) for k, v in run.items()})
    return results


def test_the_drum_settles_then_its_turning_wall_tilts_the_bed_towards_the_rising_side(tmp_path):
    results = run_drums(tmp_path, [3.0, -3.0])
    for omega, (series, run) in results.items():
        radius, dt = run["grain_radius_m"], run["timestep_s"]
        settle = dt * run["settle_steps"]
        # at rest the drum carries the bed: over the last third of the settling, the mean force
        # of the grains on the wall is the weight, downwards (momentum balance), to 5 %
        rest = series[(series[:, TIME] > 2 * settle / 3) & (series[:, TIME] <= settle)]
        carried = -np.mean(rest[:, WALL_FZ])
        assert abs(carried / run["weight_N"] - 1) < 0.05, carried / run["weight_N"]
        # turning about +y the bottom of the wall moves to -x: the bed climbs the -x side (and
        # the +x side for omega < 0), its centre of mass off by more than a grain radius
        assert np.sign(run["mean_tilt_m"]) == -np.sign(omega)
        assert abs(run["mean_tilt_m"]) > radius
        # the step is below 0.3 of the stiffest contact's critical time step (docs/dem.md)
        critical = series[:, [DT_PAIR, DT_WALL]]
        assert dt < 0.3 * critical[critical > 0].min()
