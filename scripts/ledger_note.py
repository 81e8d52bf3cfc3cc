"""The energy ledger of the small oedometer and seismic samples of the tests (300 grains), for a
law file and its like-for-like elastic baseline, printed per channel (the closing note of issue
34; docs/dem.md "Energy ledger"):

    .venv/bin/python scripts/ledger_note.py LAW.json [BASELINE.json] --out DIR [--ranks N]

BASELINE: a law file whose grains do not yield at the samples' forces (e.g. `geocontact params`
of the reference grain with sigma_c = 100 MPa), run through the same pair style and walls, so
the two differ only in the normal law.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))

from geocontact.analyses.dem import Settings, run_dem  # noqa: E402
from geocontact.analyses.dem_seismic import run_seismic  # noqa: E402

CHANNELS = (("boundary work", ("boundary_work_J",)), ("Δ kinetic", ("change_kinetic_J",)),
            *((f"Δ stored {k}", ("change_stored_J", k))
              for k in ("normal", "tangential", "rolling", "twisting")),
            *((f"dissipated {k}", ("dissipated_J", k))
              for k in ("law", "sliding", "normal_damping", "tangential_damping", "rolling",
                        "twisting")),
            ("of which contact-radius change", ("of_which_contact_radius_change_J",)),
            ("sliding + tangential damping", ("tangential_total_J",)),
            ("closure residual", ("closure_residual_J",)))


def value(energy: dict, path: tuple[str, ...]) -> float:
    for key in path:
        energy = energy[key]
    return energy


def main(argv=None) -> int:
    parser = argparse.ArgumentParser()
    parser.add_argument("laws", nargs="+")
    parser.add_argument("--out", required=True)
    parser.add_argument("--ranks", type=int, default=1)
    args = parser.parse_args(argv)
    from test_dem import SMALL
    from test_dem_seismic import RECORD, small

    ledgers = {}
    for law in args.laws:
        name = Path(law).stem
        oed = run_dem("oedometer", law, Settings(**SMALL, walls="geocontact"),
                      contacts=("geocontact",), ranks=args.ranks,
                      out=Path(args.out) / f"oedometer-{name}")
        seis = run_seismic(RECORD, law, small(), contacts=("geocontact",), ranks=args.ranks,
                           out=Path(args.out) / f"seismic-{name}")
        ledgers[f"oedometer cycle, {name}"] = oed["runs"]["geocontact"]["energy"]
        ledgers[f"seismic shaking, {name}"] = seis["runs"]["geocontact"]["energy"]
    print("| channel (J) | " + " | ".join(ledgers) + " |")
    print("| --- |" + " --- |" * len(ledgers))
    for label, path in CHANNELS:
        cells = []
        for energy in ledgers.values():
            v = value(energy, path)
            share = v / energy["boundary_work_J"]
            cells.append(f"{v:.3e} ({100 * share:.1f} %)")
        print(f"| {label} | " + " | ".join(cells) + " |")
    Path(args.out, "ledgers.json").write_text(json.dumps(ledgers, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
