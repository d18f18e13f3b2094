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
from kinserve.kinematics.validation import as_rows, as_vector

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


def _as_q(robot: Robot, c: Result | VectorLike, name: str) -> np.ndarray:
    """The joint vector of a candidate (a ``Result``'s ``q`` or a vector), checked: ``nq`` finite numbers
    (:class:`ShapeError` / :class:`NonFiniteError` naming ``name`` otherwise)."""
    return as_vector(c.q if isinstance(c, Result) else c, robot.nq, name)


def checked_candidates(robot: Robot, candidates: Sequence[Result | VectorLike]) -> list[np.ndarray]:
    """The joint vectors of ``candidates`` (a sequence of ``Result`` or of joint vectors, or an ``(N, nq)``
    array), each checked; :class:`InputError` naming the argument (and the index) otherwise."""
    if not (hasattr(robot, "nq") and hasattr(robot, "lower") and hasattr(robot, "copy")):
        raise InputError(f"robot must be a kinserve.kinematics.Robot, got {type(robot).__name__}")
    if isinstance(candidates, np.ndarray):
        return list(as_rows(candidates, robot.nq, "candidates"))
    if candidates is None or isinstance(candidates, (str, bytes, dict)) \
            or not hasattr(candidates, "__iter__"):
        raise InputError(f"candidates must be a sequence of ik.Result or joint vectors ({robot.nq} numbers "
                         f"each), got {candidates!r}"[:300])
    return [_as_q(robot, c, f"candidates[{i}]") for i, c in enumerate(candidates)]


def scores(robot: Robot, candidates: Sequence[Result | VectorLike], criterion: str,
           q_current: VectorLike | None = None, frame: str | None = None) -> np.ndarray:
    """Score of every candidate for one criterion (higher is better; filters give 1 = keep, 0 = drop).

    Refused (:class:`InputError`): candidates that are not ``nq`` finite numbers each (see
    :func:`checked_candidates`), an unknown criterion, ``displacement`` without a valid ``q_current``."""
    qs = checked_candidates(robot, candidates)
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
    """Index of the best candidate (a list of ``Result`` or joint vectors), or None if the filters drop all
    (or there is no candidate).

    See the module docstring for the criteria and how they combine. Refused (:class:`InputError` and its
    subclasses, naming the argument): ``candidates`` that is not a sequence (or ``(N, nq)`` array) of
    ``Result`` / joint vectors of ``nq`` finite numbers (``candidates[i]`` names the bad one),
    ``criteria`` that is not one name or a non-empty sequence of names of :data:`CRITERIA`, a ``frame``
    that is not a frame name of the robot, a ``q_current`` that is not ``nq`` finite numbers.
    """
    criteria = _checked_criteria(criteria)
    qs = checked_candidates(robot, candidates)
    if frame is not None:
        if not isinstance(frame, str):
            raise InputError(f"frame must be a frame name or None (the robot's tip), got {frame!r}")
        robot.frame_id(frame)  # (FrameError naming close matches)
    if not qs:
        return None
    if q_current is not None:
        q_current = robot.check_q(q_current, "q_current")
    idx = list(range(len(qs)))
    for c in criteria:
        if c in FILTERS:
            keep = scores(robot, [qs[i] for i in idx], c, q_current, frame)
            idx = [i for i, k in zip(idx, keep) if k > 0]
            if not idx:
                return None
    for c in (c for c in criteria if c not in FILTERS):  # ranked by the first score, ties by the next ones
        s = scores(robot, [qs[i] for i in idx], c, q_current, frame)
        best = s.max()
        idx = [i for i, v in zip(idx, s) if v >= best - 1e-9]
        if len(idx) == 1:
            break
    return idx[0]


def _checked_criteria(criteria: str | Sequence[str]) -> tuple[str, ...]:
    """``criteria`` as a non-empty tuple of names of :data:`CRITERIA`; :class:`InputError` otherwise."""
    if isinstance(criteria, str):
        criteria = (criteria,)
    elif criteria is None or isinstance(criteria, (bytes, dict)) or not hasattr(criteria, "__iter__"):
        raise InputError(f"criteria must be one name or a sequence of names from {CRITERIA}, "
                         f"got {criteria!r}")
    else:
        criteria = tuple(criteria)
    if not criteria:
        raise InputError(f"criteria must name at least one of {CRITERIA}")
    for c in criteria:
        if not isinstance(c, str) or c not in CRITERIA:
            raise InputError(f"unknown criterion {c!r}; expected one of {CRITERIA}")
    return criteria
