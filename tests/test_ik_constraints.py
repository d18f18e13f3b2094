"""kinserve.ik.constraints: sphere validation, the link segments (links, quill, tool, frame points),
clearances against dense sampling and their gradients against finite differences."""

import numpy as np
import pinocchio as pin
import pytest

from kinserve import ik, robots
from kinserve.ik.constraints import ObstacleAvoidance, as_sphere, robot_segments
from kinserve.kinematics.errors import FrameError, InputError, NonFiniteError, ShapeError

from segment_clearance import rows_and_finite_differences, sampled_clearance


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


def _margin(avoid, robot, q):
    pin.forwardKinematics(robot.model, robot.data, q)
    return avoid.margin(robot, robot.data, q)


def test_scara_segments_cover_links_quill_and_tool():
    scara = robots.load("scara", geometry=False)
    names = [s.name for s in robot_segments(scara, "tool")]
    assert any(n.startswith("slider joint3") for n in names)  # the quill of the prismatic joint
    assert names[-1] == "tool tool"
    # the quill spans from the arm (z = 1) down to the tool: a sphere it crosses is detected
    q = np.array([0.0, 0.0, 0.8, 0.0])  # tool at (1, 0, 0.2)
    sphere = ik.Sphere((1.0, 0.0, 0.6), 0.05)
    avoid = ObstacleAvoidance([sphere], tool_frames="tool").bind(scara)
    assert _margin(avoid, scara, q) < 0
    assert _margin(avoid, scara, q) == pytest.approx(sampled_clearance(scara, q, "tool", sphere), abs=1e-6)
    only_tool = ObstacleAvoidance([ik.Sphere((1.0, 0.0, 0.6), 0.05, frames=["tool"])],
                                  tool_frames="tool").bind(scara)
    assert _margin(only_tool, scara, q) == pytest.approx(0.4 - 0.05)


def test_sphere_containing_the_base_or_an_unknown_frame_is_rejected():
    panda = robots.load("panda", geometry=False)
    with pytest.raises(InputError, match="base"):
        ObstacleAvoidance([ik.Sphere((0, 0, 0.1), 0.2)], tool_frames="panda_hand").bind(panda)
    with pytest.raises(FrameError):
        ObstacleAvoidance([ik.Sphere((1, 1, 1), 0.1, frames=["nope"])], tool_frames="panda_hand").bind(panda)


def test_ur5_sphere_clearance_and_gradient_against_independent_code():
    """Clearances against dense sampling, rows against central finite differences of the true clearance."""
    robot = robots.load("ur5", geometry=False)
    rng = np.random.default_rng(4)
    spheres = [ik.Sphere((0.3, -0.4, 0.6), 0.05), ik.Sphere((-0.2, 0.3, 0.9), 0.1)]
    avoid = ObstacleAvoidance(spheres, tool_frames=robot.tip).bind(robot)
    checked = 0
    for q in robot.random_q(rng, 6):
        ref = min(sampled_clearance(robot, q, robot.tip, s, n=2001) for s in spheres)
        assert _margin(avoid, robot, q) == pytest.approx(ref, abs=1e-6)
        c, G, fd = rows_and_finite_differences(robot, avoid, q, 1e-6)
        ok = c > 1e-3  # the distance to a segment is continuously differentiable away from contact
        assert np.allclose(G[ok], fd[ok], atol=1e-6)
        checked += int(ok.sum())
    assert checked >= 6 * 2 * 5
