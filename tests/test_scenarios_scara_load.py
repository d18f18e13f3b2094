"""S9's relax-z solve near the sphere gives the same answer on a busy machine as on a quiet one.

The scenario ends the solve with an iteration budget (``scara.ITERATION_BUDGET``),
not a time limit, so two processes spinning a tight Python loop beside it may
slow it down but cannot change what it returns: ``q``, the tool's distance to the
sphere on every iterate and the message are compared bit for bit with a quiet run.
Before the budget, the same solve ended on "time budget exhausted" one iteration
early in a loaded test worker, and the README's distance changed with it.
"""

from __future__ import annotations

import multiprocessing

import numpy as np

from kinserve import ik, robots
from kinserve.scenarios import scara

BUSY_PROCESSES = 2


def spin(started, stop) -> None:
    """A busy child: report, then a tight Python loop until ``stop`` is set."""
    started.put(True)
    x = 0
    while not stop.is_set():
        for _ in range(100_000):
            x += 1


def relax_z_near_sphere() -> tuple[ik.Result, np.ndarray]:
    """The scenario's solve (same function, target, start and sphere) and the tool-sphere distance of each
    iterate."""
    robot = robots.load("scara")
    sphere = ik.Sphere(scara.SPHERE_CENTER, scara.SPHERE_RADIUS)
    res = scara.relax_z_solve(robot, scara.near_sphere_target(robot), np.asarray(scara.Q_START_Z), sphere)
    tool = robot.fk_batch(res.history.q)[:, :3, 3]
    return res, np.linalg.norm(tool - np.asarray(scara.SPHERE_CENTER), axis=1)


def test_relax_z_answer_beside_busy_processes_equals_the_quiet_one():
    quiet, d_quiet = relax_z_near_sphere()
    ctx = multiprocessing.get_context("spawn")  # (no fork of a process holding BLAS / compiler threads)
    started, stop = ctx.Queue(), ctx.Event()
    children = [ctx.Process(target=spin, args=(started, stop), daemon=True) for _ in range(BUSY_PROCESSES)]
    try:
        for child in children:
            child.start()
        for _ in children:
            started.get(timeout=120)
        busy, d_busy = relax_z_near_sphere()
        spinning = [child.is_alive() for child in children]
    finally:
        stop.set()
        for child in children:
            child.join(timeout=10)
            if child.is_alive():
                child.terminate()
                child.join(timeout=10)
        started.close()
        started.join_thread()
    assert spinning == [True] * BUSY_PROCESSES  # the solve ran while both children spun
    assert all(child.exitcode is not None for child in children)
    assert busy.q.tobytes() == quiet.q.tobytes()
    assert d_busy.tobytes() == d_quiet.tobytes()
    assert (busy.message, busy.iterations, busy.restarts) == (quiet.message, quiet.iterations, quiet.restarts)
    # the answer itself: converged on the sphere's top, never inside it, well inside the budget
    assert quiet.success and quiet.message.startswith("converged")
    assert d_quiet.min() >= scara.SPHERE_RADIUS and d_quiet[-1] - scara.SPHERE_RADIUS < 1e-4
    assert quiet.iterations < scara.ITERATION_BUDGET // 10

