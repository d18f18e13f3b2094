"""The compiled clearance checks (ik.constraints.clearance_kernel) against independent code.

* the skeleton's end points from the compiled tree FK equal Pinocchio's (``LinkSkeleton.points``);
* the segment-segment and segment-box distances equal the vectorised NumPy closed forms of
  ``segment_distance`` (themselves tested against sampling), the box verdict against dense sampling;
* ``ObstacleAvoidance.violations`` (the kernel) agrees with the minimum clearance of ``margin`` per
  configuration, for spheres, capsules and rotated boxes, with and without a link radius.
"""

import numpy as np
import pinocchio as pin
import pytest

from kinserve import ik, robots
from kinserve.ik.constraints import clearance_kernel as K
from kinserve.ik.constraints.obstacles import ObstacleAvoidance
from kinserve.ik.constraints.segment_distance import segment_box, segment_segment


@pytest.mark.parametrize("name", ["panda", "scara", "baxter", "ur5"])
def test_skeleton_points_match_pinocchio(name):
    robot = robots.load(name, geometry=False)
    avoid = ObstacleAvoidance([ik.Sphere((5.0, 5.0, 5.0), 0.1)]).bind(robot)
    sk = avoid.skeleton
    assert sk.tree is not None
    Q = robot.random_q(np.random.default_rng(4), 30)
    P = np.empty((len(Q), sk.n_points, 3))
    K.skeleton_points(*sk.tree, *sk.point_table, Q, P)
    data = robot.model.createData()
    for q, Pk in zip(Q, P):
        pin.forwardKinematics(robot.model, data, q)
        assert np.abs(Pk - sk.points(data)).max() < 1e-12


def test_segment_distances_match_the_numpy_closed_forms():
    rng = np.random.default_rng(8)
    n = 3000
    a, b = rng.normal(size=(n, 3)), rng.normal(size=(n, 3))
    c, d = rng.normal(size=(n, 3)), rng.normal(size=(n, 3))
    b[::7] = a[::7]  # point-like segments
    d[::11] = c[::11]
    d[::13] = c[::13] + (b[::13] - a[::13])  # parallel segments
    _, _, X, Y = segment_segment(a, b, c, d)
    ref = np.linalg.norm(X - Y, axis=1)
    got = np.array([K.segment_to_segment(a[i], b[i], c[i], d[i]) for i in range(n)])
    assert np.abs(got - ref).max() < 1e-12
    h = rng.uniform(0.05, 0.8, size=(n, 3))
    ref_box = segment_box(a, b, h)[1]
    got_box = np.array([K.segment_to_box(a[i], b[i], h[i]) for i in range(n)])
    assert np.abs(got_box - ref_box).max() < 1e-12
    assert np.any(ref_box == 0.0) and np.any(ref_box > 0.1)  # both verdicts occur


def test_box_distance_against_sampling():
    rng = np.random.default_rng(9)
    t = np.linspace(0.0, 1.0, 4001)[:, None]
    for _ in range(200):
        a, b, h = rng.normal(size=3), rng.normal(size=3), rng.uniform(0.1, 0.6, 3)
        pts = a + t * (b - a)
        sampled = np.linalg.norm(pts - np.clip(pts, -h, h), axis=1).min()
        d = K.segment_to_box(a, b, h)
        assert d <= sampled + 1e-12 and sampled - d < 1e-3 * np.linalg.norm(b - a) + 1e-12


def _box(center, size, angle):
    T = np.eye(4)
    T[:3, :3] = pin.exp3(np.array([0.3, -0.5, 0.8]) / np.linalg.norm([0.3, -0.5, 0.8]) * angle)
    T[:3, 3] = center
    return ik.Box(T, size)


def _margin(robot, avoid, q):
    data = robot.model.createData()
    pin.forwardKinematics(robot.model, data, q)
    return avoid.margin(robot, data, q)


@pytest.mark.parametrize("link_radius", [0.0, 0.03])
def test_violations_agree_with_margin(panda, link_radius):
    rng = np.random.default_rng(12)
    checked = hits = 0
    for _ in range(40):
        lo, hi = np.array([-0.6, -0.6, 0.15]), np.array([0.6, 0.6, 0.9])
        obs = [ik.Sphere(rng.uniform(lo, hi), rng.uniform(0.03, 0.12)),
               ik.Capsule(rng.uniform(lo, hi), rng.uniform(lo, hi), rng.uniform(0.02, 0.08)),
               _box(rng.uniform(lo, hi), rng.uniform(0.05, 0.3, 3), rng.uniform(0.0, 3.0))]
        try:
            avoid = ObstacleAvoidance(obs, link_radius=link_radius).bind(panda)
        except Exception:  # an obstacle drawn around the base
            continue
        Q = panda.random_q(rng, 25)
        bad = avoid.violations(panda, Q)
        ref = np.array([_margin(panda, avoid, q) < 0.0 for q in Q])
        assert np.array_equal(bad, ref)
        assert np.array_equal(avoid.violations(panda, list(Q)), bad)  # a list of iterates as well
        checked += len(Q)
        hits += int(bad.sum())
    assert checked >= 500 and 0 < hits < checked
