"""The small exception hierarchy of kinserve.

Invalid *input* raises; failing to *reach* a target does not (that is an
``ik.Result`` with ``success=False``). Every message names the offending
argument and says what was expected, so a caller never has to read a
traceback from inside Pinocchio.

    KinserveError
    ├── ModelError            a model file / URDF / xacro / DH table is unusable
    ├── InputError (ValueError)
    │   ├── ShapeError        wrong shape or dtype
    │   ├── NonFiniteError    NaN or infinity (or absurdly large numbers)
    │   ├── FrameError        unknown frame name (lists close matches)
    │   ├── RotationError     rotation block not orthonormal / det != +1
    │   ├── JointLimitError   a joint value outside [lower, upper] when limits are checked
    │   └── UnknownRobotError unknown built-in robot name (lists the known ones)
    ├── SingularityError      a representation is undefined here (e.g. RPY at pitch = ±pi/2)
    └── WorkerError           a worker process of a batch failed (ik.solve_many)
        └── WorkerTimeoutError (TimeoutError)  a worker stalled or the batch's timeout expired
"""

from __future__ import annotations

import difflib
from collections.abc import Iterable


class KinserveError(Exception):
    """Base class of every error raised on purpose by kinserve.

    ``argument`` names the offending argument of the public call when the
    raiser knows it (e.g. ``"spheres"`` or ``"q0"`` from :func:`ik.solve`), so a
    front end (the HTTP service) can point at the right request field; None
    when not set.
    """

    argument: str | None = None


class ModelError(KinserveError):
    """A robot model (URDF, xacro, DH table, mesh reference) cannot be used."""


class InputError(KinserveError, ValueError):
    """An argument has the wrong value; the message names it and what was expected."""


class ShapeError(InputError):
    """An array argument has the wrong shape or cannot be read as numbers."""


class NonFiniteError(InputError):
    """An argument holds NaN, +-inf, or a magnitude beyond any physical meaning."""


class FrameError(InputError):
    """A frame name is not part of the model."""


class RotationError(InputError):
    """A rotation matrix is not orthonormal with determinant +1."""


class JointLimitError(InputError):
    """A joint value lies outside its limits (only raised when limits are checked)."""


class UnknownRobotError(InputError):
    """A robot name is neither built in nor a readable model file."""


class SingularityError(KinserveError):
    """A quantity is undefined at this configuration (a representation singularity)."""


class WorkerError(KinserveError):
    """A worker process of a batch (``ik.solve_many``) failed; the message names the worker and its chunk."""


class WorkerTimeoutError(WorkerError, TimeoutError):
    """A batch worker stalled (no answer within its chunk's time limit, or stopped) or the batch timed out."""


def suggest(name: str, known: Iterable[str], n: int = 3) -> str:
    """Return ' Did you mean: a, b?' for the closest names in ``known`` (or '').

    Case is ignored when comparing (``"UR5"`` suggests ``ur5``); names that
    differ only in case come first.
    """
    known = [str(k) for k in known]
    by_lower: dict[str, list[str]] = {}
    for k in known:
        by_lower.setdefault(k.lower(), []).append(k)
    key = str(name).lower()
    close = list(by_lower.get(key, []))
    for match in difflib.get_close_matches(key, list(by_lower), n=n, cutoff=0.5):
        close += [k for k in by_lower[match] if k not in close]
    close = close[:n]
    return f" Did you mean: {', '.join(close)}?" if close else ""
