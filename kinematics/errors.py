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
    └── SingularityError      a representation is undefined here (e.g. RPY at pitch = ±pi/2)
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


def suggest(name: str, known: Iterable[str], n: int = 3) -> str:
    """Return ' Did you mean: a, b?' for the closest names in ``known`` (or '')."""
    close = difflib.get_close_matches(str(name), list(known), n=n, cutoff=0.5)
    return f" Did you mean: {', '.join(close)}?" if close else ""
