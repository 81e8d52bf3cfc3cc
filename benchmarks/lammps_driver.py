"""One timed LAMMPS run for bench_lammps.py (run under mpiexec): the test packing scaled up,
compressed by the top wall for STEPS steps with a given pair style; prints LAMMPS's own
pair time per step (max over ranks) as JSON on rank 0."""

from __future__ import annotations

import argparse
import json
import re
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))

import lammps_scenarios as scenarios  # noqa: E402

from geocontact.lammps_plugin import open_lammps  # noqa: E402

G = scenarios.PARAMS_FILE
MATERIAL = json.loads(G.read_text())["material"]
PEERS = {
    "geocontact": None,
    # LAMMPS's own Hertz with material constants, Mindlin tangential history, Tsuji damping
    "granular_hertz_material": [
        "pair_style granular",
        f"pair_coeff * * hertz/material {MATERIAL['youngs_modulus']} 0.5 "
        f"{MATERIAL['poissons_ratio']} tangential mindlin NULL 1.0 0.5 damping tsuji",
    ],
    # the elastic-plastic peer (Zunker & Kamrin's MDR model)
    "granular_mdr": [
        "newton off",  # MDR requires it; set before the box (build_packing)
        "pair_style granular",
        f"pair_coeff * * mdr {MATERIAL['youngs_modulus']} {MATERIAL['poissons_ratio']} "
        f"{MATERIAL['compressive_yield_stress']} 0.0 0.0 0.5 damping mdr 1 "
        "tangential linear_history 0.0 1.0 0.5",
    ],
}


def main() -> int:
    parser = argparse.ArgumentParser()
    parser.add_argument("--pair", choices=sorted(PEERS), required=True)
    parser.add_argument("--cells", type=int, default=17)
    parser.add_argument("--steps", type=int, default=200)
    parser.add_argument("--out", required=True)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        log = Path(tmp) / "log.lammps"
        lmp = open_lammps(log=str(log))
        scenarios.build_packing(lmp, cells=args.cells, pair=PEERS[args.pair])
        lmp.command("run 0 post no")
        velocity = -scenarios.AMPLITUDE / (scenarios.STEPS_PER_LEG * scenarios.TIMESTEP)
        lmp.command(f"fix push top move linear 0 0 {velocity!r} units box")
        lmp.command(f"run {args.steps // 2}")  # load into contact first
        lmp.command(f"run {args.steps}")  # timed: the second run's breakdown
        atoms, rank = lmp.get_natoms(), lmp.extract_setting("world_rank")
        ranks = lmp.extract_setting("world_size")
        lmp.close()
        if rank == 0:
            text = log.read_text()
            # last "Pair | min | avg | max | %varavg | %total" line of the timing breakdown
            pair = re.findall(r"^Pair\s*\|\s*([\d.e+-]+)\s*\|\s*([\d.e+-]+)\s*\|\s*([\d.e+-]+)",
                              text, re.M)[-1]
            Path(args.out).write_text(json.dumps({
                "pair": args.pair, "atoms": atoms, "ranks": ranks, "steps": args.steps,
                "pair_seconds_per_step": float(pair[2]) / args.steps,
            }))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
