"""``ik.solve`` and ``ik.solve_all``: validate once, pick a method, return a :class:`Result`.

Methods
-------
``"auto"`` (default) picks the fastest method that can honour the request:

1. spheres or centring  -> ``"qp"`` (hard inequalities / strict priority need the QP);
2. a closed-form solver with finitely many branches exists for the robot and
   frame and handles the relaxed components -> ``"analytic"`` (2R/3R, SCARA,
   youBot; it falls back to ``"lm"`` only when no branch is usable). The
   redundant 4R arm's closed form is a sampled one-parameter family, slower
   to enumerate than one LM solve, so ``"auto"`` uses ``"lm"`` for it (name
   ``"analytic"`` or call :func:`solve_all` to get the family);
3. otherwise -> ``"lm"`` (joint limits are the only inequalities).

``"qp"``, ``"lm"``, ``"analytic"`` and the classical ``"jacobian_inverse"``,
``"jacobian_transpose"``, ``"pseudo_inverse"``, ``"dls"`` can be named
directly (see :mod:`ik.qp_solver`, :mod:`ik.lm_solver`, :mod:`ik.analytic`,
:mod:`ik.classical`).

Validation (once, before any solver runs; errors from :mod:`kinematics.errors`):
the target pose (shape, NaN/inf, rotation orthonormal), ``q0`` (shape,
finite), the frame name, the relaxed component names, tolerances, time
budget, seed, method, backend, centring weights, and the spheres (radius
positive, centre finite, frames known, neither the base nor the start
configuration inside a sphere). Not reaching the target is not an error:
``Result.success`` is False, ``Result.q`` the best configuration found
(inside the limits) and ``Result.message`` the reason.
"""

from __future__ import annotations

import contextlib
import math
import numbers

import numpy as np

from kinserve.kinematics.errors import InputError, KinserveError, NonFiniteError

from . import analytic as _analytic
from .centring import centring_weights
from .chooser import choose
from .classical import METHODS as CLASSICAL_METHODS
from .classical import solve_classical
from .constraints import SphereSet
from .lm_solver import solve_lm
from .qp_backends import available_backends
from .qp_solver import solve_qp
from .targets import Target

METHODS = ("auto", "qp", "lm", "analytic") + CLASSICAL_METHODS
_METHOD_SET = frozenset(METHODS)


def _check_positive(value, name: str, allow_none: bool = False) -> float | None:
    if value is None and allow_none:
        return None
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise InputError(f"{name} must be a positive number, got {value!r}")
    v = float(value)
    if not math.isfinite(v):
        raise NonFiniteError(f"{name} must be finite, got {value!r}")
    if v <= 0:
        raise InputError(f"{name} must be positive, got {value!r}")
    return v


def _check_robot(robot):
    if not (hasattr(robot, "model") and hasattr(robot, "frame_id") and hasattr(robot, "nq")):
        raise InputError(f"robot must be a kinserve.kinematics.Robot (e.g. robots.load('panda')), got {type(robot).__name__}")


def _check_seed(seed):
    if seed is None:
        return None
    if isinstance(seed, bool) or not isinstance(seed, numbers.Integral) or seed < 0:
        raise InputError(f"seed must be a non-negative integer or None, got {seed!r}")
    return int(seed)


def _check_backend(backend):
    if backend == "osqp":
        return backend
    if not isinstance(backend, str) or backend.lower() not in available_backends():
        raise InputError(f"backend must be one of the installed QP solvers {available_backends()}, got {backend!r}")
    return backend.lower()


@contextlib.contextmanager
def _argument(name: str):
    """Tag a :class:`KinserveError` raised inside with the argument it concerns (``exc.argument``)."""
    try:
        yield
    except KinserveError as exc:
        if exc.argument is None:
            exc.argument = name
        raise


def prepare(robot, target, q0=None, *, frame=None, relax=(), relax_frame="world", spheres=(), centring=0.0,
            method="auto", backend="osqp", tol_pos=1e-4, tol_rot=1e-3, max_time=None, seed=None):
    """Validate every argument of :func:`solve`; return a dict of checked values.

    Exposed so that batch solving (:mod:`ik.batch`) validates each target once
    in the parent process.
    """
    _check_robot(robot)
    if method not in _METHOD_SET:
        raise InputError(f"method must be one of {METHODS}, got {method!r}")
    tgt = target if isinstance(target, Target) else Target(robot, target, frame, relax, relax_frame)
    if q0 is not None:
        with _argument("q0"):
            q0 = robot.check_q(q0, "q0")
    if tol_pos != 1e-4:
        tol_pos = _check_positive(tol_pos, "tol_pos")
    if tol_rot != 1e-3:
        tol_rot = _check_positive(tol_rot, "tol_rot")
    if max_time is not None:
        max_time = _check_positive(max_time, "max_time")
    seed = _check_seed(seed)
    backend = _check_backend(backend)
    weights = centring_weights(robot, centring)
    with _argument("spheres"):
        sphere_set = _sphere_set(robot, spheres, tgt.frame, q0)
    if method in ("lm", "analytic", "jacobian_inverse", "jacobian_transpose") and weights is not None:
        raise InputError(f"method {method!r} cannot honour centring; use 'qp' (or 'pseudo_inverse' / 'dls')")
    if method in ("lm", "analytic") + CLASSICAL_METHODS and sphere_set is not None:
        raise InputError(f"method {method!r} cannot honour sphere constraints; use 'qp' or 'auto'")
    return dict(target=tgt, q0=q0, tol_pos=tol_pos, tol_rot=tol_rot, max_time=max_time, seed=seed,
                backend=backend, weights=weights, spheres=sphere_set, method=method)


def _sphere_set(robot, spheres, frame: str, q0):
    """The :class:`SphereSet` of ``spheres`` (None when there are none), checked against the start.

    The solvers start from ``q0`` clipped into the joint limits, so that is the
    configuration that must lie outside every sphere.
    """
    if spheres is None or (type(spheres) is tuple and not spheres):
        return None
    if isinstance(spheres, (str, bytes)):
        raise InputError(f"spheres must be a sequence of ik.Sphere, got {spheres!r}")
    try:
        spheres = list(spheres)
    except TypeError:
        spheres = [spheres]
    if not spheres:
        return None
    sphere_set = SphereSet(robot, spheres, frame)
    if q0 is not None:
        start = np.clip(q0, robot.lower, robot.upper)
        clear = sphere_set.clearances_at(start)
        if clear.size and clear.min() < 0:
            clipped = "" if np.array_equal(start, q0) else " (q0 clipped into the joint limits, where the solver starts)"
            raise InputError(
                f"a sphere already contains the start configuration q0{clipped}: {sphere_set.describe_violation(clear)}"
            )
    return sphere_set


def solve(
    robot,
    target,
    q0=None,
    *,
    frame: str | None = None,
    relax=(),
    relax_frame: str = "world",
    spheres=(),
    centring=0.0,
    method: str = "auto",
    backend: str = "osqp",
    tol_pos: float = 1e-4,
    tol_rot: float = 1e-3,
    max_time: float | None = None,
    seed: int | None = None,
    **options,
):
    """Inverse kinematics: a configuration placing ``frame`` at ``target``.

    Parameters
    ----------
    robot:
        A :class:`kinserve.kinematics.Robot`.
    target:
        4x4 homogeneous pose (or ``pinocchio.SE3``) of ``frame`` in the world.
    q0:
        Start / current configuration (``nq`` values; clipped into the joint
        limits if outside). The iterative solvers try ``q0`` and the nearest
        samples of a precomputed table of configurations (:mod:`ik.seeds`) in
        order of their pose distance to the target; pass ``prefer_q0=True`` to
        always start from ``q0``. The classical methods start from ``q0``
        (default: the neutral configuration); the closed forms use it to pick
        the branch nearest to it.
    frame:
        The frame to place (default ``robot.tip``).
    relax:
        Components left free, any of ``x y z roll pitch yaw`` (``phi`` =
        ``yaw``); position-only IK is ``relax=("roll", "pitch", "yaw")``.
        Relaxed components are expressed in the **world** frame by default
        (``relax_frame="world"``: relaxing ``z`` frees the height, ``yaw`` the
        rotation about the world vertical); ``relax_frame="target"`` measures
        them along the target frame's own axes. See :mod:`ik.targets`.
    spheres:
        :class:`ik.Sphere` obstacles: hard constraints on every iterate (QP).
    centring:
        Weight(s) of the secondary objective pulling joints to mid-range, in
        the task's null space only (strict priority; 0 = off). See :mod:`ik.centring`.
    method:
        ``"auto"``, ``"qp"``, ``"lm"``, ``"analytic"``, ``"jacobian_inverse"``,
        ``"jacobian_transpose"``, ``"pseudo_inverse"``, ``"dls"``.
    backend:
        QP solver of ``"qp"``: ``"osqp"`` (default), ``"daqp"``, ``"proxqp"``, ``"quadprog"``.
    tol_pos, tol_rot:
        Success thresholds on the position (m) and orientation (rad) errors of the kept components.
    max_time:
        Time budget (s) for restarts (default 0.1 s for ``lm``, 0.5 s for ``qp``).
    seed:
        Seed of the random restarts (None = 0): the same seed gives the same answer.
    options:
        Method-specific: ``max_iter``, ``damping`` (``lm``/``qp``; DLS ``lambda``
        for ``"dls"``), ``gain`` (classical), ``max_step`` and ``shortcut``
        (``qp``: False calls the QP solver at every step), ``max_starts``
        (``lm``/``qp``), ``prefer_q0``, ``seed_table`` (False disables the
        table of starts), ``samples`` (4R family), ``choose`` (chooser
        criteria for ``"analytic"``).

    Returns
    -------
    :class:`ik.Result`
    """
    p = prepare(robot, target, q0, frame=frame, relax=relax, relax_frame=relax_frame, spheres=spheres,
                centring=centring, method=method, backend=backend, tol_pos=tol_pos, tol_rot=tol_rot,
                max_time=max_time, seed=seed)
    return solve_prepared(robot, p, **options)


_LM_OPTIONS = ("max_iter", "damping", "max_starts", "prefer_q0", "seed_table")
_QP_OPTIONS = _LM_OPTIONS + ("max_step", "shortcut")
_CLASSICAL_OPTIONS = ("gain", "damping", "max_iter")
_ANALYTIC_OPTIONS = ("samples", "choose")
_AUTO_OPTIONS = tuple(dict.fromkeys(_QP_OPTIONS + _ANALYTIC_OPTIONS))


def _check_options(method, options, allowed):
    if not options:
        return
    bad = [k for k in options if k not in allowed]
    if bad:
        raise InputError(f"unknown option(s) {bad} for method {method!r}; accepted: {', '.join(allowed) or 'none'}")


def solve_prepared(robot, p: dict, **options):
    """Run the solver on arguments already checked by :func:`prepare`."""
    method = p["method"]
    tgt = p["target"]
    if method == "auto":
        _check_options("auto", options, _AUTO_OPTIONS)
        if p["spheres"] is not None or p["weights"] is not None:
            method = "qp"
        else:
            solver = _analytic.closed_form_solver(robot, tgt.frame)
            # closed forms with finitely many branches; a sampled family (4R) is slower than LM in Python
            if solver is not None and solver.finite and solver.supports(tgt.relaxed):
                res = _solve_analytic(robot, solver, p, **{k: v for k, v in options.items() if k in _ANALYTIC_OPTIONS})
                if res is not None:
                    return res
            method = "lm"
        if options:
            options = {k: v for k, v in options.items() if k in (_QP_OPTIONS if method == "qp" else _LM_OPTIONS)}
    if method == "lm":
        _check_options(method, options, _LM_OPTIONS)
        opts = options
        if "seed_table" in opts:
            opts = dict(options)
            opts["seed_table_enabled"] = bool(opts.pop("seed_table"))
        return solve_lm(robot, tgt, p["q0"], tol_pos=p["tol_pos"], tol_rot=p["tol_rot"], max_time=p["max_time"],
                        seed=p["seed"], **opts)
    if method == "qp":
        _check_options(method, options, _QP_OPTIONS)
        opts = dict(options)
        if "seed_table" in opts:
            opts["seed_table_enabled"] = bool(opts.pop("seed_table"))
        return solve_qp(robot, tgt, p["q0"], spheres=p["spheres"], weights=p["weights"], backend=p["backend"],
                        tol_pos=p["tol_pos"], tol_rot=p["tol_rot"], max_time=p["max_time"], seed=p["seed"], **opts)
    if method == "analytic":
        _check_options(method, options, _ANALYTIC_OPTIONS)
        solver = _analytic.closed_form_solver(robot, tgt.frame)
        if solver is None:
            raise InputError(f"no closed-form solver for robot {robot.name!r} and frame {tgt.frame!r}; use 'auto', 'lm' or 'qp'")
        if not solver.supports(tgt.relaxed):
            raise InputError(
                f"the closed-form solver of {robot.name!r} does not handle relaxing {_names(tgt.relaxed)}; use 'lm' or 'qp'"
            )
        res = _solve_analytic(robot, solver, p, fallback=False, **options)
        return res
    _check_options(method, options, _CLASSICAL_OPTIONS)
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

    from .result import History, Result

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
    i = _choose_index(robot, [b[0] for b in raw], criteria, p["q0"], tgt.frame)
    best = _analytic.branch_result(robot, tgt, raw[i], note, extra, p["tol_pos"], p["tol_rot"], t0)
    if not best.success and not note:
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


def solve_all(robot, target, q0=None, *, frame: str | None = None, relax=(), relax_frame: str = "world",
              tol_pos: float = 1e-4, tol_rot: float = 1e-3, samples: int = 24):
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
