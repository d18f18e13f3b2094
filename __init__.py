"""kinserve: a Pinocchio-based kinematics service for robot arms and mobile bases.

One import namespace: the repository's top-level folders are installed as its
subpackages::

    import kinserve
    from kinserve import robots, ik
    panda = robots.load("panda")
    result = ik.solve(panda, kinserve.pose([0.4, 0.1, 0.5], quat=[1, 0, 0, 0]))

Poses are accepted everywhere as a 4x4 homogeneous matrix, a ``pinocchio.SE3``,
a pair ``(position [x, y, z], quaternion [qx, qy, qz, qw])`` (scalar last, as
Pinocchio and ROS write it) or a 7-vector ``[x, y, z, qx, qy, qz, qw]``;
:func:`kinserve.pose` builds the 4x4 from a position and a quaternion, roll /
pitch / yaw or a rotation matrix.

Subpackages: :mod:`kinserve.robots` (models and loaders), :mod:`kinserve.kinematics`
(the ``Robot``, FK, Jacobians, errors), :mod:`kinserve.ik` (tasks, constraints,
solvers), :mod:`kinserve.planners` (trajectories, paths, mobile bases),
:mod:`kinserve.viz` (meshcat scenes and plots), :mod:`kinserve.scenarios` (the
seed scenarios S1-S9) and :mod:`kinserve.service` (the CLI and HTTP service).
Subpackages are imported on first use, so ``import kinserve`` stays cheap.
"""

from __future__ import annotations

import importlib
from importlib.metadata import PackageNotFoundError, version
from types import ModuleType
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:  # kinserve.pose, imported on first use (see __getattr__)
    from kinserve.kinematics.validation import make_pose as pose

try:
    __version__: str = version("kinserve")
except PackageNotFoundError:  # pragma: no cover - running from a tree that was never installed
    __version__ = "0+unknown"

SUBPACKAGES = ("robots", "kinematics", "ik", "planners", "viz", "scenarios", "service")
__all__ = ["__version__", "clear_caches", "pose", *SUBPACKAGES]


def clear_caches(*robots: object) -> None:
    """Forget what kinserve keeps between calls, so the next call builds it again.

    Process-wide: the registry's parsed models (:func:`kinserve.robots.registry.clear_cache`) and the meshes
    read for them (:func:`kinserve.robots.urdf_loader.clear_mesh_cache`). Per robot,
    for each robot given: its IK state (seed tables, closed-form solvers, bound collision constraints; shared
    with its copies) and its collision models' scene layouts and last scene
    (:meth:`~kinserve.kinematics.robot.Robot.forget_collision_scenes`; a model not built yet is not built).
    Files cached on disk (collision models) stay: delete the cache folder to drop them.

    Refused (:class:`~kinserve.kinematics.errors.InputError`, before anything is cleared): an argument
    that is not a kinserve ``Robot`` (a robot's name, ``None``, ...).
    """
    from kinserve.ik.state import clear
    from kinserve.kinematics.errors import InputError
    from kinserve.kinematics.robot import Robot
    from kinserve.robots.registry import clear_cache
    from kinserve.robots.urdf_loader import clear_mesh_cache

    for i, robot in enumerate(robots):
        if not isinstance(robot, Robot):
            hint = " (load it first: kinserve.robots.load(name))" if isinstance(robot, str) else ""
            raise InputError(f"clear_caches: argument {i + 1} must be a kinserve Robot, got "
                             f"{type(robot).__name__} {robot!r}{hint}")
    clear_cache()
    clear_mesh_cache()
    for robot in robots:
        clear(robot)
        robot.forget_collision_scenes()


def __getattr__(name: str) -> ModuleType | Any:
    """``kinserve.ik`` and friends without importing every subpackage up front (PEP 562); ``kinserve.pose``
    is :func:`kinserve.kinematics.validation.make_pose`."""
    if name in SUBPACKAGES:
        return importlib.import_module(f"{__name__}.{name}")
    if name == "pose":
        from kinserve.kinematics.validation import make_pose

        return make_pose
    raise AttributeError(f"module 'kinserve' has no attribute {name!r}")
