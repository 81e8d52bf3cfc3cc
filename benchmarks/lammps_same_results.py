"""Do two builds of the plugin give the same results, to the bit? A speed change to the pair
style or the wall fixes must not change any result: this runs the same scenarios with each
build and compares every output exactly (positions, velocities, spins, forces, torques at the
end; `compute pair geocontact` and the walls' global vectors at every output step; the walls'
per-atom arrays at the end).

    python benchmarks/lammps_same_results.py OLD.so NEW.so [--ranks 1 2]

Scenarios (lammps_same_results.py --scenario NAME --out J, under mpiexec, one plugin each):
`poly` (the polydisperse sample of lammps_poly_driver.py, 1000 grains, squeezed, friction and
damping; the ledger output every step), `poly_rolling` (with rolling and twisting resistance,
`memory place`, the ledger every 7th step), `walls` (a layer between a sheared floor and a
wiggling roof, friction, damping, rolling and twisting; the walls' vectors every 5th step:
contacts migrate between ranks between two outputs), `region` (grains in a rotating
cylindrical drum, fix wall/geocontact/region, gravity). Exit status 1 on any difference, which
is printed.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))
sys.path.insert(0, str(Path(__file__).resolve().parent))

import lammps_scenarios as scenarios  # noqa: E402

G = scenarios.PARAMS_FILE
RADIUS = scenarios.RADIUS
DY = scenarios.YIELD_APPROACH
SCENARIOS = ("poly", "poly_rolling", "walls", "region")
PER_ATOM = ("x", "v", "omega", "f", "torque")
ROLLING = "rolling sds 1e3 1.0 0.1 twisting marshall"


def gathered(lmp) -> dict:
    """Per-atom vectors in atom-ID order (gather_atoms), as plain lists."""
    return {name: list(lmp.gather_atoms(name, 1, 3)) for name in PER_ATOM}


def thermo_rows(lmp, columns: list[str], steps: int, every: int) -> None:
    """Run `steps` steps with the given thermo columns every `every` steps, at full precision in
    the log (read by log_rows once LAMMPS is closed)."""
    lmp.command(f"thermo_style custom step {' '.join(columns)}")
    lmp.command("thermo_modify format float %.17g")
    lmp.command(f"thermo {every}")
    lmp.command(f"run {steps}")


def log_rows(log: Path) -> list[list[str]]:
    """The thermo rows of the log's runs (the text of each number: compared exactly)."""
    rows, inside = [], False
    for line in log.read_text().splitlines():
        if line.startswith("   Step ") or line.startswith("Step "):
            inside = True
        elif inside and line.startswith("Loop time"):
            inside = False
        elif inside and not line.startswith("WARNING"):  # (a warning names a source line)
            rows.append(line.split())
    return rows


def poly(lmp, data: Path, rolling: bool) -> dict:
    keywords = f"friction 0.5 damping 0.5 {ROLLING if rolling else ''}"
    for line in ("units si", "atom_style sphere", "atom_modify map array", "boundary p p p",
                 "comm_modify vel yes", f"read_data {data}",
                 f"pair_style geocontact{' memory place' if rolling else ''}",
                 f"pair_coeff * * {G} {keywords}", "neighbor 0.005 bin", "timestep 5e-5",
                 "fix nve all nve/sphere",
                 "fix squeeze all deform 1 x erate -2e-3 y erate -2e-3 z erate -2e-3 remap x",
                 "compute e all pair geocontact", "thermo_style custom step pe c_e[1]",
                 "run 0"):
        lmp.command(line)
    every = 7 if rolling else 1
    thermo_rows(lmp, [f"c_e[{k}]" for k in range(1, 19)] + ["pe", "press"],
                140 if rolling else 100, every)
    return gathered(lmp)


def walls(lmp) -> dict:
    side, spacing = 8, 2.2 * RADIUS
    model = f"wall/geocontact {G} friction 0.5 damping 0.5 {ROLLING}"
    for line in ("units si", "atom_style sphere", "atom_modify map array", "boundary p p f",
                 "comm_modify vel yes",
                 f"region box block 0 {side * spacing!r} 0 {side * spacing!r} "
                 f"{-0.5 * RADIUS!r} {2.5 * RADIUS!r} units box", "create_box 1 box",
                 f"lattice sc {spacing!r}", f"region layer block 0 {side} 0 {side} 0 0.5",
                 "create_atoms 1 region layer",
                 f"displace_atoms all move {0.5 * spacing!r} {0.5 * spacing!r} {RADIUS!r} "
                 "units box",
                 f"set type 1 diameter {2 * RADIUS}", f"set type 1 density {scenarios.DENSITY}",
                 "velocity all set 0.5 0.2 0", "neighbor 0.002 bin",
                 "neigh_modify every 1 delay 0 check yes",
                 f"timestep {scenarios.TIMESTEP}", "fix integrate all nve/sphere",
                 f"fix floor all {model} zplane 0.0 NULL shear x 0.3",
                 f"fix roof all {model} zplane NULL {2 * RADIUS - 0.25 * DY!r} wiggle z "
                 f"{-4.0 * DY!r} {100 * scenarios.TIMESTEP!r}",
                 "run 0"):
        lmp.command(line)
    columns = [f"f_{w}[{k}]" for w in ("floor", "roof") for k in range(1, 21)]
    thermo_rows(lmp, columns, 200, 5)
    arrays = {}
    for w in ("floor", "roof"):
        lmp.command(f"compute a_{w} all reduce sum " + " ".join(
            f"f_{w}[{k}]" for k in range(1, 7)))
        lmp.command(f"variable s_{w} atom f_{w}[2]*id+f_{w}[3]*id*id+f_{w}[5]")
        lmp.command(f"compute t_{w} all reduce sum v_s_{w}")
    lmp.command("run 0 post no")
    from lammps import LMP_STYLE_GLOBAL, LMP_TYPE_SCALAR, LMP_TYPE_VECTOR

    for w in ("floor", "roof"):
        arrays[w] = [lmp.extract_compute(f"a_{w}", LMP_STYLE_GLOBAL, LMP_TYPE_VECTOR)[k]
                     for k in range(6)]
        arrays[f"{w}_weighted"] = lmp.extract_compute(f"t_{w}", LMP_STYLE_GLOBAL,
                                                      LMP_TYPE_SCALAR)
    return {"arrays": arrays, **gathered(lmp)}


def region(lmp) -> dict:
    for line in ("units si", "atom_style sphere", "atom_modify map array", "boundary f f f",
                 "comm_modify vel yes", "region box block -1 1 -1 1 -1 1", "create_box 1 box",
                 "region fill block -0.25 0.25 -0.25 0.25 -0.44 0.2 units box",
                 "lattice sc 0.15", "create_atoms 1 region fill",
                 "set type 1 diameter 0.12", f"set type 1 density {scenarios.DENSITY}",
                 "displace_atoms all move 0 0 -0.13 units box", "velocity all set 3.0 1.5 -1.0",
                 "variable theta equal 2.0*time",
                 "region drum cylinder z 0 0 0.45 -0.5 0.5 side in units box "
                 "rotate v_theta 0 0 0 0 0 1",
                 "pair_style geocontact", f"pair_coeff * * {G} friction 0.5 damping 0.3",
                 f"fix wall all wall/geocontact/region {G} friction 0.5 damping 0.3 "
                 f"{ROLLING} drum",
                 "fix g all gravity 9.81 vector 0 0 -1", "neighbor 0.01 bin",
                 "neigh_modify every 1 delay 0 check yes", "timestep 5e-5",
                 "fix nve all nve/sphere", "compute e all pair geocontact", "run 0"):
        lmp.command(line)
    columns = ([f"f_wall[{k}]" for k in range(1, 21)]
               + [f"c_e[{k}]" for k in range(1, 19)])
    thermo_rows(lmp, columns, 2400, 60)
    return gathered(lmp)


def run_scenario(name: str, data: Path) -> dict:
    from geocontact.analyses.lammps_plugin import open_lammps

    log = Path("log.lammps").resolve()
    lmp = open_lammps(["-log", str(log), "-screen", "none"])
    lmp.command("processors * 1 1")
    if name == "poly":
        result = poly(lmp, data, rolling=False)
    elif name == "poly_rolling":
        result = poly(lmp, data, rolling=True)
    elif name == "walls":
        result = walls(lmp)
    else:
        result = region(lmp)
    result["rank"] = lmp.extract_setting("world_rank")
    lmp.close()
    if result["rank"] == 0:
        result["thermo"] = log_rows(log)
    return result


def differences(old, new, where="") -> list[str]:
    """Every place two nested results differ (floats compared exactly, NaN equal to NaN)."""
    if isinstance(old, dict):
        return [d for k in old for d in differences(old[k], new.get(k), f"{where}.{k}")]
    if isinstance(old, list):
        if not isinstance(new, list) or len(old) != len(new):
            return [f"{where}: lengths {len(old)} and {len(new or [])}"]
        return [d for k, (a, b) in enumerate(zip(old, new, strict=True))
                for d in differences(a, b, f"{where}[{k}]")]
    same = old == new or (isinstance(old, float) and math.isnan(old) and math.isnan(new))
    return [] if same else [f"{where}: {old!r} and {new!r}"]


def run_build(plugin: Path, name: str, ranks: int, data: Path) -> dict:
    mpiexec = Path(sys.executable).with_name("mpiexec")
    env = {**os.environ, "GEOCONTACT_LAMMPS_PLUGIN": str(plugin),
           "PYTHONPATH": str(ROOT / "src"), "OMP_NUM_THREADS": "1"}
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "result.json"
        run = subprocess.run([str(mpiexec), "-n", str(ranks), sys.executable, __file__,
                              "--scenario", name, "--data", str(data), "--out", str(out)],
                             env=env, cwd=tmp, capture_output=True, text=True, timeout=3600)
        if run.returncode != 0 or not out.exists():
            raise RuntimeError(f"{name} with {plugin}: {run.stderr[-2000:]}")
        return json.loads(out.read_text())


def main() -> int:
    parser = argparse.ArgumentParser()
    parser.add_argument("builds", nargs="*", type=Path, help="OLD.so NEW.so")
    parser.add_argument("--scenario", choices=SCENARIOS)
    parser.add_argument("--only", nargs="*", choices=SCENARIOS, default=list(SCENARIOS))
    parser.add_argument("--ranks", nargs="*", type=int, default=[1, 2])
    parser.add_argument("--data")
    parser.add_argument("--out")
    args = parser.parse_args()
    if args.scenario:
        result = run_scenario(args.scenario, Path(args.data))
        if result["rank"] == 0:
            Path(args.out).write_text(json.dumps(result))
        return 0
    old, new = args.builds
    os.environ["GEOCONTACT_LAMMPS_PLUGIN"] = str(old)  # the sample's preparation loads one
    with tempfile.TemporaryDirectory() as tmp:
        from lammps_poly_driver import prepare

        data = Path(tmp) / "poly-10.data"
        prepare(data, 10)
        failed = False
        for ranks in args.ranks:
            for name in args.only:
                results = [run_build(build, name, ranks, data) for build in (old, new)]
                found = differences(*results)
                rows = len(results[0].get("thermo", []))
                print(f"{name}, {ranks} rank(s), {rows} output rows: "
                      f"{'the same to the bit' if not found else f'{len(found)} differences'}")
                for line in found[:10]:
                    print("   ", line)
                failed |= bool(found)
    return 1 if failed else 0


if __name__ == "__main__":
    raise SystemExit(main())
