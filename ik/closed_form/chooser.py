"""Pick one solution among several (closed-form branches, a sampled family) by named criteria.

Criteria (higher is better after the sign shown):

* ``"joint_limit_distance"``: ``min_i min(q_i - lower_i, upper_i - q_i) / (upper_i - lower_i)``
  - the normalised distance of the closest joint to its limit (maximised);
* ``"displacement"``: ``|q - q_current|`` (minimised; needs ``q_current``);
* ``"manipulability"``: Yoshikawa's ``sqrt(det(J J^T))`` of the robot's task
  rows at the frame (maximised);
* ``"no_self_overlap"``: a *filter*, not a score - keeps the solutions whose
  link segments (see :func:`ik.constraints.robot_segments`) do not touch each
  other (non-adjacent segments at least ``1e-6`` m apart). Meant for planar
  arms, whose links can cross in the plane.

``criteria`` is one name or a sequence: filters apply first, then the
solutions are ranked by the first score, ties (within ``1e-9``) broken by
the next ones.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from kinserve.ik.constraints import robot_segments
from kinserve.ik.constraints.segment_distance import segment_segment
from kinserve.ik.result import Result
from kinserve.kinematics import Robot
from kinserve.kinematics.errors import InputError
from kinserve.kinematics.types import VectorLike

CRITERIA = ("joint_limit_distance", "displacement", "manipulability", "no_self_overlap")
FILTERS = ("no_self_overlap",)

#: Minimum distance (m) between non-adjacent link segments for "no_self_overlap".
OVERLAP_TOL = 1e-6


def joint_limit_distance(robot: Robot, q: VectorLike) -> float:
    """Normalised distance of the joint closest to a limit (0 at a limit, 0.5 at mid-range)."""
    rng = robot.upper - robot.lower
    rng = np.where(rng > 0, rng, 1.0)
    return float(np.min(np.minimum(q - robot.lower, robot.upper - q) / rng))


def self_overlap(robot: Robot, q: VectorLike, frame: str | None = None) -> bool:
    """True when two non-adjacent link segments of the arm at ``q`` touch (within :data:`OVERLAP_TOL`)."""
    frame = robot.tip if frame is None else frame
    r = robot.copy()
    r.fk(q, frame)
    segs = []
    for seg in robot_segments(r, frame):
        a = r.data.oMi[seg.ja].act(seg.la) if seg.ja else seg.la
        b = r.data.oMi[seg.jb].act(seg.lb) if seg.jb else seg.lb
        if np.linalg.norm(b - a) > 1e-9:
            segs.append((np.asarray(a), np.asarray(b)))
    i, j = np.triu_indices(len(segs), 2)  # every non-adjacent pair
    if i.size == 0:
        return False
    S = np.array(segs)  # (segments, 2, 3): start, end
    _, _, X, Y = segment_segment(S[i, 0], S[i, 1], S[j, 0], S[j, 1])
    return bool(np.min(np.linalg.norm(X - Y, axis=1)) < OVERLAP_TOL)


def _as_q(c):
    return np.asarray(c.q if hasattr(c, "q") else c, dtype=float)


def scores(robot: Robot, candidates: Sequence[Result | VectorLike], criterion: str,
           q_current: VectorLike | None = None, frame: str | None = None) -> np.ndarray:
    """Score of every candidate for one criterion (higher is better; filters give 1 = keep, 0 = drop)."""
    qs = [_as_q(c) for c in candidates]
    if criterion == "joint_limit_distance":
        return np.array([joint_limit_distance(robot, q) for q in qs])
    if criterion == "displacement":
        if q_current is None:
            raise InputError("criterion 'displacement' needs the current configuration (q_current / q0)")
        qc = robot.check_q(q_current, "q_current")
        return np.array([-float(np.linalg.norm(q - qc)) for q in qs])
    if criterion == "manipulability":
        r = robot.copy()
        return np.array([r.manipulability(q, frame) for q in qs])
    if criterion == "no_self_overlap":
        return np.array([0.0 if self_overlap(robot, q, frame) else 1.0 for q in qs])
    raise InputError(f"unknown criterion {criterion!r}; expected one of {CRITERIA}")


def choose(robot: Robot, candidates: Sequence[Result | VectorLike],
           criteria: str | Sequence[str] = ("joint_limit_distance",), q_current: VectorLike | None = None,
           frame: str | None = None) -> int | None:
    """Index of the best candidate (a list of ``Result`` or joint vectors), or None if the filters drop all.

    See the module docstring for the criteria and how they combine.
    """
    criteria = _checked_criteria(criteria)
    if not candidates:
        return None
    idx = list(range(len(candidates)))
    for c in criteria:
        if c in FILTERS:
            keep = scores(robot, [candidates[i] for i in idx], c, q_current, frame)
            idx = [i for i, k in zip(idx, keep) if k > 0]
            if not idx:
                return None
    for c in (c for c in criteria if c not in FILTERS):  # ranked by the first score, ties by the next ones
        s = scores(robot, [candidates[i] for i in idx], c, q_current, frame)
        best = s.max()
        idx = [i for i, v in zip(idx, s) if v >= best - 1e-9]
        if len(idx) == 1:
            break
    return idx[0]


def _checked_criteria(criteria: str | Sequence[str]) -> tuple[str, ...]:
    """``criteria`` as a non-empty tuple of names of :data:`CRITERIA`; :class:`InputError` otherwise."""
    criteria = (criteria,) if isinstance(criteria, str) else tuple(criteria)
    if not criteria:
        raise InputError(f"criteria must name at least one of {CRITERIA}")
    for c in criteria:
        if c not in CRITERIA:
            raise InputError(f"unknown criterion {c!r}; expected one of {CRITERIA}")
    return criteria
