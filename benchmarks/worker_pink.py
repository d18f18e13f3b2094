"""Pink worker: Pink's collision barrier IK (``_pink_peer.PinkBarrierIK``) in a process of its own.

Pink works with the main venv's Pinocchio, so this worker runs in that venv's interpreter; it runs apart
from the benchmark all the same, as roboplan's does, so that Pink's Python-heavy solves (milliseconds each)
do not evict the caches of the in-process solvers timed between its blocks. JSON lines on stdin/stdout
(``_worker_loop.serve``; see ``_peers.py``).

Requests:

* ``{"cmd": "version"}``
* ``{"cmd": "setup", "urdf": PATH, "srdf": PATH, "package_dirs": [DIR], "locked": {JOINT: value},
  "frame": NAME, "boxes": [{"pose": 4x4, "size": [x, y, z]}, ...]}`` - the URDF's collision meshes as convex
  hulls, the reduced model (``locked`` joints held), every robot geometry paired with every box, the SRDF's
  disabled pairs removed; the last box is the movable one. Answers ``{"pairs": n}``.
* ``{"cmd": "move_box", "center": [x, y, z]}`` - the movable box's placement.
* ``{"cmd": "solve", "T": 4x4, "q0": [...], "seed": int, "max_time": s, "tol_pos": m, "tol_rot": rad}`` ->
  ``{"q": [...], "time": s, "cpu": s}``; wall and CPU time measured here, around the solve only.
* ``{"cmd": "quit"}``
"""

from __future__ import annotations

import time
import warnings

import numpy as np
import pinocchio as pin

from _worker_loop import serve


def barrier_model(req: dict) -> tuple:
    """``(model, geometry, movable box id)`` of a ``setup`` request (module docstring)."""
    import coal

    full = pin.buildModelFromUrdf(req["urdf"])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        geom = pin.buildGeomFromUrdf(full, req["urdf"], pin.GeometryType.COLLISION, req["package_dirs"])
    lock = [full.getJointId(n) for n in req["locked"]]
    model, (geom,) = pin.buildReducedModel(full, [geom], lock, pin.neutral(full))
    for go in geom.geometryObjects:  # convex hulls: the Panda's meshes are convex already
        if isinstance(go.geometry, coal.BVHModelBase):
            go.geometry.buildConvexRepresentation(False)
            go.geometry = go.geometry.convex
    geom.addAllCollisionPairs()
    pin.removeCollisionPairs(model, geom, req["srdf"])
    n_robot = geom.ngeoms
    ids = []
    for k, b in enumerate(req["boxes"]):
        T = np.asarray(b["pose"], dtype=float)
        placement = pin.SE3(T[:3, :3].copy(), T[:3, 3].copy())
        ids.append(geom.addGeometryObject(pin.GeometryObject(f"scene_{k}", 0, placement,
                                                             coal.Box(*[float(s) for s in b["size"]]))))
    for g in range(n_robot):
        for oid in ids:
            geom.addCollisionPair(pin.CollisionPair(g, oid))
    return model, geom, ids[-1]


class _Handler:
    """One Pink solver per worker, set up by the ``setup`` request."""

    def __init__(self) -> None:
        self.ik = None
        self.geom = None
        self.box = -1

    def __call__(self, cmd: str, req: dict) -> dict:
        if cmd == "version":
            from importlib.metadata import version

            return {"version": f"pink {version('pin-pink')} / pin {pin.__version__}"}
        if cmd == "setup":
            from _pink_peer import PinkBarrierIK

            model, self.geom, self.box = barrier_model(req)
            self.ik = PinkBarrierIK(model, req["frame"], self.geom)
            return {"pairs": len(self.geom.collisionPairs)}
        if cmd == "move_box":
            self.geom.geometryObjects[self.box].placement = pin.SE3(np.eye(3),
                                                                    np.asarray(req["center"], dtype=float))
            return {}
        if cmd == "solve":
            T, q0 = np.asarray(req["T"], dtype=float), np.asarray(req["q0"], dtype=float)
            t0, c0 = time.perf_counter(), time.process_time()
            q = self.ik.solve(T, q0, int(req["seed"]), float(req["max_time"]), float(req["tol_pos"]),
                              float(req["tol_rot"]))
            wall, cpu = time.perf_counter() - t0, time.process_time() - c0
            return {"q": np.asarray(q).tolist(), "time": wall, "cpu": cpu}
        return {"error": f"unknown cmd {cmd!r}"}


def main() -> None:
    serve(_Handler())


if __name__ == "__main__":
    main()
