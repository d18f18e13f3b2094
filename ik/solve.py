"""``ik.solve`` and ``ik.solve_all``: one request, one plan, one strategy.

``ik.solve`` validates its arguments once into an immutable :class:`~kinserve.ik.request.SolveRequest`
(:mod:`kinserve.ik.request`, which also warms the robot's IK state outside the time budget), picks the
strategy from the table of :mod:`kinserve.ik.plan`, and runs it (:mod:`kinserve.ik.strategies`).
``ik.solve_many`` builds one request and runs every target through :func:`run`.

Validation errors come from :mod:`kinserve.kinematics.errors` and name the argument. Not reaching the target
is not an error: ``Result.success`` is False, ``Result.q`` the best configuration found (inside the limits)
and ``Result.message`` the reason.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any

from kinserve.ik.options import MAX_SAMPLES
from kinserve.ik.plan import choose_strategy
from kinserve.ik.request import (
    SolveRequest,
    pose_request,
    target_request,
    task_request,
)
from kinserve.ik.result import Result
from kinserve.ik.state import closed_form_solver
from kinserve.ik.strategies.closed_form import relaxed_names
from kinserve.ik.targets import Target
from kinserve.kinematics.errors import InputError
from kinserve.kinematics.robot import Robot
from kinserve.kinematics.types import PoseLike, VectorLike
from kinserve.kinematics.validation import as_count


def _is_zero(value: Any) -> bool:
    """True for a plain ``0`` / ``0.0`` (the defaults of the fast routes); anything else, arrays included,
    goes to the path that validates it."""
    return type(value) in (float, int) and value == 0


def run(req: SolveRequest) -> Result:
    """Solve a validated request: the strategy of :func:`kinserve.ik.plan.choose_strategy`."""
    return choose_strategy(req).run(req)


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
        Time budget (s) of the whole solve (default 0.1 s when LM alone answers, 0.5 s when the QP may
        run: :data:`kinserve.ik.options.MAX_TIME_LM` / ``MAX_TIME_QP``). One-time set-up (seed tables,
        collision models, compiled kernels) is done before the clock starts. With the option
        ``iteration_budget`` and no ``max_time`` the clock is never read: the answer depends only on the
        inputs and the seed.
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
        See :mod:`kinserve.ik.strategies.checked`. (``constraints=[ik.SceneCollision(obstacles)]``
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

    Raises
    ------
    :class:`~kinserve.kinematics.errors.InputError` (or a subclass), naming the argument, before any solve
    starts: a malformed pose or ``q0``, an unknown frame / method / backend / option, ``tol_pos``,
    ``tol_rot`` or ``max_time`` that is not a finite number in ``(0, 1e6]``, ``link_radius`` or
    ``centring`` that is not finite in ``[0, 1e6]``, ``collision_margin`` outside ``[0, 1000]`` m, a
    ``seed`` that is not an integer in ``[0, 2**64 - 1]``, option counts above their bounds
    (:mod:`kinserve.ik.options`), arrays where a number or a flag is expected.
    """
    if tasks is not None:
        if target is not None:
            raise InputError("give either a target pose or tasks=[...], not both "
                             "(add a FrameTask to the tasks)")
        return run(task_request(robot, tasks, constraints, q0, method=method, backend=backend,
                                tol_pos=tol_pos, tol_rot=tol_rot, max_time=max_time, seed=seed,
                                options=options))
    if target is None:
        raise InputError("target (a 4x4 pose of the frame) is required, or tasks=[...]")
    if type(spheres) is tuple and not spheres and type(obstacles) is tuple and not obstacles \
            and _is_zero(link_radius) and type(centring) is float and centring == 0.0 and backend is None \
            and constraints is None and self_collision is False and _is_zero(collision_margin):
        req = pose_request(robot, target, q0, frame, relax, relax_frame, method, tol_pos, tol_rot, max_time,
                           seed, options)
    elif (self_collision is True or (type(collision_margin) is float and collision_margin > 0.0)) \
            and type(self_collision) is bool and type(centring) is float and centring == 0.0 \
            and _is_zero(link_radius) and backend is None and constraints is None:  # (common collision call)
        req = pose_request(robot, target, q0, frame, relax, relax_frame, method, tol_pos, tol_rot, max_time,
                           seed, options, (self_collision, obstacles, collision_margin, spheres))
    else:
        req = target_request(robot, target, q0, frame=frame, relax=relax, relax_frame=relax_frame,
                             spheres=spheres, obstacles=obstacles, link_radius=link_radius, centring=centring,
                             method=method, backend=backend, tol_pos=tol_pos, tol_rot=tol_rot,
                             max_time=max_time, seed=seed, constraints=constraints,
                             self_collision=self_collision, collision_margin=collision_margin,
                             options=options)
    return choose_strategy(req).run(req)  # (run's body: one call less on every solve)


def solve_all(robot: Robot, target: PoseLike | Target, q0: VectorLike | None = None, *,
              frame: str | None = None, relax: str | Iterable[str] | None = (), relax_frame: str = "world",
              tol_pos: float = 1e-4, tol_rot: float = 1e-3, samples: int = 24) -> list[Result]:
    """Every closed-form branch for ``target`` (list of :class:`ik.Result`, each verified by FK).

    Planar 4R arms return their one-parameter family sampled at about
    ``samples`` values of the free parameter ``q1`` (both elbow branches;
    ``info["free_parameter"]``); the youBot returns every branch inside the
    joint limits (front / back, elbow up / down). Only branches inside the
    joint limits are returned. Robots without a closed form raise
    :class:`InputError`.

    Refused (:class:`InputError`, before any work): ``samples`` that is not an integer from 2 to
    :data:`~kinserve.ik.options.MAX_SAMPLES` (10**4; each sample is two branches built and verified),
    ``tol_pos`` / ``tol_rot`` that are not finite numbers in ``(0, 1e6]``, and every invalid pose, frame
    or ``q0`` as in :func:`solve`.
    """
    from kinserve.ik.closed_form import branches

    req = pose_request(robot, target, q0, frame, relax, relax_frame, "analytic", tol_pos, tol_rot)
    samples = as_count(samples, "samples", 2, MAX_SAMPLES)
    tgt = req.target
    solver = closed_form_solver(robot, tgt.frame)
    if solver is None:
        raise InputError(f"no closed-form solver for robot {robot.name!r} and frame {tgt.frame!r}")
    if not solver.supports(tgt.relaxed):
        raise InputError(f"the closed-form solver of {robot.name!r} does not handle relaxing "
                         f"{relaxed_names(tgt.relaxed)}")
    return branches(robot, solver, tgt, tol_pos=req.tol_pos, tol_rot=req.tol_rot, samples=samples)
