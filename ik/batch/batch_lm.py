"""Vectorised Levenberg-Marquardt: many full-pose targets of one serial chain solved at once.

:func:`ik.solve_many` uses this for plain pose targets (method ``"lm"``, or
``"auto"`` on a robot without a finite closed form; no relaxation, spheres
or centring): instead of one Python loop per target, every iteration
advances *all* unfinished targets with NumPy operations on stacked arrays.
The mathematics is the method of :mod:`ik.lm.solver`, written for stacks:

* kinematics of the chain for ``N`` configurations (:class:`BatchChain`):
  joint frames by the product of the fixed placements and the joint motions
  (Rodrigues' formula for revolute joints), then the geometric Jacobian
  columns ``[a_i x (p - o_i); a_i]`` (revolute) / ``[a_i; 0]`` (prismatic),
  world axes;
* error ``e = [p* - p; log(R* R^T)]`` (world axes; ``log`` by the stable
  ``theta = atan2(|v| / 2, (tr R - 1) / 2)``, ``w = theta v / |v|``, with
  Pinocchio's ``log3`` for the rare rotations within 1e-6 rad of ``pi``);
* damped step ``(J^T J + lambda I) dq = J^T e`` with
  ``lambda = 0.01 |e|^2 + 1e-5`` (``numpy.linalg.solve`` on the stack; the
  scalar solver steps on the LOCAL ``log6`` error and damps with its
  ``|log6|^2``, so single iterates differ slightly while the rule is the
  same), the same active-set handling of the joint limits, the same stall rule and
  restart order (table samples and ``q0`` by pose distance, full-range
  samples, then seeded random configurations, see :mod:`ik.starts.seed_table`).

Targets that are still unsolved when only a few remain are finished by the
scalar :func:`ik.lm.solver.solve_lm` (a stacked iteration has a fixed cost
that only pays off on many rows). The answers are valid solutions within
the same tolerances, but - the restarts being interleaved differently - not
necessarily the very configurations ``ik.solve`` returns one by one.
"""

from __future__ import annotations

import math
import time
from typing import TYPE_CHECKING, Any

import numpy as np
import pinocchio as pin

from kinserve.kinematics.serial_chain import joint_axis, joint_chain

from kinserve.ik.lm.solver import DAMPING, DAMPING_GAIN, MAX_ITER, STALL_PATIENCE, STALL_RATIO, solve_lm
from kinserve.ik.starts.seed_table import seed_table

if TYPE_CHECKING:  # annotations only
    from kinserve.kinematics.robot import Robot


#: Below this many unfinished targets the scalar solver takes over.
SCALAR_BELOW = 24
#: Starts per target before giving up (the scalar solver's time budget bounds it otherwise).
MAX_STARTS = 100


class BatchChain:
    """Stacked forward kinematics and geometric Jacobian of one frame of a serial chain."""

    def __init__(self, robot: Robot, frame: str) -> None:
        model = robot.model
        fid = robot.frame_id(frame)
        f = model.frames[fid]
        chain = joint_chain(model, fid)
        if len(chain) != robot.nq:
            raise ValueError("the frame does not depend on every joint")
        self.nq = robot.nq
        self.steps = []
        for j in chain:
            info = joint_axis(model.joints[j])
            if info is None:
                raise ValueError(f"unsupported joint {model.joints[j].shortname()}")
            kind, axis = info
            M = model.jointPlacements[j]
            K = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
            self.steps.append((model.joints[j].idx_q, kind, axis, M.rotation.copy(), M.translation.copy(), K, K @ K))
        self.frame_R = f.placement.rotation.copy()
        self.frame_p = f.placement.translation.copy()

    def __call__(self, Q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(R (N,3,3), p (N,3), J (N,6,nq))`` of the frame for configurations ``Q`` (N, nq)."""
        N = Q.shape[0]
        R = np.broadcast_to(np.eye(3), (N, 3, 3))
        p = np.zeros((N, 3))
        J = np.empty((N, 6, self.nq))
        cols = []
        for iq, kind, axis, MR, Mp, K, K2 in self.steps:
            p = p + R @ Mp
            R = R @ MR
            a = R @ axis
            qi = Q[:, iq]
            if kind == "R":
                cols.append((iq, True, a, p))
                s = np.sin(qi)[:, None, None]
                c1 = (1.0 - np.cos(qi))[:, None, None]
                R = R + s * (R @ K) + c1 * (R @ K2)
            else:
                cols.append((iq, False, a, None))
                p = p + a * qi[:, None]
        p_tool = p + R @ self.frame_p
        R_tool = R @ self.frame_R
        for iq, revolute, a, o in cols:
            if revolute:
                d = p_tool - o
                ax, ay, az = a[:, 0], a[:, 1], a[:, 2]
                dx, dy, dz = d[:, 0], d[:, 1], d[:, 2]
                J[:, 0, iq] = ay * dz - az * dy
                J[:, 1, iq] = az * dx - ax * dz
                J[:, 2, iq] = ax * dy - ay * dx
                J[:, 3:, iq] = a
            else:
                J[:, :3, iq] = a
                J[:, 3:, iq] = 0.0
        return R_tool, p_tool, J


def log3_batch(R: np.ndarray) -> np.ndarray:
    """Rotation vectors ``w`` (N, 3) with ``exp([w]x) = R`` for a stack of rotations."""
    v = np.stack([R[:, 2, 1] - R[:, 1, 2], R[:, 0, 2] - R[:, 2, 0], R[:, 1, 0] - R[:, 0, 1]], axis=1)
    nv = np.linalg.norm(v, axis=1)  # 2 sin(theta)
    c = 0.5 * (R[:, 0, 0] + R[:, 1, 1] + R[:, 2, 2] - 1.0)  # cos(theta)
    theta = np.arctan2(0.5 * nv, c)
    with np.errstate(invalid="ignore", divide="ignore"):
        factor = np.where(theta < 1e-8, 0.5 + theta * theta / 12.0, theta / nv)
    w = factor[:, None] * v
    near_pi = np.flatnonzero(theta > math.pi - 1e-6)
    for i in near_pi:
        w[i] = pin.log3(np.ascontiguousarray(R[i]))
    return w


class _Starts:
    """The restart order of :func:`ik.starts.seed_table.start_sequence` for every target, computed lazily.

    The first start of every target costs one matrix product and an
    ``argmin`` over the table; the full ordered list (8 nearest interior
    samples with ``q0`` inserted by its distance, then 8 nearest full-range
    samples, then seeded random configurations) is only built for targets
    that need a restart.
    """

    K = 8

    def __init__(self, robot, table, targets, q0s, seed):
        self.robot, self.table, self.q0s = robot, table, q0s
        self.base_seed = 0 if seed is None else seed
        N = len(targets)
        s = table._s
        f = np.empty((N, 13))
        f[:, :3] = targets[:, :3, 3]
        f[:, 3:12] = s * targets[:, :3, :3].reshape(N, 9)
        f[:, 12] = 1.0
        self.f = f
        self.f2 = np.einsum("ij,ij->i", f[:, :12], f[:, :12])
        S = f @ table.G.T  # (N, K) scores D - |f*|^2
        best = S.argmin(axis=1)
        d_best = S[np.arange(N), best] + self.f2
        self.d_q0 = None
        first = table.Q[best].copy()
        if q0s is not None:
            T0 = robot.fk_batch(q0s)
            f0 = np.empty((N, 12))
            f0[:, :3] = T0[:, :3, 3]
            f0[:, 3:] = s * T0[:, :3, :3].reshape(N, 9)
            d = f0 - f[:, :12]
            self.d_q0 = np.einsum("ij,ij->i", d, d)
            use_q0 = self.d_q0 <= d_best
            first[use_q0] = q0s[use_q0]
        self.first = first
        self.lists = {}
        self.rngs = {}

    def _list(self, i):
        c = self.lists.get(i)
        if c is None:
            t, f = self.table, self.f[i]
            S = t.G.dot(f)
            idx = np.argpartition(S, self.K - 1)[: self.K]
            idx = idx[np.argsort(S[idx])]
            c = [t.Q[j] for j in idx]
            if self.q0s is not None:
                pos = int(np.searchsorted(S[idx] + self.f2[i], self.d_q0[i], side="left"))
                c.insert(pos, self.q0s[i])
            Sf = t.G_full.dot(f)
            idx = np.argpartition(Sf, self.K - 1)[: self.K]
            c.extend(t.Q_full[j] for j in idx[np.argsort(Sf[idx])])
            self.lists[i] = c
        return c

    def start(self, i, k):
        """Start number ``k`` (0-based) of target ``i``."""
        if k == 0:
            return self.first[i].copy()
        c = self._list(i)
        if k < len(c):
            return np.array(c[k], dtype=float)
        rng = self.rngs.get(i)
        if rng is None:
            rng = self.rngs[i] = np.random.default_rng([self.base_seed, int(i)])
        return self.robot.random_q(rng)


def solve_batch(robot: Robot, frame: str, targets: np.ndarray, q0s: np.ndarray | None = None, *,
                tol_pos: float = 1e-4, tol_rot: float = 1e-3, seed: int | None = None,
                max_time: float | None = None, max_iter: int = MAX_ITER, damping: float = DAMPING) -> dict[str, Any]:
    """Solve full-pose targets ``(N, 4, 4)`` together; returns a dict of per-target arrays.

    Keys: ``q``, ``success``, ``position_error``, ``orientation_error``,
    ``iterations``, ``restarts``, ``elapsed`` (wall time of the batch shared
    out in proportion to each target's iterations), ``message``.
    """
    t_start = time.perf_counter()
    chain = BatchChain(robot, frame)
    N, n = len(targets), robot.nq
    lo, hi = robot.lower, robot.upper
    tp2, tr2 = tol_pos * tol_pos, tol_rot * tol_rot
    table = seed_table(robot, frame)
    sts = _Starts(robot, table, targets, q0s, seed)
    base_seed = sts.base_seed

    q_out = np.empty((N, n))
    success = np.zeros(N, dtype=bool)
    pe_out = np.full(N, np.inf)
    re_out = np.full(N, np.inf)
    iters = np.zeros(N, dtype=np.int64)
    starts = np.ones(N, dtype=np.int64)
    message = ["converged"] * N
    done = np.zeros(N, dtype=bool)
    best_score = np.full(N, np.inf)

    # state of the unfinished rows
    rows = np.arange(N)
    Q = sts.first.copy()
    best_E = np.full(N, np.inf)
    stalls = np.zeros(N, dtype=np.int64)
    it_start = np.zeros(N, dtype=np.int64)
    Rt = targets[:, :3, :3]
    pt = targets[:, :3, 3]
    eye = np.eye(n)
    while rows.size >= SCALAR_BELOW:
        R, p, J = chain(Q)
        ep = pt[rows] - p
        w = log3_batch(Rt[rows] @ R.transpose(0, 2, 1))
        pe2 = np.einsum("ij,ij->i", ep, ep)
        re2 = np.einsum("ij,ij->i", w, w)
        E = pe2 + re2
        # remember each row's best configuration (the answer if it never converges)
        better = E < best_score[rows]
        if better.any():
            b = rows[better]
            best_score[b] = E[better]
            q_out[b] = Q[better]
            pe_out[b] = np.sqrt(pe2[better])
            re_out[b] = np.sqrt(re2[better])
        conv = (pe2 < tp2) & (re2 < tr2)
        if conv.any():
            c = rows[conv]
            success[c] = True
            done[c] = True
        # stall rule: best |e|^2 of the current start not improved by STALL_RATIO for STALL_PATIENCE iterations
        improved = E < STALL_RATIO * best_E[rows]
        best_E[rows] = np.where(improved, E, best_E[rows])
        stalls[rows] = np.where(improved, 0, stalls[rows] + 1)
        restart = ~conv & ((stalls[rows] >= STALL_PATIENCE) | (it_start[rows] >= max_iter))
        keep = ~conv
        if restart.any():
            for j in np.flatnonzero(restart):
                i = rows[j]
                if starts[i] >= MAX_STARTS:
                    done[i] = True
                    keep[j] = False
                    message[i] = f"no start converged in {starts[i]} starts; best residual shown"
                    continue
                Q[j] = sts.start(i, int(starts[i]))
                starts[i] += 1
                best_E[i] = np.inf
                stalls[i] = 0
                it_start[i] = 0
        if max_time is not None and time.perf_counter() - t_start > max_time * N:
            for i in rows[keep]:
                message[i] = "time budget exhausted"
            done[rows[keep]] = True
            keep[:] = False
        # LM step on the rows that continue (restarted rows take their step from the new start next time)
        step = keep & ~restart
        if step.any():
            s_rows = np.flatnonzero(step)
            Js = J[s_rows]
            es = np.concatenate([ep[s_rows], w[s_rows]], axis=1)
            lam = DAMPING_GAIN * E[s_rows] + damping
            Q[s_rows] = _bounded_steps(Js, es, lam, Q[s_rows], lo, hi, eye)
            iters[rows[s_rows]] += 1
            it_start[rows[s_rows]] += 1
        Q = Q[keep]
        rows = rows[keep]

    # the last few rows: the scalar solver (same method) with what is left of their starts
    from kinserve.ik.targets import Target

    for j, i in enumerate(rows):
        res = solve_lm(robot, Target(robot, targets[i], frame), Q[j], tol_pos=tol_pos, tol_rot=tol_rot,
                       max_time=max_time, seed=base_seed + int(i), prefer_q0=True,
                       max_starts=max(1, MAX_STARTS - int(starts[i]) + 1))
        iters[i] += res.iterations
        starts[i] += res.restarts
        if res.success or res.position_error ** 2 + res.orientation_error ** 2 < best_score[i]:
            q_out[i] = res.q
            pe_out[i] = res.position_error
            re_out[i] = res.orientation_error
            success[i] = res.success
        if not res.success:
            message[i] = res.message
    elapsed = time.perf_counter() - t_start
    total = max(1, int(iters.sum() + N))
    return {
        "q": q_out, "success": success, "position_error": pe_out, "orientation_error": re_out,
        "iterations": iters, "restarts": starts - 1, "elapsed": elapsed * (iters + 1) / total, "message": message,
    }


def _bounded_steps(J, e, lam, Q, lo, hi, eye):
    """Stacked version of :func:`ik.lm.solver._bounded_step` (same active-set rule for the limits)."""
    JT = J.transpose(0, 2, 1)
    A = JT @ J + lam[:, None, None] * eye
    dq = np.linalg.solve(A, (JT @ e[:, :, None]))[:, :, 0]
    Qn = Q + dq
    out = (Qn < lo) | (Qn > hi)
    bad = np.flatnonzero(out.any(axis=1))
    if bad.size == 0:
        return Qn
    fixed = out[bad]
    Jb, eb, Qb, lb = J[bad], e[bad], Q[bad], lam[bad]
    Qnb = Qn[bad]
    for _ in range(3):
        free = ~fixed
        Qc = np.clip(Qnb, lo, hi)
        dfix = np.where(fixed, Qc - Qb, 0.0)
        e2 = eb - (Jb @ dfix[:, :, None])[:, :, 0]
        Jf = Jb * free[:, None, :]
        JfT = Jf.transpose(0, 2, 1)
        A = JfT @ Jf + lb[:, None, None] * eye
        dq = np.linalg.solve(A, (JfT @ e2[:, :, None]))[:, :, 0]
        Qnb = Qb + np.where(free, dq, dfix)
        new_out = (Qnb < lo) | (Qnb > hi)
        if not new_out.any():
            break
        fixed = fixed | new_out
    Qn[bad] = np.clip(Qnb, lo, hi)
    return Qn
