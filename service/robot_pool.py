"""Robots for concurrent requests: a bounded LRU of robot variants, each thread with its own copy.

A *variant* is a built-in robot name with its model parameters (``planar4r``
with ``l1=1.2``). Every variant's Pinocchio model is loaded once; each thread
that uses it gets its own ``Robot.copy()`` (a fresh ``Data`` sharing the
immutable model), so no request can ever see another request's workspace.

Memory is bounded: the pool keeps at most ``max_entries`` variants and at most
``max_bytes`` of their estimated memory, evicting the least recently used.
An entry's estimate is

    model + (1 + copies) * data + seed tables (built lazily by IK) + URDF text

with the model and ``Data`` sizes measured as their pickled sizes (once per
robot structure). The
pool gives each variant a model of its own (not the registry's cached one),
so the IK seed tables - cached per model, about 0.6 MB each - are freed with
the entry that owns them.
"""

from __future__ import annotations

import pickle
import threading
from collections import OrderedDict

from kinserve import robots
from kinserve.ik.state import clear, ik_state
from kinserve.kinematics import Robot
from kinserve.kinematics.errors import UnknownRobotError, suggest

_sizes: dict[tuple, tuple[int, int]] = {}


def model_and_data_bytes(robot: Robot) -> tuple[int, int]:
    """Pickled sizes of ``robot``'s model and of one ``Data``, measured once per model structure.

    Variants of one robot differ in numbers, not in structure (joints, frames),
    so their sizes are the same; measuring costs about a millisecond.
    """
    m = robot.model
    key = (robot.name, m.nq, m.njoints, m.nframes)
    sizes = _sizes.get(key)
    if sizes is None:
        sizes = _sizes[key] = (len(pickle.dumps(m, protocol=pickle.HIGHEST_PROTOCOL)),
                               len(pickle.dumps(robot.data, protocol=pickle.HIGHEST_PROTOCOL)))
    return sizes


class _Variant:
    """One cached robot variant: the owner robot and the per-thread copies."""

    __slots__ = ("base", "copies", "fixed_bytes", "data_bytes")

    def __init__(self, base: Robot):
        self.base = base
        self.copies: dict[int, Robot] = {}
        model_bytes, self.data_bytes = model_and_data_bytes(base)
        self.fixed_bytes = model_bytes + len(base.source or "")

    def nbytes(self) -> int:
        tables = sum(t.nbytes for t in ik_state(self.base).seed_tables.values())
        return self.fixed_bytes + (1 + len(self.copies)) * self.data_bytes + tables


def _own_model(robot: Robot) -> Robot:
    """A copy of ``robot`` on a private copy of its Pinocchio model (everything else shared).

    ``Robot.__setstate__`` rebuilds the per-thread workspaces from the state's model.
    """
    state = robot.__getstate__()
    state["model"] = robot.model.copy()
    state["_chains"] = {}
    other = object.__new__(Robot)
    other.__setstate__(state)
    return other


class RobotPool:
    """Bounded LRU cache of built-in robots keyed by (name, params), with thread-local copies.

    Only built-in names are served (never file paths: a path from the network
    would read the server's files). Thread-safe.
    """

    def __init__(self, max_entries: int = 64, max_bytes: int = 256 << 20):
        if max_entries < 1 or max_bytes < 1:
            raise ValueError("RobotPool needs max_entries >= 1 and max_bytes >= 1")
        self.max_entries = int(max_entries)
        self.max_bytes = int(max_bytes)
        self._lock = threading.Lock()
        self._variants: OrderedDict[tuple, _Variant] = OrderedDict()
        self.catalogue: dict[str, str] = robots.available()  # read once: it stats every xacro file
        self.evictions = 0

    @staticmethod
    def key(name: str, params: dict) -> tuple:
        """Cache key of a model variant: its name and its sorted parameters."""
        return (name, tuple(sorted(params.items())))

    def __len__(self) -> int:
        return len(self._variants)

    def nbytes(self) -> int:
        """Estimated memory of every cached variant (bytes)."""
        with self._lock:
            return sum(v.nbytes() for v in self._variants.values())

    def check_name(self, name: str) -> str:
        """The built-in name ``name`` means (any case); :class:`UnknownRobotError` for anything else."""
        if name in self.catalogue:
            return name
        try:
            return robots.canonical_name(name)
        except UnknownRobotError:
            raise UnknownRobotError(
                f"unknown robot {name!r}.{suggest(str(name), self.catalogue)} Known robots: "
                f"{', '.join(self.catalogue)}"
            ) from None

    def cached(self, name: str, params: dict | None = None) -> Robot | None:
        """This thread's Robot for the variant if it is loaded already (microseconds), else None."""
        key = self.key(name, params or {})
        me = threading.get_ident()
        with self._lock:
            variant = self._variants.get(key)
            if variant is None:
                return None
            self._variants.move_to_end(key)
            robot = variant.copies.get(me)
            if robot is None:
                robot = variant.copies[me] = variant.base.copy()
            return robot

    def get(self, name: str, params: dict | None = None) -> Robot:
        """This thread's own Robot for ``name`` with ``params``, loading the variant if needed.

        Loading parses a model (milliseconds): call it off the event loop.
        """
        params = params or {}
        robot = self.cached(name, params)
        if robot is not None:
            return robot
        name = self.check_name(name)
        robot = self.cached(name, params)
        if robot is not None:
            return robot
        base = _own_model(robots.load(name, params=params, geometry=False))
        variant = _Variant(base)
        key = self.key(name, params)
        with self._lock:
            existing = self._variants.get(key)
            if existing is not None:  # another thread loaded it meanwhile
                variant = existing
            else:
                self._variants[key] = variant
            self._variants.move_to_end(key)
            robot = variant.copies.get(threading.get_ident())
            if robot is None:
                robot = variant.copies[threading.get_ident()] = variant.base.copy()
            self._evict(keep=key)
        return robot

    def _evict(self, keep: tuple) -> None:
        """Drop least recently used variants until both bounds hold (never ``keep``). Lock held."""
        while len(self._variants) > self.max_entries:
            self._drop_oldest(keep)
        total = sum(v.nbytes() for v in self._variants.values())
        while total > self.max_bytes and len(self._variants) > 1:
            total -= self._drop_oldest(keep)

    def _drop_oldest(self, keep: tuple) -> int:
        key = next(iter(self._variants))
        if key == keep:
            self._variants.move_to_end(key)
            key = next(iter(self._variants))
        self.evictions += 1
        variant = self._variants.pop(key)
        size = variant.nbytes()
        clear(variant.base)  # its IK state (shared by its copies) goes now, not whenever a GC pass finds it
        return size
