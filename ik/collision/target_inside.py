"""Whether an IK target's position lies inside an obstacle: the fast "no configuration can reach it" test of
the checked strategy (:mod:`kinserve.ik.strategies.checked`)."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from kinserve.ik.targets import Target


def position_fixed(target: Target) -> bool:
    """True when the target fixes the frame's position (no position component is relaxed)."""
    return not any(k in target.relaxed for k in (0, 1, 2))


def inside(obstacles: Any, target: Target, reach: float = 0.0) -> str:
    """The start of the reason when the target position lies inside one of ``obstacles`` grown by ``reach``
    ("the target position [..] lies inside obstacle[k]:kind (d m"), else ""."""
    point = np.array(target.T[:3, 3], dtype=float)
    for k, ob in enumerate(obstacles):
        depth = _depth(ob, point, reach)
        if depth > 0.0:
            return (f"the target position {np.round(point, 4).tolist()} lies inside obstacle[{k}]:{ob.kind} "
                    f"({depth:.4g} m")
    return ""


def _depth(obstacle: Any, point: np.ndarray, reach: float = 0.0) -> float:
    """How deep ``point`` lies inside ``obstacle`` grown by ``reach`` (m; <= 0 when outside): the bounding
    ball answers "outside" at once, the exact signed distance decides the rest."""
    (cx, cy, cz), r = obstacle.bounding_ball()
    if math.hypot(point[0] - cx, point[1] - cy, point[2] - cz) >= r + reach:
        return 0.0
    if obstacle.kind == "box":  # outside the box grown by reach along some axis of its own frame: outside
        T = obstacle.pose
        local = T[:3, :3].T @ (point - T[:3, 3])
        if any(abs(x) >= 0.5 * s + reach for x, s in zip(local.tolist(), obstacle.size)):
            return 0.0
    return reach - float(obstacle.signed_distance(point)[0])


__all__ = ["inside", "position_fixed"]
