"""kinematics: the Robot (Pinocchio model + data), FK, Jacobians, singularity, collision, SE(3), errors.

The names below are imported on first use (PEP 562), so ``from kinserve.kinematics.errors import ...``
(the command line, a solver process starting up) does not import Pinocchio, Numba and the collision
core. The compiled kernels still load when the module that needs them is imported (see
:mod:`kinserve.kinematics.kernel_cache`), not inside a timed call.
"""

from __future__ import annotations

import importlib
import importlib.util
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from . import errors, se3, shapes, singularity
    from .collision_model import CollisionModel
    from .collision_queries import PairDistance
    from .errors import (
        FrameError,
        InputError,
        JointLimitError,
        KinserveError,
        ModelError,
        NonFiniteError,
        RotationError,
        ShapeError,
        SingularityError,
        UnknownRobotError,
        WorkerError,
        WorkerTimeoutError,
    )
    from .robot import TASK_AXES, Robot, axis_rows
    from .shapes import Box, Capsule, Cylinder, Mesh, Shape, Sphere, as_shape
    from .task_axes import TaskAxes, detect_task_axes
    from .validation import as_matrix, as_pose, as_vector

#: Each public name and the submodule that defines it.
_HOMES: dict[str, str] = {
    **dict.fromkeys(("Robot", "TASK_AXES", "axis_rows"), "robot"),
    **dict.fromkeys(("TaskAxes", "detect_task_axes"), "task_axes"),
    **dict.fromkeys(("as_pose", "as_vector", "as_matrix"), "validation"),
    **dict.fromkeys(("Shape", "Sphere", "Box", "Capsule", "Cylinder", "Mesh", "as_shape"), "shapes"),
    "CollisionModel": "collision_model",
    "PairDistance": "collision_queries",
    **dict.fromkeys(("KinserveError", "ModelError", "InputError", "ShapeError", "NonFiniteError",
                     "FrameError", "RotationError", "JointLimitError", "UnknownRobotError",
                     "SingularityError", "WorkerError", "WorkerTimeoutError"), "errors"),
}
#: Submodules that are public names of this package.
_SUBMODULES = ("errors", "se3", "shapes", "singularity")

__all__ = [
    "Robot", "TASK_AXES", "axis_rows", "TaskAxes", "detect_task_axes", "as_pose", "as_vector", "as_matrix",
    "errors", "se3", "shapes", "singularity",
    "Shape", "Sphere", "Box", "Capsule", "Cylinder", "Mesh", "as_shape", "CollisionModel", "PairDistance",
    "KinserveError", "ModelError", "InputError", "ShapeError", "NonFiniteError", "FrameError",
    "RotationError", "JointLimitError", "UnknownRobotError", "SingularityError", "WorkerError",
    "WorkerTimeoutError",
]


def __getattr__(name: str) -> Any:
    """A public name, imported from its submodule on first use (then kept in the package's namespace); any
    other submodule (``kinserve.kinematics.robot``) is imported too, as the package's eager imports made it
    an attribute before."""
    if name in _HOMES:
        value: Any = getattr(importlib.import_module(f"{__name__}.{_HOMES[name]}"), name)
    elif name in _SUBMODULES or (not name.startswith("_")
                                 and importlib.util.find_spec(f"{__name__}.{name}") is not None):
        value = importlib.import_module(f"{__name__}.{name}")
    else:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted({*globals(), *__all__})
