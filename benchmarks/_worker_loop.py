"""The JSON-lines loop shared by the peer workers (``worker_placo.py``, ``worker_roboplan.py``).

Each worker runs in its peer's own venv; the parent (``_peers.PeerWorker``) writes one JSON request a
line to its stdin and reads one JSON answer a line from its stdout. ``{"cmd": "quit"}`` ends the
loop; any exception becomes ``{"error": "..."}`` so that one bad request never ends the worker.
"""

from __future__ import annotations

import json
import sys
from collections.abc import Callable


def serve(handle: Callable[[str, dict], dict]) -> None:
    """Answer every request line with ``handle(cmd, request)`` until ``quit`` or end of input."""
    for line in sys.stdin:
        try:
            req = json.loads(line)
            cmd = req.get("cmd")
            if cmd == "quit":
                break
            ans = handle(cmd, req)
        except Exception as exc:  # noqa: BLE001 - report every failure to the parent, keep serving
            ans = {"error": f"{type(exc).__name__}: {exc}"}
        sys.stdout.write(json.dumps(ans) + "\n")
        sys.stdout.flush()
