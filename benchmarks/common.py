"""Shared pieces of the benchmarks: result files (docs/interfaces.md) and the docs table."""

from __future__ import annotations

import json
import os
import platform
from pathlib import Path

from geocontact import __version__
from geocontact.files import write_json_atomic, write_text_atomic

ROOT = Path(__file__).resolve().parents[1]
# the plugin of this checkout, also for the MPI drivers that run in temporary folders
os.environ.setdefault("GEOCONTACT_LAMMPS_PLUGIN",
                      str(ROOT / "build" / "lammps-plugin" / "geocontactplugin.so"))
OUT = ROOT / "out" / "bench"
DOC = ROOT / "docs" / "benchmarks.md"
RECORDED: list[str] = []  # the benchmarks this process measured (record), in order


def record(name: str, value: float, unit: str, peer: str, peer_value: float, **extra) -> dict:
    """Write out/bench/NAME.json; ratio = this project's cost / the peer's cost."""
    document = {
        "name": name,
        "value": value,
        "unit": unit,
        "peer": peer,
        "peer_value": peer_value,
        "ratio": extra.pop("ratio"),
        "version": __version__,
        "machine": {"cpu": platform.processor() or platform.machine(),
                    "python": platform.python_version()},
        **extra,
    }
    write_json_atomic(OUT / f"{name}.json", document)
    RECORDED.append(name)
    print(f"{name}: {value:.4g} {unit}; {peer}: {peer_value:.4g} {unit}; "
          f"cost ratio {document['ratio']:.3f}")
    return document


def write_table() -> None:
    """Update the results table (the end of docs/benchmarks.md) with the benchmarks this
    process measured (their out/bench/*.json); rows of benchmarks not run this time stay as
    they were (an out/bench/*.json of an earlier run, perhaps of other sources, is not used)."""
    text = DOC.read_text() if DOC.exists() else "# Benchmarks\n\n<!-- results -->\n"
    head, _, tail = text.partition("<!-- results -->")
    rows = {}
    for line in tail.splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if line.startswith("|") and cells[0] not in ("benchmark", "---"):
            rows[cells[0]] = line
    for name in RECORDED:
        d = json.loads((OUT / f"{name}.json").read_text())
        rows[d["name"]] = (f"| {d['name']} | {d['value']:.4g} {d['unit']} | {d['peer']} | "
                           f"{d['peer_value']:.4g} {d['unit']} | {d['ratio']:.3f} | "
                           f"{d.get('note', '')} |")
    table = ("<!-- results -->\n"
             "| benchmark | geocontact | peer | peer value | cost ratio | note |\n"
             "| --- | --- | --- | --- | --- | --- |\n" + "\n".join(rows[k] for k in sorted(rows))
             + "\n")
    write_text_atomic(DOC, head + table)  # the table ends the page


def run_mpi_driver(driver: Path, ranks: int, args: list[str]) -> dict | str:
    """Run a LAMMPS driver script under ``mpiexec -n ranks`` (one OpenMP thread) in a temporary
    folder; its JSON result, or the last LAMMPS ERROR line (or exit status) as text."""
    import subprocess
    import sys
    import tempfile

    mpiexec = Path(sys.executable).with_name("mpiexec")
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "result.json"
        env = {**os.environ, "PYTHONPATH": str(ROOT / "src"), "OMP_NUM_THREADS": "1"}
        run = subprocess.run([str(mpiexec), "-n", str(ranks), sys.executable, str(driver),
                              *args, "--out", str(out)], env=env, cwd=tmp,
                             capture_output=True, text=True, timeout=3600)
        if run.returncode != 0 or not out.exists():
            errors = [line for line in run.stderr.splitlines() if "ERROR" in line]
            return errors[-1].strip() if errors else f"exit status {run.returncode}"
        return json.loads(out.read_text())
