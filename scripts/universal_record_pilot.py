"""The pilot of the campaign of record (issue 37, docs/universal.md): its points through the
whole pipeline to a law file, and its cost and levels as tables.

    nice -n 10 .venv/bin/python -m geocontact.universal.campaign --design record --points 3 \\
        --mesh coarse --dataset datasets/universal/record-pilot \\
        --cache datasets/fe-runs/universal-record-pilot          # the FE work (resumable)
    PYTHONPATH=src .venv/bin/python scripts/universal_record_pilot.py [--laws] [--json]
    nice -n 10 .venv/bin/python scripts/universal_record_pilot.py --mesh-ratio 0

``--laws``: for every pilot point, its material as ``material-point-I.toml`` and the universal law
of record at it, ``law-point-I.json``, written by ``geocontact params --design record`` (the
interpolation is exact at a node, so the file is the law of that point's own FE data). Without
it: the tables only (per point: CPU and wall time, FE runs, solves, Newton iterations, elements;
per level: target and achieved a/R). ``--mesh-ratio I``: the cost of the default mesh against the
coarse one on point I's last probe and top level (what the cost of the campaign of record on the
default mesh is estimated from, docs/universal.md).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "src"))

PILOT = ROOT / "datasets" / "universal" / "record-pilot"


def material_toml(material: dict, index: int) -> str:
    return (f'description = "pilot point {index} of the universal campaign of record"\n\n'
            "[material]\n"
            f"youngs_modulus = {material['youngs_modulus']!r}\n"
            f"poissons_ratio = {material['poissons_ratio']!r}\n"
            f"compressive_yield_stress = {material['compressive_yield_stress']!r}\n"
            f"friction_angle_deg = {material['friction_angle_deg']!r}\n"
            f"hardening_ratio = {material['hardening_ratio']!r}\n\n"
            f"[geometry]\nradius = {material['radius']!r}\n")


def write_laws(provenance: dict) -> None:
    from geocontact.cli import main
    from geocontact.files import Output, claim, write_text_atomic

    for index, info in sorted(provenance["points"].items(), key=lambda kv: int(kv[0])):
        toml = PILOT / f"material-point-{index}.toml"
        with claim([Output(toml, "file", "material")], "universal record pilot",
                   overwrite=False):
            write_text_atomic(toml, material_toml(info["material"], int(index)))
        code = main(["params", "--design", "record", "--dataset", str(PILOT),
                     "--material", str(toml), "--out", str(PILOT / f"law-point-{index}.json")])
        if code:
            raise SystemExit(code)


def mesh_ratio(provenance: dict, index: int, cache: Path) -> dict:
    """The point's last probe and its top level rerun on the default mesh (same forces, mesh
    sized for the same top) in this process, one after the other, against the pilot's coarse
    runs: CPU time (this process, resource.getrusage), solves, Newton iterations, elements."""
    import resource

    from geocontact.fem.campaign import run_campaign
    from geocontact.fem.identity import load_result
    from geocontact.universal import record

    info = provenance["points"][str(index)]
    point = record.design_points(index + 1)[index]
    material = point.material()
    coarse = record.fe_settings(**record.PILOT_FE)
    default = record.fe_settings(**{**record.PILOT_FE, "mesh": "default"})
    top = max(info["levels"]["forces_N"])
    probe_forces = info["probes"][-1]["forces_N"]
    shape = [0.0, 1.0, 0.0, 1.0, 0.0]
    rows = []
    for name, forces, mesh_force in (("probe", probe_forces, None),
                                     ("top level", [s * top for s in shape], top)):
        row = {"run": name}
        for label, settings in (("coarse", coarse), ("default", default)):
            job = record.job(material, forces, settings, f"{name} {label}", mesh_force)
            usage = resource.getrusage(resource.RUSAGE_SELF)
            before = usage.ru_utime + usage.ru_stime
            if label == "coarse":  # the pilot's own run, from its committed cache
                result = load_result(ROOT / "datasets/fe-runs/universal-record-pilot" / job.key())
                cpu = None
            else:
                result = run_campaign([job], cache, workers=1, progress=False)[0]
                usage = resource.getrusage(resource.RUSAGE_SELF)
                cpu = usage.ru_utime + usage.ru_stime - before
            row[label] = {"cpu_s": cpu, "wall_s": result.summary["wall_time_s"],
                          "solves": (result.summary.get("step_control") or {}).get("solves"),
                          "newton": result.summary["newton_iterations"],
                          "elements": result.summary["mesh"]["elements"]}
        rows.append(row)
    return {"point": index, "runs": rows}


def tables(provenance: dict) -> dict:
    points = []
    for index, info in sorted(provenance["points"].items(), key=lambda kv: int(kv[0])):
        c = info["coordinates"]
        points.append({
            "point": int(index), "beta": c["friction_angle_deg"], "nu": c["poissons_ratio"],
            "m": c["hardening_ratio"], "E_over_sigma_c": 10 ** c["log10_modulus_over_strength"],
            "cpu_s": info["point_cpu_time_s"], "wall_s": info["point_wall_time_s"],
            "runs": len(info["cache_keys"]), "probes": len(info["probes"]),
            "solves": sum(s or 0 for s in info["solves"]),
            "newton": sum(n or 0 for n in info["newton_iterations"]),
            "repeated_solves": info["solves"][-1], "repeated_wall_s": info["run_wall_time_s"][-1],
            "elements": sorted(set(info["elements"])),
            "target_a_over_R": info["levels"]["target_contact_over_radius"],
            "achieved_a_over_R": info["levels"]["achieved_contact_over_radius"],
            "top": info["levels"]["top"]})
    return {"points": points}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--laws", action="store_true")
    parser.add_argument("--json", action="store_true")
    parser.add_argument("--mesh-ratio", type=int, metavar="POINT", default=None,
                        help="rerun the point's last probe and top level on the default mesh "
                             "(cache: --cache) and print their cost beside the coarse runs'")
    parser.add_argument("--cache", default="out/cache/universal-record-default",
                        help="FE cache of the --mesh-ratio runs (not committed)")
    args = parser.parse_args(argv)
    provenance = json.loads((PILOT / "provenance.json").read_text())
    if args.mesh_ratio is not None:
        print(json.dumps(mesh_ratio(provenance, args.mesh_ratio, Path(args.cache)), indent=2))
        return 0
    if args.laws:
        write_laws(provenance)
    out = tables(provenance)
    if args.json:
        print(json.dumps(out, indent=2))
        return 0
    print("| point | beta | nu | m | E/sigma_c | probes | FE runs | solves | Newton | CPU s | "
          "wall s | repeated: solves, wall s | elements |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for p in out["points"]:
        print(f"| {p['point']} | {p['beta']:.1f} | {p['nu']:.3f} | {p['m']:.3f} | "
              f"{p['E_over_sigma_c']:.4g} | {p['probes']} | {p['runs']} | {p['solves']} | "
              f"{p['newton']} | {p['cpu_s']:.0f} | {p['wall_s']:.0f} | {p['repeated_solves']}, "
              f"{p['repeated_wall_s']:.0f} | {', '.join(map(str, p['elements']))} |")
    print()
    for p in out["points"]:
        pairs = ", ".join(f"{t:.3g}/{a:.3g}" for t, a in zip(
            p["target_a_over_R"], p["achieved_a_over_R"], strict=True))
        print(f"point {p['point']}: a/R target/achieved {pairs}; top: {p['top']}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
