"""The IK state a robot owns: its seed tables, closed-form solvers and bound collision constraints.

Everything the solvers reuse between calls belongs to one :class:`IKState`, held by the robot
(``robot.extensions.ik``, shared by every ``robot.copy()`` and so by every ``robots.load`` of one cached
model) and built outside any solve's time budget:

* :func:`warm` builds it explicitly - the seed table and closed-form solver of each frame, and with
  ``self_collision`` / ``obstacles`` the robot's collision model, its sphere pre-check and the bound
  collision constraint of that scene;
* :func:`ik_state` returns it, and every front door (:func:`kinserve.ik.solve`, ``solve_many``, ``step``)
  warms the frames of its request while validating it, before the clock of the solve starts.

Seed tables and solvers are immutable once built and shared by all threads (built under the state's lock);
a frame's seed table, closed form and compiled LM chain are also gathered in one :class:`FrameState`, which a
solve finds with one look-up.
Bound collision constraints keep a memo of their last configuration while solving, so each thread has its
own store (:class:`BoundConstraints`, a few per thread, least recently used dropped first). So do the
bound problems of ``ik.step`` (:class:`~kinserve.ik.step_problems.StepProblems`: a control loop's tasks and
constraints, bound once and found again by identity and change counters). The obstacles found clear of the
robot's fixed base (:class:`~kinserve.ik.constraints.base_overlap.BaseClearance`) are shared by all threads.
"""

from __future__ import annotations

import threading
from collections import OrderedDict
from collections.abc import Iterable, Sequence
from operator import attrgetter, is_
from typing import TYPE_CHECKING, Any, NamedTuple

from kinserve.ik.closed_form import ClosedFormSolver, build_closed_form_solver
from kinserve.ik.collision.request import CollisionRequest, collision_request
from kinserve.ik.constraints.base_overlap import BaseClearance
from kinserve.ik.constraints.robot_skeleton import RobotSkeleton, build_robot_skeleton
from kinserve.ik.lm.chains import CompiledChain, compiled_chain, compiled_chains
from kinserve.ik.starts.seed_table import SeedTable
from kinserve.ik.step_problems import StepProblems
from kinserve.kinematics.errors import InputError
from kinserve.kinematics.robot import Robot

if TYPE_CHECKING:
    from kinserve.ik.collision.collision_checker import CollisionChecker
    from kinserve.ik.constraints.collision import CollisionConstraint

#: :attr:`BoundConstraints.last` before any binding: matches no request.
_NO_REQUEST = CollisionRequest(None, (), None)  # type: ignore[arg-type]
#: A shape's :attr:`~kinserve.kinematics.shapes.Shape.signature_key` (bytes, equal for equal signatures).
_SIGNATURE_KEY = attrgetter("signature_key")
#: Bound collision constraints one thread keeps per robot (least recently used dropped first).
BOUND_CONSTRAINTS_PER_THREAD = 16

_CREATE_LOCK = threading.Lock()  # makes the one IKState of a robot (a lock, not a cache)


class BoundConstraints:
    """One thread's collision constraints bound to one robot, by obstacle set (value equality of shapes), each
    with its :class:`~kinserve.ik.collision.collision_checker.CollisionChecker` (made with the binding).

    Shapes are immutable and hash by value, so a request repeating a scene - the same objects or equal
    ones - finds its bound constraint; a scene whose obstacles have the shapes and sizes of one bound before
    at other poses is bound by moving that one (:meth:`CollisionConstraint.moved`). The scene of the last
    call (``last``) is found again without hashing when the same shape objects come back.
    """

    def __init__(self, size: int = BOUND_CONSTRAINTS_PER_THREAD) -> None:
        self.size = size
        self.by_scene: OrderedDict[tuple, CollisionChecker] = OrderedDict()
        self.by_layout: OrderedDict[tuple, CollisionConstraint] = OrderedDict()
        #: ``(CollisionRequest, checker)`` of the last :meth:`get`
        self.last: tuple[CollisionRequest, CollisionChecker | None] = (_NO_REQUEST, None)

    def get(self, robot: Robot, obstacles: tuple, self_collision: bool, margin: float) -> CollisionChecker:
        """The checker of the constraint of ``obstacles`` (validated shapes) bound to ``robot``."""
        if self.same_as_last(obstacles, self_collision, margin):  # that constraint (most recently used)
            return self.last[1]
        checker = self._lookup(robot, obstacles, self_collision, margin)
        self.last = (CollisionRequest(self_collision, obstacles, margin), checker)
        return checker

    def same_as_last(self, obstacles: Any, self_collision: bool, margin: float) -> bool:
        """True when ``obstacles`` (a tuple or list; not validated) holds the very shape objects of the last
        :meth:`get`, with the same options: the shapes were validated then and are immutable."""
        last = self.last[0]
        return last.self_collision is self_collision and last.margin == margin \
            and len(last.obstacles) == len(obstacles) and all(map(is_, last.obstacles, obstacles))

    def _lookup(self, robot: Robot, obstacles: tuple, self_collision: bool,
                margin: float) -> CollisionChecker:
        """:meth:`get` by value: the scene's entry, a moved template, or a new binding."""
        key = (self_collision, margin, obstacles)
        checker = self.by_scene.get(key)
        if checker is not None:
            self.by_scene.move_to_end(key)
            return checker
        from kinserve.ik.collision.collision_checker import CollisionChecker
        from kinserve.ik.constraints.collision import CollisionConstraint

        layout = (self_collision, margin, tuple(map(_SIGNATURE_KEY, obstacles)))
        template = self.by_layout.get(layout)
        if template is not None:
            bound = template.moved(obstacles)
        else:
            bound = CollisionConstraint(obstacles, self_collision=self_collision, margin=margin).bind(robot)
            _remember(self.by_layout, layout, bound, self.size)
        if bound.clearance == 0.0:
            bound.scene.precheck()  # the compiled sphere pre-check built with the constraint
        checker = CollisionChecker(robot, bound)
        _remember(self.by_scene, key, checker, self.size)
        return checker


class FrameState(NamedTuple):
    """What a solve of one frame reads from the IK state, prepared once (:meth:`IKState.frame`): one look-up
    per solve instead of one per piece."""

    seed_table: SeedTable
    closed_form: ClosedFormSolver | None  #: None: the robot has no closed form for the frame
    chain: CompiledChain | None  #: the compiled LM's chain (None: Pinocchio's iteration)


def _remember(store: OrderedDict, key: tuple, value: Any, size: int) -> None:
    store[key] = value
    while len(store) > size:
        store.popitem(last=False)


class IKState:
    """Per-robot IK state (see the module docstring). Made by :func:`ik_state`; filled by :func:`warm`."""

    def __init__(self, robot: Robot) -> None:
        self.robot = robot
        self.lock = threading.Lock()
        self.seed_tables: dict[str, SeedTable] = {}
        self.closed_forms: dict[str, ClosedFormSolver | None] = {}
        self.frames: dict[str, FrameState] = {}  # read without the lock: complete records only
        self.skeletons: dict[tuple[tuple[str, ...], tuple[str, ...]], RobotSkeleton] = {}
        self.threads = threading.local()  # .bound: this thread's BoundConstraints
        self.step_problems = StepProblems()  # this thread's bound problems of ik.step (per thread)
        self.base_clearance = BaseClearance()  # obstacles found clear of the fixed base (shared, locked)

    def seed_table(self, frame: str) -> SeedTable:
        """The :class:`SeedTable` of ``frame`` (built once, under the lock)."""
        table = self.seed_tables.get(frame)
        if table is None:
            with self.lock:
                table = self.seed_tables.get(frame)
                if table is None:
                    table = self.seed_tables[frame] = SeedTable(self.robot, frame)
        return table

    def install_seed_table(self, frame: str, table: SeedTable) -> None:
        """Use an existing table for ``frame`` (one shipped to a worker process)."""
        with self.lock:
            self.seed_tables[frame] = table
            self.frames.pop(frame, None)  # prepared again with this table

    def frame(self, name: str) -> FrameState:
        """The :class:`FrameState` of frame ``name`` (its seed table, closed form and compiled chain built
        once; an unknown name raises ``FrameError``)."""
        record = self.frames.get(name)
        if record is None:
            chain = compiled_chain(self.robot, self.robot.frame_id(name))
            record = FrameState(self.seed_table(name), self.closed_form(name), chain)
            self.frames[name] = record  # (two threads may both build it: equal records, either is kept)
        return record

    def closed_form(self, frame: str) -> ClosedFormSolver | None:
        """The closed-form solver of ``frame``, or None when the robot has none (decided once)."""
        if frame in self.closed_forms:
            return self.closed_forms[frame]
        with self.lock:
            if frame not in self.closed_forms:
                self.closed_forms[frame] = build_closed_form_solver(self.robot, frame)
            return self.closed_forms[frame]

    def robot_skeleton(self, tool_frames: tuple[str, ...], frames: tuple[str, ...] = ()) -> RobotSkeleton:
        """The obstacle-avoidance skeleton with these tool segments and frame points (built once, under the
        lock; :func:`kinserve.ik.constraints.robot_skeleton.build_robot_skeleton`)."""
        key = (tool_frames, frames)
        skeleton = self.skeletons.get(key)
        if skeleton is None:
            with self.lock:
                skeleton = self.skeletons.get(key)
                if skeleton is None:
                    skeleton = self.skeletons[key] = build_robot_skeleton(self.robot, tool_frames, frames)
        return skeleton

    def collision_checker(self, obstacles: tuple, self_collision: bool, margin: float) -> CollisionChecker:
        """The :class:`~kinserve.ik.collision.collision_checker.CollisionChecker` of the collision constraint
        of the validated ``obstacles`` bound to the robot (this thread's)."""
        store = getattr(self.threads, "bound", None)  # this thread's BoundConstraints
        if store is None:
            store = self.threads.bound = BoundConstraints()
        return store.get(self.robot, obstacles, self_collision, margin)

    def last_collision(self, obstacles: Any, self_collision: Any, margin: float) -> tuple | None:
        """``(CollisionRequest, CollisionChecker)`` of this thread's last :meth:`collision_checker` when
        ``obstacles`` (a tuple or list, not validated) holds the very shape objects it was asked for, with the
        same options (``self_collision`` the same bool object); else None."""
        store = getattr(self.threads, "bound", None)
        if store is None or not store.same_as_last(obstacles, self_collision, margin):
            return None
        return store.last


def ik_state(robot: Robot) -> IKState:
    """The :class:`IKState` of ``robot`` (an empty one is made on first use; nothing is built)."""
    ext = robot.extensions
    state = ext.ik
    if state is None:
        with _CREATE_LOCK:
            state = ext.ik
            if state is None:
                state = ext.ik = IKState(robot)
    return state


def warm(robot: Robot, frames: str | Iterable[str] | None = None, *, self_collision: bool = False,
         obstacles: Sequence[Any] = (), collision_margin: float = 0.0) -> IKState:
    """Build the robot's IK state for ``frames`` (default ``robot.tip``) now: the compiled LM's chains, seed
    tables, closed forms and, with ``self_collision`` or ``obstacles``, the collision model, its compiled
    pre-check and the bound constraint of that scene. Every later solve of those frames (and that scene)
    starts at once.

    ``ik.solve`` does the same for its own request before its clock starts, so calling this is never needed
    for correct answers; it moves the one-time cost (a fraction of a second per frame; seconds for the first
    collision model of a large robot) to a moment of the caller's choosing.

    Every argument is checked before anything is built. Refused (:class:`InputError` and its subclasses):
    ``frames`` that is not a frame name, None or a sequence of names (an unknown name: :class:`FrameError`),
    ``self_collision`` that is not a bool, ``obstacles`` that are not shapes, ``collision_margin`` that is
    not a finite length in ``[0, 1000]`` m.
    """
    if not (hasattr(robot, "model") and hasattr(robot, "frame_id") and hasattr(robot, "tip")):
        raise InputError(f"robot must be a kinserve.kinematics.Robot, got {type(robot).__name__}")
    names = _frame_names(robot, frames)
    req = collision_request(self_collision, obstacles, collision_margin)
    state = ik_state(robot)
    compiled_chains(robot)  # the compiled LM's chains of every frame (robot.lm_chains)
    for frame in names:
        state.frame(frame)
    if req.self_collision or req.obstacles:
        state.collision_checker(req.obstacles, req.self_collision, req.margin)  # bound with its checker
    return state


def _frame_names(robot: Robot, frames: Any) -> list[str]:
    """``frames`` of :func:`warm` as a list of known frame names (:class:`FrameError` for an unknown one,
    :class:`InputError` for anything that is not a name or a sequence of names)."""
    if frames is None:
        return [robot.tip]
    if isinstance(frames, str):
        names = [frames]
    elif isinstance(frames, (bytes, dict)) or not hasattr(frames, "__iter__"):
        raise InputError(f"frames must be a frame name, a sequence of frame names or None (the robot's tip), "
                         f"got {frames!r}")
    else:
        names = list(frames)
    for i, name in enumerate(names):
        if not isinstance(name, str):
            raise InputError(f"frames[{i}] must be a frame name (str), got {name!r}")
        robot.frame_id(name)  # (a clear FrameError for an unknown name)
    return names


def frame_state(robot: Robot, frame: str) -> FrameState:
    """The :class:`FrameState` of ``frame`` of ``robot`` (``ik_state(robot).frame(frame)``)."""
    state = robot.extensions.ik
    record = None if state is None else state.frames.get(frame)
    return record if record is not None else ik_state(robot).frame(frame)


def clear(robot: Robot) -> None:
    """Drop the IK state of ``robot`` (and of every copy sharing it); the next solve builds it again."""
    robot.extensions.ik = None


def seed_table(robot: Robot, frame: str) -> SeedTable:
    """The seed table of ``robot`` for ``frame`` (``ik_state(robot).seed_table(frame)``)."""
    return ik_state(robot).seed_table(frame)


def closed_form_solver(robot: Robot, frame: str) -> ClosedFormSolver | None:
    """The closed-form solver of ``robot`` for ``frame``, or None (``ik_state(robot).closed_form(frame)``)."""
    return ik_state(robot).closed_form(frame)
