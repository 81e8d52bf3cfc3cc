"""One FE run on the numpy path and on the compiled kernels (``fem.compiled``), in the same
process, one after the other: CPU time, Newton iterations and the largest differences of the two
results (every curve column and every number of summary.json, relative to its magnitude;
scripts/reproduce_fe_runs.py ``agreement``).

    PYTHONPATH=src .venv/bin/python scripts/compare_fe_kernels.py --material reference \\
        --mesh coarse --forces 0 6000 0 --json out/compare-kernels.json

Other settings as ``fem.settings.FeSettings`` keywords (``--kinematics finite``)."""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "src"))
sys.path.insert(0, str(ROOT / "scripts"))

from reproduce_fe_runs import agreement  # noqa: E402

from geocontact import __version__  # noqa: E402
from geocontact.fem.identity import fe_code_hash  # noqa: E402
from geocontact.fem.run import run_history  # noqa: E402
from geocontact.grain.material import preset  # noqa: E402


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--material", default="reference", help="a material preset")
    parser.add_argument("--mesh", default="coarse")
    parser.add_argument("--forces", type=float, nargs="+", default=[0.0, 6000.0, 0.0])
    parser.add_argument("--kinematics", default="small", choices=["small", "finite"])
    parser.add_argument("--json", type=Path, default=None, help="write the comparison here")
    args = parser.parse_args(argv)
    material = preset(args.material)
    runs, cpu = {}, {}
    for kernels in ("numpy", "compiled"):
        start = time.process_time()
        runs[kernels] = run_history(material, args.forces, mesh=args.mesh,
                                    kinematics=args.kinematics, kernels=kernels,
                                    write_fields=False)
        cpu[kernels] = time.process_time() - start
        print(f"{kernels}: {cpu[kernels]:.1f} s CPU, "
              f"{int(sum(runs[kernels].curve['iterations']))} Newton iterations", file=sys.stderr)
    row = {"version": __version__, "fe_code": fe_code_hash(),
           "command": "scripts/compare_fe_kernels.py", "material": args.material,
           "mesh": args.mesh, "forces_N": args.forces, "kinematics": args.kinematics,
           "cpu_s": cpu, **agreement(runs["numpy"], runs["compiled"])}
    text = json.dumps(row, indent=1)
    print(text)
    if args.json is not None:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(text + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
