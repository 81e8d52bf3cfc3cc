"""Helpers shared by the sub-commands."""

from __future__ import annotations

import json
import sys
from typing import Any

from ..io import json_safe


def print_json(document: dict[str, Any]) -> None:
    json.dump(json_safe(document), sys.stdout, indent=2)
    sys.stdout.write("\n")


def add_force_flag(parser) -> None:
    """``--force``: replace an output folder that is not a result of this command."""
    parser.add_argument("--force", action="store_true",
                        help="replace the output folder even if it holds files geocontact did "
                             "not write or another command's result (without it: refused)")
