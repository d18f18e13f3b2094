"""The CLI's error boundary: every sub-command, given bad arguments, says so in one line and exits 2.

The walk is in-process (``cli.main(argv)``, fast); the cases named in issue 9
also run as real ``kinserve`` subprocesses. A traceback in-process would raise
out of ``main`` and fail the test; a bug caught by the last-resort handler
exits 70, not 2, and fails it too.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys

import pytest

from kinserve import __version__
from kinserve.service import cli

from cli_runs import assert_one_line_error, run_main


def subcommands() -> dict[str, argparse.ArgumentParser]:
    parser = cli.build_parser()
    action = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return dict(action.choices)


def takes_robot(sub: argparse.ArgumentParser) -> bool:
    return any(a.dest == "robot" and not a.option_strings for a in sub._actions)


#: Bad arguments per sub-command and a piece of the expected message.
BAD = {
    "models": [(["--json", "extra"], "unrecognized arguments")],
    "fk": [(["panda", "--q", "1", "2"], "q must have shape (7,)"),
           (["panda", "--q", "nan,0,0,0,0,0,0"], "finite"),
           (["panda", "--frame", "hand"], "unknown frame 'hand'"),
           (["planar4r", "--param", "l1"], "KEY=VALUE")],
    "jacobian": [(["panda", "--reference", "body"], "invalid choice"),
                 (["pr", "--q", "a,b"], "expected numbers")],
    "ik": [(["panda", "--xyz", "1", "2"], "argument --xyz: expected 3 numbers X Y Z, got 2"),
           (["panda"], "a target is needed"),
           (["panda", "--xyz", "0.4", "0", "0.5", "--max-time", "-1"], "argument --max-time"),
           (["panda", "--xyz", "0.4", "0", "0.5", "--centring", "inf"], "argument --centring"),
           (["panda", "--xyz", "0.4", "0", "0.5", "--sphere", "1,2,3"],
            "argument --sphere: expected 4 numbers CX CY CZ R, got 3"),
           (["panda", "--xyz", "0.4", "0", "0.5", "--quat", "0", "0", "0", "2"], "unit quaternion"),
           (["panda", "--xyz", "0.4", "0", "0.5", "--quat", "0", "0", "0", "1", "--rpy", "0", "0", "0"],
            "not allowed with argument"),
           (["panda", "--rpy", "0", "0", "0"], "--rpy needs --xyz"),
           (["panda", "--xyz", "0.4", "nan", "0.5"], "expected finite numbers X Y Z"),
           (["panda", "--xyz", "0.4", "0", "0.5", "--target", *["0"] * 16], "either --target or --xyz"),
           (["panda", "--target", "1", "2", "3"], "16 numbers")],
    "collide": [(["panda", "--box", "0", "0", "1", "0.1", "0.1"],
                 "argument --box: expected 6 or 9 numbers CX CY CZ SX SY SZ [ROLL PITCH YAW], got 5"),
                (["panda", "--scene", "/nonexistent/scene.yaml"], "cannot be read"),
                (["panda", "--sphere", "0", "0", "1", "-0.1"], "sphere radius must be positive")],
    "plan": [(["panda"], "give one goal: --goal Q..."),
             (["panda", "--goal", "1", "2"], "--goal: expected 7 joint values"),
             (["panda", "--goal", "default", "--xyz", "0.4", "0", "0.5"], "give either --goal or a goal"),
             (["panda", "--goal", "ready_pose"], "or a named state (the robot's: default)"),
             (["panda", "--goal", "default", "--out", "t.txt"], "expected a file ending in .json or .csv"),
             (["panda", "--goal", "default", "--max-time", "none"], "--max-time none needs --max-iterations"),
             (["panda", "--goal", "default", "--max-time", "0"], "argument --max-time"),
             (["panda", "--goal", "default", "--max-acceleration", "-1"], "argument --max-acceleration")],
    "demo": [(["S10"], "invalid choice"),
             (["scara", "--out", "/proc/nope"], "/proc/nope: No such file or directory")],
    "view": [(["scara", "--html", "/nonexistent/dir/x.html"], "'/nonexistent/dir' does not exist"),
             (["scara", "--html", "/"], "expected a file path"),
             (["scara", "--q", "1"], "q must have shape (4,)")],
    "serve": [(["--port", "99999"], "port number 0..65535"), (["--port", "-1"], "port number"),
              (["--port", "http"], "port number"), (["--workers", "0"], "argument --workers"),
              (["--max-time-cap", "nan"], "argument --max-time-cap"),
              (["--max-body", "inf"], "argument --max-body: expected a size from 1 byte"),
              (["--max-body", "1e30k"], "argument --max-body: expected a size from 1 byte"),
              (["--max-body", "nan"], "argument --max-body"),
              (["--robot-cache-mb", "inf"], "argument --robot-cache-mb: expected a finite number"),
              (["--robot-cache-mb", "nan"], "argument --robot-cache-mb"),
              (["--robot-cache-mb", "1e300"], "argument --robot-cache-mb"),
              (["--request-time-cap", "1e300"], "argument --request-time-cap: expected a finite number > 0"),
              (["--keep-alive", "1e300"], "argument --keep-alive"),
              (["--keep-alive", "inf"], "argument --keep-alive"),
              (["--queue", "1e9"], "argument --queue"),
              (["--robot-cache", "-1"], "argument --robot-cache")],
    "reach": [(["pr", "--samples", "0"], "argument --samples"),
              (["pr", "--resolution", "x"], "argument --resolution"),
              (["pr", "--max-time", "inf"], "argument --max-time"),
              (["pr", "--orientation", "up"], "invalid choice"),
              (["pr", "--out", "/nonexistent/dir/stem"], "'/nonexistent/dir' does not exist"),
              (["pr", "--samples", "1000000000000"], "samples must be at most 10,000,000"),
              (["pr", "--seed", "-1"], "argument --seed: expected a whole number 0.."),
              (["pr", "--seed", "1.5"], "argument --seed")],
}


def test_every_registered_subcommand_has_bad_argument_cases():
    assert set(BAD) <= set(subcommands()), "a case for a sub-command that no longer exists"


@pytest.mark.parametrize("name", sorted(subcommands()))
def test_unknown_option_is_one_line_exit_2(name, capsys):
    code, out, err = run_main([name, "--no-such-option"], capsys)
    assert_one_line_error(code, out, err)  # "unrecognized arguments", or a missing positional reported first
    assert "--no-such-option" in err or "the following arguments are required" in err


@pytest.mark.parametrize("name", sorted(n for n, p in subcommands().items() if takes_robot(p)))
def test_unknown_robot_is_one_line_exit_2(name, capsys):
    code, out, err = run_main([name, "no_such_robot"], capsys)
    assert_one_line_error(code, out, err, "unknown robot 'no_such_robot'")


@pytest.mark.parametrize("name, args, needle", [(n, a, m) for n, cases in BAD.items() for a, m in cases],
                         ids=lambda v: v if isinstance(v, str) else None)
def test_bad_arguments_are_one_line_exit_2(name, args, needle, capsys):
    code, out, err = run_main([name, *args], capsys)
    assert_one_line_error(code, out, err, needle)


def test_no_command_is_one_line_exit_2(capsys):
    assert_one_line_error(*run_main([], capsys), "COMMAND")


def test_unexpected_exception_is_one_line_exit_70(monkeypatch, capsys):
    def broken(args):
        raise TypeError("boom")

    monkeypatch.setattr(cli, "cmd_models", broken)
    code, out, err = run_main(["models"], capsys)
    assert code == cli.EXIT_INTERNAL and "Traceback" not in err
    assert err.strip() == "error: internal TypeError: boom (KINSERVE_DEBUG=1 shows the traceback)"


def kinserve(*args: str, cwd) -> subprocess.CompletedProcess:
    exe = os.path.join(os.path.dirname(sys.executable), "kinserve")
    return subprocess.run([exe, *args], cwd=cwd, capture_output=True, text=True, timeout=120)


def test_version_prints_kinserve_and_the_version(tmp_path):
    out = kinserve("--version", cwd=tmp_path)
    assert out.returncode == 0 and out.stdout.strip() == f"kinserve {__version__}"
    assert __version__.count(".") >= 2 and __version__[0].isdigit()


@pytest.mark.parametrize("args, needle", [
    (["serve", "--port", "99999"], "port number 0..65535"),
    (["demo", "scara", "--out", "/proc/nope"], "/proc/nope: No such file or directory"),
    (["view", "scara", "--html", "/nonexistent/dir/x.html"], "'/nonexistent/dir' does not exist"),
])
def test_issue_cases_as_real_processes(args, needle, tmp_path):
    out = kinserve(*args, cwd=tmp_path)
    assert_one_line_error(out.returncode, out.stdout, out.stderr, needle)
    assert not os.path.exists("/nonexistent/dir")


def test_serve_on_a_busy_port_or_unknown_host_is_one_line_exit_2(tmp_path):
    import socket

    with socket.socket() as busy:
        busy.bind(("127.0.0.1", 0))
        busy.listen()
        port = str(busy.getsockname()[1])
        for extra in ([], ["--workers", "2"]):
            out = kinserve("serve", "--port", port, *extra, cwd=tmp_path)
            assert_one_line_error(out.returncode, out.stdout, out.stderr,
                                  f"cannot listen on 127.0.0.1:{port}")
    out = kinserve("serve", "--host", "no-such-host.invalid", "--port", "0", cwd=tmp_path)
    assert_one_line_error(out.returncode, out.stdout, out.stderr, "cannot listen on no-such-host.invalid:0")


_NOT_A_MESH_URDF = """<robot name="b"><link name="a"/><link name="b"><collision><geometry>
<mesh filename="part.stl"/></geometry></collision></link><joint name="j" type="revolute"><parent link="a"/>
<child link="b"/><axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint></robot>"""


@pytest.mark.parametrize("command, element", [("collide", "collision"), ("view --collision", "collision"),
                                              ("view", "visual")])
def test_a_file_that_is_not_a_mesh_is_one_line_naming_it(command, element, tmp_path, capsys):
    """coal's exception text (its source file, function and line) is cut to its message: one line naming
    the file, from each command that reads the mesh (`view` reads the collision meshes only with
    --collision)."""
    (tmp_path / "part.stl").write_text("not a mesh\n")
    (tmp_path / "r.urdf").write_text(_NOT_A_MESH_URDF.replace("collision>", f"{element}>"))
    extra = ["--html", str(tmp_path / "v.html")] if command.startswith("view") else []
    code, out, err = run_main([*command.split(), str(tmp_path / "r.urdf"), *extra], capsys)
    assert_one_line_error(code, out, err, f"cannot build the {element} geometry: Could not load resource "
                                          f"{tmp_path / 'part.stl'}")
    assert "From file" not in err and "in function" not in err and "at line" not in err


def test_view_without_collision_does_not_read_the_collision_meshes(tmp_path, capsys):
    """The viewer draws the visual model; a collision mesh it does not draw is not read (nor its error)."""
    (tmp_path / "part.stl").write_text("not a mesh\n")
    (tmp_path / "r.urdf").write_text(_NOT_A_MESH_URDF)
    code, out, err = run_main(["view", str(tmp_path / "r.urdf"), "--html", str(tmp_path / "v.html")], capsys)
    assert code == 0 and (tmp_path / "v.html").stat().st_size > 0, (code, out, err)
