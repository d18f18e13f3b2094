"""roboplan motion-planning worker: runs in bench-out/venvs/roboplan, JSON lines on stdin/stdout.

Requests (see benchmarks/_peers.py for the protocol):

* ``{"cmd": "version"}``
* ``{"cmd": "setup", "urdf": TEXT, "package_paths": [DIR], "srdf": TEXT, "joints": [NAMES]}`` - a
  roboplan ``Scene`` of the URDF (its collision meshes, loaded by roboplan's Pinocchio and coal) and the
  SRDF's disabled pairs; group ``bench_arm`` = ``joints``. Answers the scene's joint names.
* ``{"cmd": "scene", "obstacles": [shape dicts]}`` - the previous obstacles removed, these added (boxes,
  cylinders, spheres fixed in the world; obstacle-obstacle pairs never checked).
* ``{"cmd": "plan", "start": [...], "goal": [...], "seed": int, "max_time": s, "max_connection_distance":
  d}`` -> ``{"success", "path", "raw_waypoints", "plan_time", "simplify_time"}``: ``rrt.RRT`` with
  ``rrt_connect=True`` (its other options at their defaults, ``max_nodes`` large enough never to bind),
  then ``core.PathShortcutter`` with its default options and the same seed. Times are measured here,
  around ``plan`` and ``shortcut`` only.
* ``{"cmd": "quit"}``
"""

from __future__ import annotations

import time

import numpy as np

from _worker_loop import serve

#: RRT nodes allowed: large enough that only the time limit ends a search.
MAX_NODES = 1_000_000


def _pose(shape: dict) -> np.ndarray:
    if shape["kind"] == "sphere":
        T = np.eye(4)
        T[:3, 3] = shape["center"]
        return np.asfortranarray(T)
    return np.asfortranarray(np.asarray(shape["pose"], dtype=float))


class RoboplanMotion:
    """One roboplan scene of the arm; obstacles replaced per problem."""

    def __init__(self, req: dict) -> None:
        from roboplan import core

        self.core = core
        desc = core.loadUrdfSceneDescriptionFromXml(req["urdf"], req.get("package_paths", []))
        self.scene = core.Scene("bench_motion", desc)
        if req.get("srdf"):
            self.scene.importSrdf(req["srdf"])
        self.joints = list(req["joints"])
        self.scene.addGroup("bench_arm", self.joints)
        self.obstacles: list[str] = []

    def set_obstacles(self, shapes: list[dict]) -> dict:
        core = self.core
        for name in self.obstacles:
            self.scene.removeGeometry(name)
        names, color = [], np.array([0.5, 0.5, 0.5, 1.0])
        add = {"box": lambda n, s: self.scene.addBoxGeometry(n, "universe", core.Box(*s["size"]), _pose(s),
                                                             color),
               "cylinder": lambda n, s: self.scene.addCylinderGeometry(
                   n, "universe", core.Cylinder(s["radius"], s["length"]), _pose(s), color),
               "sphere": lambda n, s: self.scene.addSphereGeometry(n, "universe", core.Sphere(s["radius"]),
                                                                   _pose(s), color)}
        for k, shape in enumerate(shapes):
            name = f"obstacle_{k}"
            add[shape["kind"]](name, shape)
            names.append(name)
        pairs = [(a, b) for i, a in enumerate(names) for b in names[i + 1:]]
        if pairs:
            self.scene.setCollisions(pairs, False)
        self.obstacles = names
        return {"obstacles": len(names)}

    def plan(self, req: dict) -> dict:
        from roboplan import rrt

        core = self.core
        seed = int(req["seed"])
        opts = rrt.RRTOptions(group_name="bench_arm", max_nodes=MAX_NODES,
                              max_connection_distance=float(req.get("max_connection_distance", 1.0)),
                              max_planning_time=float(req["max_time"]), rrt_connect=True)
        planner = rrt.RRT(self.scene, opts)
        planner.setRngSeed(seed)
        self.scene.setRngSeed(seed)
        start = core.JointConfiguration(self.joints, np.asarray(req["start"], dtype=float))
        goal = core.JointConfiguration(self.joints, np.asarray(req["goal"], dtype=float))
        t0 = time.perf_counter()
        try:
            path = planner.plan(start, goal)
        except RuntimeError as exc:  # roboplan raises when its budget runs out ("RRT timed out after ...")
            return {"success": False, "path": [], "raw_waypoints": 0, "plan_time": time.perf_counter() - t0,
                    "simplify_time": 0.0, "message": str(exc)}
        t1 = time.perf_counter()
        if path is None or not list(path.positions):
            return {"success": False, "path": [], "raw_waypoints": 0, "plan_time": t1 - t0,
                    "simplify_time": 0.0}
        shortcutter = core.PathShortcutter(self.scene, core.PathShortcuttingOptions(group_name="bench_arm",
                                                                                    seed=seed))
        t2 = time.perf_counter()
        short = shortcutter.shortcut(path)
        t3 = time.perf_counter()
        return {"success": True, "path": [np.asarray(p, dtype=float).tolist() for p in short.positions],
                "raw_waypoints": len(path.positions), "plan_time": t1 - t0, "simplify_time": t3 - t2}


class RoboplanHandler:
    """The worker's commands: ``version``, ``setup`` (one :class:`RoboplanMotion`), ``scene``, ``plan``."""

    def __init__(self) -> None:
        self.rp: RoboplanMotion | None = None

    def __call__(self, cmd: str, req: dict) -> dict:
        if cmd == "version":
            from importlib.metadata import version

            import pinocchio

            return {"version": f"roboplan {version('roboplan')} / pin {pinocchio.__version__}"}
        if cmd == "setup":
            self.rp = RoboplanMotion(req)
            return {"joints": self.rp.scene.getJointNames()}
        if cmd == "scene":
            return self.rp.set_obstacles(req["obstacles"])
        if cmd == "plan":
            return self.rp.plan(req)
        return {"error": f"unknown cmd {cmd!r}"}


if __name__ == "__main__":
    serve(RoboplanHandler())
