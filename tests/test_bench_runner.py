"""``benchmarks/run.py`` (``make bench``): ``--help`` and a misspelt name run nothing."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

RUNNER = Path(__file__).resolve().parents[1] / "benchmarks" / "run.py"


def run(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, str(RUNNER), *args], capture_output=True, text=True,
                          timeout=60)


def test_help_prints_the_usage_and_runs_no_benchmark():
    proc = run("--help")
    assert proc.returncode == 0
    assert proc.stdout.startswith("usage: benchmarks/run.py")
    assert "lammps_poly" in proc.stdout


def test_an_unknown_benchmark_is_one_line_naming_the_allowed_ones():
    proc = run("lamps")
    assert proc.returncode == 2
    assert proc.stdout == ""
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1
    assert "unknown benchmark lamps" in lines[0] and "lammps_wall" in lines[0]
