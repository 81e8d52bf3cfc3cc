"""LAMMPS wall cost: time per step of two `fix wall/geocontact` walls (a fixed floor and a
wiggling roof) against LAMMPS's own `fix wall/gran granular hertz/material` (Mindlin
tangential history, Tsuji damping) on the same walls and grains: a square layer of grains
(140 x 140, radius 0.1 m, illustrative parameters) every one of which touches both walls, the
roof wiggling 8 delta_y into them (plastic for geocontact) and back. The cost is LAMMPS's
"Modify" time (max over ranks) less that of the same run without walls (the integrator), so
what is left is the walls'. Each configuration is a separate `mpiexec` run of
lammps_wall_driver.py."""

from __future__ import annotations

import math
import sys
from pathlib import Path

from common import record, run_mpi_driver

DRIVER = Path(__file__).with_name("lammps_wall_driver.py")
PEER = "wall_gran_hertz_material"


def measure(wall: str, ranks: int, side: int, steps: int) -> dict | str:
    return run_mpi_driver(DRIVER, ranks, ["--wall", wall, "--side", str(side),
                                          "--steps", str(steps)])


def median_cost(wall: str, ranks: int, side: int, steps: int, repeats: int) -> dict:
    """The run with the median "Modify" time of ``repeats`` runs, plus every run's time."""
    runs = []
    for _ in range(repeats):
        result = measure(wall, ranks, side, steps)
        if isinstance(result, str):
            raise RuntimeError(f"wall benchmark ({wall}, {ranks} rank(s)) failed: {result}")
        runs.append(result)
    runs.sort(key=lambda r: r["modify_seconds_per_step"])
    return {**runs[len(runs) // 2],
            "all": [r["modify_seconds_per_step"] for r in runs]}


def main(side: int = 140, steps: int = 200, repeats: int = 3, ranks_list=(1, 2)) -> None:
    for ranks in ranks_list:
        baseline = median_cost("none", ranks, side, steps, repeats)["modify_seconds_per_step"]
        ours = median_cost("geocontact", ranks, side, steps, repeats)
        theirs = median_cost(PEER, ranks, side, steps, repeats)
        if not math.isfinite(theirs["roof_force_N"]):
            print(f"wall peer not measured: its roof force is {theirs['roof_force_N']}")
            continue
        a = ours["modify_seconds_per_step"] - baseline
        b = theirs["modify_seconds_per_step"] - baseline
        note = (f"{ours['atoms']} grains on 2 walls, {ranks} rank(s), {steps} steps, "
                f"median of {repeats} runs each, less the wall-less run "
                f"({baseline:.3g} s/step); roof force {ours['roof_force_N']:.4g} N "
                f"(peer {theirs['roof_force_N']:.4g} N); wall contacts at the end "
                f"{ours['wall_contacts']:.0f} (peer {theirs['wall_contacts']:.0f})")
        record(f"lammps_wall_{ranks}rank", a, "s/step",
               "fix wall/gran granular hertz/material", b, ratio=a / b, note=note,
               baseline_seconds_per_step=baseline, wall_contacts=ours["wall_contacts"],
               peer_wall_contacts=theirs["wall_contacts"],
               modify_seconds_per_step_runs=ours["all"],
               peer_modify_seconds_per_step_runs=theirs["all"])


if __name__ == "__main__":
    quick = "--quick" in sys.argv
    main(side=40 if quick else 140, steps=100 if quick else 200, repeats=1 if quick else 3,
         ranks_list=(1,) if quick else (1, 2))
