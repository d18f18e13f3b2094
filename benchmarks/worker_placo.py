"""PlaCo IK worker: runs in bench-out/venvs/placo (PlaCo pins its own Pinocchio), JSON lines on stdin/stdout.

Requests (one JSON object per line; see benchmarks/_peers.py):

* ``{"cmd": "version"}``
* ``{"cmd": "setup", "urdf": TEXT, "pairs": [[link, link], ...], "frame": NAME, "joints": [NAMES],
  "avoid": bool, "margin": m, "trigger": m, "posture_weight": w}`` - load the robot (PlaCo adds a
  floating base; it is masked), one frame task (soft, weight 1), optionally a joints (posture) task
  towards the start of each attempt (weight ``w``, default 0 = none), joint limits on, and with ``avoid``
  PlaCo's hard self-collision avoidance constraint over ``pairs`` (the benchmark's obstacles are links of the
  URDF fixed to the base).
* ``{"cmd": "fk", "q": [...]}`` -> ``{"T": 4x4}``
* ``{"cmd": "solve", "T": 4x4, "q0": [...], "seed": int, "max_time": s, "max_iter": n,
  "tol_pos": m, "tol_rot": rad, "restarts": bool}`` -> ``{"q": [...], "time": s, "cpu": s, "starts": n, "ok":
  bool}``: iterate ``solver.solve(True)`` from ``q0`` until the frame error is within tolerance (and, with
  avoidance, every pair distance >= 0), at most ``max_iter`` steps per start; then restart from a
  uniform random configuration (``numpy.random.default_rng(seed)``; starts in collision are redrawn)
  until ``max_time`` s are spent. Wall and CPU time (``time.process_time``) are measured here, around the
  solve only.
* ``{"cmd": "quit"}``
"""

from __future__ import annotations

import json
import math
import tempfile
import time
from pathlib import Path

import numpy as np

from _worker_loop import serve


def rot_err(Ra, Rb) -> float:
    c = (np.trace(Ra.T @ Rb) - 1.0) / 2.0
    return math.acos(max(-1.0, min(1.0, c)))


class PlacoIK:
    def __init__(self, req: dict):
        import placo

        self.placo = placo
        self.tmp = tempfile.TemporaryDirectory(prefix="placo_bench_")
        path = Path(self.tmp.name) / "robot.urdf"
        path.write_text(req["urdf"])
        pairs = req.get("pairs") or []
        (Path(self.tmp.name) / "collisions.json").write_text(json.dumps(pairs))
        flags = 0 if pairs else placo.Flags.ignore_collisions
        self.robot = placo.RobotWrapper(str(path), flags)
        self.joints = list(req["joints"])
        self.frame = req["frame"]
        lim = [self.robot.get_joint_limits(j) for j in self.joints]
        self.lower = np.array([bounds[0] for bounds in lim])
        self.upper = np.array([bounds[1] for bounds in lim])
        self.avoid = bool(req.get("avoid")) and bool(pairs)
        solver = self.solver = placo.KinematicsSolver(self.robot)
        solver.mask_fbase(True)
        solver.enable_joint_limits(True)
        solver.enable_velocity_limits(False)
        self.task = solver.add_frame_task(self.frame, np.eye(4))
        self.task.configure("frame", "soft", 1.0, 1.0)
        # A soft posture task biases the answer away from the target (the frame task stops at a residual
        # of about weight * distance); by default there is none (PlaCo's solver regularises dq itself).
        self.posture = None
        if float(req.get("posture_weight", 0.0)) > 0.0:
            self.posture = solver.add_joints_task()
            self.posture.configure("posture", "soft", float(req["posture_weight"]))
        if self.avoid:
            c = solver.add_avoid_self_collisions_constraint()
            c.configure("avoid", "hard")
            c.self_collisions_margin = float(req.get("margin", 0.0))
            c.self_collisions_trigger = float(req.get("trigger", 0.05))

    def set_q(self, q) -> None:
        for name, v in zip(self.joints, q):
            self.robot.set_joint(name, float(v))
        self.robot.update_kinematics()

    def get_q(self) -> np.ndarray:
        return np.array([self.robot.get_joint(n) for n in self.joints])

    def fk(self, q) -> np.ndarray:
        self.set_q(q)
        return np.asarray(self.robot.get_T_world_frame(self.frame))

    def clear(self) -> bool:
        if not self.avoid:
            return True
        return all(d.min_distance >= 0.0 for d in self.robot.distances())

    def solve(self, req: dict) -> dict:
        T = np.asarray(req["T"], dtype=float)
        tol_p, tol_r = req["tol_pos"], req["tol_rot"]
        max_iter, max_time = int(req.get("max_iter", 100)), float(req["max_time"])
        rng = np.random.default_rng(int(req.get("seed", 0)))
        t0, c0 = time.perf_counter(), time.process_time()
        self.task.T_world_frame = T
        q = np.clip(np.asarray(req["q0"], dtype=float), self.lower, self.upper)
        starts, best = 0, None
        while True:
            self.set_q(q)
            if self.avoid and not self.clear():
                if not req.get("restarts", True) or time.perf_counter() - t0 > max_time:
                    break
                q = rng.uniform(self.lower, self.upper)
                continue
            starts += 1
            if self.posture is not None:
                self.posture.set_joints({n: float(v) for n, v in zip(self.joints, q)})
            for _ in range(max_iter):
                Tc = np.asarray(self.robot.get_T_world_frame(self.frame))
                if (np.linalg.norm(Tc[:3, 3] - T[:3, 3]) < tol_p and rot_err(Tc[:3, :3], T[:3, :3]) < tol_r
                        and self.clear()):
                    return {"q": self.get_q().tolist(), "time": time.perf_counter() - t0,
                            "cpu": time.process_time() - c0, "starts": starts, "ok": True}
                if time.perf_counter() - t0 > max_time:
                    break
                try:
                    self.solver.solve(True)
                except RuntimeError:
                    break
                self.robot.update_kinematics()
            best = self.get_q()
            if not req.get("restarts", True) or time.perf_counter() - t0 > max_time:
                break
            q = rng.uniform(self.lower, self.upper)
        q_out = best if best is not None else q
        return {"q": q_out.tolist(), "time": time.perf_counter() - t0, "cpu": time.process_time() - c0,
                "starts": starts, "ok": False}


class _Handler:
    """One PlaCo solver per worker, set up by the ``setup`` request."""

    def __init__(self) -> None:
        self.ik: PlacoIK | None = None

    def __call__(self, cmd: str, req: dict) -> dict:
        if cmd == "version":
            import pinocchio
            import placo

            ans = {"version": f"placo {getattr(placo, '__version__', '?')} / pin {pinocchio.__version__}"}
            try:
                from importlib.metadata import version

                ans["version"] = f"placo {version('placo')} / pin {pinocchio.__version__}"
            except Exception:  # noqa: BLE001
                pass
            return ans
        if cmd == "setup":
            self.ik = PlacoIK(req)
            return {"nq": len(self.ik.joints), "lower": self.ik.lower.tolist(),
                    "upper": self.ik.upper.tolist()}
        if cmd == "fk":
            return {"T": self.ik.fk(req["q"]).tolist()}
        if cmd == "solve":
            return self.ik.solve(req)
        return {"error": f"unknown cmd {cmd!r}"}


def main() -> None:
    serve(_Handler())


if __name__ == "__main__":
    main()
