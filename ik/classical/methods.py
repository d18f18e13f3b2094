"""The classical (teaching) iterations of the seed documents, with their convergence histories.

With the task error ``e`` and the task Jacobian ``J`` of :mod:`ik.targets`
(world axes by default, kept rows only), every method iterates
``q <- clip(q + dq, lower, upper)`` from ``q0`` until the errors are within
tolerance:

* ``"jacobian_inverse"``:   ``dq = K J^-1 e``   (square ``J`` only: as many kept rows as joints)
* ``"jacobian_transpose"``: ``dq = alpha J^T e``   with ``alpha = K`` if given, otherwise the
  step that minimises the linearised error along ``J^T e``:
  ``alpha = <e, J J^T e> / |J J^T e|^2`` (Buss' choice)
* ``"pseudo_inverse"``:     ``dq = K J^+ e``,  ``J^+ = J^T (J J^T)^-1`` for a wide ``J``
  (the SVD pseudo-inverse in general)
* ``"dls"``:                ``dq = K J^T (J J^T + lambda^2 I)^-1 e``   (damped least squares,
  damping ``lambda``)

``K`` is the ``gain`` (default 1). For ``pseudo_inverse`` and ``dls`` a
``centring`` weight adds the null-space term of :mod:`ik.tasks.centring_weights`
(``dq += Z z``, in the null space of ``J``), which is how seed 004 keeps
``theta4`` (relax phi) or ``d3`` (relax z) mid-range. The secondary step
asks for ``CENTRING_GAIN * (mid - q)`` per iteration and its joint motion is
capped at ``CENTRING_MAX_STEP`` (rad or m, max-norm): near a singularity the
numerical null space grows by directions that are only approximately free,
and a full step along them lets the arm wander across its joint range
while the primary task cannot be met (seen as 5.8 rad jumps between samples
of a tracked path). With the gain below 1 the centring still converges
geometrically to mid-range and never overshoots it.

These methods run once from ``q0`` (no restarts): their value is the
history (``Result.history``: joint variables, position/orientation error and
the signed task error per iteration), as the seed documents plot it. The
Jacobian inverse stops with a failure at a singular configuration.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from types import MappingProxyType
from typing import TYPE_CHECKING, NamedTuple

import numpy as np
import pinocchio as pin

from kinserve.ik.result import History, Result
from kinserve.ik.tasks.centring_weights import null_space_basis, null_space_correction
from kinserve.kinematics.errors import InputError
from kinserve.kinematics.validation import as_choice

if TYPE_CHECKING:  # annotations only
    from kinserve.ik.targets import Target
    from kinserve.kinematics.robot import Robot

METHODS = ("jacobian_inverse", "jacobian_transpose", "pseudo_inverse", "dls")

#: Default damping ``lambda`` of DLS.
DLS_DAMPING = 0.05
#: Default iteration caps (the transpose method converges linearly and slowly); a read-only table.
MAX_ITER = MappingProxyType({"jacobian_inverse": 200, "jacobian_transpose": 5000, "pseudo_inverse": 200,
                             "dls": 500})
#: ``sigma_min / sigma_max`` below which the Jacobian inverse is declared singular.
SINGULAR_RCOND = 1e-10

_LWA = pin.LOCAL_WORLD_ALIGNED


#: Share of the remaining distance to mid-range that one iteration's centring step asks for.
CENTRING_GAIN = 0.5
#: Largest joint motion (rad or m) one iteration's centring correction may make.
CENTRING_MAX_STEP = 0.1
#: The iteration ends (task met) once the centring correction is below this (rad or m).
CENTRING_TOL = 1e-9


class _Settings(NamedTuple):
    """One run's settings: the method's step (one of :data:`_STEPS`), the gain ``K`` (``gain`` as given:
    None for Buss' step of the transpose), the DLS damping, the centring weights (None = off), the
    tolerances (m, rad), the iteration cap with the message of a run that ends on it, and the deadline
    (``perf_counter`` time; None = the clock is not read)."""

    step: Callable[[np.ndarray, np.ndarray, _Settings], np.ndarray | None]
    K: float
    gain: float | None
    damping: float
    weights: np.ndarray | None
    tol_pos: float
    tol_rot: float
    cap: int
    cap_message: str
    deadline: float | None


class _Trace:
    """The iterates of one run and their errors, in the lists :meth:`History.from_lists` takes."""

    def __init__(self) -> None:
        self.qs: list[np.ndarray] = []
        self.pes: list[float] = []
        self.res: list[float] = []
        self.tes: list[np.ndarray] = []

    def add(self, q: np.ndarray, pe: float, re: float, e: np.ndarray) -> None:
        """Record the iterate ``q``, its position / orientation errors and its kept task error."""
        self.qs.append(q)
        self.pes.append(pe)
        self.res.append(re)
        self.tes.append(e)


def solve_classical(
    robot: Robot,
    target: Target,
    q0: np.ndarray,
    method: str,
    *,
    gain: float | None = None,
    damping: float = DLS_DAMPING,
    weights: np.ndarray | None = None,
    tol_pos: float = 1e-4,
    tol_rot: float = 1e-3,
    max_iter: int | None = None,
    max_time: float | None = None,
    iteration_budget: int | None = None,
) -> Result:
    """Run one classical iteration from ``q0`` (validated, required). See the module docstring.

    The run ends after ``max_iter`` iterations (default :data:`MAX_ITER` of the method),
    ``iteration_budget`` iterations (one start: the smaller of the two caps) or ``max_time`` seconds;
    without ``max_time`` the clock decides nothing and the answer depends only on the inputs.
    """
    _check_arguments(robot, target, method, gain, damping, weights)
    t0 = time.perf_counter()
    max_iter = MAX_ITER[method] if max_iter is None else int(max_iter)
    cap, cap_message = _iteration_cap(max_iter, iteration_budget)
    run = _Settings(_STEPS[method], 1.0 if gain is None else float(gain), gain, damping, weights, tol_pos,
                    tol_rot, cap, cap_message, None if max_time is None else t0 + max_time)
    q = np.clip(np.array(q0, dtype=float), robot.lower, robot.upper)
    trace, it, ok, message = _iterate(robot, target, q, run)
    hist = History.from_lists(trace.qs, trace.pes, trace.res, trace.tes, target.components)
    return Result(
        q=trace.qs[-1].copy(), success=ok, position_error=float(trace.pes[-1]),
        orientation_error=float(trace.res[-1]), iterations=it, restarts=0, elapsed=time.perf_counter() - t0,
        message=message, history=hist, method=method, frame=target.frame,
        info={"gain": gain, "damping": damping if method == "dls" else None},
    )


def _check_arguments(robot: Robot, target: Target, method: str, gain: float | None, damping: float,
                     weights: np.ndarray | None) -> None:
    """:class:`InputError` unless the method, its gain and damping, the task's shape (square for the
    inverse) and the centring (null-space methods only) fit together."""
    as_choice(method, "classical method", METHODS)
    if gain is not None and not (isinstance(gain, (int, float)) and math.isfinite(gain) and gain > 0):
        raise InputError(f"gain must be a positive number, got {gain!r}")
    if not (isinstance(damping, (int, float)) and math.isfinite(damping) and damping >= 0):
        raise InputError(f"damping (lambda) must be a number >= 0, got {damping!r}")
    m, n = len(target.kept), robot.nq
    if method == "jacobian_inverse" and m != n:
        hint = ""
        extra = [a for a in target.components if a not in robot.task_axes]
        if len(target.components) - len(extra) == n and extra:
            hint = f" (this robot acts on {', '.join(robot.task_axes)}: relax={tuple(extra)!r})"
        raise InputError(
            f"jacobian_inverse needs a square Jacobian: the task keeps {m} components "
            f"({', '.join(target.components)}) for {n} joints; relax components{hint} or use "
            "'pseudo_inverse' / 'dls'"
        )
    if weights is not None and method in ("jacobian_inverse", "jacobian_transpose"):
        raise InputError(f"centring needs a null-space method ('pseudo_inverse' or 'dls'), not {method!r}")


def _iterate(robot: Robot, target: Target, q: np.ndarray, run: _Settings) -> tuple[_Trace, int, bool, str]:
    """``(trace, iterations, success, message)`` of the iteration ``q <- clip(q + dq)`` from ``q``."""
    model, data, fid = robot.model, robot.data, target.frame_id
    lo, hi = robot.lower, robot.upper
    trace = _Trace()
    # max-norm of the last centring correction: the loop goes on while centring still moves the joints
    centring_left = math.inf if run.weights is not None else 0.0
    it = 0
    while True:
        pin.computeJointJacobians(model, data, q)
        M = pin.updateFramePlacement(model, data, fid)
        e6 = target.error6(M.rotation, M.translation)
        pe, re = target.errors_from6(e6)
        e = e6[target.kept]
        trace.add(q, pe, re, e)
        end = _end(run, it, pe < run.tol_pos and re < run.tol_rot, centring_left)
        if end is not None:
            return trace, it, *end
        J = target.jacobian(pin.getFrameJacobian(model, data, fid, _LWA))
        dq = run.step(J, e, run)
        if dq is None:
            return trace, it, False, _singular_message(J, it)
        if run.weights is not None:
            dq, centring_left = _centred(robot, J, q, dq, run.weights)
        if not np.all(np.isfinite(dq)):
            return trace, it, False, f"the step is not finite at iteration {it} (singular configuration)"
        q = np.clip(q + dq, lo, hi)
        it += 1


def _end(run: _Settings, it: int, task_ok: bool, centring_left: float) -> tuple[bool, str] | None:
    """``(success, message)`` when the run ends at iteration ``it``, else None: converged (the task met and
    the centring still), or the cap or the deadline reached (the clock is read only below the cap)."""
    if task_ok and centring_left <= CENTRING_TOL:
        return True, "converged"
    if it < run.cap and (run.deadline is None or time.perf_counter() <= run.deadline):
        return None
    if task_ok:  # the task is met; only the secondary centring was still moving
        return True, "converged (centring stopped by the iteration/time limit)"
    return False, run.cap_message if it >= run.cap else "time budget exhausted"


def _inverse_step(J: np.ndarray, e: np.ndarray, run: _Settings) -> np.ndarray | None:
    """``K J^-1 e``; None when ``sigma_min / sigma_max <= SINGULAR_RCOND``."""
    s = np.linalg.svd(J, compute_uv=False)
    if s[-1] <= SINGULAR_RCOND * max(s[0], 1e-300):
        return None
    return run.K * np.linalg.solve(J, e)


def _singular_message(J: np.ndarray, it: int) -> str:
    """The message of a run stopped by a singular Jacobian at iteration ``it``."""
    s = np.linalg.svd(J, compute_uv=False)
    return f"singular Jacobian at iteration {it} (sigma_min/sigma_max = {s[-1] / max(s[0], 1e-300):.2e})"


def _transpose_step(J: np.ndarray, e: np.ndarray, run: _Settings) -> np.ndarray:
    """``alpha g``, ``g = J^T e``: ``alpha = K`` when a gain is given, else Buss' ``<e, J g> / |J g|^2``."""
    g = J.T @ e
    if run.gain is None:
        Jg = J @ g
        denom = float(Jg @ Jg)
        alpha = float(e @ Jg) / denom if denom > 0 else 0.0
    else:
        alpha = run.K
    return alpha * g


def _pseudo_inverse_step(J: np.ndarray, e: np.ndarray, run: _Settings) -> np.ndarray:
    """``K J^+ e`` (the SVD pseudo-inverse)."""
    Jp = np.linalg.pinv(J)
    return run.K * (Jp @ e)


def _dls_step(J: np.ndarray, e: np.ndarray, run: _Settings) -> np.ndarray:
    """``K J^T (J J^T + lambda^2 I)^-1 e``."""
    return run.K * (J.T @ np.linalg.solve(J @ J.T + run.damping * run.damping * np.eye(J.shape[0]), e))


#: The step of each method (a read-only table).
_STEPS = MappingProxyType({"jacobian_inverse": _inverse_step, "jacobian_transpose": _transpose_step,
                           "pseudo_inverse": _pseudo_inverse_step, "dls": _dls_step})


def _centred(robot: Robot, J: np.ndarray, q: np.ndarray, dq: np.ndarray,
             weights: np.ndarray) -> tuple[np.ndarray, float]:
    """``(dq + Z z, |Z z|_max)``: the step with the null-space centring correction (module docstring), the
    correction capped at :data:`CENTRING_MAX_STEP` (its size before the cap is returned)."""
    Z = null_space_basis(J)
    target_step = np.where(weights > 0, CENTRING_GAIN * (robot.middle() - q), 0.0)
    correction = null_space_correction(Z, weights, target_step - dq)
    biggest = float(np.abs(correction).max()) if correction.size else 0.0
    if biggest > CENTRING_MAX_STEP:
        correction *= CENTRING_MAX_STEP / biggest
    return dq + correction, biggest


def _iteration_cap(max_iter: int, iteration_budget: int | None) -> tuple[int, str]:
    """``(cap, message)``: the iterations a run may take and the message of a run that ends on that cap."""
    if iteration_budget is not None and int(iteration_budget) <= max_iter:
        return int(iteration_budget), f"iteration budget exhausted ({int(iteration_budget)} iterations)"
    return max_iter, f"iteration limit ({max_iter}) reached"
