"""kinserve.viz.Animation: keyframes equal FK at the trajectory's q; tool attachment; planar bases."""

import numpy as np
import pytest

from kinserve import robots, viz
from kinserve.kinematics import InputError, se3
from kinserve.viz.animation import pose_at


@pytest.fixture(scope="module")
def panda():
    return robots.load("panda")


def trajectory(robot, n=25, seed=7):
    rng = np.random.default_rng(seed)
    a, b = robot.random_q(rng), robot.random_q(rng)
    s = 0.5 - 0.5 * np.cos(np.linspace(0, np.pi, n))
    return a + s[:, None] * (b - a)


def link_pose_from_fk(robot, q, g):
    frame = robot.model.frames[g.parentFrame]
    return robot.fk_all(q)[frame.name] @ np.linalg.inv(frame.placement.homogeneous) @ g.placement.homogeneous


def test_robot_keyframes_equal_fk(panda):
    scene = viz.Scene()
    base = se3.pose(se3.rot_z(-0.3), [0.2, 0.1, 0.0])
    arm = scene.add_robot(panda, name="arm", base=base)
    Q = trajectory(panda)
    anim = viz.Animation(scene, fps=20)
    frames = anim.robot("arm", Q, start=5, step=2)
    assert list(frames) == list(5 + 2 * np.arange(len(Q)))
    assert anim.n_frames == 5 + 2 * (len(Q) - 1) + 1
    assert anim.duration == pytest.approx((anim.n_frames - 1) / 20)
    anim.apply()
    cmd = scene.animation
    assert cmd["type"] == "set_animation" and cmd["options"] == {"play": True, "repetitions": 1}
    assert len(cmd["animations"]) == len(arm.nodes)
    for i in (0, 7, len(Q) - 1):
        for g in panda.visual_model.geometryObjects:
            path = arm.nodes[g.name]
            keyed = pose_at(cmd, path, int(frames[i]))          # relative to the robot root (the base)
            np.testing.assert_allclose(keyed, link_pose_from_fk(panda, Q[i], g), atol=1e-6)
            np.testing.assert_allclose(anim.world_pose(path, int(frames[i])),
                                       base @ link_pose_from_fk(panda, Q[i], g), atol=1e-6)
    for entry in cmd["animations"]:
        clip = entry["clip"]
        assert clip["fps"] == 20
        for track in clip["tracks"]:
            times = [k["time"] for k in track["keys"]]
            assert times == sorted(times) and times[-1] == anim.n_frames - 1
            if track["name"] == ".quaternion":   # no sign flips between consecutive keys
                V = np.array([k["value"] for k in track["keys"]])
                assert (np.sum(V[1:] * V[:-1], axis=1) >= 0).all()


def test_attached_object_follows_the_tool_between_grasp_and_release(panda):
    scene = viz.Scene()
    base = se3.pose(se3.rot_z(0.5), [0.0, 0.3, 0.1])
    scene.add_robot(panda, name="arm", base=base)
    Q = trajectory(panda, n=30, seed=3)
    grasp, release = 8, 21
    tool = np.array([base @ panda.fk(q) for q in Q])
    # the object starts exactly in the gripper at the grasp step, offset along the tool z axis
    offset = se3.pose(se3.rot_x(0.3), [0.0, 0.0, 0.05])
    T0 = tool[grasp] @ offset
    scene.add_cylinder("can", 0.02, 0.06, T0)
    anim = viz.Animation(scene)
    anim.robot("arm", Q)
    world = anim.attach("can", "arm", grasp=grasp, release=release)
    for k in range(len(Q)):
        if k < grasp:
            np.testing.assert_allclose(world[k], T0, atol=1e-9)
        elif k <= release:
            np.testing.assert_allclose(np.linalg.solve(tool[k], world[k]), offset, atol=1e-9)
        else:
            np.testing.assert_allclose(world[k], tool[release] @ offset, atol=1e-9)
        np.testing.assert_allclose(anim.world_pose("can", k), world[k], atol=1e-9)
    anim.apply()
    np.testing.assert_allclose(pose_at(scene.animation, "/meshcat/can", len(Q) - 1),
                               tool[release] @ offset, atol=1e-6)


def test_attach_under_a_transformed_parent(panda):
    scene = viz.Scene()
    scene.add_robot(panda)
    table = se3.pose(se3.rot_z(1.0), [0.5, 0.0, 0.2])
    scene["table"].set_transform(table)
    scene.add_box("table/part", [0.04, 0.04, 0.04], [0.1, 0.0, 0.0])
    Q = trajectory(panda, n=12)
    anim = viz.Animation(scene)
    anim.robot("panda", Q)
    world = anim.attach("table/part", "panda", grasp=3, release=9)
    np.testing.assert_allclose(world[0], table @ se3.pose(p=[0.1, 0, 0]), atol=1e-12)
    for k in range(12):  # keys are relative to the parent: world = table @ key
        np.testing.assert_allclose(table @ anim.local_pose("table/part", k), world[k], atol=1e-9)


def test_planar_base_on_a_map():
    scene = viz.Scene()
    scene.add_map("map", [viz.Circle(240, 240, 40)], (0, 0, 480, 480), scale=0.01)
    scene.add_box("map/robot", [20, 20, 10], [0, 0, 5])
    t = np.linspace(0, 1, 11)
    X = np.c_[260 + 100 * t, 60 + 110 * t, np.full_like(t, np.arctan2(110, 100))]
    anim = viz.Animation(scene, fps=10)
    anim.planar("map/robot", X, z=5.0)
    for k in (0, 4, 10):
        W = anim.world_pose("map/robot", k)
        np.testing.assert_allclose(W[:3, 3], 0.01 * np.array([X[k, 0], X[k, 1], 5.0]), atol=1e-12)
        np.testing.assert_allclose(W[:3, :3] / 0.01, se3.rot_z(X[k, 2]), atol=1e-12)
    anim.apply(repetitions=3)
    assert scene.animation["options"]["repetitions"] == 3
    np.testing.assert_allclose(pose_at(scene.animation, "/meshcat/map/robot", 4)[:2, 3], X[4, :2], atol=1e-4)


def test_invalid_animation_input(panda):
    scene = viz.Scene()
    scene.add_robot(panda)
    anim = viz.Animation(scene)
    with pytest.raises(InputError, match="no robot"):
        anim.robot("ghost", np.zeros((2, 7)))
    with pytest.raises(InputError, match="Q"):
        anim.robot("panda", np.zeros((2, 5)))
    with pytest.raises(InputError, match="no such node"):
        anim.planar("nothing", np.zeros((3, 3)))
    with pytest.raises(InputError, match="keyed trajectory"):
        anim.attach("panda", "panda", 0, 1)
    with pytest.raises(InputError, match="keyframes"):
        anim.apply()
    with pytest.raises(InputError, match="fps"):
        viz.Animation(scene, fps=0)
    anim.robot("panda", trajectory(panda, n=5))
    scene.add_sphere("s", [0, 0, 0], 0.01)
    with pytest.raises(InputError, match="grasp"):
        anim.attach("s", "panda", grasp=4, release=2)


@pytest.mark.parametrize("play, repetitions, message", [
    ("no", 1, "play must be True or False"), (0, 1, "play must be True or False"),
    (True, 0, "repetitions must be an integer from 1"), (True, 2.5, "repetitions must be an integer"),
    (True, "3", "repetitions must be an integer"), (True, 10**7, "repetitions must be an integer from 1"),
])
def test_apply_refuses_a_play_or_repetitions_it_would_misread(play, repetitions, message):
    """``play="no"`` played the animation and ``repetitions=2.5`` repeated it twice (``bool`` / ``int``
    casts); each is now refused by name, and nothing is recorded."""
    scene = viz.Scene()
    scene.add_box("box", [0.1, 0.1, 0.1])
    anim = viz.Animation(scene)
    anim.key("box", 0, np.eye(4))
    anim.key("box", 3, se3.pose(np.eye(3), [0.5, 0.0, 0.0]))
    with pytest.raises(InputError, match=message):
        anim.apply(play=play, repetitions=repetitions)
    assert scene.animation is None
    anim.apply(play=np.False_, repetitions=np.int64(3))
    assert scene.animation["options"] == {"play": False, "repetitions": 3}
