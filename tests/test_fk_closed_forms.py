"""Forward kinematics of the seed robots against closed forms written independently here.

Each test evaluates a textbook formula with NumPy (no Pinocchio, no robots.dh)
at >= 100 random configurations and compares it with ``Robot.fk``.
"""

import math

import numpy as np
import pytest

from kinserve import robots

N = 150
ATOL = 1e-10


def rot_z(t):
    c, s = math.cos(t), math.sin(t)
    return np.array([[c, -s, 0, 0], [s, c, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1.0]])


def rot_x(t):
    c, s = math.cos(t), math.sin(t)
    return np.array([[1, 0, 0, 0], [0, c, -s, 0], [0, s, c, 0], [0, 0, 0, 1.0]])


def trans(x=0.0, y=0.0, z=0.0):
    T = np.eye(4)
    T[:3, 3] = (x, y, z)
    return T


def dh(a, alpha, d, theta):
    """Standard DH: Rz(theta) Tz(d) Tx(a) Rx(alpha)."""
    return rot_z(theta) @ trans(z=d) @ trans(x=a) @ rot_x(alpha)


def skew(w):
    return np.array([[0, -w[2], w[1]], [w[2], 0, -w[0]], [-w[1], w[0], 0.0]])


def twist_exp(S, theta):
    """exp([S] theta) for a unit screw S = (w, v) (Lynch & Park, Prop. 3.25)."""
    w, v = np.asarray(S[:3], float), np.asarray(S[3:], float)
    W = skew(w)
    R = np.eye(3) + math.sin(theta) * W + (1 - math.cos(theta)) * W @ W
    G = np.eye(3) * theta + (1 - math.cos(theta)) * W + (theta - math.sin(theta)) * W @ W
    T = np.eye(4)
    T[:3, :3] = R
    T[:3, 3] = G @ v
    return T


def samples(robot, seed):
    return robot.random_q(np.random.default_rng(seed), n=N)


# --------------------------------------------------------------------------- youBot
YOUBOT_A = [-0.033, 0.155, 0.135, 0.002, 0.0]
YOUBOT_ALPHA = [math.pi / 2, 0, 0, math.pi / 2, math.pi]
YOUBOT_D = [0.145, 0, 0, 0, -0.185]


def test_youbot_equals_its_dh_product():
    robot = robots.load("youbot", geometry=False)
    assert robot.nq == 5
    for q in samples(robot, 1):
        T = np.eye(4)
        for i in range(5):
            T = T @ dh(YOUBOT_A[i], YOUBOT_ALPHA[i], YOUBOT_D[i], q[i])
        np.testing.assert_allclose(robot.fk(q), T, atol=ATOL)


def test_youbot_limits_are_the_arm_spec_in_degrees():
    robot = robots.load("youbot", geometry=False)
    np.testing.assert_allclose(np.degrees(robot.lower), [-169, -65, -151, -102.5, -167.5])
    np.testing.assert_allclose(np.degrees(robot.upper), [169, 90, 146, 102.5, 167.5])


# --------------------------------------------------------------------------- Panda
#: Space-frame screw axes (w, v) as printed in SCENARIOS.md S4 (seed 002).
PANDA_SCREWS_DOC = [
    (0, 0, 1, 0, 0, 0),
    (0, 1, 0, -0.333, 0, 0),
    (0, 0, 1, 0, 0, 0),
    (0, -1, 0, 0.649, 0, -0.088),
    (0, 0, 1, 0, 0, 0),
    (0, -1, 0, 1.033, 0, 0),
    (0, 0, 1, 0, -0.088, 0),
]
#: The same axes read off the Franka geometry: joint 4 sits 0.0825 m along x (Franka DH a4 = 0.0825;
#: 0.088 is the flange offset a7), and joint 7 turns about -z of the world at home (the flange
#: points down), so S7 = (0, 0, -1, 0, 0.088, 0) - the document's S7 is the same line, reversed.
PANDA_SCREWS = [list(S) for S in PANDA_SCREWS_DOC]
PANDA_SCREWS[3] = [0, -1, 0, 0.649, 0, -0.0825]
PANDA_SCREWS[6] = [0, 0, -1, 0, 0.088, 0]
PANDA_HOME = np.array([[1, 0, 0, 0.088], [0, -1, 0, 0], [0, 0, -1, 0.926], [0, 0, 0, 1.0]])


def poe(screws, q, M):
    T = np.eye(4)
    for S, qi in zip(screws, q):
        T = T @ twist_exp(S, qi)
    return T @ M


def test_panda_flange_equals_product_of_exponentials():
    robot = robots.load("panda", geometry=False)
    assert robot.nq == 7
    np.testing.assert_allclose(robot.fk(np.zeros(7), "panda_link8"), PANDA_HOME, atol=1e-12)
    for q in samples(robot, 2):
        np.testing.assert_allclose(robot.fk(q, "panda_link8"), poe(PANDA_SCREWS, q, PANDA_HOME), atol=ATOL)


def test_panda_document_screw_axes_differ_only_in_s4_offset_and_s7_direction():
    """S1-S3, S5, S6 of the document are the URDF's; S4 uses 0.088 for 0.0825 and S7 is reversed."""
    robot = robots.load("panda", geometry=False)
    J0 = robot.jacobian(np.zeros(7), "panda_link8", reference="spatial")
    screws_urdf = np.vstack([J0[3:], J0[:3]]).T  # rows (w, v): space-frame screw axes at home
    np.testing.assert_allclose(screws_urdf, PANDA_SCREWS, atol=1e-12)
    differ = [i + 1 for i in range(7) if not np.allclose(screws_urdf[i], PANDA_SCREWS_DOC[i], atol=1e-9)]
    assert differ == [4, 7]
    np.testing.assert_allclose(screws_urdf[6], -np.asarray(PANDA_SCREWS_DOC[6]), atol=1e-12)
    # with the document's axes the flange pose is off by ~cm as soon as joints move
    q = samples(robot, 7)[0]
    assert np.abs(poe(PANDA_SCREWS_DOC, q, PANDA_HOME) - robot.fk(q, "panda_link8")).max() > 1e-3


# ------------------------------------------------------------------------------ PR
@pytest.mark.parametrize("d2", [1.0, 0.7])
def test_pr_closed_form(d2):
    robot = robots.load("pr", geometry=False) if d2 == 1.0 else robots.load("pr", geometry=False, d2=d2)
    for d1, th in samples(robot, 3):
        T = robot.fk([d1, th])
        np.testing.assert_allclose(T[:3, 3], [d1 + d2 * math.cos(th), d2 * math.sin(th), 0.0], atol=ATOL)
        np.testing.assert_allclose(T[:3, :3], rot_z(th)[:3, :3], atol=ATOL)


# ---------------------------------------------------------------------------- SCARA
@pytest.mark.parametrize("a1,a2,base_z", [(0.5, 0.5, 1.0), (0.3, 0.7, 1.2)])
def test_scara_closed_form(a1, a2, base_z):
    params = {} if (a1, a2, base_z) == (0.5, 0.5, 1.0) else {"a1": a1, "a2": a2, "base_z": base_z}
    robot = robots.load("scara", geometry=False, **params)
    assert robot.lower[2] == 0.25 and robot.upper[2] == 1.0
    for t1, t2, d3, t4 in samples(robot, 4):
        T = robot.fk([t1, t2, d3, t4])
        p = [a1 * math.cos(t1) + a2 * math.cos(t1 + t2),
             a1 * math.sin(t1) + a2 * math.sin(t1 + t2), base_z - d3]
        np.testing.assert_allclose(T[:3, 3], p, atol=ATOL)
        phi = t1 + t2 - t4
        # tool x axis at yaw phi in the horizontal plane, tool z pointing down
        np.testing.assert_allclose(T[:3, 0], [math.cos(phi), math.sin(phi), 0.0], atol=ATOL)
        np.testing.assert_allclose(T[:3, 2], [0.0, 0.0, -1.0], atol=ATOL)


def test_scara_matches_dh_rows_through_from_dh():
    """The xacro model and robots.from_dh on the same DH table agree frame by frame."""
    scara = robots.load("scara", geometry=False)
    rows = [(0.5, 0, 0, 0), (0.5, math.pi, 0, 0), (0, 0, 0, 0), (0, 0, 0, 0)]
    twin = robots.from_dh(rows, "RRPR", scara.lower, scara.upper, base=trans(z=1.0), geometry=False)
    for q in samples(scara, 5)[:20]:
        for frame in ("link1", "link2", "link3", "link4", "tool"):
            np.testing.assert_allclose(scara.fk(q, frame), twin.fk(q, frame), atol=ATOL)


# ------------------------------------------------------------------------- planar 4R
@pytest.mark.parametrize("lengths", [(1.0, 0.8, 0.6, 0.4), (0.5, 1.5, 0.25, 0.75)])
def test_planar4r_sum_of_angles(lengths):
    params = {} if lengths == (1.0, 0.8, 0.6, 0.4) else dict(zip(("l1", "l2", "l3", "l4"), lengths))
    robot = robots.load("planar4r", geometry=False, **params)
    for q in samples(robot, 6):
        cum = np.cumsum(q)
        x = sum(length * math.cos(c) for length, c in zip(lengths, cum))
        y = sum(length * math.sin(c) for length, c in zip(lengths, cum))
        T = robot.fk(q)
        np.testing.assert_allclose(T[:3, 3], [x, y, 0.0], atol=ATOL)
        np.testing.assert_allclose(T[:3, :3], rot_z(cum[-1])[:3, :3], atol=ATOL)
