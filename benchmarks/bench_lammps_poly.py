"""LAMMPS pair cost on a polydisperse sample (lognormal radii, spread 26 %; the sample is
described in lammps_poly_driver.py): pair time per step of pair_style geocontact against
LAMMPS's pair granular hertz/material with Mindlin tangential history on the same sample (the
same data file: positions, radii), the same steps, 1 and 2 ranks, median of `repeats` runs
(ours and the peer alternating, so a shared machine's load falls on both alike);
then both with the same rolling resistance (`rolling sds`). Each configuration is a separate
`mpiexec` run of lammps_poly_driver.py."""

from __future__ import annotations

import json
import sys
from pathlib import Path

from common import OUT, record, run_mpi_driver

DRIVER = Path(__file__).with_name("lammps_poly_driver.py")
PAIRS = (("geocontact", "granular_hertz_material", "pair granular hertz/material + mindlin"),
         ("geocontact_rolling", "granular_hertz_material_rolling",
          "pair granular hertz/material + mindlin + rolling sds"))


def measure(pair: str, ranks: int, data: Path, steps: int) -> dict:
    result = run_mpi_driver(DRIVER, ranks, ["--pair", pair, "--data", str(data),
                                            "--steps", str(steps)])
    if isinstance(result, str):
        raise RuntimeError(f"polydisperse benchmark ({pair}, {ranks} rank(s)): {result}")
    return result


def interleaved(ours: str, peer: str, ranks: int, data: Path, steps: int,
                repeats: int) -> tuple[dict, dict, list[float]]:
    """``repeats`` runs of each, alternating ours and the peer (a shared machine's load then
    falls on both alike): the run with the median pair time of each, and each pair of
    consecutive runs' ratio."""
    runs = {ours: [], peer: []}
    for _ in range(repeats):
        for pair in (ours, peer):
            runs[pair].append(measure(pair, ranks, data, steps))
    ratios = [a["pair_seconds_per_step"] / b["pair_seconds_per_step"]
              for a, b in zip(runs[ours], runs[peer], strict=True)]
    medians = []
    for pair in (ours, peer):
        ordered = sorted(runs[pair], key=lambda r: r["pair_seconds_per_step"])
        medians.append({**ordered[len(ordered) // 2],
                        "all": [r["pair_seconds_per_step"] for r in runs[pair]]})
    return medians[0], medians[1], ratios


def main(cells: int = 20, steps: int = 200, repeats: int = 3, ranks_list=(1, 2)) -> None:
    data = OUT / f"polydisperse-{cells}.data"
    data.parent.mkdir(parents=True, exist_ok=True)
    sample = run_mpi_driver(DRIVER, 1, ["--prepare", str(data), "--cells", str(cells)])
    if isinstance(sample, str):
        raise RuntimeError(f"polydisperse sample not prepared: {sample}")
    for ranks in ranks_list:
        for ours_name, peer_name, label in PAIRS:
            ours, theirs, ratios = interleaved(ours_name, peer_name, ranks, data, steps,
                                               repeats)
            a, b = ours["pair_seconds_per_step"], theirs["pair_seconds_per_step"]
            name = f"lammps_pair_poly{'_rolling' if 'rolling' in ours_name else ''}_{ranks}rank"
            note = (f"{sample['grains']} grains, lognormal radii (spread "
                    f"{100 * sample['spread']:.0f} %), {ranks} rank(s), {steps} steps, median "
                    f"of {repeats} runs each; contacts at the end {ours['contacts']} (peer "
                    f"{theirs['contacts']}); ratios of consecutive runs "
                    f"{', '.join(f'{r:.3g}' for r in ratios)}")
            record(name, a, "s/step", label, b, ratio=a / b, note=note,
                   pair_seconds_per_step_runs=ours["all"],
                   peer_pair_seconds_per_step_runs=theirs["all"], consecutive_ratios=ratios,
                   contacts=ours["contacts"], peer_contacts=theirs["contacts"],
                   pressure_Pa=ours["pressure_Pa"], peer_pressure_Pa=theirs["pressure_Pa"])


if __name__ == "__main__":
    quick = "--quick" in sys.argv
    main(cells=10 if quick else 20, steps=100 if quick else 200, repeats=1 if quick else 3,
         ranks_list=(1,) if quick else (1, 2))
    print(json.dumps(sorted(p.name for p in OUT.glob("lammps_pair_poly*.json"))))
