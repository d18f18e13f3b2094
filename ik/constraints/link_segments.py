"""The robot's links as segments between body points: what obstacle avoidance keeps clear by default.

* every link between consecutive joint origins (the segment from a joint's
  origin to the point where its child joint is mounted);
* the sliding segment of each prismatic joint (from where it is mounted to
  where its moving body is now - the quill of a SCARA);
* the tool segment from the tool's parent joint to the tool frame origin.

An obstacle with ``frames=[...]`` is checked against the origins of the
listed frames only (zero-length segments, :func:`frame_points`).

A segment joins two body points ``(joint j_a, local point l_a)`` and
``(joint j_b, local point l_b)``, each expressed in its joint's frame;
joint 0 is the world, so a segment with both ends on joint 0 is fixed
(part of the base). :mod:`.link_capsules` turns these into capsules.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from kinserve.kinematics.robot import Robot


class LinkSegment:
    """A segment between two body points ``(joint, local point)``; joint 0 = fixed in the world."""

    __slots__ = ("name", "ja", "la", "jb", "lb")

    def __init__(self, name: str, ja: int, la: np.ndarray, jb: int, lb: np.ndarray) -> None:
        self.name = name
        self.ja, self.la = int(ja), np.asarray(la, dtype=float).copy()
        self.jb, self.lb = int(jb), np.asarray(lb, dtype=float).copy()

    @property
    def fixed(self) -> bool:
        """Both ends on the world (the segment is part of the fixed base)."""
        return self.ja == 0 and self.jb == 0


def robot_segments(robot: Robot, tool_frame: str) -> list[LinkSegment]:
    """The default checked geometry of ``robot``: link, prismatic and tool segments (module docstring)."""
    model = robot.model
    segs = []
    for j in range(1, model.njoints):
        p = model.parents[j]
        mount = model.jointPlacements[j].translation
        pname = "base" if p == 0 else model.names[p]
        segs.append(LinkSegment(f"link {pname} -> {model.names[j]}", p, np.zeros(3), p, mount))
        if model.joints[j].shortname().startswith("JointModelP"):
            segs.append(LinkSegment(f"slider {model.names[j]}", p, mount, j, np.zeros(3)))
    f = model.frames[robot.frame_id(tool_frame)]
    segs.append(LinkSegment(f"tool {tool_frame}", f.parentJoint, np.zeros(3), f.parentJoint,
                            f.placement.translation))
    return segs


def frame_points(robot: Robot, frames: Iterable[str]) -> list[LinkSegment]:
    """Zero-length segments at the origins of the named frames."""
    segs = []
    for name in frames:
        f = robot.model.frames[robot.frame_id(name)]
        t = f.placement.translation
        segs.append(LinkSegment(f"frame {name}", f.parentJoint, t, f.parentJoint, t))
    return segs
