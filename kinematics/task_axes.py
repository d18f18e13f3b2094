"""Which task components (rows of the Jacobian) a mechanism can act on, read from its joint axes.

Singularity measures (:mod:`kinematics.singularity`) are computed on the
rows ``Robot.task_axes`` of the geometric Jacobian ``[v; w]``. Using all six
rows for every robot is wrong in two ways: a planar 4R arm has a 6x4
Jacobian of rank at most 3 (so it would always look singular), and a 3-joint
positioning arm stretched straight still has rank 3 over six rows (its
angular rows hide the lost position direction).

:func:`detect_task_axes` classifies the joint axes at one configuration
(parallelism and perpendicularity of joint axes are preserved by every
motion, so one configuration tells for all):

* **planar** - every revolute axis is parallel to one world axis ``n`` and
  every prismatic axis lies in the plane normal to ``n`` (or along ``n``):
  the plane's two translations plus the rotation about ``n`` (``x y yaw``
  for ``n = z``), plus the translation along ``n`` when a prismatic joint
  moves along it (a SCARA: ``x y z yaw``);
* **prismatic only** - the world axes the prismatic joints move along;
* **spatial with 3 joints or fewer** - the position rows ``x y z``: such an
  arm positions its tool, its orientation follows from the position;
* otherwise all six rows; with ``nq < 6`` the Jacobian has rank at most
  ``nq``, and a singularity is a rank below ``nq``.

A plane that is not normal to a world axis cannot be named with ``x y z
roll pitch yaw``; such a model gets the general rule (the reason says so).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from .robot import TASK_AXES

#: Tolerance on |sin| / |cos| of angles between unit joint axes.
PARALLEL_TOL = 1e-6

_TRANSLATION = ("x", "y", "z")
_ROTATION = ("roll", "pitch", "yaw")


@dataclass(frozen=True)
class TaskAxes:
    """Detected task components and the reason, in words."""

    axes: tuple[str, ...]
    reason: str


def joint_axes(model: pin.Model, q: np.ndarray | None = None) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """World directions ``(revolute axes, prismatic axes)`` of the 1-DOF joints at ``q``.

    Read from the joints' own columns of the LOCAL_WORLD_ALIGNED joint
    Jacobian: a revolute joint's column is ``[0; axis]``, a prismatic
    joint's ``[axis; 0]``.
    """
    if q is None:
        q = np.clip(pin.neutral(model), model.lowerPositionLimit, model.upperPositionLimit)
    data = model.createData()
    pin.computeJointJacobians(model, data, q)
    revolute, prismatic = [], []
    for j in range(1, model.njoints):
        if model.joints[j].nv != 1:
            continue
        J = np.asarray(pin.getJointJacobian(model, data, j, pin.LOCAL_WORLD_ALIGNED)).reshape(6, model.nv)
        col = J[:, model.joints[j].idx_v]
        lin, ang = col[:3], col[3:]
        if np.linalg.norm(ang) > 0.5:
            revolute.append(ang / np.linalg.norm(ang))
        else:
            prismatic.append(lin / np.linalg.norm(lin))
    return revolute, prismatic


def _world_axis(n: np.ndarray) -> int | None:
    """Index 0/1/2 of the world axis ``n`` is parallel to, or None."""
    k = int(np.argmax(np.abs(n)))
    return k if abs(n[k]) > 1.0 - PARALLEL_TOL else None


def _ordered(names) -> tuple[str, ...]:
    return tuple(a for a in TASK_AXES if a in set(names))


def detect_task_axes(model: pin.Model) -> TaskAxes:
    """The task components a model can act on (see the module docstring for the rules)."""
    revolute, prismatic = joint_axes(model)
    nq = model.nv
    if revolute:
        n = revolute[0]
        if all(np.linalg.norm(np.cross(n, r)) < PARALLEL_TOL for r in revolute):
            in_plane = [abs(float(np.dot(p, n))) < PARALLEL_TOL for p in prismatic]
            along = [np.linalg.norm(np.cross(p, n)) < PARALLEL_TOL for p in prismatic]
            k = _world_axis(n)
            if all(a or b for a, b in zip(in_plane, along)) and k is not None:
                names = [t for i, t in enumerate(_TRANSLATION) if i != k] + [_ROTATION[k]]
                if any(along):
                    names.append(_TRANSLATION[k])
                axes = _ordered(names)
                slides = ""
                if prismatic:
                    normal = " or along its normal" if any(along) else ""
                    slides = f" and every prismatic axis lies in the plane{normal}"
                return TaskAxes(axes, "planar: every revolute axis is parallel to world "
                                      f"{_TRANSLATION[k]}{slides}; task rows {' '.join(axes)}")
            if all(a or b for a, b in zip(in_plane, along)):
                note = "planar in a plane not normal to a world axis (rows cannot be named); "
                return _general(nq, note)
    elif prismatic:
        ks = [_world_axis(p) for p in prismatic]
        names = [_TRANSLATION[k] for k in ks if k is not None] if None not in ks else list(_TRANSLATION)
        axes = _ordered(names)
        return TaskAxes(axes, f"prismatic joints only: task rows {' '.join(axes)}")
    return _general(nq, "")


def _general(nq: int, note: str) -> TaskAxes:
    if nq <= 3:
        return TaskAxes(_TRANSLATION, f"{note}{nq} joint(s), not planar: the position rows x y z are the "
                                      "meaningful ones (the orientation follows from the position)")
    if nq < 6:
        return TaskAxes(TASK_AXES, f"{note}{nq} joints: all six rows, the Jacobian has rank at most {nq}; "
                                   f"singular means rank below {nq}")
    return TaskAxes(TASK_AXES, f"{note}{nq} joints: all six rows")
