"""``kinserve frames ROBOT``: end to end, compared with the model file and the library."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pinocchio as pin

from kinserve import robots
from kinserve.robots.paths import erd_file

ROOT = Path(__file__).resolve().parents[1]


def kinserve(*args: str) -> subprocess.CompletedProcess:
    env = dict(os.environ, MPLBACKEND="Agg")
    return subprocess.run([sys.executable, "-m", "kinserve.service.cli", *args], cwd=ROOT, env=env,
                          capture_output=True, text=True, timeout=120)


def test_frames_panda_json_matches_the_urdf():
    out = kinserve("frames", "panda", "--json")
    assert out.returncode == 0, out.stderr
    d = json.loads(out.stdout)
    full = pin.buildModelFromUrdf(str(erd_file("panda_description/urdf/panda.urdf")))
    arm = [f"panda_joint{i}" for i in range(1, 8)]
    assert d["robot"] == "panda" and d["nq"] == 7 and d["tool_frame"] == "panda_hand"
    assert [j["name"] for j in d["joints"]] == arm
    for j in d["joints"]:  # limits straight from the URDF, via Pinocchio's own parser
        jid = full.getJointId(j["name"])
        assert j["lower"] == full.lowerPositionLimit[full.joints[jid].idx_q]
        assert j["upper"] == full.upperPositionLimit[full.joints[jid].idx_q]
        assert j["type"] == "revolute" and j["unit"] == "rad"
    names = [f["name"] for f in d["frames"]]
    assert len(names) == 26 and {"panda_link8", "panda_hand", "panda_hand_tcp"} <= set(names)
    assert {f["name"]: f["moved_by"] for f in d["frames"]}["panda_hand"] == "panda_joint7"
    assert d["task_axes"] == ["x", "y", "z", "roll", "pitch", "yaw"]
    assert (d["named_states"]["default"]
            == robots.load("panda", geometry=False).named_states["default"].tolist())
    assert d["groups"]["arm"] == arm


def test_frames_text_and_error_pointing_to_it(tmp_path):
    out = kinserve("frames", "PR")
    assert out.returncode == 0, out.stderr
    text = out.stdout
    assert text.startswith("pr: 2 joints, tool frame tool")
    assert "prismatic" in text and "revolute" in text and "<- tool frame" in text
    assert "task axes: x y" in text
    bad = kinserve("fk", "pr", "--frame", "Tool")
    assert bad.returncode == 2 and "Did you mean: tool" in bad.stderr and "kinserve frames" in bad.stderr


def test_frames_of_a_file_with_package_dir(tmp_path):
    urdf = tmp_path / "desc" / "urdf" / "one.urdf"
    urdf.parent.mkdir(parents=True)
    urdf.write_text(
        '<robot name="one"><link name="base"/><link name="slider"><visual><geometry>'
        '<mesh filename="package://one_meshes/s.stl"/></geometry></visual></link>'
        '<joint name="slide" type="prismatic"><parent link="base"/><child link="slider"/><axis xyz="0 1 0"/>'
        '<limit lower="-0.2" upper="0.3" effort="1" velocity="1"/></joint></robot>')
    out = kinserve("frames", str(urdf), "--package-dir", str(tmp_path), "--json")
    assert out.returncode == 0, out.stderr
    d = json.loads(out.stdout)
    assert d["joints"] == [{"name": "slide", "type": "prismatic", "unit": "m", "lower": -0.2, "upper": 0.3}]
    assert d["task_axes"] == ["y"] and "prismatic joints only" in d["task_axes_origin"]
    missing = kinserve("frames", str(urdf), "--package-dir", str(tmp_path / "nope"))
    assert missing.returncode == 2 and "is not a folder" in missing.stderr
