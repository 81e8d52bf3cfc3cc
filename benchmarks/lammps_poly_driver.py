"""The polydisperse sample of bench_lammps_poly.py and one timed LAMMPS run on it (run under
mpiexec).

    python lammps_poly_driver.py --prepare DATA [--cells N]        # write the sample (1 rank)
    mpiexec -n R python lammps_poly_driver.py --pair P --data DATA --steps S --out J

The sample: cells^3 grains of lognormal radii (median the parameter file's radius R, log
standard deviation 0.27, clipped at 2 sigma: 0.58 R to 1.72 R; a spread, standard deviation
over mean, of 26 %) placed on a loose simple cubic lattice, squeezed isotropically (periodic
box) to a solid fraction of 0.62 with a soft Hooke contact and viscous drag, and left to
settle: a jammed random packing, whose positions and radii go into a LAMMPS data file read by
every timed run. A timed run loads that file, sets a pair style, and squeezes the box further
at a constant rate (every contact loads); it prints LAMMPS's own pair time per step (max over
ranks) and the number of contacts at the end as JSON on rank 0.
"""

from __future__ import annotations

import argparse
import ctypes
import json
import math
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))

import lammps_scenarios as scenarios  # noqa: E402
import numpy as np  # noqa: E402
from lammps_driver import timing_max  # noqa: E402

from geocontact.analyses.lammps_plugin import open_lammps  # noqa: E402

G = scenarios.PARAMS_FILE
MATERIAL = json.loads(G.read_text())["material"]
RADIUS = MATERIAL["radius"]
LOG_SIGMA = 0.27
SOLID_FRACTION = 0.62
SEED = 7321
TIMESTEP = 5e-5
STRAIN_RATE = -2e-3  # 1/s: the timed runs' isotropic squeeze
MINDLIN = "tangential mindlin NULL 1.0 0.5"
PEERS = {
    "geocontact": ["pair_style geocontact", f"pair_coeff * * {G} friction 0.5 damping 0.5"],
    # LAMMPS's Hertz with material constants, Mindlin tangential history, Tsuji damping
    "granular_hertz_material": [
        "pair_style granular",
        f"pair_coeff * * hertz/material {MATERIAL['youngs_modulus']} 0.5 "
        f"{MATERIAL['poissons_ratio']} {MINDLIN} damping tsuji",
    ],
}
ROLLING = "rolling sds 1e3 1.0 0.1"  # the same rolling resistance on both sides
PEERS["geocontact_rolling"] = [PEERS["geocontact"][0], f"{PEERS['geocontact'][1]} {ROLLING}"]
PEERS["granular_hertz_material_rolling"] = [PEERS["granular_hertz_material"][0],
                                            f"{PEERS['granular_hertz_material'][1]} {ROLLING}"]


def radii(n: int) -> np.ndarray:
    z = np.clip(np.random.default_rng(SEED).standard_normal(n), -2.0, 2.0)
    return RADIUS * np.exp(LOG_SIGMA * z)


def prepare(data: Path, cells: int) -> dict:
    n = cells**3
    r = radii(n)
    spacing = float(2.0 * r.max())  # no overlaps on the lattice
    side = float(np.sum(4.0 / 3.0 * math.pi * r**3) / SOLID_FRACTION) ** (1.0 / 3.0)
    lmp = open_lammps()
    for line in ("units si", "atom_style sphere", "atom_modify map array", "boundary p p p",
                 "comm_modify vel yes", f"lattice sc {spacing!r}",
                 f"region box block 0 {cells} 0 {cells} 0 {cells}", "create_box 1 box",
                 "create_atoms 1 box"):
        lmp.command(line)
    lmp.scatter_atoms("radius", 1, 1, (ctypes.c_double * n)(*r))
    for line in (f"set type 1 density {scenarios.DENSITY}",
                 "pair_style granular",
                 "pair_coeff * * hooke 5e6 0.5 tangential linear_history 4e6 1.0 0.5 "
                 "damping mass_velocity",
                 "neighbor 0.02 bin", "timestep 2e-4", "fix nve all nve/sphere",
                 "fix drag all viscous 20",
                 f"fix squeeze all deform 1 x final 0 {side!r} y final 0 {side!r} "
                 f"z final 0 {side!r} remap x units box",
                 "run 3000", "unfix squeeze", "run 2000",
                 "velocity all set 0 0 0", "set group all omega 0 0 0",
                 f"write_data {data}"):
        lmp.command(line)
    lmp.close()
    return {"grains": n, "spread": float(np.std(r) / np.mean(r)), "side_m": side}


def count_contacts(lmp) -> int:
    """Touching pairs (centre distance below the sum of the radii) at the end of a run."""
    from scipy.spatial import cKDTree

    x = np.array(lmp.gather_atoms("x", 1, 3)).reshape(-1, 3)
    r = np.array(lmp.gather_atoms("radius", 1, 1))
    lo, hi = lmp.extract_box()[:2]
    box = np.array(hi) - np.array(lo)
    tree = cKDTree(np.mod(x - np.array(lo), box), boxsize=box)
    pairs = tree.query_pairs(2.0 * r.max(), output_type="ndarray")
    i, j = pairs[:, 0], pairs[:, 1]
    d = x[i] - x[j]
    d -= box * np.round(d / box)
    return int(np.sum(np.linalg.norm(d, axis=1) < r[i] + r[j]))


def timed(args) -> dict:
    with tempfile.TemporaryDirectory() as tmp:
        log = Path(tmp) / "log.lammps"
        lmp = open_lammps(log=str(log))
        for line in ("units si", "atom_style sphere", "atom_modify map array",
                     "boundary p p p", "comm_modify vel yes", f"read_data {args.data}",
                     *PEERS[args.pair], "neighbor 0.005 bin", f"timestep {TIMESTEP}",
                     "fix nve all nve/sphere",
                     f"fix squeeze all deform 1 x erate {STRAIN_RATE} y erate {STRAIN_RATE} "
                     f"z erate {STRAIN_RATE} remap x",
                     "thermo_style custom step ke press", "thermo 50"):
            lmp.command(line)
        lmp.command(f"run {args.steps // 2}")  # settle into the new contact law
        lmp.command(f"run {args.steps}")  # timed: the second run's breakdown
        contacts = count_contacts(lmp)
        pressure = lmp.get_thermo("press")
        atoms, rank = lmp.get_natoms(), lmp.extract_setting("world_rank")
        ranks = lmp.extract_setting("world_size")
        lmp.close()
        text = log.read_text() if rank == 0 else ""
    return {"pair": args.pair, "atoms": atoms, "ranks": ranks, "steps": args.steps,
            "pair_seconds_per_step": timing_max(text, "Pair") / args.steps if text else 0.0,
            "contacts": contacts, "pressure_Pa": pressure, "rank": rank}


def main() -> int:
    parser = argparse.ArgumentParser()
    parser.add_argument("--prepare", help="write the sample to this data file")
    parser.add_argument("--cells", type=int, default=20)
    parser.add_argument("--pair", choices=sorted(PEERS))
    parser.add_argument("--data")
    parser.add_argument("--steps", type=int, default=200)
    parser.add_argument("--out")
    args = parser.parse_args()
    result = prepare(Path(args.prepare), args.cells) if args.prepare else timed(args)
    if result.get("rank", 0) == 0 and args.out:
        Path(args.out).write_text(json.dumps(result))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
