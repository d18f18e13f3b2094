"""The shared option syntax of the ``kinserve`` sub-commands: one pose form, one obstacle form, help texts
with defaults, and no "reached" pose after a failed solve.

Parsing is checked in-process against rotations and shapes built here by independent formulas; each
sub-command's use of the obstacles is checked by running it as a real process.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import subprocess
import sys

import numpy as np
import pytest

from kinserve import robots
from kinserve.service import cli
from kinserve.service.cli_help import DefaultsHelpFormatter
from kinserve.service.cli_ik import parse_target
from kinserve.service.cli_obstacles import obstacles_from_args

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
OBSTACLE_COMMANDS = ("ik", "collide", "view", "reach", "plan")


def kinserve(*args: str, timeout: float = 300) -> subprocess.CompletedProcess:
    env = dict(os.environ, MPLBACKEND="Agg")
    return subprocess.run([sys.executable, "-m", "kinserve.service.cli", *args], cwd=ROOT, env=env,
                          capture_output=True, text=True, timeout=timeout)


def subcommands() -> dict[str, argparse.ArgumentParser]:
    parser = cli.build_parser()
    action = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return dict(action.choices)


def rpy_matrix(r: float, p: float, y: float) -> np.ndarray:
    """Rz(y) Ry(p) Rx(r), written out."""
    cr, sr, cp, sp, cy, sy = np.cos(r), np.sin(r), np.cos(p), np.sin(p), np.cos(y), np.sin(y)
    Rx = np.array([[1, 0, 0], [0, cr, -sr], [0, sr, cr]])
    Ry = np.array([[cp, 0, sp], [0, 1, 0], [-sp, 0, cp]])
    Rz = np.array([[cy, -sy, 0], [sy, cy, 0], [0, 0, 1]])
    return Rz @ Ry @ Rx


def quat_matrix(x: float, y: float, z: float, w: float) -> np.ndarray:
    """The rotation of the unit quaternion w + xi + yj + zk (the textbook formula)."""
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def quat_of_rpy(r: float, p: float, y: float) -> tuple[float, float, float, float]:
    """(x, y, z, w) of Rz(y) Ry(p) Rx(r): the Hamilton product qz qy qx of the half-angle quaternions."""
    def mul(a, b):
        (ax, ay, az, aw), (bx, by, bz, bw) = a, b
        return (aw * bx + ax * bw + ay * bz - az * by, aw * by - ax * bz + ay * bw + az * bx,
                aw * bz + ax * by - ay * bx + az * bw, aw * bw - ax * bx - ay * by - az * bz)

    qx = (np.sin(r / 2), 0.0, 0.0, np.cos(r / 2))
    qy = (0.0, np.sin(p / 2), 0.0, np.cos(p / 2))
    qz = (0.0, 0.0, np.sin(y / 2), np.cos(y / 2))
    return tuple(float(v) for v in mul(mul(qz, qy), qx))


# ------------------------------------------------------------------------------------------- pose forms
RPY = (0.3, -0.2, 0.5)
XYZ = ("0.4", "0.1", "0.5")


def test_quat_and_rpy_give_the_same_pose_as_the_independent_formulas():
    parser = cli.build_parser()
    quat = quat_of_rpy(*RPY)
    by_quat, free_q = parse_target(parser.parse_args(["ik", "panda", "--xyz", *XYZ, "--quat",
                                                      *map(repr, quat)]))
    by_rpy, free_r = parse_target(parser.parse_args(["ik", "panda", "--xyz", *XYZ, "--rpy", *map(repr, RPY)]))
    assert free_q == free_r == ()
    np.testing.assert_allclose(by_quat[:3, :3], quat_matrix(*quat), atol=1e-12)
    np.testing.assert_allclose(by_rpy[:3, :3], rpy_matrix(*RPY), atol=1e-12)
    np.testing.assert_allclose(by_quat, by_rpy, atol=1e-12)
    np.testing.assert_array_equal(by_quat[:3, 3], [0.4, 0.1, 0.5])
    np.testing.assert_array_equal(by_quat[3], [0, 0, 0, 1])


def test_quat_is_x_y_z_w():
    """A quarter turn about z is (0, 0, sin 45, cos 45) in x y z w order (w first would be another turn)."""
    s = float(np.sqrt(0.5))
    T, _ = parse_target(cli.build_parser().parse_args(["ik", "panda", "--xyz", *XYZ, "--quat", "0", "0",
                                                       repr(s), repr(s)]))
    np.testing.assert_allclose(T[:3, :3], [[0, -1, 0], [1, 0, 0], [0, 0, 1]], atol=1e-12)


def test_xyz_alone_frees_the_orientation_and_commas_work():
    T, free = parse_target(cli.build_parser().parse_args(["ik", "panda", "--xyz", "0.4,0.1,0.5"]))
    assert free == ("roll", "pitch", "yaw")
    np.testing.assert_array_equal(T, [[1, 0, 0, 0.4], [0, 1, 0, 0.1], [0, 0, 1, 0.5], [0, 0, 0, 1]])


def test_ik_reaches_a_quat_target_end_to_end():
    quat = quat_of_rpy(np.pi, 0.1, 0.2)  # tool pointing down, slightly tilted: reachable by the Panda
    out = kinserve("ik", "panda", "--xyz", *XYZ, "--quat", *map(repr, quat), "--json")
    assert out.returncode == 0, out.stderr
    body = json.loads(out.stdout)
    T = robots.load("panda", geometry=False).fk(np.array(body["q"]))
    np.testing.assert_allclose(T[:3, 3], [0.4, 0.1, 0.5], atol=1e-4)
    R_err = T[:3, :3].T @ quat_matrix(*quat)
    assert np.arccos(np.clip((np.trace(R_err) - 1) / 2, -1, 1)) < 1e-3


# ------------------------------------------------------------------------------------------- obstacles
def obstacle_args(scene_file) -> list[str]:
    return ["--sphere", "0.5", "0", "0.4", "0.1", "--box", "0.3", "-0.4", "0.2", "0.1", "0.2", "0.3",
            "--box", "0.3,0.4,0.2,0.1,0.2,0.3,0.1,0.2,0.3", "--cylinder", "-0.4", "0", "0.3", "0.05", "0.6",
            "--scene", str(scene_file), "--sphere", "0.1,0.6,0.9,0.05"]


@pytest.fixture
def scene_file(tmp_path):
    path = tmp_path / "scene.yaml"
    path.write_text("world:\n  collision_objects:\n    - id: shelf\n      primitives:\n"
                    "        - {type: box, dimensions: [0.2, 0.4, 0.02]}\n"
                    "      primitive_poses:\n"
                    "        - {position: [-0.5, -0.5, 0.7], orientation: [0, 0, 0.7071067811865476, "
                    "0.7071067811865476]}\n")
    return path


def expected_obstacles() -> list[dict]:
    """The shapes of :func:`obstacle_args`, in order, built here from the numbers."""
    def pose(R, p):
        T = np.eye(4)
        T[:3, :3], T[:3, 3] = R, p
        return T.tolist()

    quarter_z = [[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]
    return [{"kind": "sphere", "center": [0.5, 0.0, 0.4], "radius": 0.1},
            {"kind": "box", "pose": pose(np.eye(3), [0.3, -0.4, 0.2]), "size": [0.1, 0.2, 0.3]},
            {"kind": "box", "pose": pose(rpy_matrix(0.1, 0.2, 0.3), [0.3, 0.4, 0.2]),
             "size": [0.1, 0.2, 0.3]},
            {"kind": "cylinder", "pose": pose(np.eye(3), [-0.4, 0.0, 0.3]), "radius": 0.05, "length": 0.6},
            {"kind": "box", "pose": pose(quarter_z, [-0.5, -0.5, 0.7]), "size": [0.2, 0.4, 0.02]},
            {"kind": "sphere", "center": [0.1, 0.6, 0.9], "radius": 0.05}]


def same_shape(got: dict, want: dict) -> bool:
    if got.keys() - {"frames"} != want.keys():
        return False
    return all(np.allclose(got[k], want[k], atol=1e-9) if k != "kind" else got[k] == want[k] for k in want)


@pytest.mark.parametrize("command", OBSTACLE_COMMANDS)
def test_every_obstacle_command_parses_the_same_obstacles(command, scene_file):
    head = ["--xyz", *XYZ] if command == "ik" else ["--goal", "default"] if command == "plan" else []
    args = cli.build_parser().parse_args([command, "panda", *head, *obstacle_args(scene_file)])
    got = [o.to_dict() for o in obstacles_from_args(args)]
    want = expected_obstacles()
    assert len(got) == len(want)
    for g, w in zip(got, want):
        assert same_shape(g, w), (g, w)


@pytest.mark.parametrize("command", OBSTACLE_COMMANDS)
@pytest.mark.parametrize("bad, needle", [
    (["--sphere", "0", "0", "1"], "argument --sphere: expected 4 numbers CX CY CZ R, got 3"),
    (["--box", "0", "0", "1", "0.1", "0.1", "0.1", "0.2"],
     "argument --box: expected 6 or 9 numbers CX CY CZ SX SY SZ [ROLL PITCH YAW], got 7"),
    (["--box", "0", "0", "1", "0.1", "x", "0.1"], "argument --box: expected 6 or 9 numbers"),
    (["--sphere", "0", "0", "inf", "0.1"], "argument --sphere: expected finite numbers"),
])
def test_every_obstacle_command_rejects_the_same_bad_obstacles(command, bad, needle, capsys):
    with pytest.raises(SystemExit) as exc:
        cli.main([command, "panda", *bad])
    err = capsys.readouterr().err
    assert exc.value.code == 2 and len(err.strip().splitlines()) == 1 and needle in err, err


def test_collide_ik_reach_plan_use_every_obstacle_end_to_end(scene_file, tmp_path):
    """Each sub-command, run as a user runs it, reports the six obstacles it was given."""
    obstacles = obstacle_args(scene_file)
    collide = kinserve("collide", "panda", *obstacles, "--json")
    assert collide.returncode == 0, collide.stderr
    body = json.loads(collide.stdout)
    assert all(same_shape(g, w) for g, w in zip(body["obstacles"], expected_obstacles()))
    assert len(body["obstacles"]) == 6
    ik_run = kinserve("ik", "panda", "--xyz", *XYZ, *obstacles, "--json")
    assert ik_run.returncode in (0, 1), ik_run.stderr
    assert len(json.loads(ik_run.stdout)["obstacles"]) == 6
    reach = kinserve("reach", "panda", "--samples", "8", "--backend", "serial", "--out", str(tmp_path / "r"),
                     *obstacles)
    assert reach.returncode == 0 and "(6 obstacle(s)" in reach.stdout, reach.stderr
    plan = kinserve("plan", "panda", "--goal", "default", "--max-time", "none", "--max-iterations", "300",
                    *obstacles, "--json")
    assert plan.returncode in (0, 1), plan.stderr
    assert len(json.loads(plan.stdout)["obstacles"]) == 6
    view = kinserve("view", "panda", *obstacles, "--html", str(tmp_path / "v.html"))
    assert view.returncode == 0 and (tmp_path / "v.html").stat().st_size > 100_000, view.stderr


@pytest.mark.parametrize("collision", [False, True])
def test_view_draws_every_obstacle_given(collision, scene_file, tmp_path, monkeypatch, capsys):
    import kinserve.viz

    scenes = []
    monkeypatch.setattr(kinserve.viz, "export_html", lambda scene, path: scenes.append(scene) or path)
    argv = ["view", "panda", *obstacle_args(scene_file), "--html", str(tmp_path / "v.html")]
    assert cli.main(argv + (["--collision"] if collision else [])) == 0
    scene = scenes[0]
    for k, want in enumerate(expected_obstacles()):
        assert f"obstacles/{k}" in scene, scene.paths()
        if want["kind"] != "sphere":
            np.testing.assert_allclose(scene.world_transform(f"obstacles/{k}"), want["pose"], atol=1e-9)
    assert "obstacles/6" not in scene
    assert any("_collision/" in p for p in scene.paths()) == collision


# ------------------------------------------------------------------------------------------------- help
def test_every_option_of_every_subcommand_has_help_showing_its_default():
    for name, parser in subcommands().items():
        formatter = DefaultsHelpFormatter(prog=parser.prog)
        for action in parser._actions:
            if not action.option_strings or isinstance(action, argparse._HelpAction):
                continue
            text = formatter._expand_help(action)
            assert action.help, f"{name} {action.option_strings[0]} has no help text"
            assert "default" in text, f"{name} {action.option_strings[0]}: {text!r}"


@pytest.mark.parametrize("name", sorted(subcommands()))
def test_help_of_each_subcommand_shows_defaults(name, capsys):
    with pytest.raises(SystemExit) as exc:
        cli.main([name, "--help"])
    out = capsys.readouterr().out
    assert exc.value.code == 0 and "(default:" in out
    parser = subcommands()[name]
    flags = [a for a in parser._actions if a.option_strings and not isinstance(a, argparse._HelpAction)]
    assert out.count("default") >= len(flags)


def test_help_as_a_real_process_shows_the_forms_and_defaults():
    out = kinserve("plan", "--help")
    assert out.returncode == 0
    text = " ".join(out.stdout.split())
    assert "--box CX CY CZ SX SY SZ [ROLL PITCH YAW]" in text and "--sphere CX CY CZ R" in text
    assert "(default: 1.0)" in text and "(default: 0)" in text
    ik_text = " ".join(kinserve("ik", "--help").stdout.split())
    assert "--quat QX QY QZ QW" in ik_text and "--rpy ROLL PITCH YAW" in ik_text
    assert "(default: auto)" in ik_text


# ------------------------------------------------------------------------------------- failure wording
def test_a_failed_ik_never_calls_its_pose_reached():
    out = kinserve("ik", "panda", "--xyz", "3", "0", "0.5", "--max-time", "0.05")
    assert out.returncode == 1, out.stderr
    assert "success False" in out.stdout and "closest pose (not reached):" in out.stdout
    assert re.search(r"(?<!not )reached", out.stdout) is None, out.stdout
    ok = kinserve("ik", "panda", "--xyz", *XYZ)
    assert ok.returncode == 0 and "reached pose:" in ok.stdout
