"""SE(3) helpers on homogeneous 4x4 arrays (thin, named wrappers over Pinocchio).

Twists and pose errors are 6-vectors ``[v; w]`` (linear first, as Pinocchio's
``Motion``). Quaternions are ``(x, y, z, w)`` (Pinocchio / ROS / TRAC-IK order).
RPY angles give ``R = Rz(yaw) Ry(pitch) Rx(roll)`` (rad). These helpers trust
their input; ``kinserve.pose(xyz, quat=... | rpy=... | R=...)``
(:func:`kinserve.kinematics.validation.make_pose`) checks it and builds a pose.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from .types import MatrixLike, PoseLike, VectorLike


def pose(R: MatrixLike | None = None, p: VectorLike | None = None) -> np.ndarray:
    """Homogeneous matrix ``[[R, p], [0, 1]]`` (identity / zero by default), unchecked.

    Note the order: rotation first. ``kinserve.pose(xyz, quat=...)`` takes the
    position first and checks every argument.
    """
    T = np.eye(4)
    if R is not None:
        T[:3, :3] = R
    if p is not None:
        T[:3, 3] = p
    return T


def to_se3(T: PoseLike) -> pin.SE3:
    """4x4 array (or SE3) to ``pinocchio.SE3``."""
    if isinstance(T, pin.SE3):
        return T
    T = np.asarray(T, dtype=float)
    return pin.SE3(T[:3, :3].copy(), T[:3, 3].copy())


def inverse(T: np.ndarray) -> np.ndarray:
    """``T^-1 = [[R^T, -R^T p], [0, 1]]``."""
    Ti = np.eye(4)
    Ti[:3, :3] = T[:3, :3].T
    Ti[:3, 3] = -T[:3, :3].T @ T[:3, 3]
    return Ti


def log6(T: PoseLike) -> np.ndarray:
    """Twist ``xi = [v; w]`` with ``exp([xi]) = T`` (matrix logarithm on SE(3))."""
    return np.array(pin.log6(to_se3(T)).vector)


def exp6(xi: VectorLike) -> np.ndarray:
    """``exp([xi])`` for a twist ``xi = [v; w]`` (4x4)."""
    return pin.exp6(pin.Motion(np.asarray(xi, dtype=float))).homogeneous


def log3(R: MatrixLike) -> np.ndarray:
    """Rotation vector ``w`` (axis * angle, rad) with ``exp([w]x) = R``."""
    return np.array(pin.log3(np.asarray(R, dtype=float)))


def exp3(w: VectorLike) -> np.ndarray:
    """Rotation matrix ``exp([w]x)`` of a rotation vector (rad)."""
    return np.array(pin.exp3(np.asarray(w, dtype=float)))


def rotation_angle(R_a: MatrixLike, R_b: MatrixLike) -> float:
    """Geodesic angle (rad, in [0, pi]) between two rotations: ``|log(R_a^T R_b)|``."""
    return float(np.linalg.norm(log3(np.asarray(R_a).T @ np.asarray(R_b))))


def pose_error(T_current: MatrixLike, T_target: MatrixLike) -> tuple[float, float]:
    """(position error in m, orientation error in rad) between two poses."""
    Tc, Tt = np.asarray(T_current), np.asarray(T_target)
    return float(np.linalg.norm(Tt[:3, 3] - Tc[:3, 3])), rotation_angle(Tc[:3, :3], Tt[:3, :3])


def rpy_from_matrix(R: MatrixLike) -> np.ndarray:
    """(roll, pitch, yaw) with ``R = Rz(yaw) Ry(pitch) Rx(roll)``."""
    return np.array(pin.rpy.matrixToRpy(np.asarray(R, dtype=float)))


def matrix_from_rpy(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """``Rz(yaw) Ry(pitch) Rx(roll)``."""
    return np.array(pin.rpy.rpyToMatrix(float(roll), float(pitch), float(yaw)))


def quat_from_matrix(R: MatrixLike) -> np.ndarray:
    """Unit quaternion ``(x, y, z, w)`` of a rotation matrix."""
    return np.array(pin.Quaternion(np.asarray(R, dtype=float)).coeffs())


def matrix_from_quat(xyzw: VectorLike) -> np.ndarray:
    """Rotation matrix of a quaternion ``(x, y, z, w)`` (normalised first)."""
    x, y, z, w = (float(v) for v in xyzw)
    qt = pin.Quaternion(w, x, y, z)
    qt.normalize()
    return np.array(qt.toRotationMatrix())


def rot_x(a: float) -> np.ndarray:
    """Rotation about x by ``a`` rad (3x3)."""
    c, s = np.cos(a), np.sin(a)
    return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])


def rot_y(a: float) -> np.ndarray:
    """Rotation about y by ``a`` rad (3x3)."""
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


def rot_z(a: float) -> np.ndarray:
    """Rotation about z by ``a`` rad (3x3)."""
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])
