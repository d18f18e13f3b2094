"""Request/response schemas of the collision endpoint and of the collision options of ``/ik``.

Obstacles over HTTP are the solid primitives of :mod:`kinserve.kinematics.shapes`
(sphere, box, capsule, cylinder) in their ``to_dict()`` form; meshes are not
accepted (they would name files on the server). Lengths are metres, bounded
and finite; sizes must be positive (a zero or negative size is a 422 naming
the field).
"""

from __future__ import annotations

from pydantic import BaseModel, Field

from .schemas import PANDA_READY, Flag, JointVector, Obstacles, RobotRef, Strict, examples


class CollisionOptions(Strict):
    """Collision options shared by ``/collision`` and ``/ik``."""

    obstacles: Obstacles = Field(default_factory=list)
    self_collision: Flag = Field(default=True,
                                 description="check the robot's own link pairs (SRDF / MoveIt-style)")


class CollisionRequest(RobotRef, CollisionOptions):
    """Body of ``POST /collision``: a robot, a configuration and the collision options."""

    model_config = examples({
        "robot": "panda", "q": PANDA_READY, "obstacles": [
            {"kind": "sphere", "center": [0.31, 0.0, 0.59], "radius": 0.05},
            {"kind": "box", "pose": {"position": [0.0, 0.0, -0.05], "quaternion": [0.0, 0.0, 0.0, 1.0]},
             "size": [1.0, 1.0, 0.1]}]})

    q: JointVector
    distances: Flag = Field(default=False,
                            description="also return every checked pair's distance and witness points")


class PairDistanceOut(BaseModel):
    """Signed distance (m) between two named bodies."""

    a: str
    b: str
    distance: float
    point_a: list[float]
    point_b: list[float]
    normal: list[float]


class CollisionResponse(BaseModel):
    """Answer of ``POST /collision``."""

    model_config = examples({
        "in_collision": True,
        "pairs": [["panda_link7", "obstacle[0]:sphere"], ["panda_hand", "obstacle[0]:sphere"]],
        "min_distance": -0.0692, "closest_pair": ["panda_hand", "obstacle[0]:sphere"], "distances": None},
        strict=False)

    in_collision: bool
    pairs: list[list[str]] = Field(description="colliding pairs, named by link / obstacle[k]:kind")
    min_distance: float | None = Field(description="smallest signed distance (m) over the checked pairs; "
                                                   "null if none")
    closest_pair: list[str] | None
    distances: list[PairDistanceOut] | None = None
