"""FE check of the plugin's 2 a_max rule (``memory place``): how far does the dent a plastic
contact leaves reach, in units of its contact radius a_max?

Each run loads one grain to F and unloads it to 0 on the axisymmetric FE (coarse mesh) and reads
its residual surface (geocontact.analyses.dent): the dent depth D(r) behind the sphere moved with
the grain's centre, where the hollow ends (D = 0), the rim round it (the most negative D, a
surface standing proud of the sphere), the radii past which |D| stays below 5 % and 1 % of the
centre depth D0, and what a new contact disc of radius a_max centred at an offset s would meet:
its punch-weighted mean of D (the change of approach the new contact feels, to first order) and
the deepest |D| it covers. The rule forgets the dent once the contact point has travelled
DENT_TRAVEL_FACTOR x a_max; a new disc there starts at (DENT_TRAVEL_FACTOR - 1) a_max.

The reference grain (sigma_c = 10 MPa) at F / Fy = 10, 100, 1e3, 1e4 in small strain, and the
weak grain (reference-weak, sigma_c = 1 MPa) at F / Fy = 1e4 and 1e5 in finite strain (and at 1e4
in small strain, to tell the kinematics from the grain):

    PYTHONPATH=src nice -n 10 .venv/bin/python scripts/verify_dent_extent.py \\
        [--only reference] [--json docs/verification/dent_extent.json]

No FE cache: each run is made again (1-5 minutes each on the coarse mesh, on a loaded machine).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "src"))

from geocontact import __version__  # noqa: E402
from geocontact.analyses import dent as dents  # noqa: E402
from geocontact.fem.run import run_history  # noqa: E402
from geocontact.fem.settings import FeSettings  # noqa: E402
from geocontact.files import write_json_atomic  # noqa: E402
from geocontact.grain.hertz import incipient_yield  # noqa: E402
from geocontact.grain.material import preset  # noqa: E402

# (material, F / Fy, kinematics)
CASES = (("reference", 10.0, "small"), ("reference", 100.0, "small"),
         ("reference", 1e3, "small"), ("reference", 1e4, "small"),
         ("reference-weak", 1e4, "small"), ("reference-weak", 1e4, "finite"),
         ("reference-weak", 1e5, "finite"))
OFFSETS = (0.0, 1.0, 1.5, 2.0, 2.5, 3.0, 4.0)  # s / a_max of the new contact disc
MESH = "coarse"


def dent_of(material_name: str, ratio: float, kinematics: str,
            steps_per_segment: int | None = None) -> tuple[dents.ResidualDent, dict]:
    """The residual dent of the grain ``material_name`` loaded to ``ratio`` x Fy and unloaded,
    and the run's numbers (force, a_max, approach at the peak, plastic zone)."""
    material = preset(material_name)
    force = ratio * float(incipient_yield(material).force)
    # the "yield" meshes and fixed steps (the defaults before issue 36): the documented runs
    settings = FeSettings(MESH, kinematics=kinematics, steps_per_segment=steps_per_segment,
                          mesh_rule="yield", step_control="fixed")
    result = run_history(material, [0.0, force, 0.0], settings=settings, keep_states=True,
                         write_fields=False)
    peak = int(np.argmax(result.curve["force_N"]))
    a_max = float(result.curve["contact_radius_m"][peak])
    unloaded = result.states[-1]
    dent = dents.residual_dent(result.solver, unloaded, a_max)
    run = {"material": material_name, "force_over_yield": ratio, "force_N": force,
           "kinematics": kinematics, "mesh": MESH,
           "elements": int(result.solver.mesh.t.shape[1]),
           "contact_radius_m": a_max, "contact_radius_over_R": a_max / material.radius,
           "peak_approach_ball_wall_m": float(result.curve["approach_m"][peak]) / 2.0,
           "plastic_zone_radius_over_a": dents.plastic_zone_radius(result.solver, unloaded)
           / a_max}
    return dent, run


def measures(dent: dents.ResidualDent) -> dict:
    """The dent's extent and what new contacts beside it meet, in a_max and in D0."""
    a, d0 = dent.contact_radius_m, dent.centre_depth_m
    rim_height, rim_radius = dents.rim(dent)
    hollow = dents.hollow_radius(dent)
    rule = dents.DENT_TRAVEL_FACTOR * a
    return {
        "centre_depth_m": d0,
        "hollow_radius_over_a": hollow / a,
        "rim_over_D0": rim_height / d0, "rim_radius_over_a": rim_radius / a,
        "extent_5pct_over_a": dents.extent(dent, 0.05) / a,
        "extent_1pct_over_a": dents.extent(dent, 0.01) / a,
        # the offset past which a new disc covers no hollow at all: a + the hollow's radius
        "hollow_free_offset_over_a": 1.0 + hollow / a,
        "clear_5pct_offset_over_a": dents.clear_offset(dent, 0.05) / a,
        "clear_1pct_offset_over_a": dents.clear_offset(dent, 0.01) / a,
        "at_rule": {"offset_over_a": dents.DENT_TRAVEL_FACTOR,
                    "felt_over_D0": dents.punch_mean(dent, rule) / d0,
                    "deepest_over_D0": dents.disc_peak(dent, rule) / d0},
        "offsets": {f"{s:g}": {"depth_over_D0": float(dent.depth_at(s * a)) / d0,
                               "felt_over_D0": dents.punch_mean(dent, s * a) / d0,
                               "deepest_over_D0": dents.disc_peak(dent, s * a) / d0}
                    for s in OFFSETS},
        "profile": {"radius_over_a": (dent.radius_m / a).tolist(),
                    "depth_over_D0": (dent.depth_m / d0).tolist()},
    }


COLUMNS = ("grain", "F/Fy", "a_max/R", "D0/w_max", "hollow ends (a)", "rim (D0) at (a)",
           "D within 5 % past (a)", "D within 1 % past (a)", "felt at 2 a_max (D0)",
           "deepest at 2 a_max (D0)", "felt < 5 % past (a)", "felt < 1 % past (a)",
           "plastic zone (a)")


def table(rows: list[dict]) -> str:
    """The results as a Markdown table (docs/dem.md, "FE check of the 2 a_max rule")."""
    lines = ["| " + " | ".join(COLUMNS) + " |", "|" + " --- |" * len(COLUMNS)]
    for r in rows:
        m = r["measures"]
        cells = (f"{r['material']} ({r['kinematics']})", f"{r['force_over_yield']:g}",
                 f"{r['contact_radius_over_R']:.4f}",
                 f"{m['centre_depth_m'] / r['peak_approach_ball_wall_m']:.2f}",
                 f"{m['hollow_radius_over_a']:.2f}",
                 f"{m['rim_over_D0']:+.3f} at {m['rim_radius_over_a']:.2f}",
                 f"{m['extent_5pct_over_a']:.2f}", f"{m['extent_1pct_over_a']:.2f}",
                 f"{m['at_rule']['felt_over_D0']:+.3f}", f"{m['at_rule']['deepest_over_D0']:.3f}",
                 f"{m['clear_5pct_offset_over_a']:.2f}", f"{m['clear_1pct_offset_over_a']:.2f}",
                 f"{r['plastic_zone_radius_over_a']:.2f}")
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--only", choices=sorted({c[0] for c in CASES}), default=None,
                        help="run only this grain's cases")
    parser.add_argument("--json", type=Path, default=None, help="also write the results here")
    args = parser.parse_args(argv)
    rows = []
    for name, ratio, kinematics in CASES:
        if args.only is not None and name != args.only:
            continue
        dent, run = dent_of(name, ratio, kinematics)
        rows.append({**run, "measures": measures(dent)})
        print(f"{name} F/Fy = {ratio:g}: done", file=sys.stderr, flush=True)
    print(table(rows))
    if args.json is not None:
        write_json_atomic(args.json, {
            "schema": "geocontact.verify-dent-extent/1", "version": __version__,
            "inputs": {"cases": [list(c) for c in CASES if args.only in (None, c[0])],
                       "mesh": MESH, "offsets_over_a": list(OFFSETS),
                       "dent_travel_factor": dents.DENT_TRAVEL_FACTOR},
            "results": rows})
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
