"""roboplan worker: runs in bench-out/venvs/roboplan (roboplan pins its own Pinocchio), JSON lines on
stdin/stdout.

Requests (one JSON object per line; see benchmarks/_peers.py):

* ``{"cmd": "version"}``
* ``{"cmd": "setup", "urdf": TEXT, "package_paths": [DIR], "srdf": TEXT, "joints": [NAMES],
  "boxes": [{"name", "pose": 4x4, "size": [x, y, z]}], "base": LINK, "frame": NAME}`` - a roboplan
  ``Scene`` from the URDF and SRDF (disabled pairs; group ``arm`` = ``joints``), the other joints
  held at 0, scene boxes fixed in the world.
* ``{"cmd": "move_box", "name": NAME, "pose": 4x4}`` - ``updateGeometryPlacement`` of a scene box.
* ``{"cmd": "fk", "q": [...]}`` -> ``{"T": 4x4}``
* ``{"cmd": "collides", "q": [...]}`` -> ``{"collision": bool}`` (``Scene.hasCollisions``)
* ``{"cmd": "time_collision", "qs": [[...], ...], "repeats": n}`` -> ``{"us": ..., "cpu_us": ...}``: median
  over the repeats of the wall / CPU time per call
* ``{"cmd": "solve", "T": 4x4, "q0": [...], "seed": int, "max_time": s, "tol_pos": m, "tol_rot": rad,
  "check_collisions": bool}`` -> ``{"q": [...] | null, "time": s, "cpu": s, "ok": bool}``:
  ``SimpleIk.solveIk`` with ``max_time`` and unlimited restarts, ``fast_return``, errors bounded by
  ``tol_pos``/``tol_rot``. Wall and CPU time are measured here, around ``solveIk`` only.
* ``{"cmd": "quit"}``
"""

from __future__ import annotations

import statistics
import time

import numpy as np

from _worker_loop import serve


class RoboplanIK:
    def __init__(self, req: dict):
        from roboplan import core

        self.core = core
        desc = core.loadUrdfSceneDescriptionFromXml(req["urdf"], req.get("package_paths", []))
        self.scene = core.Scene("bench", desc)
        if req.get("srdf"):
            self.scene.importSrdf(req["srdf"])
        self.joints = list(req["joints"])
        self.scene.addGroup("bench_arm", self.joints)
        self.full_names = self.scene.getJointNames()
        self.idx = self.scene.getJointPositionIndices(self.joints)
        self.q_full = np.zeros(len(self.scene.getCurrentJointPositions()))
        self.scene.setJointPositions(self.q_full)
        self.base, self.frame = req.get("base", "panda_link0"), req["frame"]
        names = []
        for b in req.get("boxes", []):
            T = np.asfortranarray(np.asarray(b["pose"], dtype=float))
            self.scene.addBoxGeometry(b["name"], "universe", core.Box(*[float(v) for v in b["size"]]), T,
                                      np.array([0.5, 0.5, 0.5, 1.0]))
            names.append(b["name"])
        # scene objects may touch each other (the wall stands on the table): only robot pairs count
        for i, a in enumerate(names):
            for b in names[i + 1:]:
                self.scene.setCollisions(a, b, False)

    def full(self, q) -> np.ndarray:
        qf = self.q_full.copy()
        qf[self.idx] = q
        return qf

    def solve(self, req: dict) -> dict:
        from roboplan import simple_ik

        core = self.core
        opts = simple_ik.SimpleIkOptions(
            group_name="bench_arm", max_time=float(req["max_time"]), max_restarts=1_000_000,
            max_linear_error_norm=float(req["tol_pos"]), max_angular_error_norm=float(req["tol_rot"]),
            check_collisions=bool(req.get("check_collisions", True)))
        ik = simple_ik.SimpleIk(self.scene, opts)  # built per solve (not timed): options and seed per target
        ik.setRngSeed(int(req.get("seed", 0)))
        goal = core.CartesianConfiguration(self.base, self.frame,
                                           np.asfortranarray(np.asarray(req["T"], dtype=float)))
        start = core.JointConfiguration(self.joints, np.asarray(req["q0"], dtype=float))
        sol = core.JointConfiguration()
        t0, c0 = time.perf_counter(), time.process_time()
        ok = ik.solveIk(goal, start, sol)
        dt, dc = time.perf_counter() - t0, time.process_time() - c0
        q = np.asarray(sol.positions, dtype=float)
        if q.size == len(self.q_full):
            q = q[self.idx]
        return {"q": q.tolist() if q.size == len(self.joints) else None, "time": dt, "cpu": dc,
                "ok": bool(ok)}


class _Handler:
    """One roboplan scene and solver per worker, set up by the ``setup`` request."""

    def __init__(self) -> None:
        self.rp: RoboplanIK | None = None

    def __call__(self, cmd: str, req: dict) -> dict:
        rp = self.rp
        if cmd == "version":
            from importlib.metadata import version

            import pinocchio

            return {"version": f"roboplan {version('roboplan')} / pin {pinocchio.__version__}"}
        if cmd == "setup":
            self.rp = RoboplanIK(req)
            return {"joints": self.rp.full_names}
        if cmd == "move_box":
            rp.scene.updateGeometryPlacement(req["name"], "universe",
                                             np.asfortranarray(np.asarray(req["pose"], dtype=float)))
            return {}
        if cmd == "fk":
            return {"T": np.asarray(rp.scene.forwardKinematics(rp.full(req["q"]), rp.frame)).tolist()}
        if cmd == "collides":
            return {"collision": bool(rp.scene.hasCollisions(rp.full(req["q"])))}
        if cmd == "time_collision":
            qs = [rp.full(q) for q in req["qs"]]
            has = rp.scene.hasCollisions
            wall, cpu = [], []
            for _ in range(int(req.get("repeats", 5))):
                t0, c0 = time.perf_counter(), time.process_time()
                for q in qs:
                    has(q)
                wall.append((time.perf_counter() - t0) / len(qs))
                cpu.append((time.process_time() - c0) / len(qs))
            return {"us": statistics.median(wall) * 1e6, "cpu_us": statistics.median(cpu) * 1e6}
        if cmd == "solve":
            return rp.solve(req)
        return {"error": f"unknown cmd {cmd!r}"}


def main() -> None:
    serve(_Handler())


if __name__ == "__main__":
    main()
