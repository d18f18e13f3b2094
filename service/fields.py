"""Library errors attributed to the request field they concern (the ``loc`` of an error answer)."""

from __future__ import annotations

import contextlib

from kinserve.kinematics.errors import FrameError, KinserveError, UnknownRobotError


class FieldError(Exception):
    """A library error tagged with the request field it concerns (picklable: it crosses process pools)."""

    def __init__(self, field: str, error: Exception, status: int = 422):
        super().__init__(str(error))
        self.field, self.error, self.status = field, error, status

    def __reduce__(self):
        return (FieldError, (self.field, self.error, self.status))


@contextlib.contextmanager
def field(name: str):
    """Attribute any :class:`KinserveError` raised inside to request field ``name``.

    An error that names its own argument (``exc.argument``, e.g. ``spheres`` or
    ``q0`` from :func:`ik.solve`) is attributed to that field instead; an
    unknown frame to ``frame`` (or to ``spheres`` when raised for a sphere);
    an unknown robot to ``robot`` with status 404.
    """
    try:
        yield
    except UnknownRobotError as exc:
        raise FieldError("robot", exc, 404) from None
    except KinserveError as exc:
        arg = exc.argument
        if arg is None or arg == "target":
            arg = "frame" if isinstance(exc, FrameError) and name != "spheres" else name
        raise FieldError(arg, exc) from None
