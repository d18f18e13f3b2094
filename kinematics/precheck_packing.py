"""The packed arguments of the compiled pre-check: one float array per scene, one integer array per robot.

A compiled call pays per array argument, so the kernels of
:mod:`.precheck_kernels` take everything they read in two flat arrays
(:func:`pack`; the kernels' ``unpack`` gives the arrays back as views, no copy):

* ``floats``: the scene's obstacle table ``(O, 16)`` (:mod:`.obstacle_table`),
  row-major: ``O`` is the array's length over 16. Nothing else: a new scene joins
  its obstacles' rows and copies nothing of the robot;
* ``ints``: the robot's words, int64: ``(J, S, G, M, N)``, then ``joints`` ``(J, 3)``,
  ``geoms`` ``(G, 5)`` (joint, first and end cover row, first and end inner point
  row), then the **robot's floats** - ``tree`` ``(J, 15)``, ``reach`` ``(J,)``,
  ``spheres`` ``(S, 4)`` (the robot's spheres, then its inner balls: inner points
  with their radii), row-major, as the bit patterns of their float64 values (the
  kernels read them through a float64 view of these words) - then the **pair
  table**: rows of (robot geometry, other robot geometry or obstacle index, pair
  kind, index of the pair in the scene). ``M`` is the number of moving robot
  geometries (each is paired with every obstacle) and ``N`` the number of self
  pairs. The table's last ``N`` rows are the self pairs (scene indices
  ``0..N-1``); before them, obstacle ``k``'s ``M`` rows (scene indices
  ``N + k M + r``, as :class:`~.collision_layout.SceneLayout` orders its pairs),
  the obstacles in decreasing ``k``, for as many obstacles as the table's
  capacity. A scene of ``O`` obstacles reads the table's last ``P = N + M O``
  rows: its obstacle pairs first (a configuration in collision usually hits an
  obstacle: found sooner), then the self pairs.

So the integer array does not depend on the obstacles: :class:`RobotPacking`
makes one per robot geometry and self-collision choice, shared by every scene
and every layout (a scene with more obstacles than the table holds gets a larger
table, made once). Its memory - the robot's floats with it - stays warm from one
scene's checks to the next scene's first check, and a scene's own array holds its
obstacles' rows only (:attr:`~.shapes.Shape.obstacle_bytes`, made with each shape).
"""

from __future__ import annotations

import threading
from typing import NamedTuple

import numpy as np

from .robot_spheres import RobotSpheres

#: Kinds of the pair table's rows (column 2).
SELF_PAIR, OBSTACLE_PAIR = 0, 1
#: Length of the integer array's header ``(J, S, G, M, N)``.
HEADER = 5
#: Obstacles a :class:`RobotPacking`'s first pair table holds (it grows to twice the need when a scene has
#: more).
FIRST_CAPACITY = 32


class PackedArrays(NamedTuple):
    """The two arguments of every pre-check kernel (module docstring)."""

    floats: np.ndarray
    ints: np.ndarray


def robot_floats(robot: RobotSpheres, inner_radii: np.ndarray | None = None) -> np.ndarray:
    """The robot's floats (module docstring): ``tree``, ``reach``, the sphere rows then the inner balls (inner
    points with ``inner_radii`` ``(I,)``, m; None: 0, points), float64 ``(16 J + 4 S,)``."""
    radii = np.zeros(len(robot.inner)) if inner_radii is None else np.asarray(inner_radii, dtype=float)
    rows = np.concatenate([robot.spheres, np.column_stack([robot.inner, radii])])
    return np.concatenate([robot.tree.ravel(), robot.reach, rows.ravel()])


def pair_rows(self_pairs: np.ndarray, moving: np.ndarray, capacity: int) -> np.ndarray:
    """The pair table ``(capacity M + N, 4)`` of the module docstring for the self pairs ``self_pairs``
    ``(N, 2)`` (robot geometry indices, scene order) and the moving geometries ``moving`` ``(M,)``, for
    ``capacity`` obstacles."""
    self_pairs = np.asarray(self_pairs, dtype=np.int64).reshape(-1, 2)
    moving = np.asarray(moving, dtype=np.int64).reshape(-1)
    N, M = len(self_pairs), len(moving)
    k = np.repeat(np.arange(capacity - 1, -1, -1, dtype=np.int64), M)  # obstacles in decreasing k
    r = np.tile(np.arange(M, dtype=np.int64), capacity)
    obstacle_rows = np.column_stack([moving[r], k, np.full(len(k), OBSTACLE_PAIR), N + k * M + r])
    own = np.column_stack([self_pairs, np.full(N, SELF_PAIR), np.arange(N)]).astype(np.int64)
    return np.concatenate([obstacle_rows.reshape(-1, 4), own.reshape(-1, 4)])


def pack(robot: RobotSpheres, self_pairs: np.ndarray, moving: np.ndarray, obstacles: np.ndarray,
         inner_radii: np.ndarray | None = None, capacity: int | None = None) -> PackedArrays:
    """The kernels' two arguments for the robot's spheres ``robot``, its self pairs ``self_pairs`` ``(N, 2)``,
    moving geometries ``moving`` ``(M,)``, the obstacle table ``obstacles`` ``(O, 16)`` and the inner radii
    (module docstring); the pair table holds ``capacity`` obstacles (None: ``O``)."""
    obstacles = np.asarray(obstacles, dtype=float).reshape(-1, 16)
    capacity = len(obstacles) if capacity is None else int(capacity)
    if capacity < len(obstacles):
        raise ValueError(f"a pair table for {capacity} obstacles cannot serve {len(obstacles)}")
    ints = robot_ints(robot, self_pairs, moving, robot_floats(robot, inner_radii), capacity)
    return PackedArrays(obstacles.ravel(), ints)


def robot_ints(robot: RobotSpheres, self_pairs: np.ndarray, moving: np.ndarray, floats: np.ndarray,
               capacity: int) -> np.ndarray:
    """The integer array (module docstring) with the robot's floats ``floats`` (:func:`robot_floats`) and a
    pair table for ``capacity`` obstacles. Never written once made, but left writable: every compiled call
    reads it, and Numba's dispatch types a read-only array through a slower path (a type fingerprint and a
    hash look-up, on every call) than a writable one."""
    moving = np.asarray(moving, dtype=np.int64).reshape(-1)
    table = pair_rows(self_pairs, moving, capacity)
    n_spheres = len(robot.spheres)
    geoms = np.column_stack([robot.geoms, robot.inner_ranges + n_spheres]).astype(np.int64)
    n_self = len(table) - capacity * len(moving)
    sizes = [len(robot.joints), n_spheres + len(robot.inner), len(robot.geoms), len(moving), n_self]
    floats = np.ascontiguousarray(floats, dtype=np.float64)
    if len(floats) != 16 * sizes[0] + 4 * sizes[1]:
        raise ValueError(f"the robot's floats hold {len(floats)} values, not 16 J + 4 S = "
                         f"{16 * sizes[0] + 4 * sizes[1]}")
    return np.concatenate([np.array(sizes, dtype=np.int64), robot.joints.ravel().astype(np.int64),
                           geoms.ravel(), floats.view(np.int64), table.ravel()])


def robot_floats_span(ints: np.ndarray) -> tuple[int, int]:
    """``(start, end)``: where the robot's floats lie in ``ints`` (module docstring), after the header,
    ``joints`` and ``geoms``; the pair table starts at ``end``. (The kernels' ``_robot_floats_start`` is
    the compiled twin of ``start``.)"""
    J, S, G = int(ints[0]), int(ints[1]), int(ints[2])
    start = HEADER + 3 * J + 5 * G
    return start, start + 16 * J + 4 * S


def robot_floats_of(ints: np.ndarray) -> np.ndarray:
    """The robot's floats that ``ints`` holds (module docstring): a float64 view of its words, read-only."""
    start, end = robot_floats_span(ints)
    out = ints[start:end].view(np.float64)
    out.setflags(write=False)
    return out


def table_view(ints: np.ndarray, n_obstacles: int) -> np.ndarray:
    """The pair table ``(P, 4)`` a scene of ``n_obstacles`` obstacles reads: the last ``N + M n_obstacles``
    rows of ``ints``' table (a view)."""
    M, N = int(ints[3]), int(ints[4])
    P = N + M * int(n_obstacles)
    return ints[len(ints) - 4 * P:].reshape(P, 4)


def table_capacity(ints: np.ndarray) -> int:
    """How many obstacles the pair table of ``ints`` holds."""
    M, N = int(ints[3]), int(ints[4])
    rows = (len(ints) - robot_floats_span(ints)[1]) // 4
    return (rows - N) // M if M else 1 << 62


class RobotPacking:
    """The pre-check's integer array (:meth:`ints_for`, holding the robot's floats), for one robot geometry
    and one self-collision choice, shared by every layout and scene (module docstring).

    ``robot``: the sphere model; ``self_pairs`` ``(N, 2)``: the checked self pairs in scene order (empty
    without self collision); ``moving`` ``(M,)``: the robot geometries on a moving joint, each paired with
    every obstacle; ``inner_radii``: as :func:`robot_floats`.
    """

    def __init__(self, robot: RobotSpheres, self_pairs: np.ndarray, moving: np.ndarray,
                 inner_radii: np.ndarray | None = None) -> None:
        self.robot = robot
        self.self_pairs = np.asarray(self_pairs, dtype=np.int64).reshape(-1, 2)
        self.moving = np.asarray(moving, dtype=np.int64).reshape(-1)
        self._lock = threading.Lock()
        self._ints = robot_ints(robot, self.self_pairs, self.moving, robot_floats(robot, inner_radii),
                                FIRST_CAPACITY)

    def ints_for(self, n_obstacles: int) -> np.ndarray:
        """The shared integer array, its table holding at least ``n_obstacles`` obstacles (a larger one is
        made, once, when the current one is too small; arrays handed out before stay valid)."""
        ints = self._ints
        if table_capacity(ints) < n_obstacles:
            with self._lock:
                ints = self._ints
                if table_capacity(ints) < n_obstacles:
                    ints = self._ints = robot_ints(self.robot, self.self_pairs, self.moving,
                                                   robot_floats_of(ints),
                                                   max(2 * table_capacity(ints), int(n_obstacles)))
        return ints


__all__ = ["FIRST_CAPACITY", "HEADER", "OBSTACLE_PAIR", "SELF_PAIR", "PackedArrays", "RobotPacking", "pack",
           "pair_rows", "robot_floats", "robot_floats_of", "robot_floats_span", "robot_ints",
           "table_capacity", "table_view"]
