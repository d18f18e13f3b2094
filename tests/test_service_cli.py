"""End-to-end runs of the ``kinserve`` command line (subprocesses, like a user)."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import numpy as np
import pytest

from kinserve import robots

from import_probe import imported_after

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def kinserve(*args: str, timeout: float = 120) -> subprocess.CompletedProcess:
    env = dict(os.environ, MPLBACKEND="Agg")
    return subprocess.run([sys.executable, "-m", "kinserve.service.cli", *args], cwd=ROOT, env=env,
                          capture_output=True, text=True, timeout=timeout)


def test_models_lists_the_registry():
    out = kinserve("models", "--json")
    assert out.returncode == 0, out.stderr
    assert json.loads(out.stdout) == robots.available()
    text = kinserve("models").stdout
    assert "panda" in text and "youbot" in text


def test_fk_json_matches_library():
    q = [0.1, -0.4, 0.2, -2.1, 0.3, 1.7, 0.5]
    out = kinserve("fk", "panda", "--q", ",".join(map(str, q)), "--frame", "panda_link8", "--json")
    assert out.returncode == 0, out.stderr
    pose = np.array(json.loads(out.stdout)["pose"])
    assert np.allclose(pose, robots.load("panda").fk(np.array(q), "panda_link8"), atol=1e-12)


#: What ``kinserve fk`` / ``jacobian`` / ``frames`` never need: the compiled collision core (Numba), scipy
#: (its qhull is a collision model's fallback), the IK package. Importing them took about 1.5 s per call.
NOT_FOR_FK = ("numba", "scipy", "kinserve.kinematics.collision_model", "kinserve.ik")


@pytest.mark.parametrize("command", [["fk", "panda", "--q", "0", "0", "0", "-1", "0", "1", "0"],
                                     ["jacobian", "ur5"], ["frames", "panda"]])
def test_fk_jacobian_and_frames_import_no_solver(command):
    code = (f"import sys\nsys.argv = ['kinserve', *{command!r}]\n"
            "from kinserve.service.cli import main\n"
            "try:\n    main()\nexcept SystemExit as exc:\n    assert not exc.code, exc.code")
    imported, printed = imported_after(code, NOT_FOR_FK, cwd=ROOT)
    assert "pose" in printed or "panda" in printed or "ur5" in printed  # it answered
    assert imported == []


def test_fk_with_xacro_param():
    out = kinserve("fk", "planar4r", "--q", "0", "0", "0", "0", "--param", "l1=2.0", "--json")
    assert out.returncode == 0, out.stderr
    assert np.isclose(json.loads(out.stdout)["pose"][0][3], 2.0 + 0.8 + 0.6 + 0.4)


def test_jacobian_reports_singularity():
    out = kinserve("jacobian", "planar4r", "--q", "0 0 0 0", "--json")
    body = json.loads(out.stdout)
    assert np.array(body["jacobian"]).shape == (6, 4)
    # Stretched along x, no joint can move the tip along x: the x row vanishes, rank (x, y, yaw) = 2 < 3.
    assert np.allclose(np.array(body["jacobian"])[0], 0.0, atol=1e-12)
    assert body["singular"] is True and body["task_axes"] == ["x", "y", "yaw"]
    bent = json.loads(kinserve("jacobian", "planar4r", "--q", "0.3 0.5 -0.4 0.2", "--json").stdout)
    assert bent["singular"] is False
    text = kinserve("jacobian", "panda", "--q", "0 0 0 0 0 0 0").stdout
    assert "SINGULAR" in text


@pytest.mark.parametrize(
    "args, needle",
    [
        (("fk", "pandaa"), "unknown robot 'pandaa'"),
        (("fk", "panda", "--q", "1", "2"), "q must have shape (7,)"),
        (("fk", "panda", "--q", "a,b"), "expected numbers"),
        (("fk", "panda", "--frame", "hand"), "unknown frame 'hand'"),
        (("fk", "panda", "--q", "nan,0,0,0,0,0,0"), "finite"),
        (("fk", "planar4r", "--param", "l9=1"), "l9"),
    ],
)
def test_bad_input_is_one_clear_line_and_exit_2(args, needle):
    out = kinserve(*args)
    assert out.returncode == 2
    assert needle in out.stderr
    assert "Traceback" not in out.stderr
