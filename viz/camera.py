"""Camera framing: where meshcat's camera stands to show what a scene draws, and the commands that put it
there.

The camera model is meshcat's default camera, a three.js ``PerspectiveCamera``
with a vertical field of view of :data:`CAMERA_FOV_DEG`, looking from ``eye``
at ``target`` with world ``z`` up. With the view basis

    f = (target - eye) / |target - eye|,   r = f x z / |f x z|,   u = r x f,

a world point ``p`` projects to the normalised device coordinates

    x = ((p - eye) . r) / ((p - eye) . f) / (a tan(fov / 2)),
    y = ((p - eye) . u) / ((p - eye) . f) / tan(fov / 2),

``a`` the window's aspect (width / height); the window shows ``|x|, |y| <= 1``
(:func:`project`).

:func:`frame_points` chooses ``(eye, target)`` for a set of points (the
corners of the bounding boxes of what a scene draws): it looks along a fixed
elevation from the azimuth, among a few around the default front-right view,
that gives their projection the largest bounding rectangle, and places the
camera so that the projected points are centred in the window and span
``fill`` of it on the limiting axis - unless that would put the camera so
close that the farthest point is more than :data:`MAX_DEPTH_RATIO` times as
deep as the nearest (wide-angle distortion); then it stays back.
:func:`view_commands` turns ``(eye, target)`` into meshcat commands. The static
export and the live viewer both send a scene's :meth:`viz.Scene.commands`, so
both show the same framing.
"""

from __future__ import annotations

import numpy as np

from kinserve.kinematics.errors import InputError
from kinserve.kinematics.validation import as_vector

#: Vertical field of view of meshcat's default camera (degrees).
CAMERA_FOV_DEG = 75.0

#: Window aspect (width / height) the framing assumes: the narrowest usual window
#: (4:3), so wider windows (16:9 browsers, the 3:2 gallery shots) show a margin at the sides.
FRAMING_ASPECT = 4.0 / 3.0

#: Share of the window (normalised device coordinates) the projected points span on the limiting axis.
FRAMING_FILL = 0.9

#: Smallest distance (m) from the eye to the plane of the nearest point (meshcat's near plane is 0.01 m).
NEAR_MARGIN = 0.02

#: Largest ratio of the farthest to the nearest point's depth the framing allows (limits the
#: wide-angle distortion of a deep scene, e.g. a row of robots seen from its end).
MAX_DEPTH_RATIO = 3.0

#: Default view: from the front right, above (azimuth atan2(0.75, 1) = 36.9 deg, elevation 25.6 deg).
DEFAULT_DIRECTION = np.array([1.0, 0.75, 0.6])

#: Flat scenes (a floor plan) are seen steeply from the front (-y), above.
FLAT_DIRECTION = np.array([0.35, -0.75, 1.0])

#: Azimuth offsets (deg) tried around the default direction; the default wins ties.
AZIMUTH_OFFSETS_DEG = (0.0, -15.0, 15.0, -30.0, 30.0)


def view_basis(eye, target) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(r, u, f)``: right, up and forward unit vectors of a camera at ``eye`` looking at ``target`` (z
    up)."""
    eye, target = np.asarray(eye, dtype=float), np.asarray(target, dtype=float)
    f = target - eye
    n = np.linalg.norm(f)
    if n < 1e-12:
        raise InputError("camera eye and target must differ")
    f = f / n
    r = np.cross(f, [0.0, 0.0, 1.0])
    if np.linalg.norm(r) < 1e-9:  # looking straight down or up: any right vector will do
        r = np.array([1.0, 0.0, 0.0])
    r = r / np.linalg.norm(r)
    return r, np.cross(r, f), f


def project(points, eye, target, aspect: float = FRAMING_ASPECT,
            fov_deg: float = CAMERA_FOV_DEG) -> np.ndarray:
    """``(N, 2)`` normalised device coordinates ``(x right, y up)`` of world ``points`` (see the module
    docstring).

    Points in the window have ``|x| <= 1`` and ``|y| <= 1``; points behind the camera get NaN.
    """
    P = np.atleast_2d(np.asarray(points, dtype=float))
    r, u, f = view_basis(eye, target)
    d = P - np.asarray(eye, dtype=float)
    depth = d @ f
    t = np.tan(np.radians(fov_deg) / 2)
    with np.errstate(divide="ignore", invalid="ignore"):
        xy = np.c_[(d @ r) / (depth * aspect * t), (d @ u) / (depth * t)]
    xy[depth <= 0] = np.nan
    return xy


def box_corners(lo, hi) -> np.ndarray:
    """The 8 corners ``(8, 3)`` of the axis-aligned box ``[lo, hi]``."""
    lo, hi = np.asarray(lo, dtype=float), np.asarray(hi, dtype=float)
    return np.array([[(lo, hi)[i][0], (lo, hi)[j][1], (lo, hi)[k][2]] for i in (0, 1) for j in (0, 1)
                     for k in (0, 1)])


def fit_points(points, direction, *, aspect: float = FRAMING_ASPECT, fill: float = FRAMING_FILL,
               fov_deg: float = CAMERA_FOV_DEG,
               max_depth_ratio: float = MAX_DEPTH_RATIO) -> tuple[np.ndarray, np.ndarray]:
    """``(eye, target)`` looking along ``-direction`` (``eye - target`` is parallel to ``direction``)
    such that the projected ``points`` are centred in the window and span ``fill`` of it on
    their limiting axis (the other axis spans at most ``fill``).

    In the view basis ``(r, u, f)`` a point is in the window's ``|x| <= fill``
    band iff ``(p - e).(+-r - t_x f) <= 0`` with ``t_x = fill a tan(fov/2)``: the
    eye ``e`` lies on the inner side of two planes, ``e.n >= max_i p_i.n`` for
    ``n = +-r - t_x f``. Both tight gives the farthest-forward eye for that axis,
    ``e.f = -(m_+ + m_-) / (2 t_x)``; the same for ``y`` with ``u`` and
    ``t_y = fill tan(fov/2)``. The eye takes the farther back of the two; it
    also stays :data:`NEAR_MARGIN` behind the nearest point, and far enough
    back that the farthest point is at most ``max_depth_ratio`` times as deep
    as the nearest (``(p_max.f - e.f) <= R (p_min.f - e.f)``: a wide-angle
    camera close to a deep scene makes near objects huge; then the limiting
    axis spans less than ``fill``). On each axis its sideways
    coordinate then centres the projection (``max x + min x = 0``, monotone in
    that coordinate: bisection). The target is the point on the view axis at the
    depth of the points' bounding-box centre.
    """
    P = np.atleast_2d(np.asarray(points, dtype=float))
    if P.ndim != 2 or P.shape[1] != 3 or len(P) == 0 or not np.isfinite(P).all():
        raise InputError(f"points must be a finite (N, 3) array with N >= 1, got shape {np.shape(points)}")
    d = as_vector(direction, 3, "direction")
    if np.linalg.norm(d) < 1e-12:
        raise InputError("direction must be a non-zero 3-vector")
    if not (0.0 < fill <= 1.0 and aspect > 0.0 and max_depth_ratio > 1.0):
        raise InputError(f"fill must be in (0, 1], aspect > 0 and max_depth_ratio > 1; got fill={fill!r}, "
                         f"aspect={aspect!r}, max_depth_ratio={max_depth_ratio!r}")
    d = d / np.linalg.norm(d)
    r, u, f = view_basis(d, np.zeros(3))
    tx, ty = fill * aspect * np.tan(np.radians(fov_deg) / 2), fill * np.tan(np.radians(fov_deg) / 2)
    pr, pu, pf = P @ r, P @ u, P @ f
    # farthest-forward eye depth per axis: e.f = -(max(a - t pf) + max(-a - t pf)) / (2 t)
    ef_x = -(np.max(pr - tx * pf) + np.max(-pr - tx * pf)) / (2 * tx)
    ef_y = -(np.max(pu - ty * pf) + np.max(-pu - ty * pf)) / (2 * ty)
    R = float(max_depth_ratio)
    ef = min(ef_x, ef_y, float(pf.min()) - NEAR_MARGIN, (R * float(pf.min()) - float(pf.max())) / (R - 1.0))
    depth = pf - ef
    er = _centring_offset(pr, depth, tx)
    eu = _centring_offset(pu, depth, ty)
    eye = er * r + eu * u + ef * f
    centre = 0.5 * (P.min(axis=0) + P.max(axis=0))
    return eye, eye + float((centre - eye) @ f) * f


def _centring_offset(a: np.ndarray, depth: np.ndarray, t: float) -> float:
    """The sideways eye coordinate ``e`` with ``max + min`` of ``(a - e) / (depth t)`` equal to zero.

    The sum decreases strictly as ``e`` grows; bisection between a coordinate
    left of every point's sight line and one right of it (60 halvings).
    """
    ratio_span = float(np.max(np.abs(a))) + float(np.max(depth)) * t + 1.0
    lo, hi = -ratio_span - float(np.max(np.abs(a))), ratio_span + float(np.max(np.abs(a)))
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        x = (a - mid) / (depth * t)
        if x.max() + x.min() > 0:
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi)


def _direction(azimuth_deg: float, elevation_deg: float) -> np.ndarray:
    az, el = np.radians(azimuth_deg), np.radians(elevation_deg)
    return np.array([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)])


def frame_points(points, *, aspect: float = FRAMING_ASPECT,
                 fill: float = FRAMING_FILL) -> tuple[np.ndarray, np.ndarray]:
    """``(eye, target)`` showing the world ``points`` (``(N, 3)`` metres: e.g. the corners of the
    bounding boxes of everything a scene draws) large and centred.

    Points whose bounding box is much flatter than wide (height < 10 % of its
    larger horizontal side: a floor plan) are seen along :data:`FLAT_DIRECTION`;
    otherwise the view keeps the elevation of :data:`DEFAULT_DIRECTION` and
    takes the azimuth, among :data:`AZIMUTH_OFFSETS_DEG` around the default,
    whose framing (:func:`fit_points`, depth ratio capped) gives the projected
    points the largest bounding rectangle (the default unless another is 10 %
    larger). A set smaller than 10 cm is framed as a
    10 cm box around its centre.
    """
    P = np.atleast_2d(np.asarray(points, dtype=float))
    if P.ndim != 2 or P.shape[1] != 3 or len(P) == 0 or not np.isfinite(P).all():
        raise InputError(f"points must be a finite (N, 3) array with N >= 1, got shape {np.shape(points)}")
    lo, hi = P.min(axis=0), P.max(axis=0)
    pad = np.maximum(0.1 - (hi - lo), 0.0) / 2
    if pad.any():
        P = np.vstack([P, box_corners(lo - pad, hi + pad)])
        lo, hi = lo - pad, hi + pad
    if (hi[2] - lo[2]) < 0.1 * max(hi[0] - lo[0], hi[1] - lo[1]):
        return fit_points(P, FLAT_DIRECTION, aspect=aspect, fill=fill)
    az0 = np.degrees(np.arctan2(DEFAULT_DIRECTION[1], DEFAULT_DIRECTION[0]))
    el = np.degrees(np.arctan2(DEFAULT_DIRECTION[2], np.hypot(DEFAULT_DIRECTION[0], DEFAULT_DIRECTION[1])))
    best, best_cover = None, 0.0
    for off in AZIMUTH_OFFSETS_DEG:
        eye, target = fit_points(P, _direction(az0 + off, el), aspect=aspect, fill=fill)
        xy = project(P, eye, target, aspect)
        cover = float(np.ptp(xy[:, 0]) * np.ptp(xy[:, 1])) / 4.0  # share of the window of the points' box
        if best is None or cover > 1.1 * best_cover:
            best, best_cover = (eye, target), cover
    return best


def view_commands(eye, target) -> list[dict]:
    """meshcat commands placing the camera at ``eye`` looking at ``target``.

    meshcat's orbit controls always aim the camera at the *viewer's* world
    origin (three.js ``lookAt`` takes world coordinates), whatever the
    transform of ``/Cameras/default``. So the view is centred by shifting the
    drawing instead: ``/meshcat`` (everything a scene draws), the ground
    ``/Grid`` and the ``/Axes`` are translated by ``-target``, and the camera
    sits at ``eye - target`` from the origin, expressed in the y-up axes of its
    ``rotated`` node: ``(dx, dz, -dy)``. Orbiting then turns about ``target``.
    """
    eye, target = as_vector(eye, 3, "eye"), as_vector(target, 3, "target")
    if np.linalg.norm(eye - target) < 1e-6:
        raise InputError("camera eye and target must differ")
    d = eye - target
    shift = np.eye(4)
    shift[:3, 3] = -target
    shift = [float(v) for v in shift.T.flatten()]
    return [
        {"type": "set_transform", "path": "/meshcat", "matrix": shift},
        {"type": "set_transform", "path": "/Grid", "matrix": shift},
        {"type": "set_transform", "path": "/Axes", "matrix": shift},
        {"type": "set_transform", "path": "/Cameras/default",
         "matrix": [float(v) for v in np.eye(4).flatten()]},
        {"type": "set_property", "path": "/Cameras/default/rotated/<object>", "property": "position",
         "value": [float(d[0]), float(d[2]), float(-d[1])]},
    ]
