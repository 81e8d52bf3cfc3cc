"""``geocontact yield``: Hertz incipient yield of two identical spheres (docs/model.md §4)."""

from __future__ import annotations

from ..grain.hertz import incipient_yield
from .common import load_material_arg as load_material
from .common import print_json


def register(sub) -> None:
    p = sub.add_parser(
        "yield",
        help="Hertz incipient yield of two identical spheres (Fy, delta_y, a_y, p0, location)",
    )
    p.add_argument(
        "--material", required=True, metavar="M.toml", help="material file or preset name"
    )
    p.add_argument("--json", action="store_true", help="print one JSON document")
    p.set_defaults(run=run)


def run(args) -> int:
    material = load_material(args.material)
    first_yield = incipient_yield(material)
    if args.json:
        print_json({"material": material.to_dict(), **first_yield.to_dict()})
        return 0
    location = "surface" if first_yield.at_surface else "below the surface"
    rows = [
        ("first-yield force Fy", f"{first_yield.force:.6g}", "N"),
        ("first-yield approach delta_y (ball-ball)", f"{first_yield.approach:.6g}", "m"),
        ("contact radius a_y", f"{first_yield.contact_radius:.6g}", "m"),
        ("peak pressure p0_y", f"{first_yield.peak_pressure:.6g}", "Pa"),
        ("p0_y / sigma_c", f"{1.0 / first_yield.dp_factor:.6g}", "-"),
        ("location r / a_y", f"{first_yield.r_over_a:.6g}", "-"),
        ("location z / a_y", f"{first_yield.z_over_a:.6g}", f"- ({location})"),
    ]
    print(f"Hertz incipient yield, material {args.material}")
    for name, value, unit in rows:
        print(f"  {name:42s} {value:>14s} {unit}")
    return 0
