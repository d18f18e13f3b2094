"""OMPL motion-planning worker: runs in bench-out/venvs/ompl (OMPL 2.0.1 and kinserve), JSON lines.

OMPL plans; kinserve answers its state validity queries (``Robot.collision_scene(...).in_collision``,
the same convex collision model ``plan_motion`` uses), so the comparison is of the planners, with one
validity checker. OMPL checks its motions with its own ``DiscreteMotionValidator`` at its default
resolution (1 % of the space's extent): the benchmark's dense check reports what that misses.

Requests (see benchmarks/_peers.py for the protocol):

* ``{"cmd": "version"}``
* ``{"cmd": "setup", "urdf": PATH, "package_dir": DIR, "srdf": PATH, "seed": int}`` - the robot loaded
  by kinserve (as the benchmark loads it), its collision model built, OMPL's RNG seeded once (OMPL seeds
  every later sampler from that first seed, so a run is deterministic in its order of problems).
* ``{"cmd": "scene", "obstacles": [shape dicts]}`` - the obstacles of the next problems.
* ``{"cmd": "plan", "start": [...], "goal": [...], "max_time": s}`` -> ``{"success", "path",
  "raw_waypoints", "plan_time", "simplify_time", "checks"}``: ``RRTConnect`` (default range) in a
  ``SimpleSetup`` on the joint-limit box, then ``PathSimplifier.simplify(path, max_time)``; times
  measured here around ``solve`` and ``simplify`` only (``setup`` is done before).
* ``{"cmd": "quit"}``
"""

from __future__ import annotations

import time

import numpy as np

from _worker_loop import serve


class OmplMotion:
    """kinserve's robot and scene, OMPL's planner and simplifier."""

    def __init__(self, req: dict) -> None:
        from ompl import base as ob
        from ompl import util as ou

        from kinserve import robots

        ou.setLogLevel(ou.LOG_ERROR)
        ou.RNG.setSeed(int(req.get("seed", 0)))
        self.robot = robots.load(req["urdf"], package_dirs=[req["package_dir"]], srdf=req["srdf"],
                                 geometry=False)
        self.robot.collision  # built before any timed call  # noqa: B018
        self.space = ob.RealVectorStateSpace(self.robot.nq)
        bounds = ob.RealVectorBounds(self.robot.nq)
        for i, (lo, hi) in enumerate(zip(self.robot.lower, self.robot.upper)):
            bounds.setLow(i, float(lo))
            bounds.setHigh(i, float(hi))
        self.space.setBounds(bounds)
        self.scene = self.robot.collision_scene((), True)
        self.checks = 0

    def set_obstacles(self, shapes: list[dict]) -> dict:
        from kinserve.kinematics.shapes import as_shape

        obstacles = tuple(as_shape(s) for s in shapes)
        self.scene = self.robot.collision_scene(obstacles, True)
        return {"obstacles": len(obstacles)}

    def _state(self, q) -> object:
        s = self.space.allocState()
        for i, v in enumerate(q):
            s[i] = float(v)
        return s

    def plan(self, req: dict) -> dict:
        from ompl import geometric as og

        nq, scene = self.robot.nq, self.scene
        self.checks = 0

        def valid(state) -> bool:
            self.checks += 1
            return not scene.in_collision(np.fromiter((state[i] for i in range(nq)), float, nq))

        ss = og.SimpleSetup(self.space)
        ss.setStateValidityChecker(valid)
        ss.setStartAndGoalStates(self._state(req["start"]), self._state(req["goal"]))
        si = ss.getSpaceInformation()
        ss.setPlanner(og.RRTConnect(si))
        ss.setup()
        max_time = float(req["max_time"])
        t0 = time.perf_counter()
        ss.solve(max_time)
        t1 = time.perf_counter()
        if not ss.haveExactSolutionPath():
            return {"success": False, "path": [], "raw_waypoints": 0, "plan_time": t1 - t0,
                    "simplify_time": 0.0, "checks": self.checks}
        path = ss.getSolutionPath()
        raw = path.getStateCount()
        t2 = time.perf_counter()
        og.PathSimplifier(si).simplify(path, max_time)
        t3 = time.perf_counter()
        states = [[path.getState(k)[i] for i in range(nq)] for k in range(path.getStateCount())]
        return {"success": True, "path": states, "raw_waypoints": raw, "plan_time": t1 - t0,
                "simplify_time": t3 - t2, "checks": self.checks}


class _Handler:
    def __init__(self) -> None:
        self.om: OmplMotion | None = None

    def __call__(self, cmd: str, req: dict) -> dict:
        if cmd == "version":
            from importlib.metadata import version

            return {"version": f"ompl {version('ompl')} / kinserve {version('kinserve')} (validity)"}
        if cmd == "setup":
            self.om = OmplMotion(req)
            return {"joints": self.om.robot.joint_names}
        if cmd == "scene":
            return self.om.set_obstacles(req["obstacles"])
        if cmd == "plan":
            return self.om.plan(req)
        return {"error": f"unknown cmd {cmd!r}"}


if __name__ == "__main__":
    serve(_Handler())
