"""Hard IK constraints: the :class:`Constraint` protocol and its implementations.

* :mod:`.base` - the protocol (linear rows ``lower <= G dq <= upper`` at ``q``
  and a true check of ``q + dq``), the velocity-damper gain;
* :mod:`.sphere_set` - spheres against the link segments, pair by pair (the
  original ``"qp"`` method's constraint), the robot's segments, step bounds;
* :mod:`.collision` - self-collision and obstacles against the robot's collision
  geometry (coal witness points and normals).
"""

from .base import DAMPER_GAIN, Constraint
from .collision import CollisionConstraint, SceneCollision, SelfCollision
from .sphere_set import SphereSet, as_sphere, frame_points, joint_step_bounds, robot_segments
from kinserve.kinematics.shapes import Sphere

__all__ = ["Constraint", "CollisionConstraint", "SelfCollision", "SceneCollision", "DAMPER_GAIN", "Sphere", "SphereSet", "as_sphere", "frame_points", "joint_step_bounds",
           "robot_segments"]
