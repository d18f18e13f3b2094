"""kinserve.viz.Scene: recorded nodes and transforms against FK computed independently."""

import numpy as np
import pinocchio as pin
import pytest
import umsgpack

from kinserve import robots, viz
from kinserve.kinematics import InputError, Robot, RotationError, se3
from kinserve.viz.scene import CAMERA_FOV_DEG


@pytest.fixture(scope="module")
def panda():
    return robots.load("panda")


def expected_geometry_pose(robot: Robot, q, g: pin.GeometryObject) -> np.ndarray:
    """World pose of a geometry object from ``fk_all``: the parent frame's pose, back to its
    joint (frame.placement is joint -> frame), then the geometry's joint-relative placement."""
    frame = robot.model.frames[g.parentFrame]
    T_frame = robot.fk_all(q)[frame.name]
    return T_frame @ np.linalg.inv(frame.placement.homogeneous) @ g.placement.homogeneous


def floats(ext) -> np.ndarray:
    """Decode a meshcat packed Float32Array (msgpack Ext)."""
    return np.frombuffer(ext.data, dtype=np.float32)


def test_panda_links_are_drawn_with_meshes_at_fk(panda, rng):
    scene = viz.Scene()
    q = panda.random_q(rng)
    arm = scene.add_robot(panda, q)
    assert arm.missing == []
    names = [g.name for g in panda.visual_model.geometryObjects]
    assert sorted(arm.nodes) == sorted(names)
    for g in panda.visual_model.geometryObjects:
        path = arm.nodes[g.name]
        obj = scene.object(path)
        assert obj is not None
        assert obj["object"]["object"]["type"] == "_meshfile_object"
        assert obj["object"]["object"]["format"] == "dae"
        scale = np.diag(np.r_[g.meshScale, 1.0])
        np.testing.assert_allclose(scene.world_transform(path),
                                   expected_geometry_pose(panda, q, g) @ scale, atol=1e-9)


def test_base_pose_and_set_q_move_every_link(panda, rng):
    scene = viz.Scene()
    base = se3.pose(se3.rot_z(0.7) @ se3.rot_x(0.2), [1.0, -0.5, 0.3])
    arm = scene.add_robot(panda, panda.neutral(), name="arm", base=base)
    q = panda.random_q(rng)
    arm.set_q(q)
    assert arm.root == "/meshcat/arm"
    np.testing.assert_allclose(scene.transform("arm"), base)
    for g in panda.visual_model.geometryObjects:
        expected = base @ expected_geometry_pose(panda, q, g)
        np.testing.assert_allclose(scene.world_transform(arm.nodes[g.name]), expected, atol=1e-9)
    # the tool pose helper is base * FK
    np.testing.assert_allclose(arm.tool_pose(q), base @ panda.fk(q), atol=1e-12)
    # set_q replaced the transforms: one set_transform per node in the replay
    paths = [c["path"] for c in scene.commands() if c["type"] == "set_transform"]
    assert len(paths) == len(set(paths))


def test_primitive_visuals_of_seed_robot(rng):
    arm = robots.load("planar4r")
    scene = viz.Scene()
    q = arm.random_q(rng)
    handle = scene.add_robot(arm, q)
    kinds = {scene.object(p)["object"]["geometries"][0]["type"] for p in handle.nodes.values()}
    assert kinds <= {"CylinderGeometry", "BoxGeometry", "SphereGeometry"} and kinds
    for g in arm.visual_model.geometryObjects:
        np.testing.assert_allclose(scene.world_transform(handle.nodes[g.name])[:3, 3],
                                   expected_geometry_pose(arm, q, g)[:3, 3], atol=1e-9)


def test_skeleton_for_robot_without_visuals(panda, rng):
    bare = Robot(panda.model, tip=panda.tip, name="bare")
    scene = viz.Scene()
    q = bare.random_q(rng)
    handle = scene.add_robot(bare, q)
    data = bare.model.createData()
    pin.forwardKinematics(bare.model, data, q)
    for j in range(1, bare.model.njoints):
        name = bare.model.names[j]
        ball = scene.world_transform(handle.nodes[f"skeleton_joint_{name}"])
        np.testing.assert_allclose(ball[:3, 3], data.oMi[j].translation, atol=1e-9)
        seg = handle.nodes.get(f"skeleton_link_{name}")
        if seg is None:  # coincident joint origins draw no link
            assert np.linalg.norm(bare.model.jointPlacements[j].translation) < 1e-6
            continue
        T = scene.world_transform(seg)
        h = scene.object(seg)["object"]["geometries"][0]["height"]
        ends = {tuple(np.round(T[:3, 3] + s * 0.5 * h * T[:3, 2], 9)) for s in (-1, 1)}
        parent = data.oMi[bare.model.parents[j]].translation
        assert any(np.allclose(e, parent, atol=1e-9) for e in ends)
        assert any(np.allclose(e, data.oMi[j].translation, atol=1e-9) for e in ends)
    tip = scene.world_transform(handle.nodes[f"skeleton_tip_{bare.tip}"])
    np.testing.assert_allclose(tip[:3, 3], bare.fk(q)[:3, 3], atol=1e-9)


def test_triad_axes_follow_the_pose():
    scene = viz.Scene()
    T = se3.pose(se3.rot_z(0.4) @ se3.rot_y(-0.9), [0.3, 0.2, 0.5])
    path = scene.add_frame("target", T, length=0.2)
    assert path == "/meshcat/target"
    np.testing.assert_allclose(scene.world_transform("target"), T)
    for k, axis in enumerate("xyz"):
        W = scene.world_transform(f"target/{axis}")
        # the cylinder's own axis (local z) lies along the frame's axis k, centred half a length out
        np.testing.assert_allclose(W[:3, 2], T[:3, k], atol=1e-12)
        np.testing.assert_allclose(W[:3, 3], T[:3, 3] + 0.1 * T[:3, k], atol=1e-12)
        geom = scene.object(f"target/{axis}")["object"]
        assert (geom["geometries"][0]["type"] == "CylinderGeometry"
                and geom["geometries"][0]["height"] == pytest.approx(0.2))
        # the intrinsic matrix turns three.js's y-axis cylinder onto z
        M = np.array(geom["object"]["matrix"]).reshape(4, 4)
        np.testing.assert_allclose(M[:3, :3] @ [0, 1, 0], [0, 0, 1], atol=1e-12)


def test_sphere_box_cylinder_path_points():
    scene = viz.Scene()
    scene.add_sphere("ball", [0.4, -0.7, 0.5], 0.2, color="red", opacity=0.5)
    obj = scene.object("ball")["object"]
    assert obj["geometries"][0] == {**obj["geometries"][0], "type": "SphereGeometry", "radius": 0.2}
    assert obj["materials"][0]["transparent"] is True and obj["materials"][0]["opacity"] == 0.5
    assert obj["materials"][0]["color"] == viz.colors.NAMED["red"]
    np.testing.assert_allclose(scene.transform("ball")[:3, 3], [0.4, -0.7, 0.5])

    scene.add_box("box", [0.2, 0.3, 0.4], [0.5, 0.5, 0.1])
    assert scene.object("box")["object"]["geometries"][0]["width"] == pytest.approx(0.2)
    np.testing.assert_allclose(scene.transform("box")[:3, 3], [0.5, 0.5, 0.1])

    T = se3.pose(se3.rot_x(0.5), [0.7, 0.1, 0.0])
    scene.add_cylinder("can", 0.03, 0.05, T)
    np.testing.assert_allclose(scene.transform("can"), T)

    pts = np.array([[0, 0, 0], [0.1, 0.2, 0.3], [0.5, 0.5, 0.5]])
    scene.add_path("tool/path", pts, markers=0.01)
    line = scene.object("tool/path")["object"]
    assert line["object"]["type"] == "Line"
    np.testing.assert_allclose(_positions(line), pts, atol=1e-7)
    assert len([p for p in scene.paths() if p.startswith("/meshcat/tool/path/m")]) == 3
    # planar points are drawn on z = 0
    scene.add_path("flat", [[0, 0], [1, 1]])
    np.testing.assert_allclose(_positions(scene.object("flat")["object"]), [[0, 0, 0], [1, 1, 0]], atol=1e-7)
    cloud = np.random.default_rng(0).uniform(size=(10, 3))
    scene.add_points("cloud", cloud, size=0.02)
    np.testing.assert_allclose(_positions(scene.object("cloud")["object"]), cloud, atol=1e-6)


def _positions(obj) -> np.ndarray:
    """Points of a meshcat BufferGeometry: meshcat packs the (3, N) array column-major."""
    attr = obj["geometries"][0]["data"]["attributes"]["position"]
    assert attr["itemSize"] == 3
    return floats(attr["array"]).reshape(-1, 3)


def test_map_is_scaled_and_complete():
    scene = viz.Scene()
    obstacles = [viz.Rect(220, 100, 260, 140, "hotdog"), {"circle": [240, 240, 40]},
                 {"min": [135, 375], "max": [185, 425]}]
    mask = np.zeros((48, 48), dtype=bool)
    mask[0, 0:5] = True      # one run
    mask[3, 2:4] = True      # another
    mask[3, 10:12] = True    # and a third on the same row
    root = scene.add_map("mall", obstacles, (0, 0, 480, 480), paths={"leg 1": [[260, 60], [360, 170]]},
                         waypoints={"start": (260, 60), "end": (230, 430)},
                         coverage=viz.Grid(mask, (0, 0), 10.0), inflate=10, scale=0.01)
    assert root == "/meshcat/mall"
    np.testing.assert_allclose(scene.transform("mall"), np.diag([0.01, 0.01, 0.01, 1]))
    assert len([p for p in scene.paths() if p.startswith("/meshcat/mall/obstacles/")]) == 3
    assert len([p for p in scene.paths() if p.startswith("/meshcat/mall/inflated/")]) == 3
    # the hot-dog stand: a 40 x 40 box centred at (240, 120) map units = (2.4, 1.2) m
    np.testing.assert_allclose(scene.world_transform("mall/obstacles/hotdog")[:2, 3], [2.4, 1.2])
    box = scene.object("mall/obstacles/hotdog")["object"]["geometries"][0]
    assert (box["width"], box["height"]) == (40, 40)
    # the circle is a z-axis cylinder of radius 40 (inflated: 50)
    assert scene.object("mall/obstacles/1")["object"]["geometries"][0]["radiusTop"] == 40
    assert scene.object("mall/inflated/1")["object"]["geometries"][0]["radiusTop"] == 50
    # coverage: two triangles per merged row run
    cov = scene.object("mall/coverage")["object"]["geometries"][0]["data"]
    # 3 runs x 2 triangles x 3 indices
    assert len(np.frombuffer(cov["index"]["array"].data, np.uint32)) == 3 * 2 * 3
    corners = _positions(scene.object("mall/coverage")["object"])
    # runs [0, 50], [20, 40], [100, 120]
    np.testing.assert_allclose(sorted(set(corners[:, 0])), [0, 20, 40, 50, 100, 120])
    P = _positions(scene.object("mall/paths/leg 1")["object"])
    np.testing.assert_allclose(P[:, :2], [[260, 60], [360, 170]])
    np.testing.assert_allclose(scene.world_transform("mall/waypoints/end")[:2, 3], [2.3, 4.3])


def test_grid_rectangles_cover_exactly_the_true_cells():
    rng = np.random.default_rng(3)
    mask = rng.uniform(size=(20, 30)) < 0.4
    grid = viz.Grid(mask, origin=(-5.0, 2.0), cell=0.5)
    rebuilt = np.zeros_like(mask)
    for r in grid.rectangles():
        i = int(round((r.ymin - 2.0) / 0.5))
        j0, j1 = int(round((r.xmin + 5.0) / 0.5)), int(round((r.xmax + 5.0) / 0.5))
        assert r.ymax - r.ymin == pytest.approx(0.5)
        assert not rebuilt[i, j0:j1].any()
        rebuilt[i, j0:j1] = True
    assert (rebuilt == mask).all()
    assert grid.extent == (-5.0, 10.0, 2.0, 12.0)


def test_auto_camera_sees_everything(panda):
    scene = viz.Scene()
    scene.add_robot(panda, panda.neutral())
    scene.add_sphere("far", [1.5, -1.0, 0.2], 0.1)
    eye, target = scene.camera()
    # every drawn point is inside a 4:3 window: within the vertical field of view, and
    # horizontally within aspect * tan(fov/2) (a pyramid, not a cone)
    f = (target - eye) / np.linalg.norm(target - eye)
    r = np.cross(f, [0, 0, 1.0])
    r /= np.linalg.norm(r)
    u = np.cross(r, f)
    t = np.tan(np.radians(CAMERA_FOV_DEG / 2))
    d = scene.drawn_points() - eye
    lo, hi = scene.bounds()
    assert np.allclose(d.min(axis=0) + eye, lo) and np.allclose(d.max(axis=0) + eye, hi)
    depth = d @ f
    assert np.all(depth > 0)
    assert np.all(np.abs(d @ u) / depth < t) and np.all(np.abs(d @ r) / depth < 4 / 3 * t)
    # meshcat aims at its world origin: the drawing and the grid are shifted by -target, and the
    # camera (inside the y-up "rotated" node, Rx(90 deg)) sits at eye - target
    cmds = {c["path"]: c for c in scene.camera_commands()}
    for path in ("/meshcat", "/Grid", "/Axes"):
        np.testing.assert_allclose(np.array(cmds[path]["matrix"]).reshape(4, 4).T, se3.pose(p=-target))
    np.testing.assert_allclose(np.array(cmds["/Cameras/default"]["matrix"]).reshape(4, 4), np.eye(4))
    Rx = se3.rot_x(np.pi / 2)
    shifted_eye = Rx @ cmds["/Cameras/default/rotated/<object>"]["value"]
    np.testing.assert_allclose(shifted_eye, eye - target, atol=1e-12)
    assert scene.transform("/meshcat") is not None and np.allclose(scene.transform("/meshcat"), np.eye(4))
    scene.set_camera([2, 0, 1], [0, 0, 0.5])
    np.testing.assert_allclose(scene.camera()[0], [2, 0, 1])


def test_replay_order_and_delete(panda):
    scene = viz.Scene(grid=False)
    scene.add_robot(panda)
    scene.add_sphere("s", [0, 0, 1], 0.1)
    cmds = scene.commands()
    first = {}
    tree = cmds[: len(cmds) - len(scene.camera_commands())]
    for i, c in enumerate(tree):
        first.setdefault((c["type"], c["path"]), i)
    for (kind, path), i in first.items():
        if kind == "set_transform" and ("set_object", path) in first:
            assert first[("set_object", path)] < i  # a node's object, then its transform
        parent = path.rsplit("/", 1)[0]
        if (kind, parent) in first:
            assert first[(kind, parent)] < i  # parents before children
    assert cmds[-len(scene.camera_commands()):] == scene.camera_commands()  # camera last (no animation here)
    assert {"type": "set_property", "path": "/Grid", "property": "visible", "value": False} in cmds
    # every command survives msgpack as meshcat's server would send it
    for c in cmds:
        umsgpack.packb(c)
    scene.delete("panda")
    assert "panda" not in scene.robots and "/meshcat/panda" not in scene
    assert scene.paths() == ["/meshcat/s"]


def test_invalid_input_is_rejected(panda):
    scene = viz.Scene()
    with pytest.raises(InputError, match="color"):
        scene.add_sphere("s", [0, 0, 0], 0.1, color="not-a-colour")
    with pytest.raises(InputError, match="radius"):
        scene.add_sphere("s", [0, 0, 0], -1.0)
    with pytest.raises(InputError, match="opacity"):
        scene.add_box("b", [1, 1, 1], color="grey", opacity=0.0)
    with pytest.raises(RotationError):
        scene.add_frame("f", np.diag([2.0, 1, 1, 1]))
    with pytest.raises(InputError, match="center"):
        scene.add_sphere("s", [0, 0], 0.1)
    with pytest.raises(InputError):
        scene.add_path("p", np.zeros((3, 4)))
    scene.add_robot(panda)
    with pytest.raises(InputError, match="already"):
        scene.add_robot(panda)
    with pytest.raises(InputError, match="q"):
        scene.robots["panda"].set_q(np.zeros(3))
    with pytest.raises(InputError, match="obstacle"):
        scene.add_map("m", [object()], (0, 0, 1, 1))
    with pytest.raises(InputError, match="bounds"):
        scene.add_map("m", [], None)


def test_mobile_base_heading_marker_points_forward():
    scene = viz.Scene()
    scene.add_map("map", [], (0, 0, 480, 480), scale=0.01)
    path = scene.add_mobile_base("map/base", size=(20, 16, 8),
                                 pose=se3.pose(se3.rot_z(np.pi / 2), [100, 50, 0]))
    assert path == "/meshcat/map/base"
    body = scene.world_transform("map/base/body")
    nose = scene.world_transform("map/base/nose")
    np.testing.assert_allclose(body[:2, 3], [1.0, 0.5])  # map units scaled to metres
    heading = nose[:2, 3] - body[:2, 3]
    # x forward, turned by 90 deg
    np.testing.assert_allclose(heading / np.linalg.norm(heading), [0.0, 1.0], atol=1e-12)
    assert scene.object("map/base/body")["object"]["geometries"][0]["depth"] == 8


def test_floor_grid_covers_the_scene_with_a_nice_spacing(panda):
    scene = viz.Scene()
    scene.add_robot(panda)
    scene.add_sphere("far", [1.2, -0.9, 0.1], 0.05)
    segments, step = scene.floor_grid()
    lo, hi = scene.bounds()
    span = max(hi[0] - lo[0], hi[1] - lo[1])
    mantissa = step / 10 ** np.floor(np.log10(step))
    assert min(abs(mantissa - m) for m in (1, 2, 5)) < 1e-9 and span / 16 <= step < 2.5 * span / 16
    assert np.allclose(segments[:, 2], 0.0)
    assert segments[:, 0].min() <= lo[0] and segments[:, 0].max() >= hi[0]
    assert segments[:, 1].min() <= lo[1] and segments[:, 1].max() >= hi[1]
    # every line sits on a multiple of the spacing
    xs = segments[0::4, 0]
    np.testing.assert_allclose(xs / step, np.round(xs / step), atol=1e-9)
    grid_cmd = next(c for c in scene.commands() if c["type"] == "set_object" and c["path"] == "/Grid")
    assert grid_cmd["object"]["object"]["type"] == "LineSegments"
    assert "/Grid" not in [c["path"] for c in viz.Scene(grid=False).commands() if c["type"] == "set_object"]


def test_for_robot_shows_the_tool_frame(rng):
    arm = robots.load("youbot")
    q = arm.random_q(rng)
    base = se3.pose(se3.rot_z(0.3), [0.5, 0.0, 0.1])
    scene = viz.Scene.for_robot(arm, q, base=base, frame_length=0.05)
    assert scene.title == "youbot" and list(scene.robots) == ["youbot"]
    np.testing.assert_allclose(scene.world_transform("tool"), base @ arm.fk(q), atol=1e-12)
    np.testing.assert_allclose(scene.robots["youbot"].q, q)


def test_commands_are_deterministic(panda):
    scene = viz.Scene()
    scene.add_robot(panda)
    assert scene.commands() == scene.commands()


def test_box_and_cylinder_take_every_pose_form():
    """A box or cylinder pose may be a point, a 4x4, (position, quaternion [x, y, z, w]) or a 7-vector: the
    drawn transform is the 4x4 that scipy's rotation of the quaternion gives."""
    from scipy.spatial.transform import Rotation

    quat = np.array([0.1, -0.3, 0.2, 0.9]) / np.linalg.norm([0.1, -0.3, 0.2, 0.9])
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = Rotation.from_quat(quat).as_matrix(), [0.3, -0.2, 0.5]
    scene = viz.Scene()
    for k, pose in enumerate(([0.3, -0.2, 0.5], T, (T[:3, 3], quat), np.r_[T[:3, 3], quat])):
        scene.add_box(f"box{k}", [0.1, 0.2, 0.3], pose)
        scene.add_cylinder(f"can{k}", 0.05, 0.2, pose)
        expected = se3.pose(None, T[:3, 3]) if k == 0 else T
        np.testing.assert_allclose(scene.transform(f"box{k}"), expected, atol=1e-12)
        np.testing.assert_allclose(scene.transform(f"can{k}"), expected, atol=1e-12)
    with pytest.raises(InputError, match="pose"):
        scene.add_box("bad", [0.1, 0.1, 0.1], ([0.1, 0.2], quat))


def test_sweep_points_frames_a_moving_node_at_every_pose():
    """The camera points of a node drawn in its own frame become its corners under each pose given."""
    scene = viz.Scene()
    scene.add_box("carried/shape", [0.2, 0.4, 0.6])
    scene.add_sphere("still", [5.0, 0.0, 0.0], 0.1)
    poses = np.stack([se3.pose(se3.rot_z(a), [a, 1.0, 2.0]) for a in (0.0, 0.5, 1.0)])
    before = len(scene.drawn_points())
    scene.sweep_points("carried", poses)
    corners = np.array([0.5 * np.array([0.2, 0.4, 0.6]) * (2 * np.array(i) - 1) for i in np.ndindex(2, 2, 2)])
    expected = np.concatenate([corners @ T[:3, :3].T + T[:3, 3] for T in poses])
    drawn = scene.drawn_points()
    for p in expected:
        assert np.min(np.linalg.norm(drawn - p, axis=1)) < 1e-12
    assert np.min(np.linalg.norm(drawn - [5.0, 0.0, 0.0], axis=1)) < 0.2  # other nodes untouched
    assert len(drawn) == before - 8 + 3 * 8  # the box's 8 corners became 8 per pose


@pytest.mark.parametrize("value", ["no", 0, None])
def test_viz_flags_must_be_true_or_false(value):
    """The scene's switches, the export's compression, the plots' log axis and a drawn robot's ``world``
    were read by truthiness (``grid="no"`` showed the grid); each now names the flag."""
    import numpy as np

    from kinserve import robots, viz
    from kinserve.kinematics.errors import InputError

    arm = robots.load("planar4r", geometry=False)
    scene = viz.Scene()
    scene.add_robot(arm, name="arm")
    drawn = scene.robots["arm"]
    calls = {"grid": lambda v: viz.Scene(grid=v), "axes": lambda v: viz.Scene(axes=v),
             "tool_frame": lambda v: viz.Scene.for_robot(arm, tool_frame=v),
             "collision": lambda v: viz.Scene.for_robot(arm, collision=v),
             "collisions": lambda v: viz.Scene().add_robot(arm, collisions=v),
             "compress": lambda v: viz.static_html(viz.Scene(), compress=v),
             "logy": lambda v: viz.errors_figure(np.arange(3), {"e": np.ones(3)}, logy=v),
             "world": lambda v: drawn.geometry_poses(arm.neutral(), world=v)}
    for flag, call in calls.items():
        with pytest.raises(InputError, match=f"{flag} must be True or False"):
            call(value)
    assert viz.Scene(grid=np.False_).grid is False


@pytest.mark.parametrize("name, message", [
    (np.zeros(0), "name must be a str or None"), (0, "name must be a str or None, got 0"),
    (3.5, "name must be a str or None, got 3.5"),
])
def test_add_robot_name_must_be_text(name, message):
    """``add_robot(name=np.zeros(0))`` raised NumPy's ambiguous-truth error and ``name=0`` drew the robot
    under its own name; a name that is not a str is refused and the scene is left unchanged."""
    arm = robots.load("planar4r", geometry=False)
    scene = viz.Scene()
    with pytest.raises(InputError, match=message):
        scene.add_robot(arm, name=name)
    assert scene.robots == {}
    assert scene.add_robot(arm, name="arm").name == "arm"
