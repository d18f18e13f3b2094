"""Hard IK constraints: the :class:`Constraint` protocol and its implementations.

* :mod:`.base` - the protocol (linear rows ``lower <= G dq <= upper`` at ``q``
  and a true check of ``q + dq``), the velocity-damper gain;
* :mod:`.joint_limits` - :class:`JointLimits` (always on);
* :mod:`.velocity_limits` - :class:`VelocityLimits` (``ik.step``);
* :mod:`.obstacles` - :class:`ObstacleAvoidance`: any shape of
  :mod:`kinserve.kinematics.shapes` kept clear of the robot's link capsules, built from
  :mod:`.obstacle_arguments` (its checked arguments), :mod:`.robot_skeleton` (the robot's moving
  segments and fixed base, per robot), :mod:`.obstacle_base` (obstacles containing the base),
  :mod:`.obstacle_tables` (the immutable pair tables of a bind), :mod:`.obstacle_distance` and
  :mod:`.obstacle_geometry` (the pairs' distances: closed forms, coal), :mod:`.sphere_rows` (the
  compiled sphere-only path), :mod:`.obstacle_violations` (many configurations at once) and
  :mod:`.clearance_kernel` (the compiled kernels);
* :mod:`.link_segments` - the robot's links, sliders and tool as segments between body points;
* :mod:`.link_capsules` - those segments as capsules: their end points and distance-gradient rows;
* :mod:`.segment_distance` - vectorised point-segment, segment-segment and segment-box closed forms;
* :mod:`.collision` - :class:`SelfCollision`, :class:`SceneCollision`, :class:`CollisionConstraint`:
  the robot's collision geometry (convex hulls) against itself and obstacles (coal witness points and
  normals).
"""

from kinserve.ik.constraints.base import DAMPER_GAIN, Constraint
from kinserve.ik.constraints.collision import CollisionConstraint, SceneCollision, SelfCollision
from kinserve.ik.constraints.joint_limits import JointLimits
from kinserve.ik.constraints.link_segments import LinkSegment, frame_points, robot_segments
from kinserve.ik.constraints.obstacles import ObstacleAvoidance, as_obstacle
from kinserve.ik.constraints.velocity_limits import VelocityLimits
from kinserve.kinematics.shapes import Sphere, as_sphere

__all__ = ["Constraint", "DAMPER_GAIN", "JointLimits", "VelocityLimits", "ObstacleAvoidance", "as_obstacle",
           "SelfCollision", "SceneCollision", "CollisionConstraint",
           "Sphere", "as_sphere", "LinkSegment", "frame_points", "robot_segments"]
