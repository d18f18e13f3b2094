"""Collision-free IK: ``ik.solve(robot, target, self_collision=True, obstacles=[...])``.

Strategy (the cheap path first, as roboplan's ``SimpleIk`` does):

1. **Unconstrained solves, then check** (half the time budget at most). With
   LM, the ordinary solve exactly as ``ik.solve`` runs it without collision
   options (``q0``, the table's samples nearest the target pose, then random
   configurations), each converged run accepted only when its answer and every
   iterate pass the collision check
   (:meth:`kinserve.kinematics.collision_scene.CollisionScene.first_collision`,
   one compiled call over the stacked run): a run that collides is followed by
   the next start, a start in collision is skipped for one check (the first
   :data:`UNCERTIFIED_SKIPS` starts the sphere pre-check cannot certify free are
   skipped without coal's verdict), at most 1 + :data:`UNCONSTRAINED_ATTEMPTS` starts.
   With a closed form or QP, the ordinary solve, then up to
   :data:`UNCONSTRAINED_ATTEMPTS` solves from one start each, in the same order,
   the starts in collision skipped. In an open scene the first run is almost
   always enough; with an obstacle in the way another start often finds another
   branch.
2. **Infeasible at once**: a target position inside an obstacle, for a frame
   whose origin lies inside the robot's own collision geometry, cannot be
   reached: ``Result(success=False)`` with the reason, no constrained solve.
3. **Constrained solve**: otherwise (warm-started from the last collision-free
   iterate of the first run that failed the check) the QP method with
   :class:`~kinserve.ik.constraints.collision.CollisionConstraint` rows (velocity
   dampers from witness points and normals, hard on every iterate, the step
   halved until the true check holds), restarting only from collision-free
   starts (``q0``, then the table of starts, then random ones) until the rest of
   the budget is spent.

``spheres`` given together with collision options join the obstacles (checked
against the collision geometry, not the link capsules). A robot without
collision geometry keeps obstacles clear of its link capsules
(:class:`ik.ObstacleAvoidance`, the ``obstacles=`` path without
``self_collision``); ``self_collision=True`` then raises
:class:`~kinserve.kinematics.errors.ModelError` with the reason.

``Result.info["collision"]`` says which path produced the answer:
``"unconstrained, checked"`` or ``"constrained"``.

The bound collision constraint of an obstacle set is cached per thread by the
obstacles' identities; a new set whose shapes match a set bound before (the same
box moved) is bound by moving that one
(:meth:`~kinserve.ik.constraints.collision.CollisionConstraint.moved`, ~10 us on
the Panda).
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING, Any

import coal
import numpy as np

from kinserve.kinematics.collision_layout import shape_signature
from kinserve.kinematics.collision_queries import as_obstacles
from kinserve.kinematics.errors import InputError, ModelError
from kinserve.kinematics.robot import Robot

from kinserve.ik import closed_form as analytic
from kinserve.ik import numpy_fast
from kinserve.ik.constraints.collision import CollisionConstraint, _length
from kinserve.ik.lm.solver import ADMIT_MISSES, solve_lm
from kinserve.ik.starts.multistart import frame_starts
from kinserve.ik.options import check_options, solver_keywords
from kinserve.ik.qp.target_solver import solve_qp
from kinserve.ik.starts.seed_table import seed_table, start_sequence
from kinserve.ik.result import History, Result

if TYPE_CHECKING:  # annotations only
    from kinserve.ik.targets import Target

_clip = numpy_fast.clip
_now = time.perf_counter
_CHECKED = "; collision free (unconstrained answer and iterates checked)"
_QP_KEYS = ("max_iter", "damping", "max_starts", "prefer_q0", "seed_table", "max_step", "shortcut", "lazy")
_LM_KEYS = ("max_iter", "damping", "max_starts", "prefer_q0", "seed_table")
#: Time budget (s) when the caller gives none (as the constrained ``"qp"`` method).
MAX_TIME = 0.5
#: Unconstrained runs (each checked) before the constrained one. Measured on the Panda with a 10 cm cube on the
#: first answer's elbow (100 targets, two seeds): 8 runs left 5-6 % of the targets to the constrained solve
#: (3-10 ms each), 12 runs 3 % (mean 1.1 -> 0.8 ms, median slightly lower), 16 runs no fewer.
UNCONSTRAINED_ATTEMPTS = 12


def collision_options(self_collision: bool = False, obstacles: Sequence = (), collision_margin: float = 0.0,
                      spheres: Sequence = ()) -> dict:
    """Validated collision options for :func:`solve_collision_free` (``spheres`` join the obstacles).

    The options of a list or tuple of shapes (immutable) with the flags as plain ``bool`` / ``float`` are
    remembered per thread by the shapes' identities (the entry holds them alive): a request repeated with the
    same obstacle objects - a work cell - is one lookup. The dictionary returned is shared: read it, never
    change it.
    """
    plain = (type(obstacles) is list or type(obstacles) is tuple) and type(spheres) is tuple and not spheres \
        and type(self_collision) is bool and type(collision_margin) is float
    if plain:
        memo = getattr(_OPTIONS, "memo", None)
        if memo is None:
            memo = _OPTIONS.memo = {}
        key = (self_collision, collision_margin, *map(id, obstacles))
        hit = memo.get(key)
        if hit is not None:  # equal ids: the very objects the entry holds
            return hit
    options = _collision_options(self_collision, obstacles, collision_margin, spheres)
    held = options["obstacles"]
    if plain and len(held) == len(obstacles) and all(o is h for o, h in zip(obstacles, held)):  # the caller's shapes
        if len(memo) >= _BOUND_CACHE_SIZE:
            memo.clear()
        memo[key] = options
    return options


#: This thread's validated collision options (:func:`collision_options`), by the obstacles' identities.
_OPTIONS = threading.local()


def _collision_options(self_collision: bool, obstacles: Sequence, collision_margin: float, spheres: Sequence) -> dict:
    """:func:`collision_options` without the memo."""
    obs = as_obstacles(obstacles)
    if spheres is not None and (type(spheres) is not tuple or spheres):
        obs += as_obstacles(spheres, "spheres")
    if not isinstance(self_collision, (bool, np.bool_)):
        raise InputError(f"self_collision must be True or False, got {self_collision!r}")
    # the check CollisionConstraint makes (the default 0.0 needs none)
    margin = 0.0 if type(collision_margin) is float and collision_margin == 0.0 else _length(collision_margin,
                                                                                             "collision margin")
    return {"self_collision": bool(self_collision), "obstacles": obs, "collision_margin": margin}


def ordinary_solve_checked(robot: Robot, tgt: Target, q0: np.ndarray | None, tol_pos: float, tol_rot: float,
                           max_time: float | None, seed: int | None, lm_options: dict, collision: dict) -> tuple:
    """The unconstrained attempts of a plain LM solve (:func:`_checked_lm_solve`) without the general set-up of
    :func:`solve_collision_free`. Arguments are checked (``ik.solve``'s short path); ``collision``: the
    options of :func:`collision_options`.

    Returns ``(result, handover, t0)``: the collision-free result, or None with ``handover`` =
    ``{"failed_path": the warm start's source (or None), "t0": t0}`` to pass on in ``p`` to
    :func:`solve_collision_free`, which then goes on to the constrained solve; ``handover`` is None when the
    robot has no collision model (the general path falls back to the link capsules).
    """
    t0 = _now()
    constraint = _request_constraint(robot, collision)
    if constraint is None:
        return None, None, t0
    res, failed = _checked_lm_solve(robot, tgt, q0, tol_pos, tol_rot, 0.5 * (MAX_TIME if max_time is None else max_time),
                                    seed, lm_options, constraint)
    if res is not None:
        res.elapsed = _now() - t0
        return res, None, t0
    return None, {"failed_path": failed, "t0": t0}, t0


def _request_constraint(robot: Robot, collision: dict) -> CollisionConstraint | None:
    """:func:`_bound_constraint` of the options ``collision`` on ``robot`` (None when the robot has no
    collision model), remembered per thread by the identities of the two - :func:`collision_options`
    returns the same dictionary for the same obstacle objects, so a repeated request is one lookup (the entry
    holds both objects: their identities stay theirs)."""
    memo = getattr(_BOUND, "requests", None)
    if memo is None:
        memo = _BOUND.requests = {}
    key = (id(robot), id(collision))
    hit = memo.get(key)
    if hit is not None:
        return hit[2]
    try:
        bound = _bound_constraint(robot, collision["obstacles"], collision["self_collision"],
                                  collision["collision_margin"])
    except ModelError:
        return None
    if len(memo) >= _BOUND_CACHE_SIZE:
        memo.clear()
    memo[key] = (robot, collision, bound)
    return bound


def _checked_lm_solve(robot: Robot, tgt: Target, q0: np.ndarray | None, tol_pos: float, tol_rot: float,
                      max_time: float, seed: int | None, lm_options: dict, constraint: CollisionConstraint) -> tuple:
    """The unconstrained attempts with LM, as one call of the ordinary solver: its starts (``q0``, the table's
    nearest samples, then random ones; ``max_time`` and 1 + :data:`UNCONSTRAINED_ATTEMPTS` starts at most),
    each converged run accepted only when its answer and every iterate are collision free
    (``solve_lm(accept=...)``: the sphere pre-check over the stacked run, then the scene's check from the
    first row it cannot certify), so a run whose answer or path collides is followed by the next start at
    once; a start in collision is skipped for one check (``admit``).

    ``lm_options``: the solver's keywords (``max_iter``, ``damping``, ``max_starts``, ``prefer_q0``,
    ``seed_table_enabled``). Returns ``(result, failed)``: the checked collision-free result, or None and the
    configurations of the first run that collided (else the returned run's; the constrained solve's warm start
    comes from them), None when no attempt ran (:data:`UNCONSTRAINED_ATTEMPTS` = 0).
    """
    if UNCONSTRAINED_ATTEMPTS <= 0:  # no unconstrained solve at all: the constrained one from the usual starts
        return None, None
    rejected: list = []
    chosen = _clip(q0, robot.lower, robot.upper) if q0 is not None and lm_options and lm_options.get("prefer_q0") \
        else None
    parts = _check_parts(constraint)
    admit = _start_admission(constraint, chosen, _certified_table_starts(robot, constraint, tgt.frame), parts)
    if len(parts) == 1:
        first_collision = constraint.first_collision

        def accept(qs) -> bool:
            # the run's configurations, start first: the answer, then the others last first, down to the one
            # after the start (``admit`` found the start clear)
            if first_collision(qs[:0:-1]) < 0:
                return True
            if not rejected:
                rejected.append(qs)
            return False
    else:
        _, _, first, floats, ints, tol = parts
        scene_first = constraint.scene.first_collision  # margin 0: the constraint's check is the scene's

        def accept(qs) -> bool:  # as above; the sphere pre-check called directly, coal only when it cannot certify
            rows = qs[:0:-1]
            k = first(floats, ints, rows, 0, tol)  # the rows before k are certified free
            if k >= rows.shape[0] or scene_first(rows, k) < 0:
                return True
            if not rejected:
                rejected.append(qs)
            return False

    cap = 1 + UNCONSTRAINED_ATTEMPTS
    if not lm_options:  # the common call: no keyword dictionary to build
        res = solve_lm(robot, tgt, q0, tol_pos=tol_pos, tol_rot=tol_rot, max_time=max_time, seed=seed,
                       accept=accept, admit=admit, max_starts=cap)
    else:
        starts = lm_options.get("max_starts")
        res = solve_lm(robot, tgt, q0, tol_pos=tol_pos, tol_rot=tol_rot, max_time=max_time, seed=seed,
                       accept=accept, admit=admit,
                       **{**lm_options, "max_starts": cap if starts is None else min(int(starts), cap)})
    if res.success:
        return _checked(res, 1 + res.restarts), None
    return None, rejected[0] if rejected else (res.history.iterates() if res.history is not None else None)


#: Starts the sphere pre-check cannot certify free that one solve skips without asking coal (see
#: :func:`_start_admission`). Measured on the Panda with a 10 cm cube on the first answer's elbow (two sets of
#: 100 and 200 targets): coal finds about three quarters of those starts in collision; skipping the first 2
#: without coal took the median solve from 194 to 173 us (CPU) and sent no more targets to the constrained
#: solve (3 and 8 in both); skipping 4 sent 2 more of the 100 there (the start skipped was the one that led
#: to a clear path).
UNCERTIFIED_SKIPS = 2


#: Solves of one frame on one bound obstacle set after which the starts of the frame's seed table are
#: certified once, in one compiled call (:func:`_certified_table_starts`; ~2 ms for the Panda's 3000 samples).
TABLE_CERTIFY_AFTER = 8


def _certified_table_starts(robot: Robot, constraint: CollisionConstraint, frame: str) -> frozenset | None:
    """The byte strings of the seed-table samples of ``frame`` (:func:`kinserve.ik.starts.seed_table.seed_table`, both sets)
    that the sphere pre-check certifies free in the constraint's scene, or None.

    Built on the constraint's :data:`TABLE_CERTIFY_AFTER`-th solve for the frame (a scene that keeps serving
    solves - a work cell - then admits its table starts by one set lookup instead of a compiled check); None
    before, and for a constraint with a margin or without a pre-check.
    """
    memo = constraint.__dict__.get("_table_starts")
    if memo is None:
        memo = constraint._table_starts = {}
    entry = memo.get(frame, 0)
    if type(entry) is int:
        if entry < TABLE_CERTIFY_AFTER or constraint.clearance != 0.0:
            memo[frame] = entry + 1
            return None
        pre = constraint.scene.precheck()
        if pre is None:
            memo[frame] = entry + 1
            return None
        from kinserve.kinematics.collision_spheres import certify_configurations

        table = seed_table(robot, frame)
        Q = np.concatenate([table.Q, table.Q_full])
        entry = memo[frame] = frozenset(q.tobytes() for q in Q[certify_configurations(pre[2], pre[3], Q, pre[4])])
    return entry


def _check_parts(constraint: CollisionConstraint) -> tuple:
    """What every checked solve on ``constraint`` needs, taken once (kept on the constraint):
    ``(in_collision,)``, or with the sphere pre-check (margin 0) ``(in_collision, certify, first_uncertified,
    floats, ints, tolerance)`` (:meth:`~kinserve.kinematics.collision_spheres.ScenePrecheck.arguments`)."""
    parts = constraint.__dict__.get("_admission")
    if parts is None:
        pre = constraint.scene.precheck() if constraint.clearance == 0.0 else None
        parts = constraint._admission = (constraint.in_collision,) + (() if pre is None else pre[:5])
    return parts


def _start_admission(constraint: CollisionConstraint, q0: np.ndarray | None = None,
                     certified: frozenset | None = None, parts: tuple | None = None) -> Callable[[np.ndarray], bool]:
    """``admit(q)`` of the checked LM solve: True when start ``q`` may run.

    A start the sphere pre-check certifies free runs at once (~1.4 us; a seed-table sample of ``certified``,
    :func:`_certified_table_starts`, without the check). One it cannot certify is within
    a few centimetres of an obstacle or of the arm itself, or in collision: a poor start whatever coal
    says (its path tends to brush what is near), so the first :data:`UNCERTIFIED_SKIPS` of them are
    skipped without coal's check (~5-10 us each near contact); after that - a cramped scene, or covers
    that can never certify a pair - coal decides every start, as it always does without a pre-check and
    for the caller's ``q0`` given with ``prefer_q0`` (``q0``, clipped: that start is the caller's choice).
    ``parts``: :func:`_check_parts` of ``constraint`` when the caller has them.
    """
    if parts is None:
        parts = _check_parts(constraint)
    in_collision = parts[0]
    if len(parts) == 1:
        return lambda q: not in_collision(q)
    _, certify, _, floats, ints, tol = parts
    chosen = None if q0 is None else q0.tolist()
    skips = [0]
    known = _NOTHING if certified is None else certified

    def admit(q: np.ndarray) -> bool:
        if q.tobytes() in known or certify(floats, ints, q, tol):
            return True
        if skips[0] < UNCERTIFIED_SKIPS and (chosen is None or q.tolist() != chosen):
            skips[0] += 1
            return False
        return not in_collision(q)

    return admit


_NOTHING: frozenset = frozenset()


def solve_collision_free(robot: Robot, p: dict, solve_prepared: Callable[..., Result], *, self_collision: bool = False,
                         obstacles: Sequence = (), collision_margin: float = 0.0, **solver_opts: Any) -> Result:
    """Collision-free IK on arguments checked by :func:`ik.solve.prepare` (``p``); see the module docstring.

    ``solve_prepared`` is :func:`ik.solve.solve_prepared` (the solver without the collision layer), passed in
    by the caller so that this module does not import :mod:`ik.solve` (no import circle). ``p`` may carry
    ``failed_path`` (the unconstrained attempts already ran in :func:`ordinary_solve_checked`; the
    configurations the warm start comes from) and ``t0`` (when the solve started: the time budget counts
    from there).
    """
    t0 = p.get("t0") or time.perf_counter()
    obs = as_obstacles(obstacles)
    if p["spheres"] is not None:
        raise InputError("spheres cannot be combined with self_collision / obstacles in a prepared solve; "
                         "pass them in obstacles=")
    try:
        robot.collision
    except ModelError as exc:
        if not self_collision and obs:
            from kinserve.ik.constraints.obstacles import ObstacleAvoidance

            avoid = ObstacleAvoidance(list(obs), tool_frames=(p["target"].frame,))
            return solve_prepared(robot, dict(p, spheres=avoid), **solver_opts)
        raise ModelError(f"{exc}; ik.solve(self_collision=True) needs it (obstacles alone fall back to the "
                         "link capsules of ik.ObstacleAvoidance)") from None
    constraint = _bound_constraint(robot, obs, self_collision, collision_margin)
    budget = MAX_TIME if p["max_time"] is None else p["max_time"]
    tgt = p["target"]

    if p["weights"] is None or p["method"] != "qp":
        found, warm = _unconstrained_attempts(robot, p, solve_prepared, constraint, t0 + 0.5 * budget, solver_opts)
        if found is not None:
            found.elapsed = time.perf_counter() - t0
            return found
    else:
        warm = None

    blocked = _target_inside_obstacle(robot, constraint, tgt)
    if blocked:
        return _failure(robot, tgt, p["q0"], t0, blocked)

    remaining = max(budget - (time.perf_counter() - t0), 1e-3)
    opts = solver_keywords({k: v for k, v in solver_opts.items() if k in _QP_KEYS})
    q_start = p["q0"]
    if warm is not None and "prefer_q0" not in opts:  # the last collision-free iterate of the first attempt
        q_start, opts["prefer_q0"] = warm, True
    res = solve_qp(robot, tgt, q_start, spheres=[constraint], weights=p["weights"], backend=p["backend"],
                   tol_pos=p["tol_pos"], tol_rot=p["tol_rot"], max_time=remaining, seed=p["seed"], **opts)
    res.info["collision"] = "constrained"
    if res.message.startswith("no start configuration outside the spheres"):
        res.message = "no collision-free start configuration was found within the time budget"
    res.elapsed = time.perf_counter() - t0
    return res


#: This thread's bound constraints, per (scene, margin): a scene is cached per obstacle set, so is its constraint.
_BOUND = threading.local()
_BOUND_CACHE_SIZE = 16


def _bound_constraint(robot: Robot, obs: tuple, self_collision: bool, margin: float) -> CollisionConstraint:
    """The :class:`CollisionConstraint` of ``obs`` bound to ``robot``, reused by later solves on this thread.

    Its only state besides the scene is a memo keyed by the configuration's bytes, so reuse is exact;
    per thread because that memo is written while solving. Keyed by the identities of the robot and the
    obstacle objects (no scene lookup): the cached constraint keeps them alive, so no other object can
    carry those ids.
    """
    cache = getattr(_BOUND, "cache", None)
    if cache is None:
        cache = _BOUND.cache = {}
    key = (id(robot), self_collision is True or bool(self_collision), float(margin), *map(id, obs))
    hit = cache.get(key)
    if hit is not None:  # it holds the robot and these obstacles alive: equal ids are the very same objects
        return hit
    # obstacles shaped like those of a constraint bound before (the same layout, other poses): that one moved
    layouts = getattr(_BOUND, "layouts", None)
    if layouts is None:
        layouts = _BOUND.layouts = {}
    shape_key = (key[0], key[1], key[2], *map(shape_signature, obs))
    template = layouts.get(shape_key)
    if template is not None and template.robot is robot:
        bound = template.moved(obs)
    else:
        bound = CollisionConstraint(obs, self_collision=self_collision, margin=margin).bind(robot)
        if len(layouts) >= _BOUND_CACHE_SIZE:
            layouts.clear()
        layouts[shape_key] = bound
    if bound.clearance == 0.0:
        bound.scene.precheck()  # the compiled sphere pre-check built now, not inside the first solve's budget
    if len(cache) >= _BOUND_CACHE_SIZE:
        cache.clear()
    cache[key] = bound
    return bound


def _unconstrained_attempts(robot, p: dict, solve_prepared: Callable[..., Result], constraint: CollisionConstraint,
                            deadline: float, solver_opts: dict):
    """The cheap path: up to :data:`UNCONSTRAINED_ATTEMPTS` unconstrained solves (or the ``max_starts`` option),
    each answer checked.

    With LM: :func:`_checked_lm_solve` (the ordinary solve, its restarts taking the place of the attempts).
    With a closed form (no starts, no iterates) the first attempt is the ordinary solve; then, as with any
    other method (QP), the solves run one start at a time, in the order the ordinary solve would take them
    (``q0`` and the target's ranked table samples, then random configurations; :func:`_free_starts`),
    skipping the start already tried and every start in collision at the price of one check instead of a
    run. An answer counts when it and every iterate of its run are collision free (:func:`_path_is_free`:
    the answer first, then the iterates, last first). Returns ``(result, warm)``: the qualifying result or
    None, and the constrained solve's warm start (:func:`_last_clear_iterate` of the first run that failed
    the check; None when there is none).
    """
    if "failed_path" in p:  # the attempts ran in ordinary_solve_checked: on to the constrained solve
        failed = p["failed_path"]
        return None, (None if failed is None or not len(failed) else _last_clear_iterate(constraint, failed))
    closed = _closed_form_answers(robot, p)
    method = p["method"]
    if not closed and method in ("auto", "lm") and p["weights"] is None and not p.get("constraints"):
        if solver_opts:
            check_options(method, solver_opts)
        lm_options = solver_keywords({k: solver_opts[k] for k in _LM_KEYS if k in solver_opts})
        res, failed = _checked_lm_solve(robot, p["target"], p["q0"], p["tol_pos"], p["tol_rot"],
                                        max(deadline - time.perf_counter(), 1e-4), p["seed"], lm_options, constraint)
        return res, (None if res is not None or failed is None or not len(failed)
                     else _last_clear_iterate(constraint, failed))
    opts = {k: v for k, v in solver_opts.items() if k not in ("prefer_q0", "max_starts", "seed_table")}
    failed = None  # iterates of the first run whose answer or path collided
    attempt = 0
    skip = None
    if closed:
        res = solve_prepared(robot, dict(p, max_time=max(deadline - time.perf_counter(), 1e-4)), **solver_opts)
        attempt = 1
        if res.success and _path_is_free(constraint, res):
            return _checked(res, attempt), None
        if res.history is not None and len(res.history.q):
            skip, failed = res.history.q[0], res.history.q
    limit = UNCONSTRAINED_ATTEMPTS
    if solver_opts.get("max_starts") is not None:  # the caller's cap on starts holds here too
        limit = min(limit, int(solver_opts["max_starts"]))
    for start in _free_starts(robot, p, constraint, solver_opts, skip):
        if attempt >= limit:
            break
        left = deadline - time.perf_counter()
        if left <= 0.0:
            break
        attempt += 1
        res = solve_prepared(robot, dict(p, q0=start, max_time=left), prefer_q0=True, max_starts=1,
                             seed_table=False, **opts)
        if res.success and _path_is_free(constraint, res, start_checked=True):
            return _checked(res, attempt), None
        if failed is None and res.history is not None and len(res.history):
            failed = res.history.iterates()  # the lazy list: no stacking unless the constrained solve needs it
    return None, (None if failed is None else _last_clear_iterate(constraint, failed))


def _checked(res: Result, attempt: int) -> Result:
    res.message += (f"; collision free (unconstrained answer and iterates checked, attempt {attempt})" if attempt > 1
                    else _CHECKED)
    info = res.info
    info["collision"] = "unconstrained, checked"
    info["collision_attempts"] = attempt
    return res


def _closed_form_answers(robot, p: dict) -> bool:
    """True when the ordinary solve is a closed form (method ``"analytic"``, or ``"auto"`` with a closed form
    of finitely many branches for the frame): it has no starts to try one at a time."""
    method = p["method"]
    if method == "analytic":
        return True
    if method != "auto" or p["weights"] is not None:
        return False
    tgt = p["target"]
    solver = analytic.closed_form_solver(robot, tgt.frame)
    return solver is not None and solver.finite and solver.supports(tgt.relaxed)


#: Consecutive candidate starts in collision after which the attempts give up (the scene leaves little room):
#: the limit of ``solve_lm(admit=...)``.
RANDOM_TRIES = ADMIT_MISSES


def _free_starts(robot, p: dict, constraint: CollisionConstraint, solver_opts: dict, skip: np.ndarray | None = None):
    """The collision-free starts of the unconstrained attempts, in the ordinary solve's order.

    :func:`kinserve.ik.starts.multistart.frame_starts` with the solve's ``q0``, ``seed`` and the options
    ``seed_table`` / ``prefer_q0``: ``q0`` and the target's table samples ranked by pose distance, then
    random configurations. ``skip`` (a start already tried) and the starts in collision are left out
    (each costs one check); the sequence stops after :data:`RANDOM_TRIES` candidates in a row collide.
    """
    tgt = p["target"]
    seed = p["seed"] or 0
    q0 = p["q0"]
    if q0 is not None:
        q0 = _clip(q0, robot.lower, robot.upper)
    table, prefer_q0 = bool(solver_opts.get("seed_table", True)), bool(solver_opts.get("prefer_q0", False))
    if getattr(tgt, "frame_id", None) is None or getattr(tgt, "T", None) is None:
        seq = start_sequence(robot, None, None, q0, seed, prefer_q0=prefer_q0)
    else:
        seq = frame_starts(robot, tgt.frame, tgt.frame_id, tgt.T[:3, :3], tgt.T[:3, 3], len(tgt.rot_rows) == 3,
                           q0, seed, table, prefer_q0)
    skip_list = None if skip is None else skip.tolist()
    misses = 0
    for q in seq:
        if skip_list is not None and q.tolist() == skip_list:
            continue
        if constraint.in_collision(q):
            misses += 1
            if misses >= RANDOM_TRIES:
                return
            continue
        misses = 0
        yield q


def _last_clear_iterate(constraint: CollisionConstraint, qs) -> np.ndarray | None:
    """The iterate just before the first one in collision (None when the first collides; the last if none does)."""
    for k, q in enumerate(qs):
        if constraint.in_collision(q):
            return qs[k - 1].copy() if k else None
    return qs[-1].copy()


def _path_is_free(constraint: CollisionConstraint, res: Result, start_checked: bool = False) -> bool:
    """The answer, then every iterate of the run that produced it (last first), violates nothing.

    The answer is usually the run's last iterate: it is checked once. ``start_checked``: the run's
    first iterate (its start) was found clear before the run and is not checked again.
    """
    q_answer = res.q
    hist = res.history.iterates() if res.history is not None else []
    n = len(hist)
    first = 1 if start_checked else 0
    if type(hist) is np.ndarray and n > first and hist[n - 1].tolist() == q_answer.tolist():
        # the compiled LM's iterates: the answer (its last row), then the others last first, as one array view
        return constraint.first_collision(hist[n - 1:0:-1] if first else hist[::-1]) < 0
    last = n - 1
    if last >= 0 and hist[last].tolist() == q_answer.tolist():
        last -= 1
    # the answer, then the iterates ``last`` down to ``first``, in one loop of checks
    rest = [] if last < first else hist[last:first - 1:-1] if first else hist[last::-1]
    return constraint.first_collision([q_answer, *rest]) < 0


def _target_inside_obstacle(robot, constraint: CollisionConstraint, tgt) -> str:
    """Reason text when the target's position is inside an obstacle and the frame origin inside the body, else ""."""
    if not constraint.obstacles or any(k in tgt.relaxed for k in (0, 1, 2)):
        return ""
    point = tgt.T[:3, 3].copy()
    for k, ob in enumerate(constraint.obstacles):
        depth = float(ob.signed_distance(point)[0])
        if depth < 0.0 and _frame_origin_inside_body(robot, tgt.frame):
            return (f"the target position {np.round(point, 4).tolist()} lies inside obstacle[{k}]:{ob.kind} "
                    f"({-depth:.4g} m deep) and frame {tgt.frame!r} has its origin inside the robot's collision "
                    "geometry: no collision-free configuration reaches it")
    return ""


def _frame_origin_inside_body(robot, frame: str) -> bool:
    """True when the frame's origin lies inside a collision geometry of the body that carries it."""
    model = robot.model
    fid = robot.frame_id(frame)
    joint = model.frames[fid].parentJoint
    origin = model.frames[fid].placement  # frame in its joint's frame
    gm = robot.collision.geometry
    point = coal.Sphere(1e-9)
    req, res = coal.DistanceRequest(), coal.DistanceResult()
    for g in gm.geometryObjects:
        if g.parentJoint != joint:
            continue
        res.clear()
        d = coal.distance(g.geometry, coal.Transform3s(g.placement.rotation, g.placement.translation),
                          point, coal.Transform3s(np.eye(3), origin.translation), req, res)
        if d < 0.0:
            return True
    return False


def _failure(robot, tgt, q0, t0: float, reason: str) -> Result:
    q = np.clip(robot.neutral() if q0 is None else np.asarray(q0, dtype=float), robot.lower, robot.upper)
    return Result(q=q, success=False, position_error=float("nan"), orientation_error=float("nan"),
                  elapsed=time.perf_counter() - t0, message=reason, method="qp", frame=tgt.frame,
                  history=History.empty(robot.nq, tgt.components), info={"collision": "infeasible"})
