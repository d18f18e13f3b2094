"""Convex hulls of a robot's collision meshes: coal's qhull, and scipy's qhull when coal cannot make one.

Every mesh (coal ``BVHModel``) of a collision ``GeometryModel`` is replaced by its
convex hull (why: :mod:`.collision_model`). coal builds it first
(``BVHModel.buildConvexHull(True, "Qt")``: qhull, triangulated facets kept). coal
stores the neighbour count of a hull vertex in one byte, so it refuses a hull
with a vertex of more than :data:`MAX_NEIGHBOURS` neighbours ("Too many
neighbors"): qhull's triangulation of a flat facet of ``n`` vertices is a fan,
one vertex joined to all ``n - 1`` others (centauro's pelvis: a 564-triangle fan).

**Fallback** (:func:`qhull_convex`): scipy's qhull (``scipy.spatial.ConvexHull``)
gives the same hull, its triangles grouped by facet (the triangles of one facet
share its plane equation exactly). Each facet's vertices, sorted by angle about
their centroid in the facet plane, form a convex polygon ``v_0 ... v_{n-1}``,
triangulated as a **strip** that zig-zags between the two sides,
``(v_0, v_1, v_{n-1}), (v_1, v_{n-2}, v_{n-1}), (v_1, v_2, v_{n-2}), ...``: each
vertex gets at most four neighbours inside the facet instead of up to
``n - 1``. Triangles are oriented outwards (``(b - a) x (c - a) . n > 0`` for the
facet's outward normal ``n``). The hull is the same point set as coal's; only
its triangulation differs, so the collision answers do not depend on which
qhull made it. A hull whose vertices still have more than
:data:`MAX_NEIGHBOURS` neighbours (a vertex on that many facets) cannot be held
by coal: :class:`~.errors.ModelError`.

coal's qhull is never called on a nearly flat mesh (it crashes the process): scipy's
qhull makes the hull of a thin one and refuses a flat one.

Every refusal is a :class:`~.errors.ModelError` naming the geometry, its link,
its mesh file and the cause; :class:`HullStatistics` reports the volume ratios
and the meshes that needed the fallback.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import coal
import numpy as np
import pinocchio as pin

from .errors import ModelError

if TYPE_CHECKING:
    from scipy.spatial import ConvexHull

#: Largest number of neighbours coal can store for one hull vertex (an unsigned char).
MAX_NEIGHBOURS = 255
#: Below this :func:`relative_thickness`, a mesh's hull is made by scipy's qhull only (coal's crashes on a
#: flat point set: a segmentation fault, not an exception).
FLAT_THICKNESS = 1e-6


@dataclass(frozen=True)
class HullFallback:
    """A mesh whose convex hull scipy's qhull made because coal's failed (``cause``: coal's message)."""

    geometry: str
    link: str
    mesh_file: str
    cause: str


@dataclass(frozen=True)
class HullStatistics:
    """What :func:`convex_hulls` did: ``volume_ratio`` ``{geometry name: volume(hull) / volume(mesh)}``
    (``nan`` when the mesh encloses no volume, e.g. an open surface) and the ``fallbacks``."""

    volume_ratio: dict[str, float]
    fallbacks: tuple[HullFallback, ...]


def mesh_label(obj: pin.GeometryObject, link: str) -> str:
    """``"geometry 'g' of link 'l' (mesh file 'f')"``: how messages name a collision mesh."""
    return f"geometry {obj.name!r} of link {link!r} (mesh file {obj.meshPath!r})"


def coal_message(exc: Exception) -> str:
    """The message part of a coal exception: its text after ``message:``, without the source location
    (``From file: ... in function: ... at line: ...``), its lines joined by ``"; "``. Any other text whole."""
    lines = str(exc).rsplit("message:", 1)[-1].strip().splitlines()
    return "; ".join(line.strip() for line in lines if line.strip())


def convex_hulls(geometry: pin.GeometryModel, links: Sequence[str],
                 on_mesh: Callable[[], None] | None = None) -> HullStatistics:
    """Replace every mesh (BVH model) of ``geometry`` in place by its convex hull (module docstring).

    ``links``: the link name of each geometry object (for messages). ``on_mesh`` is
    called once per geometry object (progress). Raises :class:`ModelError` naming
    the mesh (geometry, link, file) and the cause when no hull can be made.
    """
    ratios: dict[str, float] = {}
    fallbacks: list[HullFallback] = []
    for g, link in zip(geometry.geometryObjects, links):
        mesh = g.geometry
        if isinstance(mesh, coal.BVHModelBase):
            hull, cause = mesh_hull(mesh, mesh_label(g, link))
            if cause is not None:
                fallbacks.append(HullFallback(g.name, link, g.meshPath, cause))
            vol = float(mesh.computeVolume())
            ratios[g.name] = float(hull.computeVolume()) / vol if vol > 1e-15 else float("nan")
            g.geometry = hull
        if on_mesh is not None:
            on_mesh()
    return HullStatistics(ratios, tuple(fallbacks))


def mesh_hull(mesh: coal.BVHModelBase, label: str) -> tuple[coal.ConvexBase, str | None]:
    """``(hull, cause)``: coal's hull of ``mesh`` (``cause`` None) or, when coal fails or must not be asked,
    scipy's (:func:`qhull_convex`; ``cause`` = why not coal's). :class:`ModelError` naming ``label`` when the
    mesh has fewer than 4 vertices or neither qhull can make a solid of it.

    coal is not asked for the hull of a nearly flat mesh (:func:`relative_thickness` below
    :data:`FLAT_THICKNESS`) or one with non-finite vertices: its qhull call crashes the process on those.
    """
    if mesh.num_vertices < 4:
        raise ModelError(f"collision {label} has {mesh.num_vertices} vertices; a solid needs at least 4")
    points = np.asarray(mesh.vertices(), dtype=float)
    thickness = relative_thickness(points)
    if not np.all(np.isfinite(points)):
        cause = "non-finite vertex coordinates: coal's qhull not called"
    elif not thickness >= FLAT_THICKNESS:  # NaN: coincident vertices
        cause = f"nearly flat mesh (thickness / extent = {thickness:.3g}): coal's qhull not called"
    else:
        try:
            mesh.buildConvexHull(True, "Qt")  # keep the hull triangles: volume, drawing
            return mesh.convex, None
        except (RuntimeError, ValueError) as exc:
            cause = coal_message(exc)
    try:
        return qhull_convex(points), cause
    except ModelError as exc:
        raise ModelError(f"collision {label}: no convex hull: {cause}; scipy's qhull: {exc}") from None


def relative_thickness(points: np.ndarray) -> float:
    """``s_3 / s_1``: the smallest over the largest singular value of the centred ``points`` ``(n, 3)`` - how
    thin the point set is across its flattest direction, relative to its extent (0: flat; NaN: a point)."""
    if not np.all(np.isfinite(points)):
        return float("nan")
    s = np.linalg.svd(points - points.mean(axis=0), compute_uv=False)
    return float(s[2] / s[0]) if s[0] > 0.0 else float("nan")


def qhull_convex(points: np.ndarray) -> coal.Convex:
    """The convex hull of ``points`` ``(n, 3)`` as a coal ``Convex`` (scipy's qhull, facets
    strip-triangulated, module docstring). :class:`ModelError` when the points span no volume (flat,
    collinear, non-finite) or a hull vertex has more than :data:`MAX_NEIGHBOURS` neighbours."""
    from scipy.spatial import ConvexHull, QhullError  # (a model build, only when coal's hull failed)

    points = np.asarray(points, dtype=float).reshape(-1, 3)
    if not np.all(np.isfinite(points)):
        raise ModelError("the mesh has non-finite vertices")
    try:
        hull = ConvexHull(points)
    except (QhullError, ValueError) as exc:
        first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise ModelError(f"the vertices span no volume ({first})") from None
    triangles = facet_triangles(hull)
    used = np.unique(triangles)
    index = np.full(len(points), -1, dtype=np.int64)
    index[used] = np.arange(len(used))
    triangles = index[triangles]
    worst = max_neighbours(triangles, len(used))
    if worst > MAX_NEIGHBOURS:
        raise ModelError(f"a hull vertex has {worst} neighbours; coal holds at most {MAX_NEIGHBOURS}")
    vertices = coal.StdVec_Vec3s()
    for p in points[used]:
        vertices.append(p)
    polygons = coal.StdVec_Triangle()
    for a, b, c in triangles.tolist():
        polygons.append(coal.Triangle(a, b, c))
    return coal.Convex(vertices, polygons)


def facet_triangles(hull: ConvexHull) -> np.ndarray:
    """Triangles ``(T, 3)`` (indices into ``hull.points``) of every facet of ``hull``, oriented outwards:
    qhull's own where a facet has one or two, strip-triangulated where it has more (module docstring).
    Facets are the groups of qhull triangles with equal plane equations."""
    planes, facet_of, counts = np.unique(hull.equations, axis=0, return_inverse=True, return_counts=True)
    facet_of = facet_of.ravel()
    small = counts[facet_of] <= 2
    out = [oriented(hull.points, hull.simplices[small], hull.equations[small, :3])]
    rows = np.flatnonzero(~small)
    rows = rows[np.argsort(facet_of[rows], kind="stable")]
    starts = np.flatnonzero(np.diff(facet_of[rows], prepend=-1))
    for group in np.split(rows, starts[1:]) if len(rows) else ():
        normal = planes[facet_of[group[0]], :3]
        corners = np.unique(hull.simplices[group])
        tri = strip_triangulation(corners[polygon_order(hull.points[corners], normal)])
        out.append(oriented(hull.points, tri, np.broadcast_to(normal, tri.shape)))
    return np.concatenate(out).astype(np.int64)


def polygon_order(points: np.ndarray, normal: np.ndarray) -> np.ndarray:
    """The order of coplanar ``points`` ``(n, 3)`` about their centroid (angle in the plane of ``normal``)."""
    centre = points.mean(axis=0)
    u = np.cross(normal, [1.0, 0.0, 0.0] if abs(normal[0]) < 0.9 else [0.0, 1.0, 0.0])
    u /= np.linalg.norm(u)
    v = np.cross(normal, u)
    d = points - centre
    return np.argsort(np.arctan2(d @ v, d @ u), kind="stable")


def strip_triangulation(loop: np.ndarray) -> np.ndarray:
    """Triangles ``(n - 2, 3)`` of the convex polygon ``loop`` (vertex indices in order): a strip zig-zagging
    between the two sides from ``loop[0]``, so that no vertex has more than four polygon neighbours."""
    left, right = 0, len(loop) - 1
    out = []
    take_left = True
    while right - left >= 2:
        if take_left:
            out.append((loop[left], loop[left + 1], loop[right]))
            left += 1
        else:
            out.append((loop[left], loop[right - 1], loop[right]))
            right -= 1
        take_left = not take_left
    return np.array(out, dtype=np.int64).reshape(-1, 3)


def oriented(points: np.ndarray, triangles: np.ndarray, normals: np.ndarray) -> np.ndarray:
    """``triangles`` ``(T, 3)`` with the last two corners swapped where ``(b - a) x (c - a)`` points against
    the triangle's outward normal (``normals`` ``(T, 3)``)."""
    a, b, c = (points[triangles[:, k]] for k in range(3))
    flip = np.einsum("ij,ij->i", np.cross(b - a, c - a), normals) < 0.0
    out = triangles.copy()
    out[flip, 1], out[flip, 2] = triangles[flip, 2], triangles[flip, 1]
    return out


def max_neighbours(triangles: np.ndarray, n_vertices: int) -> int:
    """The largest number of distinct neighbours (vertices joined by a triangle side) of one vertex."""
    if len(triangles) == 0:
        return 0
    sides = np.concatenate([triangles[:, [0, 1]], triangles[:, [1, 2]], triangles[:, [2, 0]]])
    sides = np.unique(np.sort(sides, axis=1), axis=0)
    return int(np.bincount(sides.ravel(), minlength=n_vertices).max())
