"""IK tasks: the :class:`Task` protocol (error ``e(q)``, Jacobian ``J(q)``, weight, priority) and its kinds.

* :mod:`.base` - the protocol, with a centre-of-mass example;
* :mod:`.frame_task` - :class:`FrameTask` (a frame at a pose, components relaxable);
* :mod:`.posture_task` - :class:`PostureTask` (joints towards a reference);
* :mod:`.centring_task` - :class:`CentringTask` (joints towards mid-range).
"""

from kinserve.ik.tasks.base import Task, check_priority, check_weight
from kinserve.ik.tasks.centring_task import CentringTask
from kinserve.ik.tasks.frame_task import FrameTask
from kinserve.ik.tasks.posture_task import PostureTask

__all__ = ["Task", "FrameTask", "PostureTask", "CentringTask", "check_priority", "check_weight"]
