"""``FrameTask``: place a frame at a target pose, some components optionally relaxed.

With the frame's pose ``(R, p)``, the target ``(R*, p*)`` and the axes ``A``
of the components (``I`` for ``relax_frame="world"``, ``R*`` for
``"target"``; see :mod:`kinserve.ik.targets`), the error is

    e = [ A^T (p - p*) ;  A^T log(R R*^T) ]        (m ; rad, kept rows only)

It vanishes exactly when the kept components match. With the geometric
(world-aligned) frame Jacobian ``[J_v; J_w]`` the rotation moves as
``R(q + dq) = exp([J_w dq]) R``, so with ``X = R R*^T``,
``log(exp(w) X) = log(X exp(X^T w)) ~= log X + Jlog3(X) X^T w``
(``Jlog3`` = Pinocchio's inverse right Jacobian of SO(3)) and

    J = [ A^T J_v ;  A^T Jlog3(X) X^T J_w ]        (kept rows)

exactly to first order: ``e(q + dq) = e(q) + J dq + O(|dq|^2)``. The success
test uses the norms of the kept position rows (m) and rotation rows (rad):
for a full pose, the distance between the origins and the geodesic angle.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import pinocchio as pin

from kinserve.ik.targets import Target, check_relax_frame, checked_pose, parse_relax
from kinserve.ik.tasks.base import Task
from kinserve.kinematics.errors import InputError
from kinserve.kinematics.robot import TASK_AXES, Robot

_LWA = pin.LOCAL_WORLD_ALIGNED
_log3 = pin.log3
_Jlog3 = pin.Jlog3
_ufp = pin.updateFramePlacement
_gfj = pin.getFrameJacobian
_concat = np.concatenate
_hypot = math.hypot


class FrameTask(Task):
    """Frame ``frame`` (default: the robot's tip) at the 4x4 ``target`` pose (or ``pinocchio.SE3``).

    ``relax`` names components left free (``x y z roll pitch yaw``, ``phi`` =
    ``yaw``) measured along ``relax_frame`` axes (``"world"`` or ``"target"``).
    ``T`` is the (validated, private copy of the) target pose; move it with
    :meth:`set_target`. ``components`` names the kept rows of the error.
    ``weight`` is a number or one number per kept component (6 for a full pose); another length, an
    unknown frame name type, an unknown relaxed component or relaxing all six raise
    :class:`~kinserve.kinematics.errors.InputError` here, when the task is made.
    """

    def __init__(self, frame: str | None, target: np.ndarray | pin.SE3, relax: Sequence[str] | str = (),
                 relax_frame: str = "world", weight: float | Sequence[float] = 1.0,
                 priority: int = 1, name: str | None = None):
        if frame is not None and not isinstance(frame, str):
            raise InputError(f"frame must be a frame name or None (the robot's tip), got {frame!r}")
        check_relax_frame(relax_frame)
        relaxed = () if relax is None or (type(relax) is tuple and not relax) else parse_relax(relax)
        if len(relaxed) == 6:
            raise InputError("relax: every component is relaxed - there is nothing left to solve")
        self.kept = np.array([i for i in range(6) if i not in relaxed], dtype=int)  # (the weight's rows)
        super().__init__(weight, priority, name if name is not None else f"frame {frame or 'tip'}")
        self.frame = frame
        self.relax_frame = relax_frame
        self.relaxed = relaxed
        self.n_pos = int((self.kept < 3).sum())
        self.components = tuple(TASK_AXES[i] for i in self.kept)
        self.set_target(target)
        self._model = None
        self.frame_id = -1

    def weight_rows(self) -> int | None:
        """A vector weight has one entry per kept component (6 for a full pose)."""
        kept = getattr(self, "kept", None)
        return None if kept is None else len(kept)

    def set_target(self, target: np.ndarray | pin.SE3) -> None:
        """Move the target (validated 4x4 pose or ``SE3``); cheap enough for a control loop."""
        T = checked_pose(target)
        self._T = T
        self._p = T[:3, 3].copy()
        self._Rt = np.ascontiguousarray(T[:3, :3].T)
        self._At = None if self.relax_frame == "world" else self._Rt.copy()

    @property
    def T(self) -> np.ndarray:
        """The target pose (4x4, the task's own copy); assigning a pose calls :meth:`set_target`."""
        return self._T

    @T.setter
    def T(self, target: np.ndarray | pin.SE3) -> None:
        self.set_target(target)

    @classmethod
    def from_target(cls, target: Target) -> "FrameTask":
        """The task (weight 1, priority 1) of a legacy :class:`kinserve.ik.Target` (already validated)."""
        self = cls.__new__(cls)
        self.weight, self.priority, self.name = 1.0, 1, f"frame {target.frame}"
        self.frame, self.relax_frame, self.relaxed = target.frame, target.relax_frame, target.relaxed
        self.kept = np.asarray(target.kept, dtype=int)
        self.n_pos = int((self.kept < 3).sum())
        self.components = target.components
        T = target.T
        self._T = T
        self._p = T[:3, 3].copy()
        self._Rt = np.ascontiguousarray(T[:3, :3].T)
        self._At = None if target.relax_frame == "world" else self._Rt.copy()
        self._model = None
        self.frame_id = -1
        return self

    def bind(self, robot: Robot) -> "FrameTask":
        """Resolve the frame on ``robot`` (None: its tip); :class:`FrameError` for an unknown frame."""
        if self._model is not robot.model:
            frame = robot.tip if self.frame is None else self.frame
            self.frame_id = robot.frame_id(frame)
            self.frame_name = frame
            if self.frame is None:
                self.name = f"frame {frame}"
            self._model = robot.model
        return self

    def compute(self, robot: Robot, data: pin.Data, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(e, J)`` of the module docstring at ``q``, kept rows only (the :class:`Task` protocol)."""
        model = robot.model
        M = _ufp(model, data, self.frame_id)
        R = M.rotation
        X = R.dot(self._Rt)
        e = _concat((M.translation - self._p, _log3(X)))
        J = _gfj(model, data, self.frame_id, _LWA)  # a fresh array: its rotation rows are replaced in place
        J[3:] = _Jlog3(X).dot(X.T).dot(J[3:])
        At = self._At
        if At is not None:
            e[:3] = At.dot(e[:3])
            e[3:] = At.dot(e[3:])
            J[:3] = At.dot(J[:3])
            J[3:] = At.dot(J[3:])
        if self.n_pos == 3 and len(self.kept) == 6:
            return e, J
        return e[self.kept], J[self.kept]

    def errors(self, e: np.ndarray) -> tuple[float, float]:
        """Norms of the kept position rows (m) and of the kept rotation rows (rad) of ``e``."""
        n = self.n_pos
        v = e.tolist()  # a few Python floats: cheaper than slicing and two dot products
        return _hypot(*v[:n]), _hypot(*v[n:])

    def __repr__(self) -> str:
        relaxed = ",".join(TASK_AXES[i] for i in self.relaxed) or "none"
        return (f"FrameTask(frame={self.frame!r}, p={np.round(self._p, 4).tolist()}, relaxed={relaxed}, "
                f"weight={self.weight!r}, priority={self.priority})")
