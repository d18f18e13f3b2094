"""kinserve.ik.constraints: sphere validation, segment geometry, clearance gradients against finite differences."""

import numpy as np
import pytest

from kinserve import ik
from kinserve import robots
from kinserve.ik.constraints import SphereSet, as_sphere, joint_step_bounds, robot_segments
from kinserve.kinematics.errors import FrameError, InputError, NonFiniteError, ShapeError


def test_sphere_validation():
    s = ik.Sphere([0.4, -0.7, 0.5], 0.2)
    assert s.center == (0.4, -0.7, 0.5) and s.radius == 0.2 and s.frames is None
    assert s.distance((0.4, -0.7, 0.0)) == pytest.approx(0.5)
    with pytest.raises(InputError, match="positive"):
        ik.Sphere((0, 0, 0), -0.1)
    with pytest.raises(InputError):
        ik.Sphere((0, 0, 0), 0.0)
    with pytest.raises(NonFiniteError):
        ik.Sphere((0, np.nan, 0), 0.1)
    with pytest.raises(NonFiniteError):
        ik.Sphere((0, 0, 0), np.inf)
    with pytest.raises(ShapeError):
        ik.Sphere((0, 0), 0.1)
    with pytest.raises(ShapeError):
        ik.Sphere((0, 0, 0), "big")
    with pytest.raises(InputError):
        ik.Sphere((0, 0, 0), 0.1, frames=[1, 2])
    assert as_sphere(((1, 2, 3), 0.5)) == ik.Sphere((1, 2, 3), 0.5)
    assert as_sphere({"center": (1, 2, 3), "radius": 0.5, "frames": ["tool"]}).frames == ("tool",)
    with pytest.raises(InputError):
        as_sphere(5)


def test_joint_step_bounds():
    lo, hi = np.array([-1.0, 0.0]), np.array([1.0, 2.0])
    lb, ub = joint_step_bounds(np.array([0.5, 0.0]), lo, hi, 0.3)
    assert np.allclose(lb, [-0.3, 0.0]) and np.allclose(ub, [0.3, 0.3])


def test_scara_segments_cover_links_quill_and_tool():
    scara = robots.load("scara", geometry=False)
    names = [s.name for s in robot_segments(scara, "tool")]
    assert any(n.startswith("slider joint3") for n in names)  # the quill of the prismatic joint
    assert names[-1] == "tool tool"
    # the quill spans from the arm (z = 1) down to the tool: a sphere it crosses is detected
    q = np.array([0.0, 0.0, 0.8, 0.0])  # tool at (1, 0, 0.2)
    sset = SphereSet(scara, [ik.Sphere((1.0, 0.0, 0.6), 0.05)], "tool")
    assert sset.clearances_at(q).min() < 0
    only_tool = SphereSet(scara, [ik.Sphere((1.0, 0.0, 0.6), 0.05, frames=["tool"])], "tool")
    assert only_tool.clearances_at(q).min() == pytest.approx(0.4 - 0.05)


def test_sphere_containing_the_base_or_an_unknown_frame_is_rejected():
    panda = robots.load("panda", geometry=False)
    with pytest.raises(InputError, match="base"):
        SphereSet(panda, [ik.Sphere((0, 0, 0.1), 0.2)], "panda_hand")
    with pytest.raises(FrameError):
        SphereSet(panda, [ik.Sphere((1, 1, 1), 0.1, frames=["nope"])], "panda_hand")


@pytest.mark.parametrize("name", ["panda", "scara", "ur5"])
def test_clearance_gradient_matches_finite_differences(name):
    robot = robots.load(name, geometry=False)
    rng = np.random.default_rng(4)
    sset = SphereSet(robot, [ik.Sphere((0.3, -0.4, 0.6), 0.05), ik.Sphere((-0.2, 0.3, 0.9), 0.1)], robot.tip)
    import pinocchio as pin

    checked = 0
    for q in robot.random_q(rng, 6):
        pin.computeJointJacobians(robot.model, robot.data, q)
        clear, G = sset.rows(robot.data)
        assert np.allclose(clear, sset.clearances_at(q))
        h = 1e-6
        fd = np.zeros_like(G)
        for i in range(robot.nq):
            dq = np.zeros(robot.nq)
            dq[i] = h
            fd[:, i] = (sset.clearances_at(q + dq) - sset.clearances_at(q - dq)) / (2 * h)
        # the distance to a segment (a convex set) is continuously differentiable outside it
        assert np.allclose(fd, G, atol=1e-6)
        checked += len(G)
    assert checked >= 6 * 2 * 5
