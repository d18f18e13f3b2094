"""Bad input to the service settings, the CLI's frames and seeds, scene YAML, viz animations and the
top-level helpers: each is a kinserve error (or a one-line CLI error) naming what was wrong."""

from __future__ import annotations

import numpy as np
import pytest

import kinserve
from kinserve import robots, viz
from kinserve.ik.batch.reachability import reachability_map
from kinserve.kinematics.errors import InputError, NonFiniteError, ShapeError
from kinserve.planners.motion.scene_yaml import read_planning_scene
from kinserve.service import cli
from kinserve.service.settings import ServiceSettings

SCENE = """world:
  collision_objects:
  - id: a
    primitives: [{{type: {kind}, dimensions: {dims}}}]
    primitive_poses: [{{position: {pos}}}]
"""


@pytest.fixture(scope="module")
def planar():
    return robots.load("planar4r")


def run_main(argv, capsys):
    try:
        code = cli.main(argv)
    except SystemExit as exc:
        code = exc.code
    out = capsys.readouterr()
    return code, out.out, out.err


def one_line_error(argv, capsys, needle):
    code, out, err = run_main(argv, capsys)
    assert code == 2, (code, out, err)
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: ") and "Traceback" not in err, err
    assert needle in err, err


# ---------------------------------------------------------------- service settings
@pytest.mark.parametrize("field, value, needle", [
    ("robot_cache_bytes", 10**300, "robot_cache_bytes must be at most"),
    ("max_body", 10**30, "max_body must be at most"),
    ("request_time_cap", 1e300, "request_time_cap must be at most 86400 s"),
    ("keep_alive", 1e300, "keep_alive must be at most"),
    ("keep_alive", float("inf"), "finite number"),
    ("queue", True, "finite number"),
])
def test_settings_refuse_absurd_values(field, value, needle):
    with pytest.raises(ValueError, match=needle):
        ServiceSettings(**{field: value})
    ServiceSettings(**{field: 2 if field != "queue" else 0})  # a sane value still works


@pytest.mark.parametrize("args, needle", [
    (["--max-body", "inf"], "argument --max-body: expected a size"),
    (["--max-body", "1e30k"], "argument --max-body: expected a size"),
    (["--robot-cache-mb", "inf"], "argument --robot-cache-mb"),
    (["--robot-cache-mb", "nan"], "argument --robot-cache-mb"),
    (["--robot-cache-mb", "1e300"], "argument --robot-cache-mb"),
    (["--request-time-cap", "1e300"], "argument --request-time-cap"),
    (["--keep-alive", "1e300"], "argument --keep-alive"),
])
def test_serve_refuses_absurd_options_while_parsing(args, needle, capsys):
    one_line_error(["serve", *args], capsys, needle)  # refused by argparse: no server is started


def test_serve_accepts_sane_options_when_parsing():
    args = cli.build_parser().parse_args(["serve", "--max-body", "2M", "--robot-cache-mb", "512",
                                          "--keep-alive", "30"])
    from kinserve.service.cli_serve import settings_of

    settings = settings_of(args)
    assert settings.max_body == 2 << 20 and settings.robot_cache_bytes == 512 << 20


# ---------------------------------------------------------------- CLI frames, seed, numbers
@pytest.mark.parametrize("argv, needle", [
    (["collide", "planar4r", "--frame", "nope"], "unknown frame 'nope'"),
    (["fk", "planar4r", "--frame", ""], "unknown frame ''"),
    (["jacobian", "planar4r", "--frame", ""], "unknown frame ''"),
    (["reach", "pr", "--seed", "-1"], "argument --seed"),
    (["collide", "planar4r", "--box", "0.5", "0", "0.3", "0.1", "0.1", "0.1", "1e300", "0", "0"],
     "argument --box: expected numbers"),
    (["collide", "planar4r", "--cylinder", "0.5", "0", "0.3", "0.1", "0.2", "0", "1e7", "0"],
     "argument --cylinder"),
])
def test_cli_bad_frame_seed_or_angle_is_one_line_error(argv, needle, capsys):
    one_line_error(argv, capsys, needle)


def test_view_html_with_unknown_frame_is_one_line_error(tmp_path, capsys):
    out = tmp_path / "f.html"
    one_line_error(["view", "planar4r", "--html", str(out), "--frame", "nope"], capsys,
                   "unknown frame 'nope'")
    assert not out.exists()


def test_cli_known_frame_and_bounded_angle_still_work(capsys):
    code, out, _ = run_main(["fk", "planar4r", "--frame", "tool"], capsys)
    assert code == 0 and "frame tool" in out
    code, _, err = run_main(["collide", "planar4r", "--frame", "tool", "--box", "5", "5", "5", "0.1", "0.1",
                             "0.1", "0.1", "0", "3"], capsys)
    assert code == 0, err


def test_reachability_map_refuses_a_negative_seed_before_any_work(planar):
    with pytest.raises(InputError, match="seed must be an integer from 0"):
        reachability_map(planar, 4, resolution=2, seed=-1)
    with pytest.raises(InputError, match="seed must be an integer"):
        reachability_map(planar, 4, resolution=2, seed=1.5)


# ---------------------------------------------------------------- scene YAML
def test_scene_yaml_not_utf8_is_input_error(tmp_path, capsys):
    path = tmp_path / "bin.yaml"
    path.write_bytes(b"\xff\xfe\x00world: 1")
    with pytest.raises(InputError, match="is not UTF-8 text"):
        read_planning_scene(path)
    one_line_error(["collide", "planar4r", "--scene", str(path)], capsys, "is not UTF-8 text")


def test_scene_yaml_directory_is_named(tmp_path):
    with pytest.raises(InputError, match="is a directory, expected a YAML file"):
        read_planning_scene(str(tmp_path))


@pytest.mark.parametrize("kind, dims, pos, needle", [
    (1, "[0.1, 0.1, 0.1]", "[0.4, no, yes]", "position must hold numbers"),
    (2, "[yes]", "[0, 0, 0]", "dimensions \\(sphere\\) must hold numbers"),
    (2, '["0.1"]', "[0, 0, 0]", "dimensions \\(sphere\\) must hold numbers"),
    (2, "[0.1]", "[0, 0, 1e7]", "position must hold finite numbers with"),
])
def test_scene_yaml_refuses_booleans_text_and_huge_numbers(kind, dims, pos, needle):
    with pytest.raises(InputError, match=needle):
        read_planning_scene(SCENE.format(kind=kind, dims=dims, pos=pos))
    shapes = read_planning_scene(SCENE.format(kind=2, dims="[0.1]", pos="[0.4, 0, 1]"))
    assert shapes[0].radius == pytest.approx(0.1)


# ---------------------------------------------------------------- viz
def test_motion_plan_scene_bounds_frames_and_fps(planar):
    a, b = np.zeros(4), np.full(4, 0.1)
    with pytest.raises(InputError, match="more than the 100,000 allowed"):
        viz.motion_plan_scene(planar, ([0.0, 1e6], np.vstack([a, b])), fps=30)
    with pytest.raises(InputError, match="fps"):
        viz.motion_plan_scene(planar, ([0.0, 1.0], np.vstack([a, b])), fps=1e6)
    scene = viz.motion_plan_scene(planar, ([0.0, 1.0], np.vstack([a, b])), fps=10)
    assert "planar4r" in scene.robots


def test_animation_refuses_huge_fps_and_empty_trajectory(planar):
    scene = viz.Scene()
    scene.add_robot(planar)
    with pytest.raises(InputError, match="fps"):
        viz.Animation(scene, fps=1e300)
    anim = viz.Animation(scene, fps=240)
    with pytest.raises(InputError, match="at least one sample"):
        anim.robot("planar4r", np.zeros((0, 4)))
    assert list(anim.robot("planar4r", np.zeros((2, 4)))) == [0, 1]


def test_add_robot_with_bad_q_leaves_the_scene_unchanged(planar):
    scene = viz.Scene()
    with pytest.raises(NonFiniteError):
        scene.add_robot(planar, [np.nan] * 4)
    assert "planar4r" not in scene.robots
    assert scene.add_robot(planar, np.zeros(4)).name == "planar4r"


# ---------------------------------------------------------------- top-level helpers
@pytest.mark.parametrize("xyz, error, needle", [
    ([10**400, 0, 0], NonFiniteError, "xyz must hold finite numbers .* an integer too large for a float"),
    (["1", "2", "3"], ShapeError, "xyz must be a sequence of 3 numbers, got \\['1'"),
    ([True, False, True], ShapeError, "xyz must be a sequence of 3 numbers, got \\[True"),
    (np.array([True, False, True]), ShapeError, "xyz must be a sequence of 3 numbers"),
])
def test_pose_refuses_text_bools_and_huge_integers(xyz, error, needle):
    with pytest.raises(error, match=needle):
        kinserve.pose(xyz)
    assert kinserve.pose([1, 2, 3], rpy=[0, 0, 1])[:3, 3].tolist() == [1.0, 2.0, 3.0]


@pytest.mark.parametrize("arg", ["panda", None])
def test_clear_caches_refuses_what_is_not_a_robot(arg, planar):
    with pytest.raises(InputError, match="clear_caches: argument 1 must be a kinserve Robot"):
        kinserve.clear_caches(arg)
    kinserve.clear_caches(planar)


def test_attach_refuses_touch_links_that_are_not_names():
    panda = robots.load("panda")
    sphere = {"kind": "sphere", "center": [0, 0, 0], "radius": 0.03}
    with pytest.raises(InputError, match="touch_links must be a link name or a list"):
        panda.attach("ball", sphere, panda.tip, touch_links=5)
    panda.attach("ball", sphere, panda.tip)
    assert "ball" in panda.attached
