"""LAMMPS pair style cost: pair time per step of pair_style geocontact against LAMMPS's own
pair_style granular (hertz/material with Mindlin history; mdr, Zunker & Kamrin's elastic-plastic
model, as the physics peer) on the same packing (≈ 20 000 grains, fcc block compressed between
grain walls), 1 and 2 ranks. Each configuration is a separate `mpiexec` run of lammps_driver.py;
the pair time is LAMMPS's own timing breakdown (max over ranks) over the timed steps."""

from __future__ import annotations

import math
from pathlib import Path

from common import record, run_mpi_driver

DRIVER = Path(__file__).with_name("lammps_driver.py")


def measure(pair: str, ranks: int, cells: int, steps: int) -> dict | str:
    return run_mpi_driver(DRIVER, ranks, ["--pair", pair, "--cells", str(cells),
                                          "--steps", str(steps)])


def repeated(pair: str, ranks: int, cells: int, steps: int, repeats: int) -> dict | str:
    """``measure`` ``repeats`` times; the run with the median pair time, plus every pair time
    (single runs of a few seconds of pair time vary by +-30 % on a shared VM)."""
    runs = []
    for _ in range(repeats):
        result = measure(pair, ranks, cells, steps)
        if isinstance(result, str):
            return result
        runs.append(result)
    runs.sort(key=lambda r: r["pair_seconds_per_step"])
    return {**runs[len(runs) // 2], "all_pair_seconds_per_step":
            [r["pair_seconds_per_step"] for r in runs]}


def main(cells: int = 17, steps: int = 200, repeats: int = 3) -> None:
    for ranks in (1, 2):
        ours = repeated("geocontact", ranks, cells, steps, repeats)
        if isinstance(ours, str):
            raise RuntimeError(f"pair_style geocontact benchmark failed: {ours}")
        note = (f"{ours['atoms']} grains, {ranks} rank(s), {steps} steps, compressed fcc packing; "
                f"median of {repeats} runs each")
        for peer, label in (("granular_hertz_material", "pair granular hertz/material"),
                            ("granular_mdr", "pair granular mdr")):
            theirs = repeated(peer, ranks, cells, steps, repeats)
            name = f"lammps_pair_{peer.removeprefix('granular_')}_{ranks}rank"
            if isinstance(theirs, str):  # reported, not recorded (no ratio to write)
                print(f"{name}: peer not measured: {theirs}")
                continue
            if not math.isfinite(theirs["top_force_N"]):
                print(f"{name}: peer not measured: its wall force is {theirs['top_force_N']}")
                continue
            a, b = ours["all_pair_seconds_per_step"], theirs["all_pair_seconds_per_step"]
            extra = f"; ratio range {min(a) / max(b):.3g}-{max(a) / min(b):.3g}"
            if peer == "granular_mdr":  # its fix granular/mdr works outside the pair time
                extra += (f"; fixes {theirs['modify_seconds_per_step']:.3g} s/step "
                          f"(ours {ours['modify_seconds_per_step']:.3g})")
            record(name, ours["pair_seconds_per_step"], "s/step", label,
                   theirs["pair_seconds_per_step"],
                   ratio=ours["pair_seconds_per_step"] / theirs["pair_seconds_per_step"],
                   note=note + extra,
                   modify_seconds_per_step=ours["modify_seconds_per_step"],
                   peer_modify_seconds_per_step=theirs["modify_seconds_per_step"],
                   wall_force_N=ours["top_force_N"], peer_wall_force_N=theirs["top_force_N"],
                   pair_seconds_per_step_runs=a, peer_pair_seconds_per_step_runs=b)
