"""Robots for concurrent requests: each model loads once, each thread gets its own copy.

``Robot.copy()`` shares the immutable Pinocchio model and allocates a fresh
``Data``, so no request can ever see another request's workspace.
"""

from __future__ import annotations

import threading

from kinserve import robots
from kinserve.kinematics import Robot
from kinserve.kinematics.errors import UnknownRobotError, suggest


class RobotPool:
    """Cache of built-in robots keyed by (name, params), with thread-local copies.

    Only built-in names are served (never file paths: a path from the network
    would read the server's files).
    """

    def __init__(self):
        self._lock = threading.Lock()
        self._base: dict[tuple, Robot] = {}
        self._local = threading.local()

    @staticmethod
    def key(name: str, params: dict) -> tuple:
        return (name, tuple(sorted(params.items())))

    def get(self, name: str, params: dict | None = None) -> Robot:
        """This thread's own Robot for ``name`` with ``params``."""
        params = params or {}
        try:
            name = robots.canonical_name(name)  # built-in names only, any case
        except UnknownRobotError:
            known = robots.ENTRIES
            raise UnknownRobotError(f"unknown robot {name!r}.{suggest(name, known)} Known robots: {', '.join(known)}") from None
        key = self.key(name, params)
        cache = getattr(self._local, "robots", None)
        if cache is None:
            cache = self._local.robots = {}
        robot = cache.get(key)
        if robot is None:
            with self._lock:
                base = self._base.get(key)
                if base is None:
                    base = self._base[key] = robots.load(name, params=params, geometry=False)
            robot = cache[key] = base.copy()
        return robot
