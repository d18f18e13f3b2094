"""The motion-planning peers of bench_motion.py, each in its own venv, driven over JSON lines.

* roboplan 0.7.0 (``bench-out/venvs/roboplan``, ``_motion_peers_roboplan.py``): its RRT-Connect
  (``max_connection_distance=1.0``) and ``PathShortcutter`` on its own Pinocchio + coal scene of the
  dataset's meshes;
* OMPL 2.0.1 (``bench-out/venvs/ompl``, which holds kinserve too; ``_motion_peers_ompl.py``):
  ``RRTConnect`` + ``PathSimplifier`` with kinserve's collision check as the state validity checker.

The protocol and the failure handling are those of :mod:`_peers` (a peer that cannot start is skipped
with a message; one that dies mid-run has its remaining problems counted as failures). Worker stderr
goes to a file under ``bench-out/`` so that a chatty extension (nanobind's exit report) cannot fill a
pipe nobody reads.
"""

from __future__ import annotations

import json
import os
import subprocess
from pathlib import Path

from _peers import HERE, ROOT, PeerError, PeerWorker, peer_python

#: peer name -> its worker script (beside this file).
SCRIPTS = {"roboplan": "_motion_peers_roboplan.py", "ompl": "_motion_peers_ompl.py"}


class MotionPeer(PeerWorker):
    """A motion-planning peer worker (:class:`_peers.PeerWorker` with its own script and a stderr log)."""

    def __init__(self, peer: str, timeout: float = 120.0, script: str | None = None,
                 log_prefix: str = "motion") -> None:
        """``script``: the worker (default :data:`SCRIPTS`'s for ``peer``); its stderr goes to
        ``bench-out/<log_prefix>_<peer>.stderr.log``."""
        py = peer_python(peer)
        if py is None:
            raise PeerError(f"no venv for {peer} (run `make peers` to create bench-out/venvs/{peer})")
        env = dict(os.environ, OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1", MKL_NUM_THREADS="1")
        env.pop("PYTHONPATH", None)
        log = ROOT / "bench-out" / f"{log_prefix}_{peer}.stderr.log"
        log.parent.mkdir(parents=True, exist_ok=True)
        self.peer, self.timeout, self.log = peer, timeout, log
        with open(log, "w") as err:
            self.proc = subprocess.Popen([str(py), str(HERE / (script or SCRIPTS[peer]))],
                                         stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=err, text=True,
                                         env=env, bufsize=1)
        self.version = self.call({"cmd": "version"}).get("version", "?")

    def call(self, request: dict) -> dict:
        """One request, one answer; :class:`PeerError` (with the tail of the worker's log) on failure."""
        if self.proc.poll() is not None:
            raise PeerError(f"{self.peer} worker exited: {self._log_tail()}")
        self.proc.stdin.write(json.dumps(request) + "\n")
        self.proc.stdin.flush()
        line = self.proc.stdout.readline()
        if not line:
            raise PeerError(f"{self.peer} worker died: {self._log_tail()}")
        answer = json.loads(line)
        if "error" in answer:
            raise PeerError(f"{self.peer} worker: {answer['error']}")
        return answer

    def _log_tail(self) -> str:
        try:
            return Path(self.log).read_text()[-2000:]
        except OSError:
            return "?"


def start_motion_peer(peer: str, setup: dict) -> MotionPeer | None:
    """Start ``peer`` and send it ``setup``; None (after printing why) when it cannot run."""
    try:
        worker = MotionPeer(peer)
    except (PeerError, OSError, json.JSONDecodeError) as exc:
        print(f"SKIP {peer}: {str(exc).strip().splitlines()[0] if str(exc).strip() else exc!r}", flush=True)
        return None
    try:
        worker.call({"cmd": "setup", **setup})
    except Exception as exc:  # noqa: BLE001 - any failure of a peer skips it, never the benchmark
        print(f"SKIP {peer}: setup failed: {exc}", flush=True)
        worker.close()
        return None
    print(f"{peer}: {worker.version}", flush=True)
    return worker
