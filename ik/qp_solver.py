"""Differential IK iterated to convergence, one QP per step (method ``"qp"``).

At the current configuration ``q`` with task error ``e`` and task Jacobian
``J`` (kept rows, see :mod:`ik.targets`), the step ``dq`` solves

    minimise   1/2 |J dq - e|^2 + 1/2 lambda |dq|^2          lambda = 0.01 |e|^2 + lambda_0
    subject to max(lower - q, -s) <= dq <= min(upper - q, s)    (joint limits, trust region s)
               g_k^T dq >= -xi (d_k - r_k)                      (every sphere / segment pair)

i.e. ``P = J^T J + lambda I``, ``c = -J^T e`` - a Levenberg-Marquardt step
with hard inequality constraints.

Exact shortcut (``shortcut=True``, default): the QP is convex, so when its
unconstrained minimiser ``-P^-1 c`` (one Cholesky solve) already satisfies
every inequality it *is* the QP's solution, and the solver call is skipped.
Without spheres the constraints are a box, and a few primal active-set
rounds (:func:`box_active_set`: fix the violated joints at their bounds,
re-solve the rest, accept only if the KKT conditions hold) usually find the
exact solution too. Otherwise the backend solves the QP. This is what an
active-set solver does in its first steps; it spares ADMM (OSQP) its
iterations in the common cases. ``shortcut=False`` calls the QP solver at
every step. With ``centring`` a second QP stage moves
in the null space of ``J`` towards mid-range (:mod:`ik.centring`), so the
task progress of the first stage is kept exactly.

After each step the true sphere clearances at ``q + dq`` are checked and the
step is halved until they are all non-negative (see :mod:`ik.constraints`),
so every iterate - not only the answer - is outside every sphere, and inside
the joint limits. Likewise, once the task is within tolerance, the
secondary (centring) part of a step is halved until the next iterate is
still within tolerance: the null space of the linearised task is only
tangent to the self-motion manifold, and a long centring step would
otherwise drift off the target before the next primary step pulls it back.

Stopping: the task is within tolerance and (with centring) the secondary
step has become negligible; or the error stalls (restart from the next start
of :func:`ik.seeds.start_sequence`) until ``max_time``.

The QP workspaces (:mod:`ik.qp_backends`) are created once per solve - their
sizes are fixed by the task and the sphere list - and every step only
updates their numbers and warm-starts from the previous solution.
"""

from __future__ import annotations

import math
import time

import numpy as np
import pinocchio as pin
from scipy.linalg import get_lapack_funcs

from .centring import CentringStage
from .constraints import DAMPER_GAIN, SphereSet
from .qp_backends import INF, make_backend
from .result import History, Result, task_evaluator
from .seeds import seed_table, start_sequence

_posv = get_lapack_funcs(("posv",), (np.eye(2),))[0]
_clip = np._core.umath.clip if hasattr(np, "_core") else np.core.umath.clip
_maximum = np.maximum
_minimum = np.minimum

#: Floor of the Levenberg-Marquardt damping.
DAMPING = 1e-5
#: Gain of the error term of the damping.
DAMPING_GAIN = 0.01
#: Trust region: largest joint step per iteration (rad or m).
MAX_STEP = 1.0
#: Iteration cap of one start.
MAX_ITER = 200
#: Default time budget (s).
MAX_TIME = 0.5
#: Stall detection (as :mod:`ik.lm_solver`): best |e|^2 not improved by this factor ...
STALL_RATIO = 0.9
#: ... for this many iterations.
STALL_PATIENCE = 4
#: The secondary objective has converged when the centring step is below this (rad or m).
CENTRING_STEP_TOL = 1e-6
#: Halvings of a step that enters a sphere before giving up on it.
MAX_BACKTRACK = 20

_now = time.perf_counter
_LWA = pin.LOCAL_WORLD_ALIGNED
_LOCAL = pin.LOCAL


def box_active_set(P, c, lb, ub, x, rounds: int = 3):
    """Exact solution of ``min 1/2 x^T P x + c^T x, lb <= x <= ub`` by a few primal active-set rounds, or None.

    Starting from the unconstrained minimiser ``x``, the coordinates outside
    the box are fixed at their bound and the reduced problem is solved for
    the others; the answer is returned only if it satisfies the KKT
    conditions - feasible, and the gradient ``g = P x + c`` has the sign of a
    non-negative multiplier on every fixed coordinate (``g_i <= 0`` at an upper
    bound, ``g_i >= 0`` at a lower bound) - so it *is* the QP's solution.
    Otherwise None (the caller asks the QP solver).

    The reduced system is solved at full size: rows and columns of the fixed
    coordinates are replaced by the identity (masks, no fancy indexing).
    """
    n = x.shape[0]
    at_hi = x > ub
    at_lo = x < lb
    for _ in range(rounds):
        fixed = at_hi | at_lo
        free = 1.0 - fixed
        xs = np.where(at_hi, ub, np.where(at_lo, lb, 0.0))
        Pm = P * free[:, None] * free[None, :]
        Pm.flat[:: n + 1] += fixed
        rhs = free * -(c + P.dot(xs)) + xs
        xs = _posv(Pm, rhs)[1]
        if _clip(xs, lb, ub).tolist() != xs.tolist():
            at_hi = at_hi | (xs > ub)
            at_lo = at_lo | (xs < lb)
            continue
        grad = P.dot(xs) + c
        tol = 1e-12 * (1.0 + np.abs(grad).max())
        if (grad[at_hi] <= tol).all() and (grad[at_lo] >= -tol).all():
            return xs
        return None
    return None


class _QPIteration:
    """Workspace of one solve: kinematics, constraint rows and the (persistent) QP backends."""

    def __init__(self, robot, target, spheres: SphereSet | None, weights, backend: str, max_step: float, damping: float,
                 shortcut: bool = True):
        self.robot = robot
        self.model, self.data = robot.model, robot.data
        self.target = target
        self.fid = target.frame_id
        self.spheres = spheres
        self.k = spheres.m if spheres is not None else 0
        self.n = robot.nq
        self.max_step = max_step
        self.damping = damping
        self.shortcut = shortcut
        self.neg_step = np.full(self.n, -max_step)
        self.pos_step = np.full(self.n, max_step)
        self.qp = make_backend(backend, self.n, self.k)
        self.qp_calls = 0
        self.centring = (
            CentringStage(robot, weights, self.k, backend, max_step, shortcut=shortcut) if weights is not None else None
        )
        self.lower, self.upper = robot.lower, robot.upper
        self.u_inf = np.full(self.k, INF)
        self.full = target.full
        self.Td = target.se3
        # stall detection: patient when spheres may legitimately slow the progress down
        self.stall_ratio, self.stall_patience = (STALL_RATIO, STALL_PATIENCE) if self.k else (0.85, 2)

    def evaluate(self, q):
        """Kinematics at ``q``: (e, J, pos_err, rot_err).

        Full pose: ``e = log6(oMf^-1 oMd)`` with the LOCAL frame Jacobian (as
        :mod:`ik.lm_solver`); relaxed targets: the kept world/target-axis rows.
        """
        pin.computeJointJacobians(self.model, self.data, q)
        M = pin.updateFramePlacement(self.model, self.data, self.fid)
        if self.full:
            iMd = M.actInv(self.Td)
            e = pin.log6(iMd).vector
            t = iMd.translation
            w = e[3:]
            return e, pin.getFrameJacobian(self.model, self.data, self.fid, _LOCAL), math.sqrt(t.dot(t)), math.sqrt(w.dot(w))
        e6 = self.target.error6(M.rotation, M.translation)
        pe, re = self.target.errors_from6(e6)
        J = self.target.jacobian(pin.getFrameJacobian(self.model, self.data, self.fid, _LWA))
        return e6[self.target.kept], J, pe, re

    def errors_at(self, q):
        """(position, orientation) errors of the kept components at ``q`` (forward kinematics only)."""
        pin.forwardKinematics(self.model, self.data, q)
        M = pin.updateFramePlacement(self.model, self.data, self.fid)
        return self.target.errors(M.rotation, M.translation)

    def step(self, q, e, J):
        """(dq, secondary part of dq, status) - dq is None when the QP failed."""
        n = self.n
        E = e.dot(e)
        P = J.T.dot(J)
        P.flat[:: n + 1] += DAMPING_GAIN * E + self.damping
        g = e.dot(J)  # -c
        c = -g
        # box of joint_step_bounds (q is inside the limits, so lower - q <= 0 <= upper - q exactly)
        lb = _maximum(self.lower - q, self.neg_step)
        ub = _minimum(self.upper - q, self.pos_step)
        if self.k:
            clear, G = self.spheres.rows(self.data)
            l = -DAMPER_GAIN * clear
            u = self.u_inf
        else:
            G = l = u = None
        dq1 = None
        if self.shortcut:
            x = _posv(P, g)[1]
            if _clip(x, lb, ub).tolist() == x.tolist():
                if G is None or (G.dot(x) >= l).all():
                    dq1 = x
            elif G is None:
                dq1 = box_active_set(P, c, lb, ub, x)
        if dq1 is None:
            self.qp_calls += 1
            dq1 = self.qp.solve(P, c, G, l, u, lb, ub)
        if dq1 is None:
            return None, None, f"QP failed ({self.qp.name}: {self.qp.status})"
        if self.centring is None:
            return dq1, None, ""
        dq2 = self.centring.step(q, J, dq1, lb, ub, G, l, u)
        return dq1 + dq2, dq2, ""

    def accept(self, q, dq):
        """``q + alpha dq`` with the largest ``alpha in {1, 1/2, 1/4, ...}`` keeping every sphere clearance >= 0."""
        qn = _clip(q + dq, self.lower, self.upper)
        if self.spheres is None:
            return qn, 1.0
        alpha = 1.0
        for _ in range(MAX_BACKTRACK):
            if self.spheres.clearances_at(qn).min() >= 0.0:
                return qn, alpha
            alpha *= 0.5
            qn = np.clip(q + alpha * dq, self.lower, self.upper)
        return None, 0.0


def _run(ws: _QPIteration, q, tol_pos, tol_rot, max_iter, deadline, record):
    """One start. Returns (ok, iterations, reason, index of the answer in the record)."""
    best_E = math.inf
    stalls = 0
    best_ok = None  # index of the last iterate that met the tolerances
    beta_prev = 1.0  # fraction of the centring step accepted last time
    qs, pes, res = record
    for it in range(max_iter + 1):
        e, J, pe, re = ws.evaluate(q)
        qs.append(q)
        pes.append(pe)
        res.append(re)
        within = pe < tol_pos and re < tol_rot
        if within:
            best_ok = len(qs) - 1
            if ws.centring is None:
                return True, it, "converged", best_ok
        if it == max_iter:
            break
        E = pe * pe + re * re
        if not within:
            if E < ws.stall_ratio * best_E:
                best_E = E
                stalls = 0
            else:
                stalls += 1
                if stalls >= ws.stall_patience:
                    return best_ok is not None, it, "stalled", best_ok
        dq, dq2, status = ws.step(q, e, J)
        if dq is None:
            return best_ok is not None, it, status, best_ok
        if within and dq2 is not None and float(np.abs(dq).max()) < CENTRING_STEP_TOL:
            return True, it, "converged (task within tolerance, centring stationary)", best_ok
        if within and dq2 is not None:
            # strict priority also along the path: once the task is within tolerance, a centring
            # step may not take it out again (the null space is curved) - halve the secondary part
            dq1 = dq - dq2
            beta = min(1.0, 2.0 * beta_prev)  # start near the last accepted fraction
            for _ in range(MAX_BACKTRACK):
                qn, alpha = ws.accept(q, dq1 + beta * dq2)
                if qn is None:
                    break
                pe_n, re_n = ws.errors_at(qn)
                if pe_n < tol_pos and re_n < tol_rot:
                    break
                beta *= 0.5
            else:
                return True, it, "converged (centring stopped by the task tolerance)", best_ok
            beta_prev = beta
        else:
            qn, alpha = ws.accept(q, dq)
        if qn is None:
            return best_ok is not None, it, "step blocked by a sphere", best_ok
        q = qn
        if _now() > deadline:
            return best_ok is not None, it + 1, "time budget exhausted", best_ok
    if best_ok is not None:
        return True, max_iter, "converged (iteration limit reached while centring)", best_ok
    return False, max_iter, "iteration limit", None


def solve_qp(
    robot,
    target,
    q0=None,
    *,
    spheres: SphereSet | None = None,
    weights=None,
    backend: str = "osqp",
    tol_pos: float = 1e-4,
    tol_rot: float = 1e-3,
    max_time: float | None = None,
    seed=None,
    max_iter: int = MAX_ITER,
    max_step: float = MAX_STEP,
    damping: float = DAMPING,
    max_starts: int | None = None,
    seed_table_enabled: bool = True,
    prefer_q0: bool = False,
    shortcut: bool = True,
) -> Result:
    """QP-based IK of ``target`` with hard joint limits, optional spheres and centring, and restarts.

    ``q0`` is validated by the caller; when ``spheres`` is given it must be
    outside every sphere (checked by :func:`ik.solve`). ``weights`` are the
    centring weights of :func:`ik.centring.centring_weights` (None = off).
    Starts that enter a sphere are skipped.
    """
    t0 = _now()
    deadline = t0 + (MAX_TIME if max_time is None else max_time)
    ws = _QPIteration(robot, target, spheres, weights, backend, max_step, damping, bool(shortcut))
    lo, hi = robot.lower, robot.upper
    table = seed_table(robot, target.frame) if seed_table_enabled else None
    f_target = q0_dist = None
    if q0 is not None:
        q0 = np.clip(q0, lo, hi)
    if table is not None:
        f_target = table.features(target._R, target._p, rotation=len(target.rot_rows) == 3)
        if q0 is not None:
            T0 = robot.fk(q0, target.frame)
            q0_dist = table.distance(f_target, table.features(T0[:3, :3], T0[:3, 3]))
    starts = start_sequence(robot, table, f_target, q0, 0 if seed is None else seed, q0_distance=q0_dist, prefer_q0=prefer_q0)

    best = None
    iterations = 0
    n_starts = 0
    skipped = 0
    for q in starts:
        if spheres is not None and spheres.m and spheres.clearances_at(q).min() < 0.0:
            skipped += 1
            if skipped > 10000 or _now() > deadline:
                break
            continue
        n_starts += 1
        record = ([], [], [])
        ok, it, reason, k = _run(ws, q, tol_pos, tol_rot, max_iter, deadline, record)
        iterations += it
        qs, pes, res = record
        if k is None:
            k = int(np.argmin(np.square(pes) + np.square(res)))
        score = pes[k] ** 2 + res[k] ** 2
        if best is None or ok or score < best[0]:
            best = (score, k, record, reason, ok)
        if ok:
            break
        if _now() > deadline or (max_starts is not None and n_starts >= max_starts):
            break

    if best is None:
        q = np.clip(robot.neutral() if q0 is None else q0, lo, hi)
        pe, re = target.errors_at(robot, q)  # the residual at the returned q: finite, never NaN
        return Result(
            q=q, success=False, position_error=float(pe), orientation_error=float(re), elapsed=_now() - t0,
            message="no start configuration outside the spheres was found", method="qp", frame=target.frame,
            history=History.empty(robot.nq, target.components),
        )
    _, k, (qs, pes, res), reason, ok = best
    if ok:
        message = reason
    else:
        message = (
            f"no start reached tol_pos={tol_pos:g} m / tol_rot={tol_rot:g} rad in {n_starts} starts "
            f"({iterations} iterations; last start: {reason}); best residual {pes[k]:.3g} m / {res[k]:.3g} rad"
        )
    hist = History.from_lists(qs[: k + 1], pes[: k + 1], res[: k + 1], components=target.components, evaluate=task_evaluator(robot, target))
    return Result(
        q=np.array(qs[k]), success=ok, position_error=float(pes[k]), orientation_error=float(res[k]),
        iterations=iterations, restarts=n_starts - 1, elapsed=_now() - t0, message=message, history=hist,
        method="qp", frame=target.frame, info={"backend": ws.qp.name, "qp_calls": ws.qp_calls},
    )
