"""``geocontact presets``: list the shipped material presets."""

from __future__ import annotations

from ..grain.material import list_presets, preset, preset_description
from .common import print_json


def register(sub) -> None:
    p = sub.add_parser("presets", help="list the material presets shipped with geocontact")
    p.add_argument("--json", action="store_true", help="print one JSON document")
    p.set_defaults(run=run)


def run(args) -> int:
    names = list_presets()
    if args.json:
        print_json({n: {"description": preset_description(n), **preset(n).to_dict()}
                    for n in names})
    else:
        for n in names:
            print(f"{n:22s} {preset_description(n)}")
    return 0
