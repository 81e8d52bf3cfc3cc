"""Illustrative law parameters: the published forms with plausible, documented values and the
analytic incipient yield of a material. Clearly labelled as an illustration (not a fit); they
let users and tests run the law before an FE calibration exists.

``make examples`` regenerates the shipped files (``python scripts/make_illustrative_params.py``).
"""

from __future__ import annotations

import json
from pathlib import Path

from geocontact.errors import ArgumentParser, run_reporting_errors
from geocontact.files import check_output_file
from geocontact.grain.hertz import incipient_yield
from geocontact.grain.material import Material, load_material
from geocontact.law.params import LawParams


def illustrative_params(material: Material) -> LawParams:
    blocks = json.loads(Path(__file__).with_name("illustrative-law.json").read_text())
    y = incipient_yield(material)
    document = {
        "schema": "geocontact.law/1",
        **blocks,
        "material": material.to_dict(),
        "yield": y.to_dict(),
        "provenance": {"source": "illustration (scripts/illustrative-law.json)",
                       "yield": "analytic Hertz + Drucker-Prager search (geocontact.grain.hertz)"},
    }
    return LawParams.from_dict(document)


def main(argv: list[str] | None = None) -> int:
    parser = ArgumentParser(prog="python scripts/make_illustrative_params.py", description=__doc__)
    parser.add_argument("--material", default="reference", help="material TOML or preset name")
    parser.add_argument("--out", required=True)

    def run() -> int:
        args = parser.parse_args(argv)
        check_output_file(args.out, "--out")
        illustrative_params(load_material(args.material)).save(args.out)
        print(f"wrote {args.out}")
        return 0

    return run_reporting_errors(run)


if __name__ == "__main__":
    raise SystemExit(main())
