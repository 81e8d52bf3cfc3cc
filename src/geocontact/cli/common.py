"""Helpers shared by the sub-commands."""

from __future__ import annotations

import json
import math
import sys
from typing import Any


def _clean(value: Any) -> Any:
    """JSON-safe copy: NaN/inf become null, tuples become lists."""
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, dict):
        return {str(k): _clean(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_clean(v) for v in value]
    return value


def print_json(document: dict[str, Any]) -> None:
    json.dump(_clean(document), sys.stdout, indent=2)
    sys.stdout.write("\n")
