"""Pink as a collision-avoiding IK contender: barrier model, multistart driver, one control step.

Pink (``pin-pink``) works with the main venv's Pinocchio, so it needs no venv of its own:
``bench_ik_constrained`` runs it in-process, ``bench_collision`` in a worker
process (``worker_pink.py``, the main venv's interpreter) so that its solves do
not evict the caches of the solvers timed beside it.
Obstacles and self-collision are both expressed the way Pink supports them: a
Pinocchio ``GeometryModel`` whose collision pairs feed one
``SelfCollisionBarrier`` (``safe_displacement_gain=0``, ``d_min=0``; the
barrier reads ``collision_data.distanceResults`` that ``Configuration``
computes). For the skeleton workloads of ``bench_ik_constrained`` the robot's
geometry is a thin capsule (radius :data:`SEGMENT_RADIUS`) along each segment
between joint origins - the same skeleton the independent check uses - and the
pairs are (segment, obstacle).

Solve = Pink's differential IK integrated to convergence: ``dt = 1``,
``FrameTask`` (position and orientation cost 1), ``PostureTask`` (cost
:data:`POSTURE_COST`) whose target is the current configuration at every step
(a damping of the step that does not bias the answer), ``ConfigurationLimit``,
the barrier, DAQP. At most ``max_iter`` steps per start, then a new start drawn
uniformly within the limits (redrawn while in collision), until ``max_time``.
"""

from __future__ import annotations

import math
import time

import numpy as np
import pinocchio as pin

SEGMENT_RADIUS = 1e-3
POSTURE_COST = 1e-3
BARRIER_GAIN = 0.5


def skeleton_capsules(model: pin.Model, flange: str, obstacles,
                      radius: float = SEGMENT_RADIUS) -> pin.GeometryModel:
    """Capsules along the segments joint origin -> next joint origin (and joint -> flange) + obstacles,
    paired."""
    import coal

    from _obstacle_check import coal_shape

    gm = pin.GeometryModel()
    ends = []
    for j in range(1, model.njoints):
        kids = [c for c in range(1, model.njoints) if model.parents[c] == j]
        for c in kids:
            ends.append((j, model.jointPlacements[c].translation.copy()))
    f = model.frames[model.getFrameId(flange)]
    ends.append((f.parentJoint, f.placement.translation.copy()))
    seg_ids = []
    for k, (j, end) in enumerate(ends):
        L = float(np.linalg.norm(end))
        if L < 1e-9:
            continue
        z = end / L
        x = np.cross([0.0, 1.0, 0.0], z) if abs(z[1]) < 0.9 else np.cross([1.0, 0.0, 0.0], z)
        x /= np.linalg.norm(x)
        R = np.column_stack([x, np.cross(z, x), z])
        go = pin.GeometryObject(f"segment_{k}", j, pin.SE3(R, 0.5 * end), coal.Capsule(radius, L))
        seg_ids.append(gm.addGeometryObject(go))
    for k, ob in enumerate(obstacles):
        shape, placement = coal_shape(ob)
        oid = gm.addGeometryObject(pin.GeometryObject(f"obstacle_{k}", 0, placement, shape))
        for s in seg_ids:
            gm.addCollisionPair(pin.CollisionPair(s, oid))
    return gm


class PinkBarrierIK:
    """Multistart Pink IK with a collision barrier over ``geom``'s pairs (module docstring)."""

    def __init__(self, model: pin.Model, frame: str, geom: pin.GeometryModel | None, max_iter: int = 100,
                 solver: str = "daqp"):
        import pink
        from pink.barriers import SelfCollisionBarrier
        from pink.limits import ConfigurationLimit
        from pink.tasks import FrameTask, PostureTask

        self.pink = pink
        self.model, self.frame, self.geom = model, frame, geom
        self.data = model.createData()
        self.gdata = pin.GeometryData(geom) if geom is not None else None
        self.limits = [ConfigurationLimit(model)]
        self.barriers = []
        if geom is not None and len(geom.collisionPairs):
            self.barriers = [SelfCollisionBarrier(n_collision_pairs=len(geom.collisionPairs),
                                                  gain=BARRIER_GAIN, safe_displacement_gain=0.0, d_min=0.0)]
        self.task = FrameTask(frame, position_cost=1.0, orientation_cost=1.0)
        self.posture = PostureTask(cost=POSTURE_COST)
        self.max_iter, self.solver = max_iter, solver
        self.lower, self.upper = model.lowerPositionLimit.copy(), model.upperPositionLimit.copy()

    def configuration(self, q):
        return self.pink.Configuration(self.model, self.data, q, collision_model=self.geom,
                                       collision_data=self.gdata)

    def _clear(self, conf) -> bool:
        if self.gdata is None:
            return True
        return all(r.min_distance >= 0.0 for r in self.gdata.distanceResults)

    def step(self, conf, dt: float = 1.0) -> np.ndarray:
        """One ``solve_ik`` velocity at ``conf`` (tasks already targeted)."""
        return self.pink.solve_ik(conf, [self.task, self.posture], dt, solver=self.solver, limits=self.limits,
                                  barriers=self.barriers)

    def solve(self, T: np.ndarray, q0: np.ndarray, seed: int, max_time: float, tol_pos: float,
              tol_rot: float) -> np.ndarray:
        pink = self.pink
        t0 = time.perf_counter()
        rng = np.random.default_rng(seed)
        self.task.set_target(pin.SE3(T[:3, :3].copy(), T[:3, 3].copy()))
        q = np.clip(np.asarray(q0, dtype=float), self.lower, self.upper)
        best = q
        while time.perf_counter() - t0 < max_time:
            conf = self.configuration(q)
            if not self._clear(conf):
                q = rng.uniform(self.lower, self.upper)
                continue
            for _ in range(self.max_iter):
                M = conf.get_transform_frame_to_world(self.frame)
                pe = float(np.linalg.norm(M.translation - T[:3, 3]))
                c = (np.trace(M.rotation.T @ T[:3, :3]) - 1.0) / 2.0
                re = math.acos(max(-1.0, min(1.0, c)))
                if pe < tol_pos and re < tol_rot and self._clear(conf):
                    return conf.q.copy()
                if time.perf_counter() - t0 > max_time:
                    break
                self.posture.set_target(conf.q)
                try:
                    v = self.step(conf)
                except (pink.exceptions.NoSolutionFound, pink.exceptions.PinkError):
                    break
                conf.integrate_inplace(v, 1.0)
            best = conf.q.copy()
            q = rng.uniform(self.lower, self.upper)
        return best
