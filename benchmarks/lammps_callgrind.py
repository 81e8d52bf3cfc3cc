"""Instruction counts of the plugin's contact work against LAMMPS's own (callgrind): a count
does not depend on the machine's load, where a time does (docs/benchmarks.md, "The plugin's
speed work").

    python benchmarks/lammps_callgrind.py CASE [--plugin SO] [--data DATA] [--keep DIR]

CASE: `poly`, `poly_rolling` (pair_style geocontact on the 1000-grain polydisperse sample of
lammps_poly_driver.py, 50 + 100 steps, without and with rolling resistance), `wall` (two
fix wall/geocontact walls on the 40 x 40 layer of lammps_wall_driver.py, 50 + 100 steps), and
the peers `peer_poly`, `peer_poly_rolling` (pair granular hertz/material, Mindlin, Tsuji),
`peer_wall` (fix wall/gran). Counted: the instructions inside the pair's `compute` or the wall's
`post_force` and everything they call (`--toggle-collect`), printed as JSON with the per-function
breakdown left in DIR (callgrind_annotate DIR/callgrind.out). Needs valgrind (`make valgrind`).
"""

from __future__ import annotations

import argparse
import json
import os
import re
import subprocess
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parent
# case: (driver, its arguments, the function whose instructions are counted)
CASES = {
    "poly": ("lammps_poly_driver.py", ["--pair", "geocontact"], "*PairGeocontact::compute*"),
    "poly_rolling": ("lammps_poly_driver.py", ["--pair", "geocontact_rolling"],
                     "*PairGeocontact::compute*"),
    "peer_poly": ("lammps_poly_driver.py", ["--pair", "granular_hertz_material"],
                  "*PairGranular::compute*"),
    "peer_poly_rolling": ("lammps_poly_driver.py", ["--pair", "granular_hertz_material_rolling"],
                          "*PairGranular::compute*"),
    "wall": ("lammps_wall_driver.py", ["--wall", "geocontact", "--side", "40"],
             "*FixWallGeocontact::post_force*"),
    "peer_wall": ("lammps_wall_driver.py", ["--wall", "wall_gran_hertz_material", "--side", "40"],
                  "*FixWallGran::post_force*"),
}
STEPS = 100  # the drivers run STEPS / 2 steps, then STEPS


def sample(data: Path) -> Path:
    """The 1000-grain polydisperse sample (10^3 cells), written once."""
    if not data.exists():
        subprocess.run([sys.executable, str(HERE / "lammps_poly_driver.py"), "--prepare",
                        str(data), "--cells", "10"], check=True)
    return data


def count(case: str, plugin: str | None, data: Path, out_dir: Path) -> dict:
    driver, arguments, function = CASES[case]
    if driver == "lammps_poly_driver.py":
        arguments = [*arguments, "--data", str(sample(data))]
    env = dict(os.environ)
    if plugin:
        env["GEOCONTACT_LAMMPS_PLUGIN"] = str(Path(plugin).resolve())
    trace = out_dir / "callgrind.out"
    subprocess.run(["valgrind", "--tool=callgrind", f"--callgrind-out-file={trace}",
                    f"--toggle-collect={function}", sys.executable, str(HERE / driver),
                    *arguments, "--steps", str(STEPS), "--out", str(out_dir / "run.json")],
                   env=env, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    totals = re.search(r"^totals:\s+(\d+)", trace.read_text(errors="replace"), re.MULTILINE)
    return {"case": case, "plugin": plugin, "instructions": int(totals.group(1)),
            "run": json.loads((out_dir / "run.json").read_text())}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("case", choices=sorted(CASES))
    parser.add_argument("--plugin", help="the plugin .so (default: the build's)")
    parser.add_argument("--data", default=str(Path(tempfile.gettempdir()) / "poly-1000.data"),
                        help="the 1000-grain sample (written if missing)")
    parser.add_argument("--keep", help="directory for callgrind.out and run.json")
    args = parser.parse_args()
    out_dir = Path(args.keep) if args.keep else Path(tempfile.mkdtemp())
    out_dir.mkdir(parents=True, exist_ok=True)
    print(json.dumps(count(args.case, args.plugin, Path(args.data), out_dir)))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
