"""Motion planning in joint space: ``plan_motion`` (certified RRT-Connect, shortcuts, toppra timing).

See :mod:`.plan` for the steps; :mod:`.edges` for the certificate of a straight
motion, :mod:`.shortcut` for the simplification and :mod:`.timing` for the time
parameterisation.
"""

from .batch import MotionProblem, plan_many
from .plan import plan_motion
from .result import MotionPlan
from .scene_yaml import (
    MotionRequest,
    joint_vector,
    read_motion_request,
    read_planning_scene,
    write_planning_scene,
)

__all__ = ["MotionPlan", "plan_motion"]
# plan_many and the MoveIt YAML scenes (issue 22)
__all__ += ["plan_many", "MotionProblem", "read_planning_scene", "write_planning_scene",
            "read_motion_request", "MotionRequest", "joint_vector"]
