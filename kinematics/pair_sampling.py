"""The sampled "always" / "never" tests of :mod:`.collision_pairs`, coal run only where it can answer yes.

**The rule**: over ``N`` sampled configurations, a link pair in collision in
``n`` of them - a sample counts when any geometry pair of the two links collides -
is *never* in collision when ``n = 0``, *always* when ``n >= f N`` (``f``:
``always_fraction``), and checked otherwise.

**The contact test** is coal's ``collide`` with a fresh ``coal.CollisionRequest()``
(contacts enabled, GJK started from its default guess, zero security margin), so
that every answer depends on the configuration only, never on the calls before
it. Pinocchio's own ``GeometryData`` requests disable contacts and start GJK from
the previous call's result: with them coal reports some penetrating shapes free
(youbot's ``joint1_link`` / ``link4`` cylinders, 3 cm deep) and an answer depends
on which calls came before - which a test that skips calls cannot reproduce.

**Bounding spheres.** Each geometry ``g`` gets a sphere ``(c_g, r_g)`` fixed in its
joint frame that contains it (:func:`bounding_spheres`). For a pair ``(a, b)`` at
sample ``q``, ``|c_a(q) - c_b(q)| - r_a - r_b`` is a lower bound of the distance
of the two geometries; when it exceeds :data:`TOLERANCE` (ten times coal's GJK
tolerance) coal cannot report a collision, so the sample
counts as free without asking coal. The centres of all samples come from one
batch of forward kinematics (:func:`~.batch_tree_fk.joint_placements`) and the
bound of every (sample, pair) from a few array operations.

**Early decisions.** With ``n`` collisions and ``m`` free samples known for a link
pair, its final count lies in ``[n, N - m]``; once ``n >= 1`` and
``N - m < f N`` it is checked whatever the other samples give, and once
``n >= f N`` it is *always*: coal is no longer called on it. A pair whose spheres
never come close is *never* without any coal call. Every verdict is the one the
full count gives.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import coal
import numpy as np
import pinocchio as pin

from .batch_tree_fk import joint_placements

#: A pair is certified free when its spheres' gap exceeds this (m): ten times coal's GJK tolerance, so that
#: coal's contact test, whose distances are exact to about 1e-6 m on these shapes, agrees.
TOLERANCE = 1e-5
#: Padding (m) of a bounding sphere's radius (rounding of the vertex distances).
PAD = 1e-9
#: Pairs per block of the bound computation (bounds the temporary arrays: block x samples floats).
PAIR_BLOCK = 256
#: Samples between two progress reports.
PROGRESS_STEP = 50

Verdict = str | None  # "Never", "Always" or None (checked)


def bounding_spheres(geometry: pin.GeometryModel) -> np.ndarray:
    """``(G, 4)``: per geometry object, a sphere (centre in its joint frame, radius; m) that contains it.

    Meshes and convex hulls: centre of the vertices' bounding box, radius the largest vertex distance from
    it; other shapes: coal's local AABB sphere (``aabb_center``, ``aabb_radius``). coal's swept-sphere radius
    and :data:`PAD` are added; a radius that is not finite becomes ``inf`` (never certified).
    """
    out = np.zeros((geometry.ngeoms, 4))
    for i, g in enumerate(geometry.geometryObjects):
        geo = g.geometry
        if isinstance(geo, coal.ConvexBase):
            V = np.asarray(geo.points(), dtype=float)
        elif isinstance(geo, coal.BVHModelBase):
            V = np.asarray(geo.vertices(), dtype=float)
        else:
            V = None
        if V is not None and len(V):
            centre = 0.5 * (V.min(axis=0) + V.max(axis=0))
            radius = float(np.sqrt(((V - centre) ** 2).sum(axis=1).max()))
        else:
            geo.computeLocalAABB()
            centre, radius = np.asarray(geo.aabb_center, dtype=float), float(geo.aabb_radius)
        swept = getattr(geo, "getSweptSphereRadius", None)  # shapes have one, BVH meshes not
        radius += (float(swept()) if swept is not None else 0.0) + PAD
        out[i, :3] = g.placement.act(centre)
        out[i, 3] = radius if np.isfinite(radius) and np.all(np.isfinite(out[i, :3])) else np.inf
    return out


def world_centres(model: pin.Model, geometry: pin.GeometryModel, spheres: np.ndarray,
                  Q: np.ndarray) -> np.ndarray:
    """``(G, 3, N)``: the bounding-sphere centres (``spheres`` ``(G, 4)``, joint frames) in the world at each
    row of ``Q`` (the configuration last): ``c_world = R_j c + t_j`` for the geometry's joint ``j``."""
    placements = joint_placements(model, Q)
    joints = np.array([g.parentJoint for g in geometry.geometryObjects], dtype=np.int64)
    return (np.einsum("gijn,gj->gin", placements.rotations[joints], spheres[:, :3])
            + placements.translations[joints])


def possibly_touching(centres: np.ndarray, radii: np.ndarray, pairs: np.ndarray) -> np.ndarray:
    """``(P, N)`` booleans: True where the spheres of pair ``p`` (geometry indices ``pairs[p]``) at sample
    ``s`` are not farther apart than :data:`TOLERANCE`, ``|c_a - c_b|^2 <= (r_a + r_b + TOLERANCE)^2``.
    ``centres`` ``(G, 3, N)`` world centres (:func:`world_centres`), ``radii`` ``(G,)`` (m)."""
    N, P = centres.shape[2], len(pairs)
    out = np.empty((P, N), dtype=bool)
    coords = [np.ascontiguousarray(centres[:, k]) for k in range(3)]  # (G, N) each
    for p0 in range(0, P, PAIR_BLOCK):
        a, b = pairs[p0:p0 + PAIR_BLOCK, 0], pairs[p0:p0 + PAIR_BLOCK, 1]
        d2 = np.zeros((len(a), N))
        for x in coords:
            d = x[a] - x[b]
            d *= d
            d2 += d
        need = radii[a] + radii[b] + TOLERANCE
        np.less_equal(d2, (need * need)[:, None], out=out[p0:p0 + PAIR_BLOCK])
    return out


def contact_request() -> coal.CollisionRequest:
    """The request of the contact test (module docstring): coal's defaults - contacts enabled, no cached GJK
    guess - at zero security margin."""
    request = coal.CollisionRequest()
    request.security_margin = 0.0
    return request


class PairChecker:
    """coal's contact test (:func:`contact_request`) of the collision pairs of ``geometry`` (a collision
    ``GeometryModel`` of ``model`` that holds the pairs), behind the bounding spheres of its geometries.

    Pair ids are indices into ``geometry.collisionPairs``. The Pinocchio workspaces are the checker's own:
    one thread at a time.
    """

    def __init__(self, model: pin.Model, geometry: pin.GeometryModel) -> None:
        self.model = model
        self.geometry = geometry
        self.pairs = np.array([(cp.first, cp.second) for cp in geometry.collisionPairs],
                              dtype=np.int64).reshape(-1, 2)
        self.spheres = bounding_spheres(geometry)
        self._data = model.createData()
        self._gdata = pin.GeometryData(geometry)
        self._request = contact_request()

    def touching(self, Q: np.ndarray, pair_ids: np.ndarray) -> np.ndarray:
        """``(len(pair_ids), N)``: :func:`possibly_touching` of pairs ``pair_ids`` at the rows of ``Q``."""
        centres = world_centres(self.model, self.geometry, self.spheres, Q)
        return possibly_touching(centres, self.spheres[:, 3], self.pairs[pair_ids])

    def place(self, q: np.ndarray) -> None:
        """Put every geometry at configuration ``q`` (Pinocchio's forward kinematics) for :meth:`collides`."""
        pin.updateGeometryPlacements(self.model, self._data, self.geometry, self._gdata, q)

    def collides(self, pair_id: int) -> bool:
        """coal's verdict (:func:`contact_request`) on pair ``pair_id`` at the configuration of the last
        :meth:`place`."""
        return bool(pin.computeCollision(self.geometry, self._gdata, pair_id, self._request))

    def colliding(self, q: np.ndarray, pair_ids: Sequence[int]) -> list[int]:
        """The pairs of ``pair_ids`` in collision at ``q``: coal on those whose spheres are not apart."""
        ids = np.asarray(pair_ids, dtype=np.int64)
        close = ids[self.touching(np.asarray(q, dtype=float)[None, :], ids)[:, 0]]
        self.place(q)
        return [k for k in close.tolist() if self.collides(k)]


class _Tally:
    """Per link pair: samples in collision (``hits``) and known free (``free``), and which are decided."""

    def __init__(self, n_links: int, certified_free: np.ndarray, n_samples: int,
                 always_fraction: float) -> None:
        self.hits = np.zeros(n_links, dtype=np.int64)
        self.free = certified_free.astype(np.int64)
        self.N = n_samples
        self.need = always_fraction * n_samples
        self.undecided = np.ones(n_links, dtype=bool)

    def add(self, tested: np.ndarray, hit: list[int]) -> None:
        """Record a sample: the link pairs ``tested`` (coal asked), of which ``hit`` were in collision."""
        self.free[tested] += 1
        if hit:
            self.free[hit] -= 1
            self.hits[hit] += 1
        h, f = self.hits[tested], self.free[tested]
        self.undecided[tested] = ~(((h >= 1) & (self.N - f < self.need)) | (h >= self.need))

    def verdicts(self) -> list[Verdict]:
        """``"Never"`` (no hit), ``"Always"`` (hits >= the fraction) or None, per link pair."""
        return ["Never" if n == 0 else "Always" if n >= self.need else None for n in self.hits.tolist()]


def sampled_verdicts(checker: PairChecker, pair_ids: Sequence[int], owner: Sequence[int], n_links: int,
                     Q: np.ndarray, always_fraction: float,
                     progress: Callable[[int], None] | None = None) -> list[Verdict]:
    """Per link pair ``l < n_links``, its verdict over the samples ``Q`` ``(N, nq)`` (module docstring).

    Geometry pair ``pair_ids[k]`` of ``checker`` belongs to link pair ``owner[k]``. ``progress(k)`` is called
    with the number of samples done since its last call.
    """
    N = len(Q)
    order = np.argsort(np.asarray(owner, dtype=np.int64), kind="stable")
    ids, owner = np.asarray(pair_ids, dtype=np.int64)[order], np.asarray(owner, dtype=np.int64)[order]
    rows, samples = np.nonzero(checker.touching(Q, ids))  # rows grouped by link pair
    link_touching = np.zeros((n_links, N), dtype=bool)
    link_touching[owner[rows], samples] = True
    tally = _Tally(n_links, N - link_touching.sum(axis=1), N, always_fraction)
    by_sample = np.argsort(samples, kind="stable")
    rows = rows[by_sample]
    bounds = np.searchsorted(samples[by_sample], np.arange(N + 1))
    reported = 0
    for s in range(N):
        cand = rows[bounds[s]:bounds[s + 1]]
        cand = cand[tally.undecided[owner[cand]]]
        if len(cand):
            checker.place(Q[s])
            links = owner[cand]  # sorted: rows are grouped by link pair
            tested = links[np.flatnonzero(np.diff(links, prepend=-1))]
            tally.add(tested, _first_hits(checker, ids[cand].tolist(), links.tolist()))
        if progress is not None and ((s + 1) % PROGRESS_STEP == 0 or s + 1 == N):
            progress(s + 1 - reported)
            reported = s + 1
    return tally.verdicts()


def _first_hits(checker: PairChecker, pair_ids: list[int], owners: list[int]) -> list[int]:
    """The link pairs (``owners[k]`` of pair ``pair_ids[k]``) found in collision at the placed configuration,
    each link pair's remaining pairs skipped after its first collision."""
    hit: list[int] = []
    for k, link in zip(pair_ids, owners):
        if (not hit or hit[-1] != link) and checker.collides(k):  # a link pair's pairs are consecutive
            hit.append(link)
    return hit
