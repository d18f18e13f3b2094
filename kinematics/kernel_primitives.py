"""Compiled primitives shared by the kernels: a rotation about an axis, the forward kinematics of a tree, and
row views of packed arrays.

Written once here and inlined (Numba IR) into the kernels of :mod:`.precheck_kernels`,
:mod:`kinserve.ik.constraints.clearance_kernel` and :mod:`kinserve.ik.lm.kernel`; the cache key of all of
them covers this file (:mod:`.kernel_cache`), so a change here recompiles every kernel that inlines it.

* :func:`axis_rotation`: ``Rot(a, q) = I + sin(q) [a]x + (1 - cos(q)) [a]x^2`` (Rodrigues, ``a`` a unit
  axis), its nine entries row by row.
* :func:`tree_placements_into`: every joint's world placement ``oMj = oM(parent) Mj exp(a_j q_j)`` of a
  tree packed by :func:`kinserve.kinematics.serial_chain.kinematic_tree` (``tree[k]``: ``Mj``'s rotation
  row-major 0-8, translation 9-11, axis 12-14; ``joints[k]``: kind, ``q`` index, parent row), into rows of
  12 (rotation row-major, translation), row 0 the universe.
* :func:`rows_view`: the ``(rows, cols)`` C-ordered view of the start of a flat C-ordered array, built
  directly: Numba's ``reshape`` calls a C helper that works out the strides, and inlines its checks, on
  every call, and the pre-check kernels view their packed arrays on every call.

Metres and radians.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numba.core import cgutils, types
from numba.core.extending import intrinsic
from numba.core.imputils import impl_ret_borrowed
from numba.np.arrayobj import make_array, populate_array

from .kernel_cache import inline
from .serial_chain import REVOLUTE as _REVOLUTE


@inline
def axis_rotation(ax: float, ay: float, az: float, q: float) -> tuple[float, ...]:
    """The entries ``(r00, r01, r02, r10, ..., r22)`` of ``Rot(a, q)`` (Rodrigues' formula)."""
    s, c = math.sin(q), math.cos(q)
    v = 1.0 - c
    return (c + v * ax * ax, v * ax * ay - s * az, v * ax * az + s * ay,
            v * ax * ay + s * az, c + v * ay * ay, v * ay * az - s * ax,
            v * ax * az - s * ay, v * ay * az + s * ax, c + v * az * az)


@inline
def tree_placements_into(tree: np.ndarray, joints: np.ndarray, q: np.ndarray, X: np.ndarray) -> None:
    """Every joint's world placement at ``q`` into ``X`` ``(J + 1, 12)`` (module docstring)."""
    for c in range(12):
        X[0, c] = 0.0
    X[0, 0] = X[0, 4] = X[0, 8] = 1.0
    for k in range(joints.shape[0]):
        g = tree[k]
        P = X[joints[k, 2]]
        out = X[k + 1]
        # out.t = P.t + P.R Mk.t ; T = P.R Mk.R (kept in out.R for now)
        for i in range(3):
            p0, p1, p2 = P[3 * i], P[3 * i + 1], P[3 * i + 2]
            out[9 + i] = P[9 + i] + p0 * g[9] + p1 * g[10] + p2 * g[11]
            for c in range(3):
                out[3 * i + c] = p0 * g[c] + p1 * g[3 + c] + p2 * g[6 + c]
        ax, ay, az = g[12], g[13], g[14]
        qk = q[joints[k, 1]]
        if joints[k, 0] == _REVOLUTE:  # R = T Rot(a, q)
            r00, r01, r02, r10, r11, r12, r20, r21, r22 = axis_rotation(ax, ay, az, qk)
            for i in range(3):
                t0, t1, t2 = out[3 * i], out[3 * i + 1], out[3 * i + 2]
                out[3 * i] = t0 * r00 + t1 * r10 + t2 * r20
                out[3 * i + 1] = t0 * r01 + t1 * r11 + t2 * r21
                out[3 * i + 2] = t0 * r02 + t1 * r12 + t2 * r22
        else:  # prismatic: t += T a q, R = T
            for i in range(3):
                out[9 + i] += (out[3 * i] * ax + out[3 * i + 1] * ay + out[3 * i + 2] * az) * qk


def _is_flat(array: types.Type, rows: types.Type, cols: types.Type) -> bool:
    """Whether the row views below have an implementation for these argument types: a 1-D C-ordered array
    and two integers."""
    return (isinstance(array, types.Array) and array.ndim == 1 and array.layout == "C"
            and isinstance(rows, types.Integer) and isinstance(cols, types.Integer))


def _rows_view_codegen(view: types.Array) -> Any:
    """The code of a ``(rows, cols)`` C-ordered view ``view`` of a 1-D C-ordered array's first
    ``rows * cols`` items: its data pointer (cast to the view's item type), shape, strides, meminfo and
    parent; no copy, no check. Both arrays' items are ``view``'s size."""

    def codegen(context, builder, signature, args):
        source = make_array(signature.args[0])(context, builder, args[0])
        out = make_array(view)(context, builder)
        n_rows, n_cols = (context.cast(builder, value, kind, types.intp)
                          for value, kind in zip(args[1:], signature.args[1:]))
        item = source.itemsize
        populate_array(out, data=builder.bitcast(source.data, out.data.type),
                       shape=cgutils.pack_array(builder, [n_rows, n_cols]),
                       strides=cgutils.pack_array(builder, [builder.mul(n_cols, item), item]),
                       itemsize=item, meminfo=source.meminfo, parent=source.parent)
        return impl_ret_borrowed(context, builder, view, out._getvalue())

    return codegen


@intrinsic
def rows_view(typingctx: Any, flat: types.Type, rows: types.Type, cols: types.Type) -> Any:
    """``flat[:rows * cols].reshape((rows, cols))`` for a 1-D C-ordered array ``flat`` (compiled code only):
    a C-ordered 2-D view sharing ``flat``'s memory and owner, read-only when ``flat`` is. Unchecked: the
    caller guarantees ``0 <= rows``, ``0 <= cols`` and ``rows * cols <= len(flat)``."""
    if not _is_flat(flat, rows, cols):
        return None  # no implementation for these types: a typing error
    view = flat.copy(ndim=2, layout="C")
    return view(flat, rows, cols), _rows_view_codegen(view)


@intrinsic
def float_rows_view(typingctx: Any, words: types.Type, rows: types.Type, cols: types.Type) -> Any:
    """``words[:rows * cols].view(np.float64).reshape((rows, cols))`` for a 1-D C-ordered int64 array
    ``words`` (compiled code only): float64 values stored as their bit patterns among integer words (one per
    word), read as a C-ordered 2-D float64 view sharing ``words``' memory and owner, read-only when ``words``
    is (as :func:`rows_view`; no call, no check). Unchecked: the caller guarantees ``0 <= rows``,
    ``0 <= cols`` and ``rows * cols <= len(words)``."""
    if not (_is_flat(words, rows, cols) and words.dtype == types.int64):
        return None  # no implementation for these types: a typing error
    view = words.copy(dtype=types.float64, ndim=2, layout="C")
    return view(words, rows, cols), _rows_view_codegen(view)
