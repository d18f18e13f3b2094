"""Writing scenario artefacts: JSON with NumPy values converted to plain lists and numbers."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np


def plain(value):
    """``value`` as JSON-ready Python data (arrays -> lists, NumPy scalars -> numbers, NaN/inf -> None)."""
    if isinstance(value, dict):
        return {str(k): plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [plain(v) for v in value]
    if isinstance(value, np.ndarray):
        return plain(value.tolist())
    if isinstance(value, (np.bool_, bool)):
        return bool(value)
    if isinstance(value, (np.integer, int)):
        return int(value)
    if isinstance(value, (np.floating, float)):
        v = float(value)
        return v if math.isfinite(v) else None
    if isinstance(value, Path):
        return str(value)
    return value


def write_json(path, data) -> Path:
    """Write ``data`` (plain-ified) as indented JSON to ``path``."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(plain(data), indent=2))
    return path
