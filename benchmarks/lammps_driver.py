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

from geocontact.analyses.lammps_plugin import open_lammps  # noqa: E402

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
    # The elastic-plastic peer: Zunker & Kamrin's MDR model (E, nu, yield stress Y, surface
    # energy 0 (no adhesion), critical confinement psi_b = 0.5, damping eta_n0 = 0.5), with the
    # same Mindlin tangential history as above. Y = sigma_c: both are the compressive yield
    # stress (MDR is von Mises, the Drucker-Prager cone with beta = 0). MDR needs newton off
    # and per-atom variable radii (its apparent radius grows with plastic deformation); its
    # only damping class is `mdr`. k_t must not be 0: `linear_history 0 ...` divides by it,
    # the NaN positions then read as contacts and LAMMPS stops with "contact not reflected in
    # the neighbor lists".
    "granular_mdr": [
        "atom_style sphere 1",
        "newton off",
        "pair_style granular",
        f"pair_coeff * * mdr {MATERIAL['youngs_modulus']} {MATERIAL['poissons_ratio']} "
        f"{MATERIAL['compressive_yield_stress']} 0.0 0.5 0.5 damping mdr 1 "
        "tangential mindlin NULL 1.0 0.5",
    ],
}


def timing_max(log: str, section: str) -> float:
    """The max-over-ranks seconds of a section ("Pair", "Modify", ...) in the last timing
    breakdown of a LAMMPS log ("Section | min | avg | max | %varavg | %total")."""
    number = r"\s*\|\s*([\d.e+-]+)"
    return float(re.findall(rf"^{section}{number}{number}{number}", log, re.M)[-1][2])


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
        from lammps import LMP_STYLE_GLOBAL, LMP_TYPE_SCALAR  # after open_lammps loaded MPI

        scenarios.build_packing(lmp, cells=args.cells, pair=PEERS[args.pair])
        lmp.command("run 0 post no")
        velocity = -scenarios.AMPLITUDE / (scenarios.STEPS_PER_LEG * scenarios.TIMESTEP)
        lmp.command(f"fix push top move linear 0 0 {velocity!r} units box")
        lmp.command(f"run {args.steps // 2}")  # load into contact first
        lmp.command(f"run {args.steps}")  # timed: the second run's breakdown
        # the force on the moving wall: the same order for every pair style, and finite
        top_force = lmp.extract_compute("ftop", LMP_STYLE_GLOBAL, LMP_TYPE_SCALAR)
        atoms, rank = lmp.get_natoms(), lmp.extract_setting("world_rank")
        ranks = lmp.extract_setting("world_size")
        lmp.close()
        if rank == 0:
            text = log.read_text()
            Path(args.out).write_text(json.dumps({
                "pair": args.pair, "atoms": atoms, "ranks": ranks, "steps": args.steps,
                "pair_seconds_per_step": timing_max(text, "Pair") / args.steps,
                # fixes' time: MDR's own fix (contact screening, mean surface displacement)
                # runs here, outside the pair time
                "modify_seconds_per_step": timing_max(text, "Modify") / args.steps,
                "top_force_N": top_force,
            }))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
