"""``make bench``: every benchmark, each against a peer measured in the same run.

Writes out/bench/*.json and the results table of docs/benchmarks.md.
Usage: python benchmarks/run.py [law] [lammps] [lammps_poly] [lammps_wall] [fem] [ccx]
       [fem_finite] [ccx_nlgeom] [fem_kernels] [fem_kernels_small] [--quick]
"""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from common import write_table  # noqa: E402

from geocontact.errors import ArgumentParser, run_reporting_errors  # noqa: E402
from geocontact.law import load_params  # noqa: E402

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "params-reference.json"
BENCHMARKS = ("law", "lammps", "lammps_poly", "lammps_wall", "fem", "ccx", "fem_finite",
              "ccx_nlgeom", "fem_kernels", "fem_kernels_small")


def parse(argv: list[str]):
    """The benchmarks to run (all when none is named) and ``--quick``; an unknown name is one
    line naming the allowed ones, and ``--help`` prints the usage instead of running anything."""
    parser = ArgumentParser(prog="benchmarks/run.py",
                            description="Every benchmark against a peer measured in the same "
                                        "run; writes out/bench/*.json and the results table.")
    parser.add_argument("names", nargs="*", metavar="NAME",
                        help="benchmarks to run, any of: " + ", ".join(BENCHMARKS)
                        + " (default: all)")
    parser.add_argument("--quick", action="store_true",
                        help="small samples and meshes, one repeat (a smoke run, not a measure)")
    args = parser.parse_args(argv)
    unknown = [n for n in args.names if n not in BENCHMARKS]
    if unknown:
        parser.error(f"unknown benchmark {', '.join(unknown)}; allowed: {', '.join(BENCHMARKS)}")
    return args.names or list(BENCHMARKS), args.quick


def main(argv: list[str]) -> int:
    names, quick = parse(argv)
    if "law" in names:
        import bench_law

        bench_law.main(load_params(EXAMPLE), n=100_000 if quick else 1_000_000)
    if "lammps" in names:
        import bench_lammps

        bench_lammps.main(cells=8 if quick else 17, steps=50 if quick else 200)
    if "lammps_poly" in names:
        import bench_lammps_poly

        bench_lammps_poly.main(cells=10 if quick else 20, steps=100 if quick else 200,
                               repeats=1 if quick else 3)
    if "lammps_wall" in names:
        import bench_lammps_wall

        bench_lammps_wall.main(side=60 if quick else 140, steps=100 if quick else 200,
                               repeats=1 if quick else 3)
    if "fem" in names:
        import bench_fem

        bench_fem.main(mesh="coarse" if quick else "default")
    if "ccx" in names:
        import bench_ccx

        bench_ccx.main(quick=quick)
    if "fem_finite" in names:
        import bench_fem

        bench_fem.main_finite(mesh="coarse" if quick else "default")
    if "ccx_nlgeom" in names:
        import bench_ccx

        bench_ccx.main_nlgeom(quick=quick)
    if "fem_kernels" in names:
        import bench_fem_kernels

        bench_fem_kernels.main(mesh="coarse" if quick else "default")
    if "fem_kernels_small" in names:
        import bench_fem_kernels_small

        bench_fem_kernels_small.main(mesh="coarse" if quick else "default")
    write_table()
    return 0


if __name__ == "__main__":
    sys.exit(run_reporting_errors(lambda: main(sys.argv[1:])))
