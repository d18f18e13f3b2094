"""Independent reference for obstacle clearance: the shape's own signed distance at densely sampled points
of every link segment (no closed forms, no coal) - shared by the obstacle, QP and constraint tests."""

import numpy as np
import pinocchio as pin

from kinserve.ik.constraints import robot_segments


def sampled_clearance(robot, q, frame, obstacle, link_radius=0.0, n=801):
    """Smallest signed distance (m) from ``obstacle`` to the moving link/slider/tool segments at ``q``,
    minus ``link_radius``; fixed base segments are skipped (the base cannot move out of an obstacle)."""
    data = robot.model.createData()
    pin.forwardKinematics(robot.model, data, q)
    best = np.inf
    for seg in robot_segments(robot, frame):
        if seg.ja == 0 and seg.jb == 0:
            continue
        a = data.oMi[seg.ja].act(seg.la) if seg.ja else seg.la
        b = data.oMi[seg.jb].act(seg.lb) if seg.jb else seg.lb
        pts = a + np.linspace(0, 1, n)[:, None] * (b - a)
        best = min(best, float(obstacle.signed_distance(pts).min()))
    return best - link_radius


def rows_and_finite_differences(robot, avoid, q, h):
    """``(c, G, fd)`` of a bound :class:`ik.ObstacleAvoidance` at ``q``: its clearances and damper-row
    gradients (``rows_all``), and central differences (step ``h``) of its exact clearance of every pair."""
    model, data = robot.model, robot.data
    pin.computeJointJacobians(model, data, q)
    c, G = avoid.rows_all(robot, data)

    def clear(qq):
        pin.forwardKinematics(model, data, qq)
        return avoid.clearances(data, np.inf)

    fd = np.array([(clear(q + h * e) - clear(q - h * e)) / (2 * h) for e in np.eye(robot.nq)]).T
    return c, G, fd
