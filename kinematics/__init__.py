"""kinematics: the Robot (Pinocchio model + data), FK, Jacobians, singularity, collision, SE(3), errors."""

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

__all__ = [
    "Robot", "TASK_AXES", "axis_rows", "TaskAxes", "detect_task_axes", "as_pose", "as_vector", "as_matrix",
    "errors", "se3", "shapes", "singularity",
    "Shape", "Sphere", "Box", "Capsule", "Cylinder", "Mesh", "as_shape", "CollisionModel", "PairDistance",
    "KinserveError", "ModelError", "InputError", "ShapeError", "NonFiniteError", "FrameError",
    "RotationError", "JointLimitError", "UnknownRobotError", "SingularityError", "WorkerError",
    "WorkerTimeoutError",
]
