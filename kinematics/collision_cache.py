"""On-disk cache of computed disabled collision pairs, one JSON file per model text.

Directory: ``$KINSERVE_CACHE_DIR`` when set, else ``$XDG_CACHE_HOME/kinserve``,
else ``~/.cache/kinserve``. File name: ``collision-pairs-<key>.json`` where
``<key>`` is the SHA-256 (first 24 hex digits) of the URDF text the model was
built from, plus the algorithm's parameters (samples, seed, version) - any edit of
the model or of the method gives a new file. A cache that cannot be read or
written is ignored (the pairs are computed again); it never fails a query.
"""

from __future__ import annotations

import hashlib
import json
import os
import tempfile
from pathlib import Path

from .collision_pairs import LinkPair

#: Environment variable naming the cache directory.
CACHE_ENV = "KINSERVE_CACHE_DIR"


def cache_dir() -> Path:
    """The cache directory (not created here)."""
    env = os.environ.get(CACHE_ENV)
    if env:
        return Path(env).expanduser()
    xdg = os.environ.get("XDG_CACHE_HOME")
    return (Path(xdg).expanduser() if xdg else Path.home() / ".cache") / "kinserve"


def cache_key(model_text: str, samples: int, seed: int, version: int) -> str:
    """Hex key of a model text and the pair-computation parameters."""
    h = hashlib.sha256(model_text.encode("utf-8"))
    h.update(f"|samples={samples}|seed={seed}|version={version}".encode())
    return h.hexdigest()[:24]


def cache_path(key: str) -> Path:
    """The JSON file of the disabled pairs of ``key`` in :func:`cache_dir`."""
    return cache_dir() / f"collision-pairs-{key}.json"


def load_pairs(key: str) -> dict[LinkPair, str] | None:
    """The cached ``{(link1, link2): reason}`` for ``key``, or None when absent or unreadable."""
    try:
        data = json.loads(cache_path(key).read_text(encoding="utf-8"))
        return {(str(a), str(b)): str(reason) for a, b, reason in data["disabled"]}
    except (OSError, ValueError, KeyError, TypeError):
        return None


def store_pairs(key: str, pairs: dict[LinkPair, str]) -> Path | None:
    """Write the pairs atomically (temp file + rename); return the path, or None when it cannot be written."""
    path = cache_path(key)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        disabled = [[a, b, r] for (a, b), r in sorted(pairs.items())]
        body = json.dumps({"key": key, "disabled": disabled}, indent=0)
        fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=".collision-pairs-", suffix=".tmp")
        with os.fdopen(fd, "w", encoding="utf-8") as fh:
            fh.write(body)
        os.replace(tmp, path)
        return path
    except OSError:
        return None
