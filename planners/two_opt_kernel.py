"""First-improvement 2-opt over an order of checkpoints, compiled (Numba): the loop of
:func:`~.checkpoint_order.two_opt`.

A move reverses the segment ``o[i..k]`` (``1 <= i < k < last``: the first point never moves, nor the last when
the caller fixes it). Its change of cost, for a cost matrix ``C`` that need not be symmetric, is

    C[o[i-1], o[k]] - C[o[i-1], o[i]] + (B[k] - B[i]) - (F[k] - F[i]) + C[o[i], o[k+1]] - C[o[k], o[k+1]]

with ``F`` and ``B`` the prefix sums of the path's forward and backward edge costs (``F[j] = sum_{t<j} C[o[t],
o[t+1]]``, ``B[j] = sum_{t<j} C[o[t+1], o[t]]``), the last two terms only when ``o[k]`` has a successor
(``o[k+1]``, or ``o[0]`` on a closed tour). Each round takes the first move (``i`` ascending, then ``k``) that
lowers the cost by more than ``1e-12`` and applies it; the rounds stop when none does, or after
``max_rounds``. A round does not evaluate again what the last move left as it was: after a move at row ``i0``,
every segment ``(i, k)`` with ``i < i0`` and ``k <= i0 - 2`` (both ends and every inner edge before ``i0``,
prefix sums included) has the change it had when that round found no move there. The arithmetic is done in the
order written above, and the prefix sums one term at a time, so the moves are the ones a NumPy evaluation of
the same expression finds. Costs in the caller's units.

The cache key covers every kernel source (:mod:`kinserve.kinematics.kernel_cache`); importing this module
compiles the kernel or loads it from that cache.
"""

from __future__ import annotations

import numba
import numpy as np

from kinserve.kinematics.kernel_cache import F2, compiled

#: Smallest decrease of the cost (in the cost's units) that counts as an improvement.
MIN_GAIN = 1e-12

_SIGNATURE = numba.types.int64(F2, numba.types.int64[::1], numba.types.int64, numba.types.boolean,
                               numba.types.int64)


@compiled(_SIGNATURE)
def reverse_while_improving(C: np.ndarray, o: np.ndarray, last: int, closed: bool, max_rounds: int) -> int:
    """Apply first-improving reversals to the order ``o`` ``(n,)`` (indices into ``C`` ``(N, N)``), in place,
    until none improves or ``max_rounds`` moves are made (module docstring); ``last``: segments end before
    it (``n - 1`` to keep the last point, else ``n``); ``closed``: a tour back to ``o[0]``. Returns the number
    of moves made."""
    n = o.shape[0]
    forward = np.empty(n)
    backward = np.empty(n)
    successors = n if closed else n - 1
    moved = 0  # the row i of the last move (0: none yet)
    for moves in range(max_rounds):
        forward[0] = 0.0
        backward[0] = 0.0
        for j in range(n - 1):
            forward[j + 1] = forward[j] + C[o[j], o[j + 1]]
            backward[j + 1] = backward[j] + C[o[j + 1], o[j]]
        best_i = -1
        best_k = -1
        for i in range(1, last - 1):
            a = o[i - 1]
            b = o[i]
            # rows before the last move's row: its ends k <= moved - 2 are unchanged and did not improve
            for k in range(max(i + 1, moved - 1) if i < moved else i + 1, last):
                c = o[k]
                delta = C[a, c] - C[a, b] + (backward[k] - backward[i]) - (forward[k] - forward[i])
                if k < successors:
                    d = o[k + 1] if k + 1 < n else o[0]
                    delta += C[b, d] - C[c, d]
                if delta < -MIN_GAIN:
                    best_i = i
                    best_k = k
                    break
            if best_i >= 0:
                break
        if best_i < 0:
            return moves
        moved = best_i
        lo = best_i
        hi = best_k
        while lo < hi:
            o[lo], o[hi] = o[hi], o[lo]
            lo += 1
            hi -= 1
    return max_rounds


__all__ = ["MIN_GAIN", "reverse_while_improving"]
