"""roboplan collision-check worker of bench_clutter.py: runs in bench-out/venvs/roboplan, JSON lines.

Requests (the protocol of benchmarks/_peers.py):

* ``{"cmd": "version"}``
* ``{"cmd": "setup", "urdf": TEXT, "package_paths": [DIR], "srdf": TEXT, "joints": [NAMES]}`` - the
  roboplan ``Scene`` of ``_motion_peers_roboplan.RoboplanMotion`` (the URDF's collision meshes in
  roboplan's Pinocchio + coal, the SRDF's disabled pairs).
* ``{"cmd": "first", "obstacles": [shape dicts], "q": [...]}`` -> ``{"scene_s", "check_s", "collision"}``:
  the previous obstacles removed, these added (timed: ``scene_s``), then one ``hasCollisions(q)``
  (timed: ``check_s``) - what roboplan pays when it meets a new scene.
* ``{"cmd": "checks", "qs": [[...], ...]}`` -> ``{"times_s": [...], "collision": [...]}``: one
  ``hasCollisions`` per configuration on the current scene, each timed alone (``perf_counter``) around
  the call only (the arrays are made before).
* ``{"cmd": "pass", "scenes": [{"obstacles": [shape dicts], "qs": [[...], ...]}, ...]}`` ->
  ``{"first_s": [...]}``: the scenes one after the other with no request in between (roboplan's pass of its
  own): per scene, its configurations made into arrays (not timed), its obstacles set and the first
  ``hasCollisions`` (timed together, as ``first``'s ``scene_s + check_s``), then ``hasCollisions`` on
  each configuration (as ``checks``).
* ``{"cmd": "quit"}``
"""

from __future__ import annotations

import time

import numpy as np
from _motion_peers_roboplan import RoboplanHandler

from _worker_loop import serve


class _ClutterHandler(RoboplanHandler):
    """The motion worker's commands (``version``, ``setup``, ...) and the collision-check ones."""

    def __call__(self, cmd: str, req: dict) -> dict:
        if cmd == "first":
            q = np.ascontiguousarray(req["q"], dtype=float)
            t0 = time.perf_counter()
            self.rp.set_obstacles(req["obstacles"])
            t1 = time.perf_counter()
            hit = bool(self.rp.scene.hasCollisions(q))
            t2 = time.perf_counter()
            return {"scene_s": t1 - t0, "check_s": t2 - t1, "collision": hit}
        if cmd == "checks":
            return self.checks(req["qs"])
        if cmd == "pass":
            return {"first_s": [self.first_then_checks(s["obstacles"], s["qs"]) for s in req["scenes"]]}
        return super().__call__(cmd, req)

    def first_then_checks(self, obstacles: list, rows: list) -> float:
        """One scene of a ``pass``: the time (s) of its obstacles set plus its first ``hasCollisions``."""
        qs = [np.ascontiguousarray(q, dtype=float) for q in rows]
        clock = time.perf_counter
        t0 = clock()
        self.rp.set_obstacles(obstacles)
        self.rp.scene.hasCollisions(qs[0])
        first = clock() - t0
        self.checks(rows)
        return first

    def checks(self, rows: list) -> dict:
        qs = [np.ascontiguousarray(q, dtype=float) for q in rows]
        has_collisions = self.rp.scene.hasCollisions
        clock = time.perf_counter
        times, hits = [], []
        for q in qs:
            t0 = clock()
            hit = has_collisions(q)
            times.append(clock() - t0)
            hits.append(bool(hit))
        return {"times_s": times, "collision": hits}


if __name__ == "__main__":
    serve(_ClutterHandler())
