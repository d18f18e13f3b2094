"""Pydantic request/response schemas of the HTTP service (they are the OpenAPI document).

Numbers are finite and bounded (|x| <= 1e6): NaN, infinities and absurd
magnitudes are rejected with a 422 naming the field before any solver runs.
"""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import BaseModel, ConfigDict, Field

BOUND = 1e6
Number = Annotated[float, Field(allow_inf_nan=False, ge=-BOUND, le=BOUND)]
Row4 = Annotated[list[Number], Field(min_length=4, max_length=4)]
Pose = Annotated[list[Row4], Field(min_length=4, max_length=4, description="homogeneous 4x4 pose, row major")]
JointVector = Annotated[list[Number], Field(min_length=1, max_length=64, description="joint values (rad / m)")]
Name = Annotated[str, Field(min_length=1, max_length=200)]
ParamValue = Annotated[float, Field(allow_inf_nan=False, ge=-BOUND, le=BOUND)] | Annotated[str, Field(max_length=200)]
RelaxName = Literal["x", "y", "z", "roll", "pitch", "yaw", "phi"]
Method = Literal["auto", "qp", "lm", "dls", "pseudo_inverse", "jacobian_inverse", "jacobian_transpose", "analytic"]


class Strict(BaseModel):
    model_config = ConfigDict(extra="forbid")


class RobotRef(Strict):
    robot: Name = Field(description="built-in robot name (GET /robots)")
    params: dict[Annotated[str, Field(max_length=50)], ParamValue] = Field(
        default_factory=dict, max_length=16, description="model parameters of a parametric robot (e.g. l1 for planar4r)"
    )


class FKRequest(RobotRef):
    q: JointVector
    frame: Name | None = Field(default=None, description="frame name; default the robot's tool frame")


class FKResponse(BaseModel):
    robot: str
    frame: str
    pose: list[list[float]]


class JacobianRequest(FKRequest):
    reference: Literal["world", "local", "spatial"] = "world"


class JacobianResponse(BaseModel):
    robot: str
    frame: str
    reference: str
    jacobian: list[list[float]]
    singular_values: list[float]
    manipulability: float


class SphereSpec(Strict):
    center: Annotated[list[Number], Field(min_length=3, max_length=3)]
    radius: Annotated[float, Field(allow_inf_nan=False, gt=0, le=BOUND)]
    frames: Annotated[list[Name], Field(max_length=64)] | None = None


Length = Annotated[float, Field(allow_inf_nan=False, gt=0, le=BOUND)]
Vec3 = Annotated[list[Number], Field(min_length=3, max_length=3)]


class ObstacleSpec(Strict):
    """One obstacle: ``kind`` and that kind's fields, as ``kinserve.kinematics.shapes``.

    Meshes are not accepted over HTTP (they would name files on the server).
    """

    kind: Literal["sphere", "box", "capsule", "cylinder"]
    center: Vec3 | None = Field(default=None, description="sphere centre (m)")
    radius: Length | None = Field(default=None, description="sphere / capsule / cylinder radius (m)")
    pose: Pose | None = Field(default=None, description="box / cylinder centre pose, 4x4 row major")
    size: Annotated[list[Length], Field(min_length=3, max_length=3)] | None = Field(
        default=None, description="box full edge lengths (m)")
    a: Vec3 | None = Field(default=None, description="capsule segment start (m)")
    b: Vec3 | None = Field(default=None, description="capsule segment end (m)")
    length: Length | None = Field(default=None, description="cylinder length (m)")

    def shape_dict(self) -> dict:
        return self.model_dump(exclude_none=True)


Obstacles = Annotated[list[ObstacleSpec], Field(max_length=64)]


class IKOptions(Strict):
    q0: JointVector | None = None
    frame: Name | None = None
    relax: Annotated[list[RelaxName], Field(max_length=6)] = Field(default_factory=list)
    spheres: Annotated[list[SphereSpec], Field(max_length=32)] = Field(default_factory=list)
    centring: Annotated[float, Field(allow_inf_nan=False, ge=0, le=1e3)] = 0.0
    method: Method = "auto"
    max_time: Annotated[float, Field(allow_inf_nan=False, gt=0, le=BOUND)] | None = Field(
        default=None, description="seconds; capped server-side"
    )
    seed: Annotated[int, Field(ge=0, le=2**32 - 1)] | None = None
    self_collision: bool = Field(default=False, description="keep the robot's collision geometry free of self-collision")
    obstacles: Obstacles = Field(default_factory=list, description="kept clear of the robot's collision geometry")
    collision_margin: Annotated[float, Field(allow_inf_nan=False, ge=0, le=1.0)] = Field(
        default=0.0, description="clearance (m) kept from obstacles and between checked link pairs")
    tol_pos: Annotated[float, Field(allow_inf_nan=False, gt=0, le=1.0)] = 1e-4
    tol_rot: Annotated[float, Field(allow_inf_nan=False, gt=0, le=3.2)] = 1e-3


Length = Annotated[float, Field(allow_inf_nan=False, gt=0, le=BOUND)]
Point3 = Annotated[list[Number], Field(min_length=3, max_length=3)]
Frames = Annotated[list[Name], Field(max_length=64)] | None


class SphereObstacle(Strict):
    kind: Literal["sphere"]
    center: Point3
    radius: Length
    frames: Frames = None


class BoxObstacle(Strict):
    kind: Literal["box"]
    pose: Pose
    size: Annotated[list[Length], Field(min_length=3, max_length=3, description="full edge lengths (m), as URDF")]
    frames: Frames = None


class CapsuleObstacle(Strict):
    kind: Literal["capsule"]
    a: Point3
    b: Point3
    radius: Length
    frames: Frames = None


class CylinderObstacle(Strict):
    kind: Literal["cylinder"]
    pose: Pose
    radius: Length
    length: Length
    frames: Frames = None


Obstacle = Annotated[SphereObstacle | BoxObstacle | CapsuleObstacle | CylinderObstacle, Field(discriminator="kind")]


class FrameTarget(Strict):
    frame: Name
    pose: Pose
    relax: Annotated[list[RelaxName], Field(max_length=6)] = Field(default_factory=list)
    relax_frame: Literal["world", "target"] = "world"


class IKRequest(RobotRef, IKOptions):
    target: Pose | None = Field(default=None, description="pose of `frame`; or give `targets`")
    targets: Annotated[list[FrameTarget], Field(min_length=1, max_length=8)] | None = Field(
        default=None, description="several frames at once (e.g. both hands), solved together"
    )
    obstacles: Annotated[list[Obstacle], Field(max_length=32)] = Field(
        default_factory=list, description="shapes kept clear of the robot's links (kind: sphere, box, capsule, cylinder)"
    )
    link_radius: Annotated[float, Field(allow_inf_nan=False, ge=0, le=1.0)] = Field(
        default=0.0, description="radius (m) of the capsules around the link segments"
    )


class TaskErrorOut(BaseModel):
    name: str
    priority: int
    goal: bool
    error: float
    position_error: float
    orientation_error: float


class IKResponse(BaseModel):
    success: bool
    q: list[float]
    position_error: float
    orientation_error: float
    iterations: int
    restarts: int
    elapsed: float
    message: str
    task_errors: list[TaskErrorOut] = Field(default_factory=list)


class IKBatchRequest(RobotRef, IKOptions):
    targets: Annotated[list[Pose], Field(min_length=1, max_length=1000)]


class IKBatchResponse(BaseModel):
    results: list[IKResponse]
    success_rate: float
    elapsed: float


class CartesianPlanRequest(RobotRef):
    poses: Annotated[list[Pose], Field(min_length=2, max_length=200, description="poses to pass through, in order")]
    q0: JointVector | None = None
    frame: Name | None = None
    steps: Annotated[int, Field(ge=1, le=200)] = Field(default=10, description="interpolated poses per segment")
    dt: Annotated[float, Field(allow_inf_nan=False, gt=0, le=60)] = 0.1
    interpolation: Literal["decoupled", "screw"] = "decoupled"
    relax: Annotated[list[RelaxName], Field(max_length=6)] = Field(default_factory=list)


class JointTrajectoryOut(BaseModel):
    joint_names: list[str]
    times: list[float]
    positions: list[list[float]]
    velocities: list[list[float]]
    accelerations: list[list[float]] | None = None


class CartesianPlanResponse(BaseModel):
    success: bool
    trajectory: JointTrajectoryOut
    max_position_error: float
    max_orientation_error: float
    events: list[dict]
    message: str


class RobotInfo(BaseModel):
    name: str
    description: str
    nq: int
    joint_names: list[str]
    lower: list[float]
    upper: list[float]
    tip: str
    task_axes: list[str]
    frames: list[str]


class ErrorItem(BaseModel):
    loc: list[str | int]
    msg: str
    type: str


class ErrorResponse(BaseModel):
    detail: list[ErrorItem]
