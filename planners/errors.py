"""Errors raised by the planners (extending :mod:`kinematics.errors`).

    KinserveError
    ├── InputError (ValueError)
    │   └── BlockedPointError   a start/goal/waypoint lies in an obstacle or outside the map
    └── PlanningError           a plan cannot be produced for valid input
        └── NoPathError         start and goal lie in different free regions of the map

A blocked start or goal is bad *input* (an :class:`kinematics.errors.InputError`);
an unreachable goal between two free points is a :class:`NoPathError`. Both
messages name the point(s) in world units.
"""

from __future__ import annotations

from kinserve.kinematics.errors import InputError, KinserveError


class PlanningError(KinserveError):
    """A plan cannot be produced (e.g. no collision-free path exists)."""


class NoPathError(PlanningError):
    """No path connects the start and the goal through the free space of the map."""


class BlockedPointError(InputError):
    """A point the planner must visit lies inside an (inflated) obstacle or outside the map."""
