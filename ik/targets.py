"""Pose targets, relaxed components, the task error and the task Jacobian rows.

A target asks frame ``f`` to reach the pose ``T* = (R*, p*)``. The six task
components are named ``x y z roll pitch yaw`` (``phi`` is an alias of
``yaw``). Any subset may be *relaxed* (left free): position-only IK is
``relax=("roll", "pitch", "yaw")``; a SCARA that does not care about its
tool angle relaxes ``("yaw",)``.

Axes of the components
----------------------
The components are measured along the axes of a reference frame ``A``:

* ``relax_frame="world"`` (default): ``A = I``, the world axes. Relaxing
  ``z`` frees the height, relaxing ``yaw`` frees rotations about the world
  ``z`` axis.
* ``relax_frame="target"``: ``A = R*``, the target frame's own axes (relax
  ``z`` to slide along the target's approach axis, ``yaw`` to spin about it).

Task error and Jacobian
-----------------------
With the current pose ``(R, p)`` of the frame, the 6-vector task error is

    e = [ A^T (p* - p) ;  A^T log(R* R^T) ]          (m ; rad)

where ``log`` is the SO(3) logarithm (rotation vector, world axes). It
vanishes exactly when the kept rows match: for one relaxed rotation axis
``a`` the zero set ``{R : log(R* R^T) || a}`` is precisely ``{Rot(a, t) R*}``.
To first order ``d e = -blockdiag(A^T, A^T) J dq`` with ``J`` the geometric
(world-aligned) Jacobian, so the Gauss-Newton step solves
``J_task dq = e_task`` with ``J_task = blockdiag(A^T, A^T) J`` restricted to
the kept rows. The reported errors are the norms of the kept position rows
(m) and of the kept rotation rows (rad): for a full pose, the distance
between origins and the geodesic angle between orientations.
"""

from __future__ import annotations

import math
from collections.abc import Iterable

import numpy as np
import pinocchio as pin

from kinserve.kinematics.errors import InputError
from kinserve.kinematics.robot import TASK_AXES, Robot, as_robot
from kinserve.kinematics.types import PoseLike
from kinserve.kinematics.validation import as_choice, as_pose, is_pose_fast

#: Accepted names of relaxable components (``phi`` = ``yaw``).
RELAX_NAMES = TASK_AXES + ("phi",)

#: Reference axes of the relaxed components.
RELAX_FRAMES = ("world", "target")

_log3 = pin.log3
_ALL6 = np.arange(6)
_ALL3 = np.arange(3)
_EYE3 = np.eye(3)
_F64 = np.dtype(np.float64)


def checked_pose(pose: object) -> np.ndarray:
    """A private float64 4x4 copy of a pose, validated: a 4x4, a ``pinocchio.SE3``, ``(position,
    quaternion [qx, qy, qz, qw])`` or ``[x, y, z, qx, qy, qz, qw]``.

    Fast path in plain Python floats for a well-formed 4x4 pose;
    anything else goes through :func:`kinematics.as_pose`, which reads the
    other forms and raises the precise error (shape, NaN/inf, bottom row,
    rotation not orthonormal, quaternion not unit).
    """
    if type(pose) is np.ndarray and pose.dtype is _F64 and pose.shape == (4, 4) and is_pose_fast(pose):
        return pose.copy()  # C-ordered
    if isinstance(pose, pin.SE3):
        pose = pose.homogeneous
        if is_pose_fast(pose):
            return pose
    return np.array(as_pose(pose, "target"), dtype=np.float64)


def check_relax_frame(relax_frame: object) -> str:
    """``relax_frame`` if it is one of :data:`RELAX_FRAMES`; else :class:`InputError` naming the choices."""
    if type(relax_frame) is str and relax_frame in RELAX_FRAMES:  # (the common case, no loop)
        return relax_frame
    return as_choice(relax_frame, "relax_frame", RELAX_FRAMES)


def parse_relax(relax: str | Iterable[str] | None) -> tuple[int, ...]:
    """Sorted row indices (0..5 into ``x y z roll pitch yaw``) of the relaxed components.

    ``relax`` is an iterable of names or one name / a comma- or space-separated
    string (``"roll,pitch,yaw"``). Unknown names raise :class:`InputError`.
    """
    if relax is None:
        return ()
    if isinstance(relax, str):
        names = [s for s in relax.replace(",", " ").split() if s]
    else:
        try:
            names = list(relax)
        except TypeError:
            raise InputError(f"relax must be a sequence of component names from {RELAX_NAMES}, "
                             f"got {relax!r}") from None
    rows = set()
    for name in names:
        if not isinstance(name, str):
            raise InputError(f"relax: component names must be strings from {RELAX_NAMES}, got {name!r}")
        key = name.strip().lower()
        key = "yaw" if key == "phi" else key
        if key not in TASK_AXES:
            raise InputError(
                f"relax: unknown component {name!r}; expected some of {' '.join(TASK_AXES)} ('phi' = 'yaw')"
            )
        rows.add(TASK_AXES.index(key))
    return tuple(sorted(rows))


class Target:
    """A pose target for one frame of a robot, with relaxed components.

    Parameters
    ----------
    robot:
        The :class:`kinserve.kinematics.Robot` (only used to resolve the frame; anything else, e.g. a
        robot's name, raises :class:`InputError`).
    pose:
        4x4 homogeneous pose, ``pinocchio.SE3``, ``(position, quaternion)`` or
        ``[x, y, z, qx, qy, qz, qw]`` (quaternion scalar last; checked: finite,
        bottom row ``[0 0 0 1]``, orthonormal rotation with det +1, unit quaternion).
    frame:
        Frame to place (default ``robot.tip``); unknown names raise ``FrameError``.
    relax:
        Components left free (see :func:`parse_relax`).
    relax_frame:
        ``"world"`` or ``"target"``: the axes of the components (module docstring).
    """

    __slots__ = (
        "T", "frame", "frame_id", "relaxed", "kept", "pos_rows", "rot_rows",
        "full", "relax_frame", "A", "components", "_p", "_R", "_Rt_axes",
    )

    def __init__(self, robot: Robot, pose: PoseLike, frame: str | None = None,
                 relax: str | Iterable[str] | None = (), relax_frame: str = "world") -> None:
        if type(robot) is not Robot:
            robot = as_robot(robot)
        T = checked_pose(pose)
        self.T = T
        self._R = T[:3, :3]
        self._p = T[:3, 3]
        self.frame = robot.tip if frame is None else frame
        self.frame_id = robot.frame_id(self.frame)
        self.relax_frame = check_relax_frame(relax_frame)
        self.relaxed = () if relax is None or (type(relax) is tuple and not relax) else parse_relax(relax)
        if not self.relaxed:
            self.kept, self.pos_rows, self.rot_rows = _ALL6, _ALL3, _ALL3
            self.full = True
            self.components = TASK_AXES
        else:
            if len(self.relaxed) == 6:
                raise InputError("relax: every component is relaxed - there is nothing left to solve")
            self.kept = np.array([i for i in range(6) if i not in self.relaxed], dtype=int)
            self.pos_rows = np.array([i for i in self.kept if i < 3], dtype=int)
            self.rot_rows = np.array([i - 3 for i in self.kept if i >= 3], dtype=int)
            self.full = False
            self.components = tuple(TASK_AXES[i] for i in self.kept)
        if relax_frame == "world":
            self.A = _EYE3
            self._Rt_axes = None
        else:
            self.A = self._R.copy()
            self._Rt_axes = self.A.T.copy()

    @property
    def se3(self) -> pin.SE3:
        """The target pose as a ``pinocchio.SE3`` (a new object per call)."""
        return pin.SE3(self._R, self._p)

    # ----------------------------------------------------------------- errors
    def error6(self, R: np.ndarray, p: np.ndarray) -> np.ndarray:
        """Full 6-vector ``[A^T (p* - p); A^T log(R* R^T)]`` (m; rad)."""
        ep = self._p - p
        ew = _log3(self._R @ R.T)
        if self._Rt_axes is not None:
            ep = self._Rt_axes @ ep
            ew = self._Rt_axes @ ew
        return np.concatenate((ep, ew))

    def residual(self, R: np.ndarray, p: np.ndarray) -> np.ndarray:
        """Kept rows of :meth:`error6` (the vector the solvers drive to zero)."""
        return self.error6(R, p)[self.kept]

    def errors(self, R: np.ndarray, p: np.ndarray) -> tuple[float, float]:
        """(position error in m, orientation error in rad) on the kept components."""
        e = self.error6(R, p)
        return self.errors_from6(e)

    def errors_from6(self, e: np.ndarray) -> tuple[float, float]:
        """(position, orientation) error norms of the kept rows of a 6-vector error."""
        ep = e[:3][self.pos_rows] if len(self.pos_rows) < 3 else e[:3]
        ew = e[3:][self.rot_rows] if len(self.rot_rows) < 3 else e[3:]
        return math.sqrt(float(ep @ ep)), math.sqrt(float(ew @ ew))

    def errors_at(self, robot: Robot, q: np.ndarray) -> tuple[float, float]:
        """Errors at configuration ``q`` (runs FK on ``robot``)."""
        T = robot.fk(q, self.frame)
        return self.errors(T[:3, :3], T[:3, 3])

    # --------------------------------------------------------------- Jacobian
    def jacobian(self, J_world: np.ndarray) -> np.ndarray:
        """Task Jacobian rows: ``blockdiag(A^T, A^T) J`` restricted to the kept rows.

        ``J_world`` is the geometric Jacobian ``(6, nq)`` (rows ``[v; w]``, world axes).
        """
        if self._Rt_axes is not None:
            J = np.empty_like(J_world)
            J[:3] = self._Rt_axes @ J_world[:3]
            J[3:] = self._Rt_axes @ J_world[3:]
        else:
            J = J_world
        return J[self.kept]

    def within(self, pos_err: float, rot_err: float, tol_pos: float, tol_rot: float) -> bool:
        """True when both errors are strictly below their tolerances."""
        return pos_err < tol_pos and rot_err < tol_rot

    def __repr__(self) -> str:
        relaxed = ",".join(TASK_AXES[i] for i in self.relaxed) or "none"
        return (f"Target(frame={self.frame!r}, p={np.round(self._p, 4).tolist()}, relaxed={relaxed}, "
                f"axes={self.relax_frame})")
