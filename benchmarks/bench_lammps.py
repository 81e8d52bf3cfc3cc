"""LAMMPS pair style cost: pair time per step of pair_style geocontact against LAMMPS's own
pair_style granular (hertz/material with Mindlin history; mdr, Zunker & Kamrin's elastic-plastic
model, as the physics peer) on the same packing (≈ 20 000 grains, fcc block compressed between
grain walls), 1 and 2 ranks. Each configuration is a separate `mpiexec` run of lammps_driver.py;
the pair time is LAMMPS's own timing breakdown (max over ranks) over the timed steps."""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
import tempfile
from pathlib import Path

from common import ROOT, record

DRIVER = Path(__file__).with_name("lammps_driver.py")


def measure(pair: str, ranks: int, cells: int, steps: int) -> dict | str:
    mpiexec = Path(sys.executable).with_name("mpiexec")
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "result.json"
        env = {**os.environ, "PYTHONPATH": str(ROOT / "src"), "OMP_NUM_THREADS": "1"}
        run = subprocess.run([str(mpiexec), "-n", str(ranks), sys.executable, str(DRIVER),
                              "--pair", pair, "--cells", str(cells), "--steps", str(steps),
                              "--out", str(out)], env=env, cwd=tmp, capture_output=True,
                             text=True, timeout=3600)
        if run.returncode != 0 or not out.exists():
            errors = [line for line in run.stderr.splitlines() if "ERROR" in line]
            return errors[-1].strip() if errors else f"exit status {run.returncode}"
        return json.loads(out.read_text())


def main(cells: int = 17, steps: int = 200) -> None:
    for ranks in (1, 2):
        ours = measure("geocontact", ranks, cells, steps)
        if isinstance(ours, str):
            raise RuntimeError(f"pair_style geocontact benchmark failed: {ours}")
        note = f"{ours['atoms']} grains, {ranks} rank(s), {steps} steps, compressed fcc packing"
        for peer, label in (("granular_hertz_material", "pair granular hertz/material"),
                            ("granular_mdr", "pair granular mdr")):
            theirs = measure(peer, ranks, cells, steps)
            name = f"lammps_pair_{peer.removeprefix('granular_')}_{ranks}rank"
            if isinstance(theirs, str):  # reported, not recorded (no ratio to write)
                print(f"{name}: peer not measured: {theirs}")
                continue
            if not math.isfinite(theirs["top_force_N"]):
                print(f"{name}: peer not measured: its wall force is {theirs['top_force_N']}")
                continue
            extra = ""
            if peer == "granular_mdr":  # its fix granular/mdr works outside the pair time
                extra = (f"; fixes {theirs['modify_seconds_per_step']:.3g} s/step "
                         f"(ours {ours['modify_seconds_per_step']:.3g})")
            record(name, ours["pair_seconds_per_step"], "s/step", label,
                   theirs["pair_seconds_per_step"],
                   ratio=ours["pair_seconds_per_step"] / theirs["pair_seconds_per_step"],
                   note=note + extra,
                   modify_seconds_per_step=ours["modify_seconds_per_step"],
                   peer_modify_seconds_per_step=theirs["modify_seconds_per_step"],
                   wall_force_N=ours["top_force_N"], peer_wall_force_N=theirs["top_force_N"])
