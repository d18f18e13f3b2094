"""NumPy entry points without their Python wrappers, for the IK's hot loops (one place for the private names).

* :data:`clip` - the ``clip`` ufunc itself: ``np.clip`` adds a Python-level dispatch
  before reaching it; the result is the same.
* :data:`einsum` - NumPy's C ``einsum``: what ``np.einsum`` without ``optimize`` calls, minus its
  Python wrapper; the result is the same.

Both live in ``numpy._core`` (``numpy.core`` before NumPy 2).
"""

from __future__ import annotations

import numpy as np

_core = getattr(np, "_core", None) or np.core

clip = _core.umath.clip
einsum = _core._multiarray_umath.c_einsum
