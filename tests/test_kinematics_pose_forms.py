"""One way to say a pose (issue 24): ``kinserve.pose`` and the forms ``as_pose`` reads - a 4x4, a
``pinocchio.SE3``, ``(position, quaternion)`` and ``[x, y, z, qx, qy, qz, qw]`` - checked against scipy's
rotations (quaternions scalar last there too) and end to end through ``ik.solve`` and the shapes."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pinocchio as pin
import pytest
from scipy.spatial.transform import Rotation

import kinserve
from kinserve import ik, robots
from kinserve.kinematics import Box, se3
from kinserve.kinematics.errors import InputError, NonFiniteError, RotationError, ShapeError
from kinserve.kinematics.validation import QUATERNION_TOL, as_pose, make_pose

FORMS = ("4x4", "pinocchio.SE3", "position [x, y, z]", "quaternion [qx, qy, qz, qw]",
         "[x, y, z, qx, qy, qz, qw]", "kinserve.pose")


def random_rotation(rng) -> Rotation:
    return Rotation.random(random_state=rng.integers(1 << 31))


def test_pose_from_quaternion_rpy_and_matrix_match_scipy(rng):
    for _ in range(20):
        rot, p = random_rotation(rng), rng.uniform(-1, 1, 3)
        R = rot.as_matrix()
        T = kinserve.pose(p, quat=rot.as_quat())  # scipy's as_quat is [x, y, z, w]
        assert T.shape == (4, 4) and np.array_equal(T[3], [0, 0, 0, 1]) and np.array_equal(T[:3, 3], p)
        np.testing.assert_allclose(T[:3, :3], R, atol=1e-12)
        np.testing.assert_allclose(kinserve.pose(p, quat=-rot.as_quat()), T, atol=1e-12)  # q and -q
        roll, pitch, yaw = rng.uniform(-np.pi, np.pi, 3)
        # scipy's lower-case "xyz": about the fixed x, then y, then z = Rz(yaw) Ry(pitch) Rx(roll)
        ref = Rotation.from_euler("xyz", [roll, pitch, yaw]).as_matrix()
        np.testing.assert_allclose(kinserve.pose(p, rpy=[roll, pitch, yaw])[:3, :3], ref, atol=1e-12)
        np.testing.assert_allclose(kinserve.pose(p, R=R)[:3, :3], R, atol=0)
    assert np.array_equal(kinserve.pose([1, 2, 3]), [[1, 0, 0, 1], [0, 1, 0, 2], [0, 0, 1, 3], [0, 0, 0, 1]])
    assert kinserve.pose is make_pose and "pose" in kinserve.__all__


def test_quaternion_near_unit_is_normalised_and_far_from_unit_is_refused(rng):
    rot = random_rotation(rng)
    q = rot.as_quat()
    near = q * (1 + 0.9 * QUATERNION_TOL)  # a rounded or printed quaternion
    T = kinserve.pose([0, 0, 0], quat=near)
    np.testing.assert_allclose(T[:3, :3], rot.as_matrix(), atol=1e-12)
    np.testing.assert_allclose(T[:3, :3].T @ T[:3, :3], np.eye(3), atol=1e-14)
    for bad in (q * 1.01, q * 0.98, [0, 0, 0, 0]):
        with pytest.raises(InputError, match=r"quat must be a unit quaternion \[qx, qy, qz, qw\].*scalar"):
            kinserve.pose([0, 0, 0], quat=bad)


def test_pose_errors_name_the_argument():
    cases = [
        (dict(xyz=[0, 0], quat=[0, 0, 0, 1]), ShapeError, r"^xyz must have shape \(3,\)"),
        (dict(xyz=[0, 0, np.nan]), NonFiniteError, "^xyz must hold finite"),
        (dict(xyz=[0, 0, 0], quat=[0, 0, 1]), ShapeError, r"^quat must have shape \(4,\)"),
        (dict(xyz=[0, 0, 0], rpy=[0, 0]), ShapeError, r"^rpy must have shape \(3,\)"),
        (dict(xyz=[0, 0, 0], rpy=[0, np.inf, 0]), NonFiniteError, "^rpy must hold finite"),
        (dict(xyz=[0, 0, 0], R=np.eye(4)), ShapeError, r"^R must have shape \(3, 3\)"),
        (dict(xyz=[0, 0, 0], R=2 * np.eye(3)), RotationError, "^R: rotation block is not a rotation"),
        (dict(xyz=[0, 0, 0], R=np.diag([1.0, 1.0, -1.0])), RotationError, "det R = -1"),
        (dict(xyz=[0, 0, 0], quat=[0, 0, 0, 1], rpy=[0, 0, 0]), InputError, "at most one.*quat and rpy"),
    ]
    for kwargs, error, message in cases:
        with pytest.raises(error, match=message):
            kinserve.pose(**kwargs)


def test_as_pose_reads_every_form_alike(rng):
    for _ in range(10):
        rot, p = random_rotation(rng), rng.uniform(-1, 1, 3)
        q = rot.as_quat()
        T = se3.pose(rot.as_matrix(), p)
        forms = [T, T.tolist(), pin.SE3(T[:3, :3], T[:3, 3]), (p, q), [p.tolist(), q.tolist()],
                 (tuple(p), np.asarray(q)), np.concatenate([p, q]), [*p, *q]]
        for form in forms:
            out = as_pose(form)
            assert out.shape == (4, 4) and out.dtype == np.float64
            np.testing.assert_allclose(out, T, atol=1e-12)
    T = se3.pose(se3.rot_z(0.3), [1, 2, 3])
    assert as_pose(T) is T  # the fast path: a well-formed float64 4x4 is returned as it is


def test_as_pose_errors_list_the_forms_and_name_the_argument(panda):
    for bad in (np.eye(3), np.zeros(6), "abc", {"position": [0, 0, 0]}, [[1, 0, 0, 0], [0, 1, 0, 0]], None):
        with pytest.raises(ShapeError) as info:
            as_pose(bad, "goal")
        text = str(info.value)
        assert text.startswith("goal must be a pose:") and all(f in text for f in FORMS), text
    with pytest.raises(ShapeError, match=r"^goal: a \(position, orientation\) pair takes a quaternion.*rpy="):
        as_pose(([0, 0, 0], [0.1, 0.2, 0.3]), "goal")
    with pytest.raises(InputError, match=r"^goal quaternion must be a unit quaternion"):
        as_pose(([0, 0, 0], [0, 0, 0, 2]), "goal")
    with pytest.raises(NonFiniteError, match="^goal position must hold finite"):
        as_pose(([0, np.nan, 0], [0, 0, 0, 1]), "goal")
    with pytest.raises(NonFiniteError, match="^goal must hold finite"):
        as_pose([0, 0, 0, 0, 0, np.inf, 1], "goal")
    # a 7-joint configuration where a pose belongs is refused (its last four values are no unit quaternion)
    q = panda.neutral()
    assert q.shape == (7,) and abs(np.linalg.norm(q[3:]) - 1) > QUATERNION_TOL
    with pytest.raises(InputError, match=r"target\[3:7\] \(a 7-vector pose is \[x, y, z, qx, qy, qz, qw\]\)"):
        ik.solve(panda, q)


def test_ik_solve_gives_the_same_answer_for_every_pose_form():
    panda = robots.load("panda", geometry=False)
    rng = np.random.default_rng(24)
    for _ in range(3):
        T = panda.fk(panda.random_q(rng)).copy()
        p, quat = T[:3, 3], se3.quat_from_matrix(T[:3, :3])
        budget = dict(seed=5, iteration_budget=400)
        ref = ik.solve(panda, T, **budget)
        assert ref.success, ref.message
        for form in ((p, quat), [*p, *quat], kinserve.pose(p, quat=quat),
                     kinserve.pose(p, rpy=se3.rpy_from_matrix(T[:3, :3]))):
            res = ik.solve(panda, form, **budget)
            assert res.success and res.iterations == ref.iterations, (res, ref)
            np.testing.assert_allclose(res.q, ref.q, atol=1e-8)
            reached = panda.fk(res.q)
            assert se3.pose_error(reached, T)[0] < 1e-4 and se3.pose_error(reached, T)[1] < 1e-3


def test_shapes_take_the_quaternion_form(rng):
    rot, p = random_rotation(rng), rng.uniform(-1, 1, 3)
    box = Box((p, rot.as_quat()), (0.1, 0.2, 0.3))
    np.testing.assert_allclose(box.pose, se3.pose(rot.as_matrix(), p), atol=1e-12)


def test_import_kinserve_stays_cheap_and_pose_comes_on_first_use():
    code = ("import sys, kinserve; cheap = 'pinocchio' not in sys.modules; "
            "T = kinserve.pose([1, 2, 3], quat=[0, 0, 1, 0]); "
            "print(cheap, T[0, 0], T[1, 1], T[2, 2], T[0, 3])")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    assert out.stdout.split() == ["True", "-1.0", "-1.0", "1.0", "1.0"]  # 180 degrees about z
