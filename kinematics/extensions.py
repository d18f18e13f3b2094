"""``Extensions``: the state that higher layers keep for one robot (held by :class:`~.robot.Robot`)."""

from __future__ import annotations


class Extensions:
    """State that higher layers keep for one robot, shared by every :meth:`Robot.copy`.

    ``ik``: the :class:`kinserve.ik.state.IKState` (seed tables, closed-form solvers, bound collision
    constraints), set by :func:`kinserve.ik.state.ik_state`; None until the first solve or
    ``ik.warm(robot)``. Pickling a robot drops it (a worker builds or receives its own).
    """

    __slots__ = ("ik",)

    def __init__(self) -> None:
        self.ik: object | None = None


__all__ = ["Extensions"]
