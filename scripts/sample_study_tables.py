"""The tables of docs/sample-study.md from a finished study (``make sample-study``).

    .venv/bin/python scripts/sample_study_tables.py datasets/sample-study [--json OUT]

For every study folder below the argument (each a ``geocontact dem cyclic-shear`` result:
``summary.json`` and ``curves.csv``; a study still under way: the runs finished so far, each
``runs/NAME/run.json``), per law and mean stress: the small-strain modulus over the
samples (mean, range), G/Gmax and the damping ratio D per amplitude (mean and range over the
samples) beside Darendeli (2001) for a clean sand at the same mean stress, the ledger's damping
split by channel (the normal law, Coulomb sliding, the dashpots; shares of the dissipated
energy), and the contacts beyond the law file's calibrated range. A sample's point that is not
a quasi-static loop (its energy balance does not close) is counted, not averaged. Markdown on
stdout; ``--json`` also writes the numbers. Reads only; every number comes from the study's own
files.
"""

from __future__ import annotations

import argparse
import csv
import json
import sys
from collections import defaultdict
from pathlib import Path

import numpy as np

from geocontact.analyses.dem_cyclic import balance_check
from geocontact.analyses.empirical_curves import darendeli


def read_curves(path: Path) -> list[dict]:
    with path.open(newline="") as handle:
        rows = list(csv.DictReader(handle))
    text = {"law", "material"}
    return [{k: (v if k in text else float(v) if v.strip() else float("nan"))
             for k, v in r.items()} for r in rows]


def spread(values) -> str:
    v = np.asarray(values, dtype=float)
    if len(v) == 1:
        return f"{v[0]:.3g}"
    return f"{np.mean(v):.3g} ({np.min(v):.3g}–{np.max(v):.3g})"


def percent(values) -> str:
    v = 100 * np.asarray(values, dtype=float)
    if len(v) == 1:
        return f"{v[0]:.2f}"
    return f"{np.mean(v):.2f} ({np.min(v):.2f}–{np.max(v):.2f})"


def finished_runs(folder: Path) -> tuple[dict, list[dict]]:
    """A study's summary and curves: from its summary.json and curves.csv when the study is
    complete, else from the runs finished so far (each run's own run.json: its summary and
    curves), marked partial."""
    if (folder / "summary.json").is_file() and (folder / "curves.csv").is_file():
        return (json.loads((folder / "summary.json").read_text()),
                read_curves(folder / "curves.csv"))
    documents = [json.loads(p.read_text()) for p in sorted(folder.glob("runs/*/run.json"))]
    # the calibrated depth of the law file the plastic runs read (kept beside each run)
    depth = None
    for law in sorted(folder.glob("runs/geocontact-*/law-no-cyclic-extension.json")):
        depth = (json.loads(law.read_text()).get("calibrated_range") or {}).get("max_depth")
    summary = {"material": folder.name, "law": f"partial: {len(documents)} runs finished",
               "runs": [d["summary"] for d in documents], "calibrated_max_depth": depth}
    return summary, [c for d in documents for c in d["curves"]]


def study_tables(folder: Path) -> tuple[str, dict]:
    summary, curves = finished_runs(folder)
    groups: dict[tuple[str, float], list[dict]] = defaultdict(list)
    for c in curves:
        groups[(c["law"], c["consolidation_stress_Pa"])].append(c)
    lines = [f"### {folder.name}: {summary['material']} (`{summary['law']}`)", ""]
    numbers: dict = {"material": summary["material"], "law_file": summary["law"], "cases": []}
    runs = summary["runs"]
    lines += ["| law | mean stress (kPa) | samples | packing fraction | contacts/grain | "
              "Gmax (MPa) | contacts beyond the file's range (largest δmax/δy; file: "
              f"{summary.get('calibrated_max_depth') or 0:.4g}) |",
              "| --- | --- | --- | --- | --- | --- | --- |"]
    for law, stress in groups:
        mine = [r for r in runs if r["law"] == law and r["consolidation_stress_Pa"] == stress]
        beyond = [r.get("beyond_range_contacts") for r in mine]
        depth = [r.get("beyond_range_max_depth") for r in mine]
        beyond_text = ("—" if all(b is None for b in beyond) else
                       ", ".join(f"{b} ({d:.3g})" if b else "0"
                                 for b, d in zip(beyond, depth, strict=True)))
        lines.append(f"| {law} | {stress / 1e3:.4g} | {len(mine)} | "
                     f"{spread([r['packing_fraction'] for r in mine])} | "
                     f"{spread([r['contacts_per_grain'] for r in mine])} | "
                     f"{spread([r['Gmax_Pa'] / 1e6 for r in mine])} | {beyond_text} |")
    lines.append("")
    for (law, stress), rows in groups.items():
        amps = sorted({r["amplitude"] for r in rows})
        dar = darendeli(np.array(amps), stress)
        lines += [f"**{law}, {stress / 1e3:.4g} kPa** (mean and range over the samples; "
                  "D in %; the ledger's shares of the dissipated energy in %)", "",
                  "| γa | quasi-static samples | G/Gmax | Darendeli G/Gmax | D (loop) | "
                  "D (ledger) | Darendeli D | law | sliding | dashpots | "
                  "mean stress change per cycle (kPa) |",
                  "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
        for j, a in enumerate(amps):
            every = [r for r in rows if r["amplitude"] == a]
            # a sample's point whose energy balance does not close is not a quasi-static loop
            # (geocontact.analyses.dem_cyclic.balance_check): counted, not averaged
            at = [r for r in every if balance_check(r)["quasi_static"] is not False]
            counted = f"{len(at)}/{len(every)}"
            if not at:
                lines.append(f"| {a:.3g} | {counted} | — | {dar['G_over_Gmax'][j]:.3g} | — | — | "
                             f"{100 * dar['damping_ratio'][j]:.2f} | — | — | — | — |")
                numbers["cases"].append({"law": law, "stress_Pa": stress, "amplitude": a,
                                         "quasi_static_samples": 0, "samples": len(every)})
                continue
            ledger = np.array([r["damping_ratio_ledger"] for r in at])
            share = {k: [r[f"damping_ratio_{k}"] / r["damping_ratio_ledger"] for r in at]
                     if np.all(np.isfinite(ledger)) and np.all(ledger > 0) else None
                     for k in ("normal_law", "sliding", "viscous")}
            case = {"law": law, "stress_Pa": stress, "amplitude": a,
                    "quasi_static_samples": len(at), "samples": len(every),
                    "G_over_Gmax": [r["G_over_Gmax"] for r in at],
                    "damping_ratio": [r["damping_ratio"] for r in at],
                    "damping_ratio_ledger": ledger.tolist(),
                    "darendeli_G_over_Gmax": float(dar["G_over_Gmax"][j]),
                    "darendeli_damping_ratio": float(dar["damping_ratio"][j]),
                    "shares": share}
            numbers["cases"].append(case)
            lines.append(
                f"| {a:.3g} | {counted} | {spread(case['G_over_Gmax'])} | "
                f"{dar['G_over_Gmax'][j]:.3g} | "
                f"{percent(case['damping_ratio'])} | "
                f"{percent(ledger) if np.all(np.isfinite(ledger)) else '—'} | "
                f"{100 * dar['damping_ratio'][j]:.2f} | "
                + " | ".join(percent(v) if v is not None else "—" for v in share.values())
                + f" | {spread([r['mean_stress_change_per_cycle_Pa'] / 1e3 for r in at])} |")
        lines.append("")
    return "\n".join(lines), numbers


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("root", type=Path)
    parser.add_argument("--json", type=Path)
    args = parser.parse_args(argv)
    folders = sorted({p.parent.parent.parent for p in args.root.rglob("runs/*/run.json")})
    if not folders:
        print(f"root: no finished cyclic-shear study below {args.root}", file=sys.stderr)
        return 2
    everything = []
    for folder in folders:
        text, numbers = study_tables(folder)
        print(text)
        everything.append(numbers)
    if args.json:
        from geocontact.files import Output, claim, write_json_atomic

        with claim([Output(args.json, "file", "--json")], "sample-study-tables"):
            write_json_atomic(args.json, {"studies": everything})
    return 0


if __name__ == "__main__":
    sys.exit(main())
