"""Motion planning in joint space: ``plan_motion`` (certified RRT-Connect, shortcuts, toppra timing).

See :mod:`.plan` for the steps; :mod:`.edges` for the certificate of a straight
motion, :mod:`.shortcut` for the simplification and :mod:`.timing` for the time
parameterisation.
"""

from .plan import plan_motion
from .result import MotionPlan

__all__ = ["MotionPlan", "plan_motion"]
