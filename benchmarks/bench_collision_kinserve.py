"""kinserve's own collision figures on the issue-11 Panda scene (no peers; the side-by-side run is bench_collision.py).

Scene: Panda with its SRDF (44 self pairs), a table top (box centre (0.65, 0, -0.05), size 0.7 x 1.2 x 0.1)
and a wall (centre (0, -0.6, 0.5), size 1.5 x 0.05 x 1.0).

1. *Check time* (self + scene, µs per call, median of 7 repeats over ``--configs`` random configurations):
   raw ``pinocchio.computeCollisions`` over every pair on the URDF meshes and on the hulls (the issue's 40 / 22 µs
   references), the broad phase alone, and ``robot.in_collision(q, obstacles)`` (validation included); wall and
   CPU time (``time.process_time``, steadier on a loaded machine), and ours scaled to the issue's units
   (``22 µs x ours / raw hulls``).
2. *IK, open scene*: ``--n`` targets = tool (``panda_hand``) poses of random collision-free configurations, random seeds
   (q0; about 15 % in collision), ``ik.solve(robot, T, q0, self_collision=True, obstacles=scene, max_time=0.5,
   seed=i)`` against ``ik.solve(robot, T, q0, max_time=0.5, seed=i)`` (unconstrained, answers then checked).
3. *IK, obstacle in the way*: per target, a 10 cm box centred on the unconstrained answer's elbow
   (``panda_link4`` origin), keeping targets whose generating configuration clears it by 2 cm.

Success = pose within 0.1 mm / 1 mrad, q within limits, and collision free by an independent check written here
with coal (pair by pair, ``coal.collide`` on hulls built in this script). Figures go to ``--out`` (JSON).
Timings on a shared machine are noisy: read the ratios, and rerun on a quiet machine for absolute numbers.

    python benchmarks/bench_collision_kinserve.py [--n 200] [--out bench-out/collision_kinserve.json]
"""

from __future__ import annotations

import argparse
import statistics
import time

import coal
import numpy as np
import pinocchio as pin

from kinserve import ik, robots  # noqa: E402
from kinserve.robots import paths  # noqa: E402
from _common import machine, write_json  # noqa: E402


def pose(c) -> np.ndarray:
    T = np.eye(4)
    T[:3, 3] = c
    return T


SCENE = [ik.Box(pose((0.65, 0.0, -0.05)), (0.7, 1.2, 0.1)), ik.Box(pose((0.0, -0.6, 0.5)), (1.5, 0.05, 1.0))]


class IndependentCheck:
    """Collision test with coal only: URDF collision model, hulls, SRDF pairs, scene pairs (moving links)."""

    def __init__(self, robot, obstacles):
        erd = paths.example_robot_data_dir()
        model = robot.model
        geom = pin.buildGeomFromUrdfString(model, robot.source, pin.GeometryType.COLLISION,
                                           package_dirs=[str(paths.example_robot_data_package_dir())])
        for g in geom.geometryObjects:
            if isinstance(g.geometry, coal.BVHModelBase):
                g.geometry.buildConvexHull(True, "Qt")
                g.geometry = g.geometry.convex
        geom.addAllCollisionPairs()
        pin.removeCollisionPairs(model, geom, str(erd / "panda_description/srdf/panda.srdf"))
        self.pairs = [(cp.first, cp.second) for cp in geom.collisionPairs]
        self.geom, self.model, self.data = geom, model, model.createData()
        self.obstacles = [(ob.geometry(), coal.Transform3s(ob.pose[:3, :3], ob.pose[:3, 3])) for ob in obstacles]

    def free(self, q) -> bool:
        pin.forwardKinematics(self.model, self.data, q)
        objs = self.geom.geometryObjects
        T = []
        for g in objs:
            M = self.data.oMi[g.parentJoint] * g.placement
            T.append(coal.Transform3s(M.rotation, M.translation))
        req, res = coal.CollisionRequest(), coal.CollisionResult()
        for i, j in self.pairs:
            res.clear()
            if coal.collide(objs[i].geometry, T[i], objs[j].geometry, T[j], req, res):
                return False
        for i, g in enumerate(objs):
            if g.parentJoint == 0:
                continue
            for geo, To in self.obstacles:
                res.clear()
                if coal.collide(g.geometry, T[i], geo, To, req, res):
                    return False
        return True


def per_call_us(fn, Q, repeats: int = 7, clock=time.perf_counter) -> float:
    """Median over ``repeats`` of the mean time (µs) of one call over the configurations ``Q``."""
    samples = []
    for _ in range(repeats):
        t0 = clock()
        for q in Q:
            fn(q)
        samples.append((clock() - t0) / len(Q) * 1e6)
    return statistics.median(samples)


def both_clocks(fn, Q) -> dict:
    """Wall time and this process's CPU time (the latter is steadier on a loaded machine)."""
    return {"wall_us": per_call_us(fn, Q), "cpu_us": per_call_us(fn, Q, clock=time.process_time)}


def check_times(robot, n: int) -> dict:
    Q = robot.random_q(np.random.default_rng(0), n)
    model = robot.model
    scene = robot.collision_scene(SCENE)
    data = model.createData()
    out = {}
    for label, hulls in (("raw_computeCollisions_meshes_us", False), ("raw_computeCollisions_hulls_us", True)):
        gm = pin.buildGeomFromUrdfString(model, robot.source, pin.GeometryType.COLLISION,
                                         package_dirs=[str(paths.example_robot_data_package_dir())])
        if hulls:
            for g in gm.geometryObjects:
                if isinstance(g.geometry, coal.BVHModelBase):
                    g.geometry.buildConvexHull(True, "Qt")
                    g.geometry = g.geometry.convex
        gm.addAllCollisionPairs()
        pin.removeCollisionPairs(model, gm, str(paths.example_robot_data_dir() / "panda_description/srdf/panda.srdf"))
        n_robot = gm.ngeoms
        for ob in SCENE:
            k = gm.addGeometryObject(pin.GeometryObject("box", 0, 0, ob.placement(), ob.geometry()))
            for i in range(n_robot):
                if gm.geometryObjects[i].parentJoint:
                    gm.addCollisionPair(pin.CollisionPair(i, k))
        gd = pin.GeometryData(gm)
        out[label] = both_clocks(lambda q: pin.computeCollisions(model, data, gm, gd, q, True), Q)
    ws_data, _gd, bpm = scene.workspace()
    out["broad_phase_raw_us"] = both_clocks(lambda q: pin.computeCollisions(model, ws_data, bpm, q, True), Q)
    out["robot_in_collision_us"] = both_clocks(lambda q: robot.in_collision(q, SCENE), Q)
    out["robot_in_collision_self_only_us"] = both_clocks(lambda q: robot.in_collision(q), Q)
    out["robot_min_distance_us"] = both_clocks(lambda q: robot.min_distance(q, SCENE), Q[:300])
    hulls = out["raw_computeCollisions_hulls_us"]["cpu_us"]
    out["in_collision_cpu_in_issue_units_us"] = 22.0 * out["robot_in_collision_us"]["cpu_us"] / hulls
    out["pairs_checked"] = len(scene)
    out["fraction_in_collision"] = float(np.mean([robot.in_collision(q, SCENE) for q in Q]))
    return out


def targets(robot, n: int, rng) -> list[tuple[np.ndarray, np.ndarray]]:
    out = []
    while len(out) < n:
        q = robot.random_q(rng)
        if not robot.in_collision(q, SCENE):
            out.append((q, robot.fk(q)))
    return out


def within(robot, q, T) -> bool:
    F = robot.fk(q)
    dR = F[:3, :3].T @ T[:3, :3]
    ang = float(np.arccos(np.clip((np.trace(dR) - 1) / 2, -1, 1)))
    return bool(np.linalg.norm(F[:3, 3] - T[:3, 3]) < 1e-4 and ang < 1e-3 and robot.within_limits(q))


def summary(times, ok) -> dict:
    t = np.array(times) * 1e3
    return {"success_pct": 100.0 * float(np.mean(ok)), "median_ms": float(np.median(t)),
            "p95_ms": float(np.percentile(t, 95)), "mean_ms": float(t.mean()), "n": len(t)}


def ik_open_scene(robot, n: int, checker: IndependentCheck) -> dict:
    rng = np.random.default_rng(1)
    work = targets(robot, n, rng)
    seeds = robot.random_q(rng, n)
    seeds_in_collision = float(np.mean([robot.in_collision(q, SCENE) for q in seeds]))
    rows = {}
    for label, kw in (("unconstrained", {}), ("self_collision+obstacles", dict(self_collision=True, obstacles=SCENE))):
        times, ok, paths_used = [], [], {}
        for i, ((_, T), q0) in enumerate(zip(work, seeds)):
            t0 = time.perf_counter()
            res = ik.solve(robot, T, q0, max_time=0.5, seed=i, **kw)
            times.append(time.perf_counter() - t0)
            ok.append(res.success and within(robot, res.q, T) and checker.free(res.q))
            key = res.info.get("collision", "-")
            paths_used[key] = paths_used.get(key, 0) + 1
        rows[label] = summary(times, ok) | {"paths": paths_used}
    rows["ratio_median_to_unconstrained"] = rows["self_collision+obstacles"]["median_ms"] / rows["unconstrained"]["median_ms"]
    rows["seeds_in_collision_pct"] = 100.0 * seeds_in_collision
    return rows


def ik_obstacle_in_the_way(robot, n: int) -> dict:
    rng = np.random.default_rng(2)
    kept, times_u, times_c, ok_c, iter_ok = 0, [], [], [], []
    attempts = 0
    while kept < n and attempts < 20 * n:
        attempts += 1
        q_gen = robot.random_q(rng)
        if robot.in_collision(q_gen, SCENE):
            continue
        T = robot.fk(q_gen)
        q0 = robot.random_q(rng)
        t0 = time.perf_counter()
        free = ik.solve(robot, T, q0, max_time=0.5, seed=kept)
        tu = time.perf_counter() - t0
        if not free.success:
            continue
        block = ik.Box(pose(robot.fk(free.q, "panda_link4")[:3, 3]), (0.1, 0.1, 0.1))
        scene = SCENE + [block]
        if robot.min_distance(q_gen, scene) < 0.02:
            continue
        checker = IndependentCheck(robot, scene)
        t0 = time.perf_counter()
        res = ik.solve(robot, T, q0, self_collision=True, obstacles=scene, max_time=0.5, seed=kept)
        times_c.append(time.perf_counter() - t0)
        times_u.append(tu)
        ok_c.append(res.success and within(robot, res.q, T) and checker.free(res.q))
        iter_ok.append(all(checker.free(q) for q in res.history.q))
        kept += 1
    out = summary(times_c, ok_c)
    out["unconstrained_median_ms"] = float(np.median(times_u) * 1e3)
    out["ratio_median_to_unconstrained"] = out["median_ms"] / out["unconstrained_median_ms"]
    out["every_iterate_free_pct"] = 100.0 * float(np.mean(iter_ok))
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--n", type=int, default=200)
    ap.add_argument("--configs", type=int, default=2000)
    ap.add_argument("--out", default="bench-out/collision_kinserve.json")
    args = ap.parse_args()
    robot = robots.load("panda")
    checker = IndependentCheck(robot, SCENE)
    t0 = time.perf_counter()
    out = {"machine": machine(), "load_average": list(__import__("os").getloadavg())}
    out["check"] = check_times(robot, args.configs)
    print("check (µs):", out["check"])
    out["ik_open_scene"] = ik_open_scene(robot, args.n, checker)
    print("IK open scene:", out["ik_open_scene"])
    out["ik_obstacle_in_the_way"] = ik_obstacle_in_the_way(robot, max(args.n // 2, 10))
    print("IK obstacle in the way:", out["ik_obstacle_in_the_way"])
    out["elapsed_s"] = time.perf_counter() - t0
    write_json(args.out, out)


if __name__ == "__main__":
    main()
