"""Pydantic request/response schemas of the HTTP service (they are the OpenAPI document).

Every number of every request model is a JSON number, built by :func:`real` (a float field; an integer is
taken as a float) or :func:`integer` (an integer field: 2.5 and 2.0 are refused): text such as ``"0.1"`` and
``true`` / ``false`` are refused, not read as numbers; a yes / no field (:data:`Flag`) takes ``true`` or
``false`` only. Numbers are finite and bounded (|x| <= 1e6, the
library's one bound ``kinematics.validation.MAX_ABS``, or the field's own tighter bounds): NaN, infinities
and absurd magnitudes are rejected with a 422 naming the field before any solver runs. String model
parameters are bounded the same way when the model is built. Response models are not affected.
"""

from __future__ import annotations

from typing import Annotated, Any, Literal

from pydantic import AfterValidator, BaseModel, ConfigDict, Discriminator, Field, Tag, field_validator

from kinserve.ik.options import MAX_TIME_QP
from kinserve.kinematics.errors import KinserveError
from kinserve.kinematics.validation import MAX_ABS, make_pose, unit_quaternion

BOUND = MAX_ABS


def real(*, gt: float | None = None, ge: float | None = None, le: float = BOUND) -> Any:
    """The type of a request's float field: a finite JSON number ``> gt`` / ``>= ge`` (when given) and
    ``<= le`` (default :data:`BOUND`). An integer is taken as a float; text (``"0.1"``) and ``true`` /
    ``false`` are refused (pydantic's strict mode), a 422 naming the field."""
    lower = {name: value for name, value in (("gt", gt), ("ge", ge)) if value is not None}
    return Annotated[float, Field(strict=True, allow_inf_nan=False, le=le, **lower)]


def integer(ge: int, le: int) -> Any:
    """The type of a request's integer field: a JSON integer in ``[ge, le]``. A number with a fraction part
    (``2.5``, and ``2.0`` too), text (``"5"``) and ``true`` / ``false`` are refused (pydantic's strict mode),
    a 422 naming the field."""
    return Annotated[int, Field(strict=True, ge=ge, le=le)]


#: A JSON number (an integer is taken as a float; text and true / false are refused, not read as numbers).
Number = real(ge=-BOUND)
#: A size (m): a JSON number in (0, 1e6].
Length = real(gt=0)
#: A time budget (s): a JSON number in (0, 1e6].
Seconds = real(gt=0)
#: A seed of random restarts or samples.
Seed = integer(0, 2**32 - 1)
#: A request's yes / no field: JSON ``true`` or ``false`` only (pydantic's lax mode read ``"yes"``, ``"true"``
#: and ``1`` as true).
Flag = Annotated[bool, Field(strict=True)]
Row4 = Annotated[list[Number], Field(min_length=4, max_length=4)]
JointVector = Annotated[list[Number], Field(min_length=1, max_length=64,
                                            description="joint values (rad / m)")]
Name = Annotated[str, Field(min_length=1, max_length=200)]
#: A model parameter: a JSON number, or text (a xacro argument; a number written as text stays text).
ParamValue = Number | Annotated[str, Field(max_length=200)]
RelaxName = Literal["x", "y", "z", "roll", "pitch", "yaw", "phi"]
Method = Literal["auto", "qp", "lm", "dls", "pseudo_inverse", "jacobian_inverse", "jacobian_transpose",
                 "analytic"]


class Strict(BaseModel):
    """A request model: unknown fields are rejected (422)."""

    model_config = ConfigDict(extra="forbid")


def examples(*bodies: dict, strict: bool = True) -> ConfigDict:
    """The model configuration carrying ``bodies`` as the schema's ``examples`` (shown in ``/docs`` and
    ``/redoc``; a test posts every request example and validates every answer example); ``strict``: unknown
    fields rejected, as every request model."""
    extra = {"json_schema_extra": {"examples": list(bodies)}}
    return ConfigDict(extra="forbid", **extra) if strict else ConfigDict(**extra)


#: The Panda's "ready" configuration (rad), the start of the examples.
PANDA_READY = [0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785]
#: The examples' IK target of ``panda_hand_tcp``: 0.4 m ahead, 0.1 m left, 0.45 m up, pointing down (a half
#: turn about x: quaternion [qx, qy, qz, qw] = [1, 0, 0, 0]).
EXAMPLE_TARGET = {"position": [0.4, 0.1, 0.45], "quaternion": [1.0, 0.0, 0.0, 0.0]}


# ---------------------------------------------------------------- poses: a 4x4, or a position and a rotation
Point3 = Annotated[list[Number], Field(min_length=3, max_length=3)]
Matrix4 = Annotated[list[Row4], Field(min_length=4, max_length=4,
                                      description="homogeneous 4x4 pose, row major")]


class PositionQuaternion(Strict):
    """A pose as a position (m) and a unit quaternion ``[qx, qy, qz, qw]`` (scalar last, as Pinocchio and ROS
    write it)."""

    position: Point3 = Field(description="[x, y, z] (m)")
    quaternion: Annotated[list[Number], Field(min_length=4, max_length=4)] = Field(
        description="unit quaternion [qx, qy, qz, qw], scalar last (Pinocchio's and ROS's order); a norm "
                    "more than 1e-3 from 1 is refused, the rest normalised")

    @field_validator("quaternion")
    @classmethod
    def _unit(cls, value: list[float]) -> list[float]:
        try:
            unit_quaternion(value, "quaternion")  # the library's rule (kinserve.pose)
        except KinserveError as exc:
            raise ValueError(str(exc)) from None
        return value

    def matrix(self) -> list[list[float]]:
        """The 4x4 pose (row major), as :func:`kinserve.pose` builds it."""
        return make_pose(self.position, quat=self.quaternion).tolist()


class PositionRPY(Strict):
    """A pose as a position (m) and roll, pitch, yaw (rad): ``R = Rz(yaw) Ry(pitch) Rx(roll)``."""

    position: Point3 = Field(description="[x, y, z] (m)")
    rpy: Point3 = Field(description="[roll, pitch, yaw] (rad): R = Rz(yaw) Ry(pitch) Rx(roll), fixed axes")

    def matrix(self) -> list[list[float]]:
        """The 4x4 pose (row major), as :func:`kinserve.pose` builds it."""
        return make_pose(self.position, rpy=self.rpy).tolist()


def _pose_form(value: Any) -> str:
    """The form of a pose: an object with ``rpy`` or else one with ``quaternion``; anything else is read as
    the 4x4 matrix (and gets that form's errors)."""
    if isinstance(value, dict):
        return "position_rpy" if "rpy" in value else "position_quaternion"
    if isinstance(value, PositionRPY):
        return "position_rpy"
    return "position_quaternion" if isinstance(value, PositionQuaternion) else "matrix"


def _pose_matrix(value: Any) -> list[list[float]]:
    return value if isinstance(value, list) else value.matrix()


Pose = Annotated[
    Annotated[Matrix4, Tag("matrix")] | Annotated[PositionQuaternion, Tag("position_quaternion")]
    | Annotated[PositionRPY, Tag("position_rpy")],
    Discriminator(_pose_form), AfterValidator(_pose_matrix),
    Field(description='a pose (m): a homogeneous 4x4 matrix (row major), or {"position": [x, y, z], '
                      '"quaternion": [qx, qy, qz, qw]} (unit quaternion, scalar last: Pinocchio\'s and '
                      'ROS\'s order), or {"position": [x, y, z], "rpy": [roll, pitch, yaw]} (rad, '
                      "R = Rz(yaw) Ry(pitch) Rx(roll))"),
]


class RobotRef(Strict):
    """The robot of a request: a built-in name and its model parameters."""

    robot: Name = Field(description="built-in robot name (GET /robots)")
    params: dict[Annotated[str, Field(max_length=50)], ParamValue] = Field(
        default_factory=dict, max_length=16,
        description="model parameters of a parametric robot (e.g. l1 for planar4r)"
    )


class FKRequest(RobotRef):
    """Body of ``POST /fk``."""

    model_config = examples({"robot": "panda", "q": PANDA_READY, "frame": "panda_hand_tcp"})

    q: JointVector
    frame: Name | None = Field(default=None, description="frame name; default the robot's tool frame")


class FKResponse(BaseModel):
    """Answer of ``POST /fk``: the frame's 4x4 pose (m)."""

    model_config = examples({"robot": "panda", "frame": "panda_hand_tcp", "pose": [
        [1.0, 0.0004, 0.0, 0.307], [0.0004, -1.0, 0.0, 0.0], [0.0, 0.0, -1.0, 0.4869], [0.0, 0.0, 0.0, 1.0]]},
        strict=False)

    robot: str
    frame: str = Field(description="the frame whose pose this is (the tool frame when none was asked)")
    pose: list[list[float]] = Field(description="homogeneous 4x4 pose in the world frame, row major (m)")


class JacobianRequest(FKRequest):
    """Body of ``POST /jacobian``."""

    model_config = examples({"robot": "planar4r", "q": [0.3, 0.6, -0.4, 0.2], "frame": "tool",
                             "reference": "world"})

    reference: Literal["world", "local", "spatial"] = Field(
        default="world", description="world: the frame's origin velocity and angular velocity in world axes "
                                     "(Pinocchio's LOCAL_WORLD_ALIGNED); local: both in the frame's axes; "
                                     "spatial: the spatial (world-origin) twist")


class JacobianResponse(BaseModel):
    """Answer of ``POST /jacobian``: the 6 x nq Jacobian, its singular values and manipulability."""

    model_config = examples({
        "robot": "planar4r", "frame": "tool", "reference": "world",
        "jacobian": [[-1.4675, -1.172, -0.5453, -0.2577], [2.2851, 1.3298, 0.8325, 0.3059],
                     [0.0, 0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 0.0], [1.0, 1.0, 1.0, 1.0]],
        "singular_values": [3.8475, 0.9043, 0.2169], "manipulability": 0.7547}, strict=False)

    robot: str
    frame: str
    reference: str
    jacobian: list[list[float]] = Field(description="6 x nq, rows [vx, vy, vz, wx, wy, wz] (m/s and rad/s "
                                                    "per unit joint velocity)")
    singular_values: list[float] = Field(description="of the world Jacobian's rows of the robot's task axes "
                                                       "(GET /robots/{name}), largest first")
    manipulability: float = Field(description="product of the singular values")


class SphereSpec(Strict):
    """A sphere obstacle (m) for the link capsules, optionally for some frames only."""

    center: Annotated[list[Number], Field(min_length=3, max_length=3)]
    radius: Length
    frames: Annotated[list[Name], Field(max_length=64)] | None = None


Frames = Annotated[list[Name], Field(max_length=64)] | None


class SphereObstacle(Strict):
    """A sphere obstacle: centre and radius (m)."""

    kind: Literal["sphere"]
    center: Point3
    radius: Length
    frames: Frames = None


class BoxObstacle(Strict):
    """A box obstacle: 4x4 pose of its centre and full edge lengths (m)."""

    kind: Literal["box"]
    pose: Pose
    size: Annotated[list[Length], Field(min_length=3, max_length=3,
                                        description="full edge lengths (m), as URDF")]
    frames: Frames = None


class CapsuleObstacle(Strict):
    """A capsule obstacle: segment ends ``a``, ``b`` and radius (m)."""

    kind: Literal["capsule"]
    a: Point3
    b: Point3
    radius: Length
    frames: Frames = None


class CylinderObstacle(Strict):
    """A cylinder obstacle: 4x4 pose of its centre (axis z), radius and length (m)."""

    kind: Literal["cylinder"]
    pose: Pose
    radius: Length
    length: Length
    frames: Frames = None


Obstacle = Annotated[SphereObstacle | BoxObstacle | CapsuleObstacle
                     | CylinderObstacle, Field(discriminator="kind")]


Obstacles = Annotated[list[Obstacle], Field(max_length=32)]


class IKOptions(Strict):
    """Solver options shared by ``POST /ik`` and ``POST /ik/batch``."""

    q0: JointVector | None = None
    frame: Name | None = None
    relax: Annotated[list[RelaxName], Field(max_length=6)] = Field(default_factory=list)
    spheres: Annotated[list[SphereSpec], Field(max_length=32)] = Field(default_factory=list)
    centring: real(ge=0, le=1e3) = 0.0
    method: Method = "auto"
    max_time: Seconds | None = Field(
        default=None, description=f"time budget (s) of one solve (each target of a batch); default "
                                  f"{MAX_TIME_QP:g} s whichever solver runs, capped by the server's "
                                  "--max-time-cap (ik.solve in Python: 0.1 s when LM alone answers, "
                                  f"{MAX_TIME_QP:g} s when the QP may run)"
    )
    seed: Seed | None = Field(
        default=None, description="seed of the random restarts (none: 0); the same seed gives the same "
                                  "answer unless the time budget cut the solve")
    self_collision: Flag = Field(
        default=False,
        description="keep the robot's collision geometry free of self-collision; obstacles are then "
                                   "kept clear of that geometry (not of the link capsules)")
    obstacles: Obstacles = Field(
        default_factory=list,
        description="shapes kept clear of the robot's links (kind: sphere, box, capsule, cylinder)"
    )
    collision_margin: real(ge=0, le=1.0) = Field(
        default=0.0, description="clearance (m) kept from obstacles and between checked link pairs")
    tol_pos: real(gt=0, le=1.0) = 1e-4
    tol_rot: real(gt=0, le=3.2) = 1e-3
    link_radius: real(ge=0, le=1.0) = Field(
        default=0.0, description="radius (m) of the capsules around the link segments"
    )


class FrameTarget(Strict):
    """One frame's target pose, with relaxed components."""

    frame: Name
    pose: Pose
    relax: Annotated[list[RelaxName], Field(max_length=6)] = Field(default_factory=list)
    relax_frame: Literal["world", "target"] = "world"


FrameTargets = Annotated[list[FrameTarget], Field(min_length=1, max_length=8,
                                                   description="several frames at once (e.g. both hands), "
                                                               "solved together")]


class IKRequest(RobotRef, IKOptions):
    """Body of ``POST /ik``: one target pose (``target``) or several frames at once (``targets``)."""

    model_config = examples(
        {"robot": "panda", "frame": "panda_hand_tcp", "target": EXAMPLE_TARGET, "q0": PANDA_READY, "seed": 0,
         "max_time": 0.2},
        {"robot": "panda", "seed": 0, "max_time": 0.2, "targets": [
            {"frame": "panda_hand_tcp", "pose": EXAMPLE_TARGET},
            {"frame": "panda_link4", "pose": {"position": [-0.0722, 0.0103, 0.6513], "rpy": [0.0, 0.0, 0.0]},
             "relax": ["roll", "pitch", "yaw"]}]})

    target: Pose | None = Field(default=None, description="pose of `frame`; or give `targets`")
    targets: FrameTargets | None = None


class TaskErrorOut(BaseModel):
    """Error of one task of the solve, by priority."""

    name: str
    priority: int
    goal: bool
    error: float
    position_error: float
    orientation_error: float


IK_ANSWER = {
    "success": True, "q": [0.04335, -0.47362, 0.16329, -2.22751, 0.07555, 1.75878, 0.96018],
    "position_error": 1.0e-06, "orientation_error": 1.7e-06, "iterations": 3, "restarts": 0,
    "elapsed": 0.0006, "message": "converged", "task_errors": []}


class IKResponse(BaseModel):
    """Answer of ``POST /ik``: success, joint values and residuals (m, rad)."""

    model_config = examples(IK_ANSWER, strict=False)

    success: bool = Field(description="both errors within tol_pos and tol_rot (every goal task's, for "
                                      "targets)")
    q: list[float] = Field(description="the joint values found (rad / m); on failure the closest found")
    position_error: float = Field(description="m, largest over the goal tasks")
    orientation_error: float = Field(description="rad, largest over the goal tasks")
    iterations: int
    restarts: int
    elapsed: float = Field(description="seconds spent solving")
    message: str = Field(description="how the solve ended (e.g. converged, or why it failed)")
    task_errors: list[TaskErrorOut] = Field(default_factory=list,
                                            description="per task, for a `targets` request")


class IKBatchRequest(RobotRef, IKOptions):
    """Body of ``POST /ik/batch``: many independent problems with the same options."""

    model_config = examples({
        "robot": "panda", "frame": "panda_hand_tcp", "q0": PANDA_READY, "seed": 0, "max_time": 0.2,
        "targets": [EXAMPLE_TARGET, {"position": [0.5, -0.1, 0.3], "rpy": [3.1416, 0.0, 0.0]}]})

    targets: Annotated[list[Pose | FrameTargets], Field(min_length=1, max_length=1000)] = Field(
        description="one problem per item: a 4x4 pose of `frame`, or a list of frame targets solved together")


class IKBatchResponse(BaseModel):
    """Answer of ``POST /ik/batch``."""

    model_config = examples({
        "results": [IK_ANSWER, {**IK_ANSWER, "q": [1.95990, 0.14341, -2.18018, -2.23781, 0.14055, 2.15096,
                                                   0.48291], "position_error": 2.7e-05,
                                "orientation_error": 0.00017, "elapsed": 0.0001}],
        "success_rate": 1.0, "elapsed": 0.0012, "attempted": 2, "stop_reason": "completed"}, strict=False)

    results: list[IKResponse] = Field(description="one per target, in order (targets not attempted included)")
    success_rate: float
    elapsed: float
    attempted: int = Field(description="targets given to the solver before the request's time cap ran out")
    stop_reason: Literal["completed", "time_cap"]


#: The shortest ``dt`` (s) of ``POST /plan/cartesian``. ``planners.cartesian_to_joint`` takes any dt in
#: (0, 1e6], but its finite-difference velocities (at most 2 x joint range / dt) must stay within 1e6, or the
#: plan fails after the solves: 1e-4 s keeps them within for joint ranges up to 50 rad or m, those of every
#: built-in robot with its default parameters.
MIN_DT = 1e-4


class CartesianPlanRequest(RobotRef):
    """Body of ``POST /plan/cartesian``: poses to pass through and the interpolation.

    Interpolated mode (the default): ``steps`` poses per segment, each solved from the one before
    (``planners.cartesian_to_joint``; ``q0`` is the first solve's start). Line mode, chosen by giving any of
    ``jump_threshold``, ``obstacles``, ``self_collision``, ``max_step``, ``max_rotation_step``: from ``q0``
    (required: the start configuration) the frame moves on straight lines to each pose in turn
    (``planners.plan_cartesian``, at rest at each pose), stopping where a pose is not reached, a joint jumps,
    meets its limit or a singularity, or the robot would collide.
    """

    model_config = examples(
        {"robot": "panda", "q0": PANDA_READY, "frame": "panda_hand_tcp", "steps": 1, "dt": 0.5,
         "poses": [{"position": [0.307, 0.0, 0.487], "quaternion": [1.0, 0.0, 0.0, 0.0]},
                   {"position": [0.307, 0.0, 0.387], "quaternion": [1.0, 0.0, 0.0, 0.0]}]},
        {"robot": "panda", "q0": PANDA_READY, "frame": "panda_hand_tcp",
         "poses": [[[1, 0, 0, 0.307], [0, -1, 0, 0.0], [0, 0, -1, 0.487], [0, 0, 0, 1]], EXAMPLE_TARGET],
         "jump_threshold": 0.3, "max_step": 0.01,
         "obstacles": [{"kind": "sphere", "center": [0.6, -0.3, 0.3], "radius": 0.05}]})

    poses: Annotated[list[Pose], Field(min_length=1, max_length=200,
                                       description="poses to pass through, in order (at least 2 in the "
                                                   "interpolated mode)")]
    q0: JointVector | None = None
    frame: Name | None = None
    steps: integer(1, 200) = Field(default=10, description="interpolated poses per segment")
    dt: real(ge=MIN_DT, le=60) = Field(
        default=0.1, description=f"seconds between consecutive points, from {MIN_DT:g} (a shorter step "
                                 "would make the finite-difference joint velocities overflow) to 60")
    interpolation: Literal["decoupled", "screw"] = "decoupled"
    relax: Annotated[list[RelaxName], Field(max_length=6)] = Field(default_factory=list)
    max_time: Seconds | None = Field(
        default=None,
        description="seconds for the whole plan; default and upper bound: the server's request time cap"
    )
    stop_on_failure: Flag = Field(default=True,
                                  description="stop at the first pose not reached (false: try every pose)")
    # the line mode (planners.plan_cartesian), chosen by giving any of these
    jump_threshold: real(gt=0, le=10) | None = Field(
        default=None, description="line mode: stop where a step moves a joint by more than this (rad or m; "
                                  "default 0.25)")
    obstacles: Obstacles = Field(default_factory=list,
                                 description="line mode: stop before the robot would touch one of these")
    self_collision: Flag | None = Field(default=None,
                                        description="line mode: check the robot's own link pairs (default "
                                                    "true)")
    max_step: real(ge=1e-3, le=1.0) | None = Field(
        default=None, description="line mode: largest move of the frame's origin per step (m; default 0.01)")
    max_rotation_step: real(ge=5e-3, le=1.0) | None = Field(
        default=None, description="line mode: largest turn of the frame per step (rad; default 0.05)")


class JointTrajectoryOut(BaseModel):
    """A joint trajectory: times (s) and positions, velocities, accelerations per point."""

    joint_names: list[str]
    times: list[float]
    positions: list[list[float]]
    velocities: list[list[float]]
    accelerations: list[list[float]] | None = None


class CartesianPlanResponse(BaseModel):
    """Answer of ``POST /plan/cartesian``."""

    model_config = examples({
        "success": True, "trajectory": {
            "joint_names": [f"panda_joint{i}" for i in range(1, 8)], "times": [0.0, 0.5, 1.0],
            "positions": [[-0.0001, -0.785, 0.0001, -2.3556, 0.0001, 1.5707, 0.7853],
                          [-0.0001, -0.8101, 0.0001, -2.4988, 0.0001, 1.6886, 0.7853],
                          [-0.0001, -0.8157, 0.0001, -2.6293, 0.0001, 1.8137, 0.7853]],
            "velocities": [[0.0, -0.07, 0.0, -0.2989, 0.0, 0.2289, 0.0],
                           [0.0, -0.0307, 0.0, -0.2737, 0.0, 0.243, 0.0],
                           [0.0, 0.0086, 0.0, -0.2485, 0.0, 0.2571, 0.0]],
            "accelerations": None},
        "max_position_error": 1.6e-05, "max_orientation_error": 1e-07, "events": [],
        "message": "all poses reached, joint path continuous", "stop_reason": "completed",
        "poses_attempted": 3, "total_poses": 3}, strict=False)

    success: bool
    trajectory: JointTrajectoryOut
    max_position_error: float
    max_orientation_error: float
    events: list[dict]
    message: str
    stop_reason: Literal["completed", "ik_failed", "time_cap", "joint_limit", "joint_jump", "singularity",
                         "collision"] = Field(
        description="completed: every pose attempted; ik_failed: stopped at the first pose not reached; "
        "time_cap: the plan's time ran out; line mode also: joint_limit, joint_jump (a step over "
        "jump_threshold), singularity, collision"
    )
    poses_attempted: int
    total_poses: int = Field(description="interpolated poses of the whole path")


class HealthResponse(BaseModel):
    """Answer of ``GET /health``."""

    model_config = examples({"status": "ok", "robots_loaded": 1, "solver_jobs": 0}, strict=False)

    status: Literal["ok"]
    robots_loaded: int = Field(description="robot variants (name + params) loaded in the serving process")
    solver_jobs: int = Field(description="heavy requests (IK, batches, plans) running or waiting now")


class RobotInfo(BaseModel):
    """A built-in robot: joints, limits, tool frame, task axes and frames."""

    model_config = examples({
        "name": "planar4r", "nq": 4,
        "description": "S1 planar 4R arm, joints about z, links l1..l4 = 1.0/0.8/0.6/0.4 m",
        "joint_names": ["joint1", "joint2", "joint3", "joint4"],
        "lower": [-3.141592653589793] * 4, "upper": [3.141592653589793] * 4, "tip": "tool",
        "task_axes": ["x", "y", "yaw"],
        "frames": ["universe", "base_link", "joint1", "link1", "joint2", "link2", "joint3", "link3", "joint4",
                   "link4", "tool_joint", "tool"]}, strict=False)

    name: str
    description: str
    nq: int
    joint_names: list[str]
    lower: list[float] = Field(description="joint lower limits (rad / m)")
    upper: list[float] = Field(description="joint upper limits (rad / m)")
    tip: str = Field(description="the default tool frame (a request's `frame` overrides it)")
    task_axes: list[str] = Field(description="the task-space components this robot can control (x y z roll "
                                             "pitch yaw); IK relaxes the others")
    frames: list[str]


class ErrorItem(BaseModel):
    """One invalid field: its location, a message and the error type."""

    loc: list[str | int]
    msg: str
    type: str


class ErrorResponse(BaseModel):
    """Body of a 4xx answer: the invalid fields."""

    detail: list[ErrorItem]
