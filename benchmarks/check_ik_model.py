"""Self-check of the IK model against issue 10's targets (not the peer benchmark).

Panda, N reachable targets (flange poses of random in-limit q), 3 spheres r 5 cm at 0.3/0.5/0.7 of the
shoulder -> target segment (kept only when the generating configuration clears them: a witness of
feasibility), and a 2-box variant; success checked by independent code (kinematics.shapes signed
distances on densely sampled link segments). Also times ik.step (frame + posture + 3 spheres) and the
plain ik.solve. Times are CPU seconds of this process (time.process_time: the machine is
shared), best of REPEATS runs of the same deterministic solve. Writes
bench-out/ik_model_check.json.

    python benchmarks/check_ik_model.py [N]
"""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path

import numpy as np
import pinocchio as pin

from kinserve import ik, robots
from kinserve.ik.constraints import robot_segments

#: CPU time of this process: the machine is shared, wall time measures the neighbours too
clock = time.process_time
#: Each solve is timed this many times, the smallest time kept (noise of the shared machine).
REPEATS = 3


def link_points(robot, q, frame, n=41):
    data = robot.model.createData()
    pin.forwardKinematics(robot.model, data, q)
    pts = []
    for seg in robot_segments(robot, frame):
        a = data.oMi[seg.ja].act(seg.la) if seg.ja else seg.la
        b = data.oMi[seg.jb].act(seg.lb) if seg.jb else seg.lb
        pts.append(a + np.linspace(0, 1, n)[:, None] * (b - a))
    return np.vstack(pts)


def clear(robot, q, frame, obstacles, link_radius=0.0):
    P = link_points(robot, q, frame)
    return min(float(o.signed_distance(P).min()) for o in obstacles) >= link_radius - 1e-9


def scene(robot, rng, kind):
    q = robot.random_q(rng)
    T = robot.fk(q).copy()
    shoulder = robot.fk(robot.neutral(), "panda_link2")[:3, 3]
    p = T[:3, 3]
    if kind == "spheres":
        obs = [ik.Sphere(shoulder + f * (p - shoulder), 0.05) for f in (0.3, 0.5, 0.7)]
    else:
        obs = []
        for f in (0.4, 0.7):
            B = np.eye(4)
            B[:3, 3] = shoulder + f * (p - shoulder)
            obs.append(ik.Box(B, (0.08, 0.08, 0.08)))
    return q, T, obs


def run(n, kind, robot, seed=0):
    rng = np.random.default_rng(seed)
    frame = robot.tip
    rows = []
    while len(rows) < n:
        q_gen, T, obs = scene(robot, rng, kind)
        if not clear(robot, q_gen, frame, obs):
            continue
        t_free = t_con = np.inf
        for _ in range(REPEATS):  # best of REPEATS (same work each time: the solves are deterministic)
            t = clock()
            ik.solve(robot, T, seed=1)
            t_free = min(t_free, clock() - t)
            t = clock()
            r = ik.solve(robot, T, obstacles=obs, seed=1)
            t_con = min(t_con, clock() - t)
        ok = (r.success and robot.within_limits(r.q) and clear(robot, r.q, frame, obs)
              and all(clear(robot, qi, frame, obs) for qi in r.history.q))
        rows.append((ok, t_con, t_free))
    ok = np.array([x[0] for x in rows])
    tc = np.array([x[1] for x in rows])
    tf = np.array([x[2] for x in rows])
    return {"n": n, "success": float(ok.mean()), "median_ms": 1e3 * float(np.median(tc)),
            "p95_ms": 1e3 * float(np.percentile(tc, 95)), "mean_ms": 1e3 * float(tc.mean()),
            "free_median_ms": 1e3 * float(np.median(tf)),
            "median_ratio": float(np.median(tc) / np.median(tf)),
            "p95_ratio": float(np.percentile(tc, 95) / np.median(tf))}


def time_step(robot, reps=2000):
    rng = np.random.default_rng(3)
    q = robot.random_q(rng)
    T = robot.fk(robot.random_q(rng)).copy()
    tasks = [ik.FrameTask(robot.tip, T), ik.PostureTask(robot.neutral(), weight=1e-2, priority=1)]
    hand = robot.fk(q)[:3, 3]
    cons = [ik.ObstacleAvoidance([ik.Sphere(hand + [0.15, 0, 0], 0.05), ik.Sphere(hand + [0, 0.2, 0], 0.05),
                                  ik.Sphere(hand + [0, 0, 0.25], 0.05)]), ik.VelocityLimits(2.0)]
    ik.step(robot, tasks, cons, q, 0.01)
    best = np.inf
    for _ in range(5):
        t = clock()
        for _ in range(reps // 5):
            ik.step(robot, tasks, cons, q, 0.01)
        best = min(best, (clock() - t) / (reps // 5))
    return 1e6 * best


def main():
    n = int(sys.argv[1]) if len(sys.argv) > 1 else 200
    robot = robots.load("panda", geometry=False)
    ik.solve(robot, robot.fk(robot.neutral()))  # builds the seed table
    out = {"spheres": run(n, "spheres", robot), "boxes": run(n, "boxes", robot), "step_us": time_step(robot)}
    Path("bench-out").mkdir(exist_ok=True)
    Path("bench-out/ik_model_check.json").write_text(json.dumps(out, indent=2))
    print(json.dumps(out, indent=2))


if __name__ == "__main__":
    main()
