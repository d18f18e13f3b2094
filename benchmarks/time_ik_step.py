"""CPU time of one ``ik.step`` call in the setups of issue 10 (Panda, FrameTask + PostureTask + 3 spheres r 5
cm): with velocity limits, the posture task at priority 1 (one level, ``check_ik_model.py``'s setup) and at
its default priority 2 (two levels); and ``bench_ik_constrained.py``'s own control step (flange frame, the
spheres at 0.3 / 0.5 / 0.7 of the shoulder -> target segment, posture at priority 2, no velocity limits). Best
of REPEATS batches of CALLS calls, CPU seconds of this process (the machine is shared). Writes
bench-out/ik_step_time.json with the load average.

    python benchmarks/time_ik_step.py [CALLS]
"""

from __future__ import annotations

import json
import os
import sys
from pathlib import Path

import numpy as np

from kinserve import ik, robots

from _common import cpu_per_call_seconds

REPEATS = 7


def setups(robot):
    rng = np.random.default_rng(3)
    q = robot.random_q(rng)
    T = robot.fk(robot.random_q(rng)).copy()
    hand = robot.fk(q)[:3, 3]
    spheres = [ik.Sphere(hand + [0.15, 0, 0], 0.05), ik.Sphere(hand + [0, 0.2, 0], 0.05),
               ik.Sphere(hand + [0, 0, 0.25], 0.05)]
    cons = [ik.ObstacleAvoidance(spheres), ik.VelocityLimits(2.0)]
    one = [ik.FrameTask(robot.tip, T), ik.PostureTask(robot.neutral(), weight=1e-2, priority=1)]
    two = [ik.FrameTask(robot.tip, T), ik.PostureTask(robot.middle())]
    out = {"one level (posture priority 1)": (one, cons, q),
           "two levels (posture priority 2)": (two, cons, q)}
    out["bench_ik_constrained step (two levels, no velocity limits)"] = bench_setup(robot)
    return out


def bench_setup(robot):
    """The control step ``bench_ik_constrained.time_steps`` times (same seed, frame, spheres and tasks)."""
    import bench_ik_constrained as bench

    rng = np.random.default_rng(7)
    q = robot.random_q(rng)
    T = robot.fk(robot.random_q(rng), bench.FRAME)
    obs = bench.spheres_for(bench.shoulder_of(robot), T[:3, 3])
    return [ik.FrameTask(bench.FRAME, T), ik.PostureTask(robot.middle())], bench.kinserve_obstacles(obs), q


def main():
    calls = int(sys.argv[1]) if len(sys.argv) > 1 else 400
    robot = robots.load("panda", geometry=False)
    out = {"loadavg_before": os.getloadavg()}
    for name, (tasks, cons, q) in setups(robot).items():
        ik.step(robot, tasks, cons, q, 0.01)  # warm-up: binds and caches the problem
        out[name + " us"] = 1e6 * cpu_per_call_seconds(lambda: ik.step(robot, tasks, cons, q, 0.01),
                                                       calls, REPEATS)
    out["loadavg_after"] = os.getloadavg()
    Path("bench-out").mkdir(exist_ok=True)
    Path("bench-out/ik_step_time.json").write_text(json.dumps(out, indent=2))
    print(json.dumps(out, indent=2))


if __name__ == "__main__":
    main()
