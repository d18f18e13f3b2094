"""One IK request: every argument of ``ik.solve`` validated once, into an immutable :class:`SolveRequest`.

``ik.solve``, ``ik.solve_many``, the CLI and the service build the request here; nothing downstream checks
an argument again or changes the request (a batch makes one request per target with ``_replace``).
Building it also warms the robot's IK state for the request's frame and scene (:mod:`kinserve.ik.state`),
so the one-time set-up never counts against the solve's time budget.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from types import MappingProxyType
from typing import Any, NamedTuple

import numpy as np

from kinserve.ik.arguments import (
    MAX_SEED,
    MAX_TIME,
    check_backend,
    check_max_time,
    check_method,
    check_q0,
    check_robot,
    check_seed,
    check_tolerances,
    tag,
)
from kinserve.ik.collision.request import CollisionRequest, collision_request
from kinserve.ik.constraints.base import Constraint
from kinserve.ik.constraints.collision import check_length
from kinserve.ik.constraints.obstacle_arguments import non_negative
from kinserve.ik.constraints.obstacles import ObstacleAvoidance
from kinserve.ik.link_obstacles import link_obstacles
from kinserve.ik.options import (
    DEFAULT_TOL_POS,
    DEFAULT_TOL_ROT,
    NO_CENTRING_METHODS,
    NO_OBSTACLE_METHODS,
    check_options,
)
from kinserve.ik.problem import Problem, as_constraints
from kinserve.ik.qp.dense_qp import DEFAULT_BACKEND
from kinserve.ik.state import ik_state
from kinserve.ik.targets import Target
from kinserve.ik.tasks.centring_weights import centring_weights
from kinserve.kinematics.errors import InputError, KinserveError, ModelError
from kinserve.kinematics.robot import TASK_AXES, Robot
from kinserve.kinematics.shapes import Shape
from kinserve.kinematics.validation import as_flag

_NO_OPTIONS: Mapping[str, Any] = MappingProxyType({})


class SolveRequest(NamedTuple):
    """A validated IK request (immutable).

    Exactly one of ``target`` (one frame at one pose) and ``problem`` (tasks and constraints bound to the
    robot) is set. ``weights``: centring weights (None = off); ``avoid``: obstacles kept clear of the link
    capsules (bound :class:`ObstacleAvoidance`, None = none); ``extra``: further constraints of a target
    request; ``collision``: the collision options (None = none); ``collision_checker``: the
    :class:`~kinserve.ik.collision.collision_checker.CollisionChecker` of their constraint bound to the
    robot (its ``constraint``; None when the robot has no collision model: then ``avoid`` holds the
    obstacles);
    ``options``: the method's options (names and values checked by :func:`kinserve.ik.options.check_options`).
    ``max_time`` None means the method's default budget (:mod:`kinserve.ik.options`).
    """

    robot: Robot
    target: Target | None
    problem: Problem | None
    q0: np.ndarray | None
    method: str
    backend: str
    tol_pos: float
    tol_rot: float
    max_time: float | None
    seed: int | None
    weights: np.ndarray | None
    avoid: ObstacleAvoidance | None
    extra: tuple[Constraint, ...]
    collision: CollisionRequest | None
    collision_checker: Any
    options: Mapping[str, Any]


def pose_request(robot: Robot, target: Any, q0: Any = None, frame: str | None = None, relax: Any = (),
                 relax_frame: str = "world", method: str = "auto", tol_pos: float = DEFAULT_TOL_POS,
                 tol_rot: float = DEFAULT_TOL_ROT, max_time: float | None = None, seed: int | None = None,
                 options: Mapping[str, Any] = _NO_OPTIONS, collision: tuple | None = None) -> SolveRequest:
    """The request of a pose target with every other argument at its default (the common call), validated;
    the frame's IK state prepared (:meth:`kinserve.ik.state.IKState.frame`).

    ``collision``: ``(self_collision, obstacles, collision_margin, spheres)`` of a call that sets
    ``self_collision`` or ``collision_margin`` (the common collision-aware call: every other argument as
    here), bound to the robot's collision model (:func:`_collision_part`); None: no collision options."""
    # (the checks are skipped for the defaults, which pass them: the common call makes fewer calls)
    if type(robot) is not Robot:
        check_robot(robot)
    tgt = target if isinstance(target, Target) else Target(robot, target, frame, relax, relax_frame)
    if type(tol_pos) is not float or type(tol_rot) is not float or tol_pos != DEFAULT_TOL_POS \
            or tol_rot != DEFAULT_TOL_ROT:
        tol_pos, tol_rot = check_tolerances(tol_pos, tol_rot)
    if type(method) is not str or method != "auto":
        check_method(method)
    if options:
        check_options(method, options)
        options = MappingProxyType(dict(options))
    else:
        options = _NO_OPTIONS
    if max_time is not None and not (type(max_time) is float and 0.0 < max_time <= MAX_TIME):
        max_time = check_max_time(max_time)  # (the fast test above accepts exactly what this accepts)
    if seed is not None and not (type(seed) is int and 0 <= seed <= MAX_SEED):
        seed = check_seed(seed)
    q0 = None if q0 is None else check_q0(robot, q0)
    state = robot.extensions.ik
    if state is None or method == "analytic" or tgt.frame not in state.frames:
        _warm(robot, tgt, method)
    if collision is None:
        return SolveRequest(robot, tgt, None, q0, method, DEFAULT_BACKEND, tol_pos, tol_rot, max_time, seed,
                            None, None, (), None, None, options)
    request, checker, avoid = _collision_part(robot, tgt.frame, *collision)
    if avoid is not None and method in NO_OBSTACLE_METHODS:
        _refuse_obstacles(method)
    return SolveRequest(robot, tgt, None, q0, method, DEFAULT_BACKEND, tol_pos, tol_rot, max_time, seed, None,
                        avoid, (), request, checker, options)


def _collision_part(robot: Robot, frame: str, self_collision: Any, obstacles: Any, collision_margin: Any,
                    spheres: Any) -> tuple:
    """``(CollisionRequest, checker, avoid)`` of the collision options (:func:`_bind_collision`); the shapes
    of this thread's last scene (the very objects, the same options) were validated and bound then."""
    if (type(obstacles) is list or type(obstacles) is tuple) and type(spheres) is tuple and not spheres \
            and type(collision_margin) is float:
        last = robot.extensions.ik.last_collision(obstacles, self_collision, collision_margin)  # (warm)
        if last is not None:
            return (*last, None)
    collision = collision_request(self_collision, obstacles, collision_margin, spheres)
    return (collision, *_bind_collision(robot, collision, frame))


def _refuse_obstacles(method: str) -> None:
    raise InputError(f"method {method!r} cannot honour obstacle constraints (spheres/obstacles); "
                     "use 'qp' or 'auto'")


def target_request(robot: Robot, target: Any, q0: Any = None, *, frame: str | None = None, relax: Any = (),
                   relax_frame: str = "world", spheres: Any = (), obstacles: Any = (), link_radius: Any = 0.0,
                   centring: Any = 0.0, method: str = "auto", backend: str | None = None,
                   tol_pos: float = DEFAULT_TOL_POS, tol_rot: float = DEFAULT_TOL_ROT,
                   max_time: float | None = None, seed: int | None = None, constraints: Any = None,
                   self_collision: Any = False, collision_margin: Any = 0.0,
                   options: Mapping[str, Any] = _NO_OPTIONS) -> SolveRequest:
    """The request of ``ik.solve(robot, target, ...)`` (see :func:`kinserve.ik.solve`)."""
    req = pose_request(robot, target, q0, frame, relax, relax_frame, method, tol_pos, tol_rot, max_time, seed,
                       options)
    tgt = req.target
    weights = None if type(centring) is float and centring == 0.0 else centring_weights(robot, centring)
    if weights is not None and method in NO_CENTRING_METHODS:
        raise InputError(f"method {method!r} cannot honour centring; use 'qp' (or 'pseudo_inverse' / 'dls')")
    collision, bound, avoid = None, None, None
    as_flag(self_collision, "self_collision")
    if not (type(collision_margin) is float and collision_margin == 0.0):
        collision_margin = check_length(collision_margin, "collision margin")
    if self_collision or collision_margin:
        non_negative(link_radius, "link_radius")  # (checked; the collision geometry replaces the capsules)
        collision, bound, avoid = _collision_part(robot, tgt.frame, self_collision, obstacles,
                                                  collision_margin, spheres)
    else:
        avoid = _link_obstacles(robot, spheres, obstacles, link_radius, tgt.frame)
        if avoid is not None and robot.attached:  # carried objects: in the collision model, not the capsules
            collision = CollisionRequest(False, tuple(avoid.obstacles), 0.0)
            bound, avoid = _bind_collision(robot, collision, tgt.frame)
    if avoid is not None and method in NO_OBSTACLE_METHODS:
        _refuse_obstacles(method)
    extra = () if constraints is None else _extra_constraints(constraints, method, tgt.frame)
    backend = DEFAULT_BACKEND if backend is None else check_backend(backend)
    return SolveRequest(robot, tgt, None, req.q0, method, backend, req.tol_pos, req.tol_rot, req.max_time,
                        req.seed, weights, avoid, extra, collision, bound, req.options)


def task_request(robot: Robot, tasks: Any, constraints: Any = None, q0: Any = None, *, method: str = "auto",
                 backend: str | None = None, tol_pos: float = DEFAULT_TOL_POS,
                 tol_rot: float = DEFAULT_TOL_ROT, max_time: float | None = None, seed: int | None = None,
                 options: Mapping[str, Any] = _NO_OPTIONS) -> SolveRequest:
    """The request of ``ik.solve(robot, tasks=[...], constraints=[...])``: the tasks and constraints bound."""
    check_robot(robot)
    if not (type(method) is str and method in ("auto", "qp")):
        raise InputError(f"method must be 'auto' or 'qp' for a composition of tasks, got {method!r}")
    tol_pos, tol_rot = check_tolerances(tol_pos, tol_rot)
    problem = Problem(robot, tasks, constraints)
    req = SolveRequest(robot, None, problem, check_q0(robot, q0), "qp", check_backend(backend), tol_pos,
                       tol_rot, check_max_time(max_time), check_seed(seed), None, None, (), None, None,
                       _checked_options("qp", options))
    for task in problem.tasks:
        frame = getattr(task, "frame_name", None)
        if frame is not None:
            ik_state(robot).seed_table(frame)
    return req


def _checked_options(method: str, options: Mapping[str, Any]) -> Mapping[str, Any]:
    if not options:
        return _NO_OPTIONS
    check_options(method, options)
    return MappingProxyType(dict(options))


def _warm(robot: Robot, tgt: Target, method: str) -> None:
    """The one-time set-up of the target's frame (its :class:`~kinserve.ik.state.FrameState`), before any
    clock starts; a clear error when ``"analytic"`` is named for a frame without a usable closed form."""
    solver = ik_state(robot).frame(tgt.frame).closed_form
    if method != "analytic":
        return
    if solver is None:
        raise InputError(f"no closed-form solver for robot {robot.name!r} and frame {tgt.frame!r}; "
                         "use 'auto', 'lm' or 'qp'")
    if not solver.supports(tgt.relaxed):
        names = ", ".join(TASK_AXES[i] for i in tgt.relaxed)
        raise InputError(f"the closed-form solver of {robot.name!r} does not handle relaxing {names}; "
                         "use 'lm' or 'qp'")


def _link_obstacles(robot: Robot, spheres: Any, obstacles: Any, link_radius: Any,
                    frame: str) -> ObstacleAvoidance | None:
    try:
        return link_obstacles(robot, spheres, obstacles, link_radius, frame)
    except KinserveError as exc:
        empty = obstacles is None or (type(obstacles) is tuple and not obstacles)
        tag(exc, "spheres" if empty else "obstacles")
        raise


def _bind_collision(robot: Robot, collision: CollisionRequest, frame: str) -> tuple:
    """``(checker of the bound collision constraint, None)``; a robot without collision geometry keeps
    obstacles clear of its link capsules instead (``(None, ObstacleAvoidance)``) and refuses
    ``self_collision``."""
    try:  # (a scene bound before is found without asking for the collision model)
        return ik_state(robot).collision_checker(collision.obstacles, collision.self_collision,
                                                 collision.margin), None
    except ModelError:
        try:
            robot.collision
        except ModelError as exc:  # no collision model: that, not something the binding ran into
            if not collision.self_collision and collision.obstacles:
                return None, ObstacleAvoidance(list(collision.obstacles), tool_frames=(frame,)).bind(robot)
            raise ModelError(f"{exc}; ik.solve(self_collision=True) needs it (obstacles alone fall back to "
                             "the link capsules of ik.ObstacleAvoidance)") from None
        raise


def _extra_constraints(constraints: Any, method: str, frame: str) -> tuple[Constraint, ...]:
    if constraints is None:
        return ()
    items = [constraints] if isinstance(constraints, Shape) else list(_iterable(constraints))
    if not items:
        return ()
    if method not in ("auto", "qp"):
        raise InputError(f"method {method!r} cannot honour constraints; use 'qp' or 'auto'")
    return tuple(as_constraints(items, (frame,)))


def _iterable(value: Any) -> Iterable[Any]:
    try:
        return iter(value)
    except TypeError:
        raise InputError(f"constraints must be a sequence of ik.Constraint objects or shapes, "
                         f"got {value!r}") from None
