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
