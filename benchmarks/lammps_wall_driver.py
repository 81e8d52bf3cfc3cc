"""One timed LAMMPS run for bench_lammps_wall.py (run under mpiexec): a layer of grains between
a fixed floor and a wiggling roof, every grain touching both, with a given wall fix; prints the
fixes' time per step (LAMMPS's "Modify" section, max over ranks) as JSON on rank 0."""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))

import lammps_scenarios as scenarios  # noqa: E402
from lammps_driver import timing_max  # noqa: E402

from geocontact.analyses.lammps_plugin import open_lammps  # noqa: E402

G = scenarios.PARAMS_FILE
MATERIAL = json.loads(G.read_text())["material"]
RADIUS = scenarios.RADIUS
DY = scenarios.YIELD_APPROACH
# The roof starts a quarter yield approach into every grain and wiggles down 8 delta_y (at
# d = 2 w: 16 pair yield approaches, plastic) and back, once per WIGGLE_STEPS.
ROOF = 2 * RADIUS - 0.25 * DY
AMPLITUDE = -4.0 * DY
WIGGLE_STEPS = 400


def walls(style: str, timestep: float) -> list[str]:
    """The floor and the roof with one wall style; `none`: no walls (the baseline)."""
    wiggle = f"wiggle z {AMPLITUDE!r} {WIGGLE_STEPS * timestep!r}"
    if style == "geocontact":
        model = f"wall/geocontact {G} friction 0.5 damping 0.5"
    elif style == "wall_gran_hertz_material":
        # LAMMPS's Hertz with material constants, Mindlin tangential history, Tsuji damping
        model = (f"wall/gran granular hertz/material {MATERIAL['youngs_modulus']} 0.5 "
                 f"{MATERIAL['poissons_ratio']} tangential mindlin NULL 1.0 0.5 damping tsuji")
    else:
        return []
    # wall/gran's per-atom `contacts` output: its roof force, and the per-atom work ours does
    contacts = " contacts" if style != "geocontact" else ""
    return [f"fix floor all {model} zplane 0.0 NULL{contacts}",
            f"fix roof all {model} zplane NULL {ROOF!r} {wiggle}{contacts}"]


def roof_force_and_contacts(lmp, style: str) -> tuple[float, float]:
    """Force of the grains on the roof along z (N) and the number of wall contacts (both
    walls) at the end of the run."""
    from lammps import LMP_STYLE_GLOBAL, LMP_TYPE_SCALAR, LMP_TYPE_VECTOR

    if style == "geocontact":
        return (lmp.extract_fix("roof", LMP_STYLE_GLOBAL, LMP_TYPE_VECTOR, 2),
                sum(lmp.extract_fix(w, LMP_STYLE_GLOBAL, LMP_TYPE_VECTOR, 5)
                    for w in ("floor", "roof")))
    if style == "none":
        return 0.0, 0.0
    # wall/gran's `contacts`: [1] in contact, [4] fz on the grain
    for line in ("compute roof all reduce sum f_roof[4]",
                 "compute touching all reduce sum f_floor[1] f_roof[1]", "run 0 post no"):
        lmp.command(line)
    touching = sum(lmp.extract_compute("touching", LMP_STYLE_GLOBAL, LMP_TYPE_VECTOR)[k]
                   for k in range(2))
    return -lmp.extract_compute("roof", LMP_STYLE_GLOBAL, LMP_TYPE_SCALAR), touching


def main() -> int:
    parser = argparse.ArgumentParser()
    parser.add_argument("--wall", choices=["geocontact", "wall_gran_hertz_material", "none"],
                        required=True)
    parser.add_argument("--side", type=int, default=140, help="grains per side of the layer")
    parser.add_argument("--steps", type=int, default=200)
    parser.add_argument("--out", required=True)
    args = parser.parse_args()
    spacing = 2.2 * RADIUS  # a square layer: grains touch the walls, not each other
    with tempfile.TemporaryDirectory() as tmp:
        log = Path(tmp) / "log.lammps"
        lmp = open_lammps(log=str(log))
        for line in [
            "units si", "atom_style sphere", "atom_modify map array", "boundary p p f",
            "comm_modify vel yes",
            f"region box block 0 {args.side * spacing!r} 0 {args.side * spacing!r} "
            f"{-0.5 * RADIUS!r} {2.5 * RADIUS!r} units box",
            "create_box 1 box",
            f"lattice sc {spacing!r}",
            f"region layer block 0 {args.side} 0 {args.side} 0 0.5",
            "create_atoms 1 region layer",
            f"displace_atoms all move {0.5 * spacing!r} {0.5 * spacing!r} {RADIUS!r} units box",
            f"set type 1 diameter {2 * RADIUS}", f"set type 1 density {scenarios.DENSITY}",
            "neighbor 0.002 bin", f"timestep {scenarios.TIMESTEP}",
            "fix integrate all nve/sphere",
            *walls(args.wall, scenarios.TIMESTEP),
            "thermo 50",
        ]:
            lmp.command(line)
        lmp.command(f"run {args.steps // 2}")  # into contact first
        lmp.command(f"run {args.steps}")  # timed: the second run's breakdown
        text = log.read_text() if lmp.extract_setting("world_rank") == 0 else ""
        force, contacts = roof_force_and_contacts(lmp, args.wall)
        atoms, rank = lmp.get_natoms(), lmp.extract_setting("world_rank")
        ranks = lmp.extract_setting("world_size")
        lmp.close()
        if rank == 0:
            Path(args.out).write_text(json.dumps({
                "wall": args.wall, "atoms": atoms, "ranks": ranks, "steps": args.steps,
                "modify_seconds_per_step": timing_max(text, "Modify") / args.steps,
                "roof_force_N": force, "wall_contacts": contacts,
            }))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
