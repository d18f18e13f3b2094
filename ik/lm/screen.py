"""The pre-check that runs in the same compiled call as each LM start (the checked LM's screen)."""

from __future__ import annotations

from collections.abc import Callable
from typing import NamedTuple

import numpy as np


class LMScreen(NamedTuple):
    """A pre-check that runs in the same compiled call as each LM start
    (:func:`kinserve.ik.lm.screened_kernel.run_screened_start` is ``run``): it certifies the start before
    the run and a converged run's rows after it. ``floats``, ``ints``, ``tolerance``: the scene's pre-check
    arguments (:class:`~kinserve.kinematics.scene_precheck.PrecheckArguments`)."""

    run: Callable[..., tuple[int, int, int, int]]
    floats: np.ndarray
    ints: np.ndarray
    tolerance: float


__all__ = ["LMScreen"]
