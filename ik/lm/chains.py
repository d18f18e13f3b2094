"""The compiled LM's chains of one robot: :class:`CompiledChains`, built by :func:`warm`, read by
:func:`compiled_chain`.

The kernel of :mod:`kinserve.ik.lm.kernel` evaluates the serial chain from the root to a frame as flat
arrays (:func:`kinserve.kinematics.serial_chain.serial_chain`). A :class:`CompiledChains` packs them for
every frame of a robot's model once, together with the kernel module (importing it loads Numba and the
compiled code from Numba's cache), so that no solve packs a chain or imports Numba inside its time budget.

It is owned by the robot: :func:`warm` builds it and sets ``robot.lm_chains`` (shared by every
``robot.copy()``; pickled with the robot - arrays only, the kernel is imported again on the other side).
:func:`compiled_chain` reads it; a robot nobody warmed is warmed there, by the request's validation, before
any solver's clock starts.
"""

from __future__ import annotations

from types import ModuleType
from typing import TYPE_CHECKING, NamedTuple

import numpy as np

from kinserve.kinematics.serial_chain import joint_table

if TYPE_CHECKING:  # annotations only
    import pinocchio as pin

    from kinserve.kinematics.robot import Robot


class CompiledChain(NamedTuple):
    """The chain to one frame as the kernel reads it (layout of :mod:`kinserve.kinematics.serial_chain`)."""

    geometry: np.ndarray  #: ``(n + 1, 15)``: joint placements and axes, then the frame's placement
    joints: np.ndarray  #: ``(n, 2)`` int64: joint kind, index in ``q``
    kernel: ModuleType  #: :mod:`kinserve.ik.lm.kernel` (``run_start``, ``run_many``)


def _load_kernel() -> ModuleType | None:
    """:mod:`kinserve.ik.lm.kernel`, or None when Numba is not installed (the Python iteration then runs)."""
    try:
        from kinserve.ik.lm import kernel
    except ImportError:
        return None
    return kernel


def packed_chains(model: pin.Model) -> tuple[tuple[np.ndarray, np.ndarray] | None, ...]:
    """:func:`kinserve.kinematics.serial_chain.serial_chain` of every frame of ``model``, in frame order:
    the model is read once (:func:`kinserve.kinematics.serial_chain.joint_table`) and each frame's chain is
    the table's rows of the joints on its path, root first, plus the frame's own placement."""
    table = joint_table(model)
    return tuple(table.serial(f) for f in range(model.nframes))


class CompiledChains:
    """The :class:`CompiledChain` of every frame of one robot's model (None for a frame whose path has a joint
    the kernel does not model, and for every frame when Numba is missing)."""

    __slots__ = ("kernel", "chains")

    def __init__(self, model: pin.Model) -> None:
        self.kernel = _load_kernel()
        packed = packed_chains(model) if self.kernel is not None else (None,) * model.nframes
        self._set(packed)

    def _set(self, packed) -> None:
        kernel = self.kernel
        self.chains = tuple(None if c is None or kernel is None else CompiledChain(c[0], c[1], kernel)
                            for c in packed)

    def chain(self, frame_id: int) -> CompiledChain | None:
        """The chain to frame ``frame_id`` (a Pinocchio frame index), or None."""
        return self.chains[frame_id]

    def __getstate__(self) -> tuple:
        return tuple(None if c is None else (c.geometry, c.joints) for c in self.chains)

    def __setstate__(self, packed: tuple) -> None:
        self.kernel = _load_kernel()
        self._set(packed)


def warm(robot: Robot) -> CompiledChains:
    """Build the robot's :class:`CompiledChains` now (the kernel imported, every frame's chain packed) and set
    it as ``robot.lm_chains``; returns it. Later solves of any frame find it ready."""
    chains = CompiledChains(robot.model)
    robot.lm_chains = chains
    return chains


def compiled_chains(robot: Robot) -> CompiledChains:
    """``robot.lm_chains``, built by :func:`warm` if nobody warmed the robot yet."""
    chains = robot.lm_chains
    return chains if chains is not None else warm(robot)


def compiled_chain(robot: Robot, frame_id: int) -> CompiledChain | None:
    """The :class:`CompiledChain` to frame ``frame_id`` of ``robot``, or None (no Numba, or a joint on the
    path that the kernel does not model: the solvers then iterate with Pinocchio's algorithms)."""
    chains = robot.lm_chains  # (compiled_chains inlined: called on every solve)
    return (chains if chains is not None else warm(robot)).chains[frame_id]
