"""Request/response schemas of ``POST /plan/motion`` (:func:`kinserve.planners.plan_motion` over HTTP).

Bounded like every request (:mod:`.schemas`): JSON numbers only (text and true / false refused,
an integer field refuses 2.5), finite, at most :data:`MAX_GOALS` goals in a goal set, 32 obstacles
(the ``/ik`` shapes), :data:`MAX_ATTACHED` carried objects, :data:`MAX_ITERATIONS` search samples; the
answer's trajectory holds at most :data:`MAX_TRAJECTORY_POINTS` samples (above,
it is left out and the message says so; the path is always there).
"""

from __future__ import annotations

from typing import Annotated, Any

from pydantic import BaseModel, ConfigDict, Discriminator, Field, Tag

from .schemas import (
    Flag,
    JointTrajectoryOut,
    JointVector,
    Name,
    Obstacle,
    Obstacles,
    Pose,
    PositionQuaternion,
    PositionRPY,
    RelaxName,
    RobotRef,
    Seconds,
    Seed,
    Strict,
    integer,
    real,
)

#: Most configurations in a goal set.
MAX_GOALS = 64
#: Most carried objects in one request.
MAX_ATTACHED = 8
#: Most RRT-Connect samples a request may ask for.
MAX_ITERATIONS = 200_000
#: Most trajectory samples in an answer (samples are 10 ms apart: 100 s of motion).
MAX_TRAJECTORY_POINTS = 10_000

GoalSet = Annotated[list[JointVector], Field(min_length=1, max_length=MAX_GOALS)]


def _goal_form(value: Any) -> str:
    """``configuration`` (a list of numbers), ``set`` (a list of lists: a goal set, or a 4x4 pose matrix),
    or a pose object (``{"position", "quaternion"}`` / ``{"position", "rpy"}``)."""
    if isinstance(value, dict):
        return "position_rpy" if "rpy" in value else "position_quaternion"
    if isinstance(value, (PositionQuaternion, PositionRPY)):
        return "position_rpy" if isinstance(value, PositionRPY) else "position_quaternion"
    if isinstance(value, list) and value and isinstance(value[0], list):
        return "set"
    return "configuration"


MotionGoal = Annotated[
    Annotated[JointVector, Tag("configuration")] | Annotated[GoalSet, Tag("set")]
    | Annotated[PositionQuaternion, Tag("position_quaternion")] | Annotated[PositionRPY, Tag("position_rpy")],
    Discriminator(_goal_form),
    Field(description="one configuration (nq numbers); a goal set (a list of configurations: reach any one); "
                      "or a pose of `frame` in the world: a 4x4 matrix (row major; on a robot with nq = 4 a "
                      "4x4 list is a goal set unless `frame` or `relax` is given), {\"position\", "
                      "\"quaternion\" [qx, qy, qz, qw]} or {\"position\", \"rpy\"}"),
]

Positive = real(ge=1e-2, le=1e4)
Accelerations = Positive | Annotated[list[Positive], Field(min_length=1, max_length=64)]


class AttachedSpec(Strict):
    """A shape carried by a frame of the robot during this plan only (``robot.attach`` on the request's own
    copy of the robot): checked against the obstacles and against every link but its touch links."""

    name: Name
    shape: Obstacle = Field(description="the shape, as an obstacle (sphere, box, capsule, cylinder), in the "
                                        "pose_in_frame coordinates")
    frame: Name = Field(description="the frame carrying it (e.g. the tool frame)")
    pose_in_frame: Pose | None = Field(default=None, description="pose of the shape's coordinates in `frame` "
                                                                 "(default identity)")
    touch_links: Annotated[list[Name], Field(max_length=64)] | None = Field(
        default=None, description="links it may touch (default: the link `frame` belongs to)")


EXAMPLE_REQUEST = {
    "robot": "panda",
    "start": [0.0, -0.3, 0.0, -2.2, 0.0, 1.9, 0.785],
    "goal": [1.2, -0.3, 0.0, -2.2, 0.0, 1.9, 0.785],
    "obstacles": [{"kind": "box", "pose": [[1, 0, 0, 0.35], [0, 1, 0, 0.35], [0, 0, 1, 0.45], [0, 0, 0, 1]],
                   "size": [0.1, 0.1, 0.3]}],
    "attached": [{"name": "part", "shape": {"kind": "sphere", "center": [0, 0, 0.05], "radius": 0.03},
                  "frame": "panda_hand", "touch_links": ["panda_hand", "panda_leftfinger",
                                                         "panda_rightfinger"]}],
    "seed": 1,
    "max_iterations": 5000,
    "max_time": 2.0,
}


class MotionPlanRequest(RobotRef):
    """Body of ``POST /plan/motion``: a collision-free joint-space motion from ``start`` to ``goal``."""

    model_config = ConfigDict(extra="forbid", json_schema_extra={"examples": [EXAMPLE_REQUEST]})

    start: JointVector
    goal: MotionGoal
    frame: Name | None = Field(default=None,
                               description="frame of a pose goal; default the robot's tool frame")
    relax: Annotated[list[RelaxName], Field(max_length=6)] = Field(
        default_factory=list, description="components of a pose goal left free")
    goal_count: integer(1, 16) = Field(
        default=4, description="a pose goal becomes a goal set of up to this many IK solutions")
    obstacles: Obstacles = Field(default_factory=list,
                                 description="shapes the robot and carried objects keep clear of")
    attached: Annotated[list[AttachedSpec], Field(max_length=MAX_ATTACHED)] = Field(
        default_factory=list, description="objects carried by the robot during this plan")
    self_collision: Flag = Field(default=True, description="check the robot's own link pairs too")
    seed: Seed | None = None
    max_iterations: integer(1, MAX_ITERATIONS) | None = Field(
        default=None, description="RRT-Connect samples; with a seed and a max_time that does not run out, "
                                  "the answer depends only on the request")
    max_time: Seconds | None = Field(
        default=None, description="seconds for the plan (a pose goal's IK included, not the one-time set-up "
                                  "of a robot); default 1 s, capped server-side (--max-time-cap)")
    acceleration_limits: Accelerations | None = Field(
        default=None, description="rad/s^2 (m/s^2), one for every joint or one per joint; default 2 x the "
                                  "URDF velocity limits")
    simplify: Flag = Field(default=True, description="shortcut the path")


class MotionTrajectoryOut(JointTrajectoryOut):
    """The timed path: times (s), positions, velocities, accelerations per sample, at rest at both ends."""


class MotionPlanResponse(BaseModel):
    """Answer of ``POST /plan/motion``; a failure (start or goal in collision, no path in the budget) is a
    200 with ``success: false`` and the reason in ``message``."""

    model_config = ConfigDict(json_schema_extra={"examples": [{
        "success": True, "message": "path found (3 waypoints), timed by toppra",
        "path": [[0.0, -0.3, 0.0, -2.2, 0.0, 1.9, 0.785], [0.6, -0.6, 0.0, -2.2, 0.0, 1.9, 0.785],
                 [1.2, -0.3, 0.0, -2.2, 0.0, 1.9, 0.785]],
        "trajectory": {"joint_names": ["panda_joint1", "panda_joint2", "panda_joint3", "panda_joint4",
                                       "panda_joint5", "panda_joint6", "panda_joint7"],
                       "times": [0.0, 1.5],
                       "positions": [[0.0, -0.3, 0.0, -2.2, 0.0, 1.9, 0.785],
                                     [1.2, -0.3, 0.0, -2.2, 0.0, 1.9, 0.785]],
                       "velocities": [[0.0] * 7, [0.0] * 7], "accelerations": [[0.0] * 7, [0.0] * 7]},
        "goal_index": 0, "goals": [[1.2, -0.3, 0.0, -2.2, 0.0, 1.9, 0.785]],
        "stats": {"plan_time": 0.01, "iterations": 12, "nodes": 20, "timing": "toppra"},
    }]})

    success: bool
    message: str
    path: list[list[float]] = Field(description="waypoints from start to the goal reached; every segment is "
                                                "certified collision free (empty on failure)")
    trajectory: MotionTrajectoryOut | None = Field(
        description="null on failure, or when it would exceed the sample limit (the message says so)")
    goal_index: int = Field(description="index in `goals` of the goal reached; -1 on failure")
    goals: list[list[float]] = Field(description="the goal configurations searched for (a pose goal's IK "
                                                 "solutions)")
    stats: dict[str, float | int | str] = Field(description="times (s), counts and path lengths (rad) of the "
                                                            "plan, as planners.MotionPlan.stats")


__all__ = ["AttachedSpec", "EXAMPLE_REQUEST", "MAX_ATTACHED", "MAX_GOALS", "MAX_ITERATIONS",
           "MAX_TRAJECTORY_POINTS", "MotionGoal", "MotionPlanRequest", "MotionPlanResponse"]
