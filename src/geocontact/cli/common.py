"""Helpers shared by the sub-commands."""

from __future__ import annotations

import json
import sys
from typing import Any

from ..io import json_safe


def print_json(document: dict[str, Any]) -> None:
    json.dump(json_safe(document), sys.stdout, indent=2)
    sys.stdout.write("\n")
