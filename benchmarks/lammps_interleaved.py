"""Same-run comparison of plugin builds and the LAMMPS peer on a shared machine: the CPU time
(not the wall time) of the pair ("Pair" section) or the walls ("Modify" less a wall-less run)
per step, from LAMMPS's `timer full` breakdown (section time x its %CPU), the builds and the
peer alternating run by run, so the machine's load falls on all alike and a rank waiting for
the CPU is not counted. Ratios are of medians.

    python benchmarks/lammps_interleaved.py BUILD.so [BUILD.so ...] [--repeats 5]
        [--cases poly poly_rolling wall] [--cells 20] [--side 140] [--steps 200]

One run: `--case C --plugin SO|peer --out J` (a subprocess per run: one plugin per process).
The samples are the benchmarks' (lammps_poly_driver.py, lammps_wall_driver.py), 1 rank.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))
sys.path.insert(0, str(Path(__file__).resolve().parent))

CASES = ("poly", "poly_rolling", "wall")


def cpu_seconds(log: str, section: str) -> float:
    """The section's CPU seconds in the last `timer full` breakdown: its (max) time times its
    %CPU ("Section | min | avg | max | %varavg | %CPU | %total")."""
    number = r"\s*\|\s*([\d.e+-]+)"
    row = re.findall(rf"^{section}{number}{number}{number}{number}{number}", log, re.M)[-1]
    return float(row[2]) * float(row[4]) / 100.0


def one_run(case: str, peer: bool, data: str, side: int, steps: int) -> float:
    from geocontact.analyses.lammps_plugin import open_lammps

    with tempfile.TemporaryDirectory() as tmp:
        log = Path(tmp) / "log.lammps"
        lmp = open_lammps(["-log", str(log), "-screen", "none"])
        if case.startswith("poly"):
            import lammps_poly_driver as poly

            name = ("granular_hertz_material" if peer else "geocontact") + (
                "_rolling" if case == "poly_rolling" else "")
            commands = ["units si", "atom_style sphere", "atom_modify map array",
                        "boundary p p p", "comm_modify vel yes", f"read_data {data}",
                        *poly.PEERS[name], "neighbor 0.005 bin",
                        f"timestep {poly.TIMESTEP}", "fix nve all nve/sphere",
                        f"fix squeeze all deform 1 x erate {poly.STRAIN_RATE} y erate "
                        f"{poly.STRAIN_RATE} z erate {poly.STRAIN_RATE} remap x",
                        "thermo_style custom step ke press", "thermo 50", "timer full"]
            section = "Pair"
        else:
            import lammps_scenarios as scenarios
            import lammps_wall_driver as wall

            spacing = 2.2 * wall.RADIUS
            commands = [
                "units si", "atom_style sphere", "atom_modify map array", "boundary p p f",
                "comm_modify vel yes",
                f"region box block 0 {side * spacing!r} 0 {side * spacing!r} "
                f"{-0.5 * wall.RADIUS!r} {2.5 * wall.RADIUS!r} units box",
                "create_box 1 box", f"lattice sc {spacing!r}",
                f"region layer block 0 {side} 0 {side} 0 0.5", "create_atoms 1 region layer",
                f"displace_atoms all move {0.5 * spacing!r} {0.5 * spacing!r} "
                f"{wall.RADIUS!r} units box",
                f"set type 1 diameter {2 * wall.RADIUS}",
                f"set type 1 density {scenarios.DENSITY}", "neighbor 0.002 bin",
                f"timestep {scenarios.TIMESTEP}", "fix integrate all nve/sphere",
                *wall.walls("wall_gran_hertz_material" if peer else
                            ("none" if case == "wall_none" else "geocontact"),
                            scenarios.TIMESTEP),
                "thermo 50", "timer full"]
            section = "Modify"
        for line in commands:
            lmp.command(line)
        lmp.command(f"run {steps // 2}")
        lmp.command(f"run {steps}")
        lmp.close()
        return cpu_seconds(log.read_text(), section) / steps


def spawn(case: str, plugin: str, data: str, side: int, steps: int) -> float:
    env = {**os.environ, "PYTHONPATH": str(ROOT / "src"), "OMP_NUM_THREADS": "1"}
    if plugin != "peer":  # (the peer's run loads the first build, which it does not use)
        env["GEOCONTACT_LAMMPS_PLUGIN"] = plugin
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "run.json"
        subprocess.run([sys.executable, __file__, "--case", case, "--plugin", plugin,
                        "--data", data, "--side", str(side), "--steps", str(steps),
                        "--out", str(out)], env=env, cwd=tmp, check=True, timeout=3600)
        return json.loads(out.read_text())["cpu_seconds_per_step"]


def main() -> int:
    parser = argparse.ArgumentParser()
    parser.add_argument("builds", nargs="*")
    parser.add_argument("--case", choices=(*CASES, "wall_none"))
    parser.add_argument("--cases", nargs="*", choices=CASES, default=list(CASES))
    parser.add_argument("--plugin")
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--cells", type=int, default=20)
    parser.add_argument("--side", type=int, default=140)
    parser.add_argument("--steps", type=int, default=200)
    parser.add_argument("--data")
    parser.add_argument("--out")
    args = parser.parse_args()
    if args.case:
        seconds = one_run(args.case, args.plugin == "peer", args.data, args.side, args.steps)
        Path(args.out).write_text(json.dumps({"cpu_seconds_per_step": seconds}))
        return 0
    os.environ.setdefault("GEOCONTACT_LAMMPS_PLUGIN", args.builds[0])
    with tempfile.TemporaryDirectory() as tmp:
        from lammps_poly_driver import prepare

        data = str(Path(tmp) / "poly.data")
        prepare(Path(data), args.cells)
        print(f"load average at the start: {os.getloadavg()}")
        for case in args.cases:
            runs = {who: [] for who in (*args.builds, "peer")}
            none = []  # the wall case's integrator alone, subtracted
            for _ in range(args.repeats):
                for who in runs:
                    runs[who].append(spawn(case, who, data, args.side, args.steps))
                if case == "wall":
                    none.append(spawn("wall_none", args.builds[0], data, args.side, args.steps))
            base = statistics.median(none) if case == "wall" else 0.0
            peer = statistics.median(runs["peer"]) - base
            for who, seconds in runs.items():
                cost = statistics.median(seconds) - base
                print(f"{case}: {who}: {cost:.4g} CPU s/step, {cost / peer:.3f} of the peer "
                      f"(runs {', '.join(f'{s:.4g}' for s in seconds)})")
        print(f"load average at the end: {os.getloadavg()}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
