"""``POST /collision``: is the robot at ``q`` in collision with itself or with obstacles; which pairs; how
far.

A separate ``APIRouter`` (included by :func:`kinserve.service.app.create_app`).
Errors follow the service's convention: 422 naming the field (``q``,
``obstacles[k]``), 404 for an unknown robot; a robot without ``<collision>``
elements is a 422 on ``robot``.
"""

from __future__ import annotations

from fastapi import APIRouter, Request

from kinserve.kinematics.shapes import as_shape

from . import collision_schemas as C
from .schemas import ErrorResponse

router = APIRouter()


def obstacles_of(specs) -> list:
    """Shapes from validated obstacle specs; a bad one is a 422 on ``obstacles[k]``."""
    from .fields import field

    shapes = []
    for k, spec in enumerate(specs):
        with field(f"obstacles[{k}]"):
            shapes.append(as_shape(spec.model_dump(exclude_none=True), f"obstacles[{k}]"))
    return shapes


@router.post("/collision", response_model=C.CollisionResponse,
             responses={404: {"model": ErrorResponse}, 422: {"model": ErrorResponse}},
             summary="Self- and obstacle collisions of the robot at a configuration")
def collision(req: C.CollisionRequest, request: Request):
    """Whether the robot at `q` collides with itself (SRDF / MoveIt-style link pairs of its collision
    geometry, with `self_collision`) or with `obstacles` (sphere, box, capsule, cylinder; m); the colliding
    pairs, named by link and `obstacle[k]:kind`; the smallest signed distance (m, negative: penetration
    depth) over the checked pairs and its pair; with `distances: true` every checked pair's distance, witness
    points and normal. Collision is a result (`in_collision: true`), not an error. Errors: 422 naming `q`,
    `obstacles[k]`, or `robot` for a robot without collision geometry; 404 for an unknown robot."""
    from .fields import field

    pool = request.app.state.pool
    with field("params" if req.params else "robot"):
        robot = pool.get(req.robot, dict(req.params))
    with field("q"):
        q = robot.check_q(req.q, "q")
    obstacles = obstacles_of(req.obstacles)
    with field("robot"):
        robot.collision  # noqa: B018 - builds the collision model; no <collision> elements -> 422 on "robot"
    scene_args = dict(obstacles=obstacles, self_collision=req.self_collision)
    dist = robot.distances(q, **scene_args)
    pairs = robot.collisions(q, **scene_args)
    closest = min(dist.items(), key=lambda kv: kv[1].distance) if dist else None
    out = {
        "in_collision": bool(pairs),
        "pairs": [list(p) for p in pairs],
        "min_distance": closest[1].distance if closest else None,
        "closest_pair": list(closest[0]) if closest else None,
    }
    if req.distances:
        out["distances"] = [{"a": a, "b": b, **d.to_dict()} for (a, b), d in dist.items()]
    return out
