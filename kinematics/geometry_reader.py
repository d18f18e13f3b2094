"""``GeometryReader``: one of a robot's mesh geometry models, read the first time it is asked for.

A ``Robot`` loaded with its geometry holds two readers (:attr:`Robot.visual_model`,
:attr:`Robot.collision_model`) instead of the two ``pinocchio.GeometryModel`` s themselves: parsing
the mesh files and building coal's bounding-volume trees takes most of a load (0.8 s of the Panda's
0.86 s, its visual COLLADA meshes; 1.8 s for the SO-101's STL meshes), and most programs never draw the
robot. The visual model is read when a viewer first draws the robot, the collision model when the
robot's collision model (hulls, spheres, pairs) is built - a one-time build that already happens
outside any time budget (:meth:`~.collision_queries.CollisionQueries.collision`).

Which files are read was decided at load: the loader resolved every mesh URI, warned about missing
files and wrote the geometry's URDF; the reader only runs the build it was given. A build that fails
(a mesh file coal cannot parse) raises its ``ModelError`` at that first use, and again at the next
(nothing is kept). The reader is shared by a robot's copies (one read for all of them) and is not
pickled (:meth:`Robot.__getstate__` drops the meshes).
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from typing import Any


class GeometryReader:
    """Runs ``read`` (no arguments, returns a ``pinocchio.GeometryModel``) on the first :meth:`get`, once,
    under a lock (threads asking together wait for the one read), and returns its model from then on."""

    __slots__ = ("_read", "_model", "_lock")

    def __init__(self, read: Callable[[], Any]) -> None:
        self._read: Callable[[], Any] | None = read
        self._model: Any = None
        self._lock = threading.Lock()

    @property
    def is_read(self) -> bool:
        """Whether the model has been read."""
        return self._model is not None

    def get(self) -> Any:
        """The geometry model, read now when this is the first call."""
        model = self._model
        if model is None:
            with self._lock:
                if self._model is None:
                    self._model = self._read()
                    self._read = None  # (the model text and loader it held are not needed again)
                model = self._model
        return model

    def __repr__(self) -> str:
        return f"GeometryReader({'read' if self.is_read else 'not read yet'})"
