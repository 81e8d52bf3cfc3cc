"""The README's LAMMPS example, run exactly as a newcomer types it on a fresh checkout."""

from __future__ import annotations

import re
import subprocess
from pathlib import Path

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
