"""Newton backtracking (FE setting ``newton="backtracking"``) against full updates where full
updates stall: the hard, perfectly plastic corner of the campaign of record.

Point 3 of the design of record (E/sigma_c 1e5, beta 0, nu 0.4, m 0) is a nearly incompressible,
perfectly plastic grain. With full Newton updates its base run stalls: the largest residual
cycles near 2e-4 N against a tolerance of 8e-9 N with the contact set unchanged, a quarter of
its solves fail and the load steps shrink to x1.00125 (docs/benchmarks.md "The hard, perfectly
plastic corner"). This script continues the committed checkpoint of that base run twice, side
by side for the same wall time (``--seconds``), once with full updates and once with
backtracking: the same state, the same mesh and settings, the Newton updates the only
difference. The backtracking run starts from a copy of the checkpoint whose identity names
``newton="backtracking"`` (the same state; the script's own file in ``--out``). Each run logs
every solve (its CPU time, forces, whether it converged, its Newton iterations, the updates
halved so far) through a wrapper of the engine's ``solve_step``; it is stopped at the end of
the time, and the logs are compared:

- progress: ln(F reached / F at the checkpoint) per CPU second, F the last converged solve's;
- failed solves (Newton did not converge, the step cut back) out of all;
- Newton iterations per converged solve.

    .venv/bin/python scripts/verify_backtracking.py --seconds 900 \\
        --json docs/verification/backtracking-point3.json

Exit status 0 when backtracking makes at least ``--gain`` x the progress per CPU second of full
updates (default 1.3), 1 otherwise.

``--pairs``: no run; every finished run of the campaign's cache (``--cache``) that has a twin
there with the other Newton updates (identity inputs equal but ``newton``) is compared with it:
the largest difference of each curve.csv column relative to that column's largest magnitude,
the Newton iterations and CPU time of each. Exit status 0 when every pair agrees within
``--pair-tolerance`` (default 1e-8, the Newton tolerance), 1 otherwise.

    .venv/bin/python scripts/verify_backtracking.py --pairs \
        --json docs/verification/backtracking-pairs.json
"""

from __future__ import annotations

import json
import math
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "src"))

from geocontact import __version__  # noqa: E402
from geocontact.errors import ArgumentParser, InputError, run_reporting_errors  # noqa: E402
from geocontact.fem.identity import compiled_code_hash, fe_code_hash  # noqa: E402
from geocontact.files import write_json_atomic  # noqa: E402

CACHE = ROOT / "datasets" / "fe-runs" / "universal-record"
VARIANTS = ("full", "backtracking")
MARK = ".verify-backtracking"  # the file that says --out is this script's folder


def _checkpoint_of(point: int) -> Path:
    """The committed checkpoint of ``point``'s base run with full updates (the campaign's
    cache), found by its material."""
    import numpy as np

    from geocontact.universal import record

    material = record.design_points(64)[point].material().to_dict()
    for path in sorted(CACHE.glob("*.checkpoint.npz")):
        with np.load(path, allow_pickle=False) as data:
            inputs = json.loads(str(data["identity"]))["inputs"]
        if (inputs["material"] == material and "follows" not in inputs
                and inputs.get("newton", "full") == "full"):
            return path
    raise InputError(f"--point: no committed checkpoint of point {point}'s base run in "
                     f"{CACHE.relative_to(ROOT)} (points with one: see docs/universal.md)")


def _copy(checkpoint: Path, target: Path, newton: str) -> None:
    """``checkpoint`` copied to ``target`` with its identity's Newton updates set to
    ``newton``."""
    import numpy as np

    with np.load(checkpoint, allow_pickle=False) as data:
        saved = {k: data[k] for k in data.files}
    identity = json.loads(str(saved["identity"]))
    if newton != "full":
        from geocontact.fem.identity import identity_key

        identity["inputs"]["newton"] = newton
        identity["key"] = identity_key(identity)  # the record's key: the hash of the rest
    saved["identity"] = np.array(json.dumps(identity))
    target.parent.mkdir(parents=True, exist_ok=True)
    with open(target, "wb") as f:
        np.savez(f, **saved)


def _child(checkpoint: Path, log: Path) -> int:
    """Continue the run of ``checkpoint`` (its identity's settings), logging every solve."""
    import numpy as np

    from geocontact.fem import solver as engine
    from geocontact.fem.finite_strain import FiniteStrainSolver
    from geocontact.fem.run import run_history
    from geocontact.fem.settings import FeSettings
    from geocontact.grain.material import Material

    with np.load(checkpoint, allow_pickle=False) as data:
        inputs = json.loads(str(data["identity"]))["inputs"]
    kind = FiniteStrainSolver if inputs.get("kinematics") == "finite" else engine.ContactSolver
    plain = kind.solve_step
    out = open(log, "w", buffering=1)

    def logged(self, old, force, **kwargs):
        entry = {"from_N": old.force, "to_N": force, "cpu_before_s": time.process_time()}

        def write(ok: bool, iterations: int) -> None:  # a solve cut short by the stop is not
            entry.update(ok=ok, iterations=iterations, cpu_s=time.process_time(),
                         halvings=self.backtracked_updates)
            out.write(json.dumps(entry) + "\n")

        try:
            state = plain(self, old, force, **kwargs)
        except engine.ConvergenceError:
            write(False, self.max_iterations)
            raise
        write(True, int(state.iterations))
        return state

    kind.solve_step = logged
    run_history(Material(**inputs["material"]), inputs["forces_N"],
                settings=FeSettings.of_record(inputs), resume=True, checkpoint=checkpoint,
                out=checkpoint.parent / "run", progress=False, write_fields=False)
    return 0


def _summary(log: Path, start_force: float) -> dict:
    solves = [json.loads(line) for line in log.read_text().splitlines() if line.strip()]
    solves = [s for s in solves if "ok" in s]  # (a log of before the stop's cut was mended)
    converged = [s for s in solves if s["ok"]]
    if not solves:
        raise InputError(f"--seconds: no solve finished in the time ({log}); give more")
    reached = max((s["to_N"] for s in converged), default=start_force)
    cpu = solves[-1]["cpu_s"] - solves[0]["cpu_before_s"]
    return {
        "solves": len(solves), "failed_solves": len(solves) - len(converged),
        "failed_fraction": (len(solves) - len(converged)) / len(solves),
        "newton_iterations": sum(s["iterations"] for s in solves),
        "iterations_per_converged_solve": (sum(s["iterations"] for s in converged)
                                           / max(len(converged), 1)),
        "halved_updates": solves[-1]["halvings"],
        "force_start_N": start_force, "force_reached_N": reached,
        "cpu_s": cpu,
        "ln_force_per_cpu_s": math.log(reached / start_force) / cpu if cpu > 0 else None,
    }


def _pairs(cache: Path, tolerance: float, json_path: Path | None, argv) -> int:
    """``--pairs`` (the module docstring)."""
    import numpy as np

    from geocontact.fem.identity import load_result

    twins: dict[str, dict[str, Path]] = {}
    for summary in sorted(cache.glob("*/summary.json")):
        inputs = dict(json.loads(summary.read_text())["identity"]["inputs"])
        newton = inputs.pop("newton", "full")
        twins.setdefault(json.dumps(inputs, sort_keys=True), {})[newton] = summary.parent
    pairs = []
    for key, runs in twins.items():
        if set(runs) != set(VARIANTS):
            continue
        full, searched = (load_result(runs[n]) for n in VARIANTS)
        inputs = json.loads(key)
        worst, column = 0.0, None
        for name, values in full.curve.items():
            if name in ("iterations", "plastic_points", "step"):
                continue
            scale = float(np.max(np.abs(values)))
            if scale > 0.0:
                gap = float(np.max(np.abs(searched.curve[name] - values))) / scale
                if gap > worst:
                    worst, column = gap, name
        pairs.append({
            "keys": {n: runs[n].name for n in VARIANTS},
            "material": inputs["material"], "forces": len(inputs["forces_N"]),
            "follows": "follows" in inputs, "largest_relative_difference": worst,
            "column": column,
            "newton_iterations": {n: r.summary["newton_iterations"]
                                  for n, r in zip(VARIANTS, (full, searched), strict=True)},
            "cpu_time_s": {n: r.summary.get("cpu_time_s")
                           for n, r in zip(VARIANTS, (full, searched), strict=True)}})
    if not pairs:
        raise InputError(f"--pairs: no run in {cache} has a twin with the other Newton updates")
    identical = sum(p["largest_relative_difference"] == 0.0 for p in pairs)
    largest = max(pairs, key=lambda p: p["largest_relative_difference"])
    ok = largest["largest_relative_difference"] <= tolerance
    print(f"{len(pairs)} pairs: {identical} identical, the largest difference "
          f"{largest['largest_relative_difference']:.3g} ({largest['column']}; tolerance "
          f"{tolerance:g}): {'PASS' if ok else 'FAIL'}")
    if json_path is not None:
        write_json_atomic(json_path, {
            "version": __version__, "fe_code": fe_code_hash(), "command": _command(argv),
            "cache": _shown(cache), "tolerance": tolerance, "pairs": pairs,
            "identical": identical, "pass": ok})
    return 0 if ok else 1


def main(argv: list[str] | None = None) -> int:
    p = ArgumentParser(prog="verify_backtracking.py", description=__doc__.split("\n\n")[0])
    p.add_argument("--point", type=int, default=3,
                   help="the design point whose committed base checkpoint is continued")
    p.add_argument("--seconds", type=float, default=900.0,
                   help="wall time each run is given (the two run side by side)")
    p.add_argument("--gain", type=float, default=1.3,
                   help="the progress ratio backtracking / full that passes")
    p.add_argument("--out", type=Path, default=Path("out/verify-backtracking"))
    p.add_argument("--json", type=Path, help="write the comparison here")
    p.add_argument("--pairs", action="store_true",
                   help="compare the cache's twin runs with full and backtracked updates")
    p.add_argument("--cache", type=Path, default=CACHE, help="the cache --pairs reads")
    p.add_argument("--pair-tolerance", type=float, default=1e-8)
    p.add_argument("--logs-only", action="store_true",
                   help="compare the solve logs an earlier call left in --out (no runs)")
    p.add_argument("--child", type=Path, help=argparse_hidden())
    p.add_argument("--log", type=Path, help=argparse_hidden())

    def run() -> int:
        args = p.parse_args(argv)
        if args.child is not None:
            return _child(args.child, args.log)
        if args.pairs:
            if not 0.0 < args.pair_tolerance < 1.0:
                raise InputError(f"--pair-tolerance: must be in (0, 1), got "
                                 f"{args.pair_tolerance:g}")
            return _pairs(args.cache, args.pair_tolerance, args.json, argv)
        if not 0 <= args.point < 64:
            raise InputError(f"--point: must be a design point 0-63, got {args.point}")
        if not 30.0 <= args.seconds <= 86400.0:
            raise InputError(f"--seconds: must be in [30, 86400], got {args.seconds:g}")
        if not 0.0 < args.gain <= 100.0:
            raise InputError(f"--gain: must be in (0, 100], got {args.gain:g}")
        source = _checkpoint_of(args.point)
        mark = args.out / MARK
        if args.logs_only:
            if not mark.exists():
                raise InputError(f"--logs-only: {args.out} holds no logs of this script")
            return _compare(args, argv, source)
        if args.out.exists():
            if not mark.exists():
                raise InputError(f"--out: {args.out} exists and was not made by this script "
                                 "(give a new folder)")
            shutil.rmtree(args.out)  # the script's own, from an earlier call (its mark)
        args.out.mkdir(parents=True)
        mark.write_text("made by scripts/verify_backtracking.py; it replaces this folder\n")
        (args.out / "call.json").write_text(json.dumps({
            "seconds_each": args.seconds, "command": _command(argv)}))
        children = {}
        env = {**os.environ, "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1"}
        for name in VARIANTS:
            target = args.out / name / "run.checkpoint.npz"
            _copy(source, target, name)
            children[name] = subprocess.Popen(
                [sys.executable, __file__, "--child", str(target), "--log",
                 str(args.out / name / "solves.jsonl")], env=env)
        try:
            deadline = time.monotonic() + args.seconds
            while time.monotonic() < deadline and any(c.poll() is None for c in
                                                      children.values()):
                time.sleep(2.0)
        finally:
            for child in children.values():
                if child.poll() is None:
                    child.terminate()
            for child in children.values():
                child.wait()
        return _compare(args, argv, source)

    return run_reporting_errors(run)


def _compare(args, argv, source: Path) -> int:
    """Compare the solve logs in ``args.out`` (see the module docstring); 0 on a pass."""
    import numpy as np

    with np.load(source, allow_pickle=False) as data:
        start = float(np.asarray(data["rows"])[-1][1])
        inputs = json.loads(str(data["identity"]))["inputs"]
    call = json.loads((args.out / "call.json").read_text())
    runs = {name: _summary(args.out / name / "solves.jsonl", start) for name in VARIANTS}
    full, searched = (runs[n]["ln_force_per_cpu_s"] for n in VARIANTS)
    gain = searched / full if full and searched is not None else math.inf
    ok = gain >= args.gain
    for name, r in runs.items():
        print(f"{name:13s} F {r['force_start_N']:.6g} -> {r['force_reached_N']:.6g} N in "
              f"{r['cpu_s']:.0f} s CPU: {r['solves']} solves, {r['failed_solves']} failed "
              f"({100 * r['failed_fraction']:.0f} %), "
              f"{r['iterations_per_converged_solve']:.1f} iterations per converged solve, "
              f"{r['halved_updates']} updates halved")
    print(f"progress per CPU second, backtracking / full: {gain:.2f} "
          f"({'>=' if ok else '<'} {args.gain:g}): {'PASS' if ok else 'FAIL'}")
    if args.json is not None:
        write_json_atomic(args.json, {
            "version": __version__, "fe_code": fe_code_hash(),
            "compiled_code": compiled_code_hash(),
            "command": _command(argv), "runs_made_by": call["command"],
            "point": args.point, "checkpoint": _shown(source),
            "material": inputs["material"],
            "settings": {k: v for k, v in inputs.items()
                         if k not in ("material", "forces_N", "newton")},
            "seconds_each": call["seconds_each"], "runs": runs, "gain": gain,
            "gain_required": args.gain, "pass": ok})
    return 0 if ok else 1


def _shown(path: Path) -> str:
    """``path`` relative to the repository where it is inside it."""
    try:
        return str(path.resolve().relative_to(ROOT))
    except ValueError:
        return str(path)


def _command(argv) -> str:
    return "python scripts/verify_backtracking.py " + " ".join(
        sys.argv[1:] if argv is None else argv)


def argparse_hidden():
    import argparse

    return argparse.SUPPRESS


if __name__ == "__main__":
    sys.exit(main())
