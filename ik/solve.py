"""``ik.solve`` and ``ik.solve_all``: validate once, pick a method, return a :class:`Result`.

Methods
-------
``"auto"`` (default) picks the fastest method that can honour the request:

1. obstacles (``spheres`` / ``obstacles``) only -> ``"lm"`` first from the first few starts;
   an answer is kept when every iterate of its run is clear of every obstacle, otherwise ``"qp"``. Centring or extra constraints -> ``"qp"`` (strict priority and hard
   inequalities need the QP);
2. a closed-form solver with finitely many branches exists for the robot and
   frame and handles the relaxed components -> ``"analytic"`` (2R/3R, SCARA,
   youBot; it falls back to ``"lm"`` only when no branch is usable). The
   redundant 4R arm's closed form is a sampled one-parameter family, slower
   to enumerate than one LM solve, so ``"auto"`` uses ``"lm"`` for it (name
   ``"analytic"`` or call :func:`solve_all` to get the family);
3. otherwise -> ``"lm"`` (joint limits are the only inequalities).

``ik.solve(robot, tasks=[...], constraints=[...])`` solves any composition of
tasks and constraints on the task model (:mod:`ik.qp.task_solver`).

``"qp"``, ``"lm"``, ``"analytic"`` and the classical ``"jacobian_inverse"``,
``"jacobian_transpose"``, ``"pseudo_inverse"``, ``"dls"`` can be named
directly (see :mod:`ik.qp.target_solver`, :mod:`ik.lm.solver`, :mod:`ik.closed_form`,
:mod:`ik.classical.methods`).

Validation (once, before any solver runs; errors from :mod:`kinematics.errors`):
the target pose (shape, NaN/inf, rotation orthonormal), ``q0`` (shape,
finite), the frame name, the relaxed component names, tolerances, time
budget, seed, method, backend, centring weights, and the obstacles (sizes
positive, numbers finite, frames known, no obstacle containing the fixed
base). A start inside an obstacle is not an error: the solve begins from
collision-free starts and says so in ``Result.message``. Not reaching the target is not an error:
``Result.success`` is False, ``Result.q`` the best configuration found
(inside the limits) and ``Result.message`` the reason.
"""

from __future__ import annotations

from itertools import islice
import numbers
import time
from typing import TYPE_CHECKING, Any

import numpy as np

from kinserve.kinematics.errors import InputError, KinserveError
from kinserve.kinematics.validation import as_positive
from kinserve.kinematics.robot import Robot
from kinserve.kinematics.shapes import Shape

from kinserve.ik import numpy_fast
from kinserve.ik import closed_form as _analytic
from kinserve.ik.tasks.centring_weights import centring_weights
from kinserve.ik.closed_form.chooser import choose
from kinserve.ik.classical.methods import METHODS as CLASSICAL_METHODS
from kinserve.ik.classical.methods import solve_classical
from kinserve.ik.constraints import as_sphere
from kinserve.ik.constraints.obstacles import ObstacleAvoidance, as_obstacle
from kinserve.ik.qp.dense_qp import DEFAULT_BACKEND
from kinserve.ik.lm.solver import compiled_chain, solve_lm
from kinserve.ik.starts.multistart import frame_starts
from kinserve.ik.options import OPTIONS, check_options, solver_keywords
from kinserve.ik.problem import Problem
from kinserve.ik.qp.backends import available_backends
from kinserve.ik.targets import Target
from kinserve.ik.qp.target_solver import solve_qp
from kinserve.ik.qp.task_solver import MAX_TIME as QP_MAX_TIME
from kinserve.ik.qp.task_solver import solve_problem

if TYPE_CHECKING:  # annotations only
    from collections.abc import Iterable

    from kinserve.kinematics.types import PoseLike, VectorLike

    from kinserve.ik.result import Result

METHODS = ("auto", "qp", "lm", "analytic") + CLASSICAL_METHODS
_METHOD_SET = frozenset(METHODS)
_NO_CENTRING_METHODS = frozenset(("lm", "analytic", "jacobian_inverse", "jacobian_transpose"))
_NO_OBSTACLE_METHODS = frozenset(("lm", "analytic") + CLASSICAL_METHODS)
_clip = numpy_fast.clip


def _check_positive(value, name: str, allow_none: bool = False) -> float | None:
    if value is None and allow_none:
        return None
    return as_positive(value, name)


def _check_robot(robot):
    if type(robot) is Robot:
        return
    if not (hasattr(robot, "model") and hasattr(robot, "frame_id") and hasattr(robot, "nq")):
        raise InputError(f"robot must be a kinserve.kinematics.Robot (e.g. robots.load('panda')), got {type(robot).__name__}")


def _check_seed(seed):
    if seed is None:
        return None
    if type(seed) is int and seed >= 0:  # the common case without the abstract-class checks (~0.4 us)
        return seed
    if isinstance(seed, bool) or not isinstance(seed, numbers.Integral) or seed < 0:
        raise InputError(f"seed must be a non-negative integer or None, got {seed!r}")
    return int(seed)


def _check_backend(backend):
    if backend is None or backend == DEFAULT_BACKEND:
        return DEFAULT_BACKEND
    if backend == "osqp":
        return backend
    if not isinstance(backend, str) or backend.lower() not in available_backends():
        raise InputError(f"backend must be one of the installed QP solvers {available_backends()}, got {backend!r}")
    return backend.lower()


def _tag(exc: KinserveError, name: str) -> None:
    """Name the argument a :class:`KinserveError` concerns (``exc.argument``) unless the raiser did."""
    if exc.argument is None:
        exc.argument = name


_closed_form = _analytic.closed_form_solver  # (memoised per model by identity and frame)


def _obstacle_constraint(robot, spheres, obstacles, link_radius, frame):
    """One :class:`ObstacleAvoidance` for the ``spheres`` and ``obstacles`` of the front door, or None."""
    if type(spheres) is tuple and not spheres and type(obstacles) is tuple and not obstacles \
            and type(link_radius) in (float, int) and link_radius == 0:
        return None  # the defaults: nothing to build or validate
    items = []
    for name, group in (("spheres", spheres), ("obstacles", obstacles)):
        if group is None or (type(group) is tuple and not group):
            continue
        if isinstance(group, (str, bytes)):
            raise InputError(f"{name} must be a sequence of shapes (ik.Sphere, ik.Box, ...), got {group!r}")
        if isinstance(group, (Shape, dict)):
            group = [group]
        try:
            group = list(group)
        except TypeError:
            group = [group]
        for i, ob in enumerate(group):
            items.append(as_sphere(ob) if name == "spheres" else ob if isinstance(ob, Shape)
                         else as_obstacle(ob, f"obstacles[{i}]"))
    if not items:
        if link_radius not in (0, 0.0):
            ObstacleAvoidance([], link_radius=link_radius)  # validates the value
        return None
    return ObstacleAvoidance(items, link_radius=link_radius, tool_frames=(frame,)).bind(robot)


def prepare(robot: Robot, target: PoseLike | Target, q0: VectorLike | None = None, *, frame: str | None = None,
            relax: str | Iterable[str] | None = (), relax_frame: str = "world", spheres: Any = (),
            obstacles: Any = (), link_radius: float = 0.0, centring: float | VectorLike = 0.0,
            method: str = "auto", backend: str | None = None, tol_pos: float = 1e-4, tol_rot: float = 1e-3,
            max_time: float | None = None, seed: int | None = None) -> dict[str, Any]:
    """Validate every argument of :func:`solve`; return a dict of checked values.

    Exposed so that batch solving (:mod:`ik.batch.solve_many`) validates each target once
    in the parent process. ``"spheres"`` holds the obstacle constraint
    (:class:`ik.constraints.ObstacleAvoidance` of the spheres and obstacles) or None.
    """
    return _prepare(robot, target, q0, frame, relax, relax_frame, spheres, obstacles, link_radius, centring, method,
                    backend, tol_pos, tol_rot, max_time, seed)


def _prepare(robot, target, q0, frame, relax, relax_frame, spheres, obstacles, link_radius, centring, method, backend,
             tol_pos, tol_rot, max_time, seed) -> dict[str, Any]:
    """:func:`prepare` with positional arguments (what :func:`solve` calls: no keyword packing per solve)."""
    _check_robot(robot)
    if method not in _METHOD_SET:
        raise InputError(f"method must be one of {METHODS}, got {method!r}")
    tgt = target if type(target) is Target or isinstance(target, Target) else Target(robot, target, frame, relax, relax_frame)
    q0 = _checked_q0(robot, q0)
    tol_pos, tol_rot, max_time, seed = _checked_numbers(tol_pos, tol_rot, max_time, seed)
    backend = DEFAULT_BACKEND if backend is None else _check_backend(backend)
    weights = None if type(centring) is float and centring == 0.0 else centring_weights(robot, centring)
    try:
        avoid = _obstacle_constraint(robot, spheres, obstacles, link_radius, tgt.frame)
    except KinserveError as exc:
        _tag(exc, "spheres" if obstacles is None or (type(obstacles) is tuple and not obstacles) else "obstacles")
        raise
    if weights is not None and method in _NO_CENTRING_METHODS:
        raise InputError(f"method {method!r} cannot honour centring; use 'qp' (or 'pseudo_inverse' / 'dls')")
    if avoid is not None and method in _NO_OBSTACLE_METHODS:
        raise InputError(f"method {method!r} cannot honour obstacle constraints (spheres/obstacles); use 'qp' or 'auto'")
    compiled_chain(robot, tgt.frame_id)  # the compiled LM loaded here, before any solver's clock starts
    return dict(target=tgt, q0=q0, tol_pos=tol_pos, tol_rot=tol_rot, max_time=max_time, seed=seed,
                backend=backend, weights=weights, spheres=avoid, method=method)


def _checked_q0(robot, q0):
    """``q0`` checked by ``robot.check_q`` (errors name the argument ``q0``), or None."""
    if q0 is None:
        return None
    try:
        return robot.check_q(q0, "q0")
    except KinserveError as exc:
        _tag(exc, "q0")
        raise


def _checked_numbers(tol_pos, tol_rot, max_time, seed):
    """``(tol_pos, tol_rot, max_time, seed)`` checked (the defaults pass on an equality test)."""
    if tol_pos != 1e-4:
        tol_pos = _check_positive(tol_pos, "tol_pos")
    if tol_rot != 1e-3:
        tol_rot = _check_positive(tol_rot, "tol_rot")
    if max_time is not None:
        max_time = _check_positive(max_time, "max_time")
    if seed is not None:
        seed = _check_seed(seed)
    return tol_pos, tol_rot, max_time, seed


def _pose_request(tgt, q0, tol_pos, tol_rot, max_time, seed, method) -> dict[str, Any]:
    """What :func:`prepare` returns for checked pose arguments with every other argument at its default."""
    return dict(target=tgt, q0=q0, tol_pos=tol_pos, tol_rot=tol_rot, max_time=max_time, seed=seed,
                backend=DEFAULT_BACKEND, weights=None, spheres=None, method=method)


def _solve_pose(robot, target, q0, frame, relax, relax_frame, method, tol_pos, tol_rot, max_time, seed, options,
                collision: dict | None = None):
    """The common request on a short path: one pose target, joint limits only, ``method`` "auto" or "lm".

    The same checks as :func:`prepare` for the arguments given (the others
    are at their defaults: no obstacle, no centring, default backend); then
    Levenberg-Marquardt directly, or :func:`solve_prepared` when ``"auto"``
    finds a closed form or an option only another method accepts.

    With ``collision`` (the checked collision options): the unconstrained attempts of
    :mod:`ik.collision.solve` without its general set-up
    (:func:`ik.collision.solve.ordinary_solve_checked`); in an open scene the ordinary answer and its
    iterates are almost always collision free. Otherwise, and whenever the robot has no collision model,
    the general path (:func:`solve_prepared`) runs - given the runs already tried and the start of the
    clock, so that nothing is solved twice and the time budget holds.
    """
    _check_robot(robot)
    tgt = target if type(target) is Target or isinstance(target, Target) else Target(robot, target, frame, relax, relax_frame)
    q0 = _checked_q0(robot, q0)
    tol_pos, tol_rot, max_time, seed = _checked_numbers(tol_pos, tol_rot, max_time, seed)
    collision = collision or {}
    if (options and not options.keys() <= _LM_OPTION_SET) or (method == "auto" and _closed_form(robot, tgt.frame) is not None):
        return solve_prepared(robot, _pose_request(tgt, q0, tol_pos, tol_rot, max_time, seed, method), **collision,
                              **options)
    _check_options("lm", options)
    if not collision:
        return solve_lm(robot, tgt, q0, tol_pos=tol_pos, tol_rot=tol_rot, max_time=max_time, seed=seed,
                        **solver_keywords(options))
    compiled_chain(robot, tgt.frame_id)  # (loaded before the clock starts)
    res, handover, t0 = _collision_module().ordinary_solve_checked(robot, tgt, q0, tol_pos, tol_rot, max_time, seed,
                                                                    solver_keywords(options), collision)
    if res is not None:
        return res
    p = _pose_request(tgt, q0, tol_pos, tol_rot, max_time, seed, method)
    p.update(handover if handover is not None else {"t0": t0})
    return solve_prepared(robot, p, **collision, **options)


def solve(
    robot: Robot,
    target: PoseLike | Target | None = None,
    q0: VectorLike | None = None,
    *,
    frame: str | None = None,
    relax: str | Iterable[str] | None = (),
    relax_frame: str = "world",
    spheres: Any = (),
    obstacles: Any = (),
    link_radius: float = 0.0,
    centring: float | VectorLike = 0.0,
    method: str = "auto",
    backend: str | None = None,
    tol_pos: float = 1e-4,
    tol_rot: float = 1e-3,
    max_time: float | None = None,
    seed: int | None = None,
    tasks: Any = None,
    constraints: Any = None,
    self_collision: bool = False,
    collision_margin: float = 0.0,
    **options: Any,
) -> Result:
    """Inverse kinematics: a configuration placing ``frame`` at ``target`` - or meeting ``tasks``.

    Two front doors:

    * ``ik.solve(robot, target, q0, ...)``: one frame at one pose. It builds
      an :class:`ik.FrameTask`, an :class:`ik.CentringTask` (priority 2) when
      ``centring`` is set, and an obstacle constraint for ``spheres`` /
      ``obstacles``, exactly the objects a user could build by hand.
    * ``ik.solve(robot, tasks=[...], constraints=[...], q0=...)``: any
      composition of tasks (priorities strict between levels, weights inside a
      level) and constraints (joint limits always on; shapes in
      ``constraints`` become obstacles). ``Result.task_errors`` reports every
      task; ``success`` means every goal task is within tolerance.

    Parameters
    ----------
    robot:
        A :class:`kinserve.kinematics.Robot`.
    target:
        4x4 homogeneous pose (or ``pinocchio.SE3``) of ``frame`` in the world.
    q0:
        Start / current configuration (``nq`` values; clipped into the joint
        limits if outside). The iterative solvers try ``q0`` and the nearest
        samples of a precomputed table of configurations (:mod:`ik.starts.seed_table`) in
        order of their pose distance to the target; pass ``prefer_q0=True`` to
        always start from ``q0``. A ``q0`` inside an obstacle is not an error:
        the solve starts from collision-free configurations and says so in
        ``Result.message``. The classical methods start from ``q0``
        (default: the neutral configuration); the closed forms use it to pick
        the branch nearest to it.
    frame:
        The frame to place (default ``robot.tip``).
    relax:
        Components left free, any of ``x y z roll pitch yaw`` (``phi`` =
        ``yaw``); position-only IK is ``relax=("roll", "pitch", "yaw")``.
        Relaxed components are expressed in the **world** frame by default
        (``relax_frame="world"``); ``relax_frame="target"`` measures them
        along the target frame's own axes. See :mod:`ik.targets`.
    spheres, obstacles:
        Obstacles kept clear of the robot's links on every iterate:
        ``spheres`` takes :class:`ik.Sphere` objects or ``(center, radius)``
        pairs, ``obstacles`` any shape (:class:`ik.Sphere`, :class:`ik.Box`,
        :class:`ik.Capsule`, :class:`ik.Cylinder`, :class:`ik.Mesh`) or its
        ``to_dict()`` form. An obstacle containing the fixed base raises.
    link_radius:
        Radius (m) of the capsules around the link segments (0 = bare segments).
    centring:
        Weight(s) of the joint-limit centring objective, strictly below the
        target (0 = off). See :mod:`ik.tasks.centring_weights`.
    method:
        ``"auto"``, ``"qp"``, ``"lm"``, ``"analytic"``, ``"jacobian_inverse"``,
        ``"jacobian_transpose"``, ``"pseudo_inverse"``, ``"dls"``.
    backend:
        QP solver of the constrained steps: ``"daqp"`` (default when
        installed; deterministic), ``"osqp"``, ``"proxqp"``, ``"quadprog"``.
    tol_pos, tol_rot:
        Success thresholds on the position (m) and orientation (rad) errors.
    max_time:
        Time budget (s) for restarts (default 0.1 s for ``lm``, 0.5 s for ``qp``).
    seed:
        Seed of the random restarts (None = 0): the same seed gives a
        bit-identical answer unless the time budget cut the solve.
    tasks, constraints:
        The composed front door (see above). ``constraints`` may also be given
        with a ``target``: they are added to the target's own.
    self_collision, collision_margin:
        ``self_collision=True`` keeps the robot's collision geometry (convex
        hulls of its URDF ``<collision>`` shapes) free of self-collision (SRDF /
        MoveIt-style pairs) and, with it, ``collision_margin`` (m) clear of the
        ``obstacles`` and ``spheres`` - against the real geometry instead of the
        link capsules. The unconstrained answer and its iterates are checked
        first; a constrained solve (hard on every iterate) runs only when needed.
        See :mod:`ik.collision.solve`. (``constraints=[ik.SceneCollision(obstacles)]``
        uses the real geometry for obstacles alone.)
    options:
        Method-specific: ``max_iter``, ``damping`` (``lm``/``qp``; DLS ``lambda``
        for ``"dls"``), ``gain`` (classical), ``max_step``, ``shortcut`` and
        ``lazy`` (``qp``), ``max_starts``, ``prefer_q0``, ``seed_table``
        (False disables the table of starts), ``samples`` (4R family),
        ``choose`` (chooser criteria for ``"analytic"``).

    Returns
    -------
    :class:`ik.Result`
    """
    if tasks is not None:
        if target is not None:
            raise InputError("give either a target pose or tasks=[...], not both (add a FrameTask to the tasks)")
        return solve_tasks(robot, tasks, constraints, q0, method=method, backend=backend, tol_pos=tol_pos,
                           tol_rot=tol_rot, max_time=max_time, seed=seed, **options)
    if target is None:
        raise InputError("target (a 4x4 pose of the frame) is required, or tasks=[...]")
    if (method == "auto" or method == "lm") and constraints is None and not self_collision and not collision_margin \
            and type(spheres) is tuple and not spheres and type(obstacles) is tuple and not obstacles \
            and type(link_radius) is float and link_radius == 0.0 and type(centring) is float and centring == 0.0 \
            and backend is None:
        # the defaults of everything but the pose: the short path (same checks, no dispatch)
        return _solve_pose(robot, target, q0, frame, relax, relax_frame, method, tol_pos, tol_rot, max_time, seed,
                           options)
    if self_collision or collision_margin:
        collision = _collision_module().collision_options(self_collision, obstacles, collision_margin, spheres)
        if (method == "auto" or method == "lm") and constraints is None and type(link_radius) is float \
                and link_radius == 0.0 and type(centring) is float and centring == 0.0 and backend is None:
            return _solve_pose(robot, target, q0, frame, relax, relax_frame, method, tol_pos, tol_rot, max_time, seed,
                               options, collision)
        options.update(collision)
        spheres, obstacles = (), ()
    p = _prepare(robot, target, q0, frame, relax, relax_frame, spheres, obstacles, link_radius, centring, method, backend,
                 tol_pos, tol_rot, max_time, seed)
    if constraints is not None:
        extra = [c for c in (constraints if not isinstance(constraints, (Shape,)) else [constraints])]
        if extra:
            if method not in ("auto", "qp"):
                raise InputError(f"method {method!r} cannot honour constraints; use 'qp' or 'auto'")
            p["constraints"] = extra
    return solve_prepared(robot, p, **options)


def solve_tasks(robot: Robot, tasks: Any, constraints: Any = None, q0: VectorLike | None = None, *,
                method: str = "auto", backend: str | None = None, tol_pos: float = 1e-4, tol_rot: float = 1e-3,
                max_time: float | None = None, seed: int | None = None, **options: Any) -> Result:
    """``ik.solve(robot, tasks=..., constraints=..., q0=...)`` (see :func:`solve`)."""
    _check_robot(robot)
    if method not in ("auto", "qp"):
        raise InputError(f"method must be 'auto' or 'qp' for a composition of tasks, got {method!r}")
    _check_options("qp", options)
    if q0 is not None:
        q0 = robot.check_q(q0, "q0")
    tol_pos = _check_positive(tol_pos, "tol_pos")
    tol_rot = _check_positive(tol_rot, "tol_rot")
    if max_time is not None:
        max_time = _check_positive(max_time, "max_time")
    pb = Problem(robot, tasks, constraints)
    return solve_problem(pb, q0, tol_pos=tol_pos, tol_rot=tol_rot, max_time=max_time, seed=_check_seed(seed),
                         backend=_check_backend(backend), **solver_keywords(options))


#: Starts tried without constraints before the constrained solve (``"auto"`` with obstacles). An LM run
#: costs a fraction of a QP solve, so runs that stall at a joint limit or whose answer is inside an obstacle
#: are cheap to retry (measured on bench_ik_constrained, CPU time: 8 rather than 4 cut the 90th-95th
#: percentiles by about a tenth, the median unchanged).
FREE_ATTEMPTS = 8


def _solve_unconstrained_first(robot, p: dict, options: dict):
    """The cheap path of ``"auto"`` with obstacles: an LM answer whose every iterate is clear, or None.

    Obstacles rarely bind: Levenberg-Marquardt runs from the first
    :data:`FREE_ATTEMPTS` starts of the usual start sequence, one at a time, and
    the first converged run whose every iterate keeps every clearance ``>= 0``
    is the answer - the constraint then held on every iterate without ever
    being imposed. The start is not checked before the run: its check is part
    of the run's (one vectorised check of ``q0`` and all the iterates).

    A converged run whose *answer* is clear but whose path was not ends the
    free attempts too: its answer, a clear configuration within tolerance, is
    a start that already meets the target and every constraint - the
    constrained solve given it as a warm start would return it at once, with a
    history of that one configuration. That answer and history are returned
    here directly (no QP problem is built for it). Otherwise None: the caller
    runs the constrained solve on the usual starts (measured: starting it from
    the last clear iterate of a free run is worse - that iterate faces the
    obstacle).
    """
    avoid = p["spheres"]
    opts = solver_keywords(options)
    tgt = p["target"]
    q0 = p["q0"]
    if q0 is not None:
        q0 = _clip(q0, robot.lower, robot.upper)
    q0_bad = None  # unknown until a run is checked
    starts = frame_starts(robot, tgt.frame, tgt.frame_id, tgt.T[:3, :3], tgt.T[:3, 3], len(tgt.rot_rows) == 3, q0,
                          p["seed"], opts.pop("seed_table_enabled", True), opts.pop("prefer_q0", False))
    opts.pop("max_starts", None)
    t0 = time.perf_counter()
    budget = p["max_time"] if p["max_time"] is not None else QP_MAX_TIME  # the whole solve's budget
    tol_pos, tol_rot = p["tol_pos"], p["tol_rot"]
    attempt = -1
    for attempt, q in enumerate(islice(starts, FREE_ATTEMPTS)):
        left = budget - (time.perf_counter() - t0)
        if left <= 0.0:
            break
        res = solve_lm(robot, tgt, q, tol_pos=tol_pos, tol_rot=tol_rot, max_time=left,
                       prefer_q0=True, seed_table_enabled=False, max_starts=1, **opts)
        if not res.success:
            continue
        Q = res.history.iterates()  # the run's configurations, not stacked (the history stays lazy)
        if q0 is not None and q0_bad is None and Q[0].tolist() != q0.tolist():  # (q0 is checked once)
            bad = avoid.violations(robot, [q0, *Q])
            q0_bad, bad = bool(bad[0]), bad[1:]
        else:
            bad = avoid.violations(robot, Q)
            if q0 is not None and q0_bad is None:  # this run started at q0
                q0_bad = bool(bad[0])
        if not bad.any():
            res.message = "converged; every iterate clear of the obstacles (checked, no constraint was needed)"
            if q0_bad:
                res.message += "; q0 is inside an obstacle: started from a configuration clear of them"
            res.restarts = attempt
            res.elapsed = time.perf_counter() - t0
            return res
        if not bad[-1]:  # the answer is clear, its path was not: the answer alone (see the docstring)
            res.history = res.history.final()
            res.message = ("converged: an unconstrained run's answer, clear of the obstacles, taken as a start of its "
                           "own (the run's path was not clear; the history is that configuration alone)")
            if q0_bad:
                res.message += "; q0 is inside an obstacle: started from a configuration clear of them"
            res.restarts = attempt
            res.elapsed = time.perf_counter() - t0
            return res
    p["max_time"] = max(budget - (time.perf_counter() - t0), 1e-3)  # the constrained solve gets what is left
    p["tried_starts"] = attempt + 1  # (the constrained solve retries them later)
    return None


def _solve_target_tasks(robot, p: dict, options: dict):
    """The single-target front door on the task model: FrameTask (+ CentringTask) and obstacle constraints."""
    tgt = p["target"]
    extra = p.get("constraints")
    if extra:
        from kinserve.ik.problem import as_constraints

        spheres = as_constraints(([p["spheres"]] if p["spheres"] is not None else []) + list(extra), (tgt.frame,))
    else:
        spheres = p["spheres"]
    opts = solver_keywords(options)
    return solve_qp(robot, tgt, p["q0"], spheres=spheres, weights=p["weights"], backend=p["backend"],
                    tol_pos=p["tol_pos"], tol_rot=p["tol_rot"], max_time=p["max_time"], seed=p["seed"],
                    defer_starts=p.get("tried_starts", 0), **opts)


_collision_solve = None


def _collision_module():
    """:mod:`ik.collision.solve`, imported on first use (it loads coal) and then held: no import per solve."""
    global _collision_solve
    if _collision_solve is None:
        from kinserve.ik.collision import solve as collision_solve

        _collision_solve = collision_solve
    return _collision_solve


_COLLISION_KEYS = frozenset(("self_collision", "obstacles", "collision_margin"))
# accepted option names per method: one list, in ik.options
_LM_OPTIONS, _QP_OPTIONS = OPTIONS["lm"], OPTIONS["qp"]
_ANALYTIC_OPTIONS = OPTIONS["analytic"]
_LM_OPTION_SET = frozenset(_LM_OPTIONS)


def _check_options(method, options):
    """Raise :class:`InputError` for an option ``method`` (a key of :data:`ik.options.OPTIONS`) does not accept
    or a value out of range (:func:`ik.options.check_options`; nothing to do without options)."""
    if options:
        check_options(method, options)


def solve_prepared(robot: Robot, p: dict, **options: Any) -> Result:
    """Run the solver on arguments already checked by :func:`prepare`.

    ``options`` may hold the collision options of :func:`solve` (``self_collision``, ``obstacles``,
    ``collision_margin``): the solve then goes through :mod:`ik.collision.solve` (so does ``ik.solve_many``).
    """
    if options and not _COLLISION_KEYS.isdisjoint(options):
        return _collision_module().solve_collision_free(robot, p, solve_prepared, **options)
    method = p["method"]
    tgt = p["target"]
    if method == "auto":
        _check_options("auto", options)
        constrained = p["spheres"] is not None or p["weights"] is not None or p.get("constraints")
        if not constrained:
            solver = _closed_form(robot, tgt.frame)
            # closed forms with finitely many branches; a sampled family (4R) is slower than LM in Python
            if solver is not None and solver.finite and solver.supports(tgt.relaxed):
                res = _solve_analytic(robot, solver, p, **{k: v for k, v in options.items() if k in _ANALYTIC_OPTIONS})
                if res is not None:
                    return res
            method = "lm"
        else:
            if p["weights"] is None and not p.get("constraints"):  # obstacles only
                res = _solve_unconstrained_first(robot, p, {k: v for k, v in options.items() if k in _LM_OPTIONS})
                if res is not None:
                    return res
            method = "qp"
        if options and not _LM_OPTION_SET.issuperset(options):
            options = {k: v for k, v in options.items() if k in (_QP_OPTIONS if method == "qp" else _LM_OPTIONS)}
    if method == "lm":
        _check_options(method, options)
        return solve_lm(robot, tgt, p["q0"], tol_pos=p["tol_pos"], tol_rot=p["tol_rot"], max_time=p["max_time"],
                        seed=p["seed"], **solver_keywords(options))
    if method == "qp":
        _check_options(method, options)
        return _solve_target_tasks(robot, p, options)
    if method == "analytic":
        _check_options(method, options)
        solver = _closed_form(robot, tgt.frame)
        if solver is None:
            raise InputError(f"no closed-form solver for robot {robot.name!r} and frame {tgt.frame!r}; use 'auto', 'lm' or 'qp'")
        if not solver.supports(tgt.relaxed):
            raise InputError(
                f"the closed-form solver of {robot.name!r} does not handle relaxing {_names(tgt.relaxed)}; use 'lm' or 'qp'"
            )
        res = _solve_analytic(robot, solver, p, fallback=False, **options)
        return res
    _check_options(method, options)
    q0 = p["q0"] if p["q0"] is not None else robot.neutral()
    return solve_classical(robot, tgt, q0, method, weights=p["weights"], tol_pos=p["tol_pos"], tol_rot=p["tol_rot"],
                           max_time=p["max_time"], **options)


def _names(rows) -> str:
    from kinserve.kinematics.robot import TASK_AXES

    return ", ".join(TASK_AXES[i] for i in rows)


def _default_criteria(q0):
    return ("displacement",) if q0 is not None else ("joint_limit_distance",)


def _solve_analytic(robot, solver, p, fallback: bool = True, samples: int = 24, choose=None):
    """Best closed-form branch by the chooser criteria; with ``fallback``, None when no branch is usable.

    Only the chosen branch is turned into a verified :class:`Result` (FK check);
    the others are compared as joint vectors.
    """
    import time

    from kinserve.ik.result import History, Result

    t0 = time.perf_counter()
    tgt = p["target"]
    raw, note, extra = _analytic.raw_branches(robot, solver, tgt, samples)
    if not raw:
        if fallback:
            return None
        q = robot.neutral() if p["q0"] is None else np.clip(p["q0"], robot.lower, robot.upper)
        T = robot.fk(q, tgt.frame)
        pe, re = tgt.errors(T[:3, :3], T[:3, 3])
        return Result(q=q, success=False, position_error=pe, orientation_error=re, method="analytic", frame=tgt.frame,
                      message="no closed-form branch inside the joint limits" + (f"; {note}" if note else ""),
                      history=History.empty(robot.nq, tgt.components), info={"note": note, **extra})
    criteria = choose if choose is not None else _default_criteria(p["q0"])
    exact = [b for b in raw if not b[3]]  # branches that reach the target (no note of their own) come first
    pool = exact or raw
    i = _choose_index(robot, [b[0] for b in pool], criteria, p["q0"], tgt.frame)
    best = _analytic.branch_result(robot, tgt, pool[i], note, extra, p["tol_pos"], p["tol_rot"], t0)
    if not best.success and not pool[i][3]:
        # numerically off (should not happen): choose among the branches that verify
        results = [_analytic.branch_result(robot, tgt, b, note, extra, p["tol_pos"], p["tol_rot"], t0) for b in raw]
        ok = [r for r in results if r.success]
        if ok:
            best = ok[_choose_index(robot, ok, criteria, p["q0"], tgt.frame)]
        elif fallback:
            return None
    best.info["branches"] = len(raw)
    best.elapsed = time.perf_counter() - t0
    return best


def _choose_index(robot, pool, criteria, q0, frame):
    i = choose(robot, pool, criteria, q_current=q0, frame=frame)
    if i is None:  # a filter dropped every branch: rank without the filters
        rest = tuple(c for c in ((criteria,) if isinstance(criteria, str) else criteria) if c != "no_self_overlap")
        i = choose(robot, pool, rest or _default_criteria(q0), q_current=q0, frame=frame)
    return i


def solve_all(robot: Robot, target: PoseLike | Target, q0: VectorLike | None = None, *, frame: str | None = None,
              relax: str | Iterable[str] | None = (), relax_frame: str = "world",
              tol_pos: float = 1e-4, tol_rot: float = 1e-3, samples: int = 24) -> list[Result]:
    """Every closed-form branch for ``target`` (list of :class:`ik.Result`, each verified by FK).

    Planar 4R arms return their one-parameter family sampled at about
    ``samples`` values of the free parameter ``q1`` (both elbow branches;
    ``info["free_parameter"]``); the youBot returns every branch inside the
    joint limits (front / back, elbow up / down). Only branches inside the
    joint limits are returned. Robots without a closed form raise
    :class:`InputError`.
    """
    p = prepare(robot, target, q0, frame=frame, relax=relax, relax_frame=relax_frame, method="analytic",
                tol_pos=tol_pos, tol_rot=tol_rot)
    if isinstance(samples, bool) or not isinstance(samples, numbers.Integral) or samples < 2:
        raise InputError(f"samples must be an integer >= 2, got {samples!r}")
    tgt = p["target"]
    solver = _analytic.closed_form_solver(robot, tgt.frame)
    if solver is None:
        raise InputError(f"no closed-form solver for robot {robot.name!r} and frame {tgt.frame!r}")
    if not solver.supports(tgt.relaxed):
        raise InputError(f"the closed-form solver of {robot.name!r} does not handle relaxing {_names(tgt.relaxed)}")
    return _analytic.branches(robot, solver, tgt, tol_pos=p["tol_pos"], tol_rot=p["tol_rot"], samples=int(samples))
