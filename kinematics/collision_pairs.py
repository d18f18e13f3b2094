"""Which pairs of a robot's links are checked for self-collision (MoveIt's allowed-collision idea).

A robot's collision geometries hang on its links; checking every pair is wasteful
and wrong (neighbouring links touch at their joint by design). The pairs *not*
checked are a set of **disabled link pairs**, taken from one of two sources:

* the model's **SRDF** (``<disable_collisions link1=... link2=...>``), when it has
  one - exactly what MoveIt and ``pinocchio.removeCollisionPairs`` use; or
* **computed** the way MoveIt's setup assistant does
  (``moveit_setup_assistant``'s ``computeDefaultCollisions``), at link level:

  1. *adjacent*: links on the same rigid body or on bodies joined by one joint
     (a fixed joint merges links into one body, as MoveIt does);
  2. *default*: links in collision at the reference configuration (the middle of
     the joint ranges);
  3. *always*: links in collision in at least :data:`ALWAYS_FRACTION` of
     :data:`SAMPLES` uniformly random configurations;
  4. *never*: links never in collision over the same samples.

  "In collision" is coal's contact test from a fresh request (contacts on, no
  GJK warm start: :func:`~.pair_sampling.contact_request`), so the answer of a
  sample does not depend on the samples before it. The samples come from
  ``numpy.random.default_rng(SEED)``, so the result is deterministic. As in
  MoveIt, "never" is statistical: a pair that collides only in a region of volume
  below about ``1 / SAMPLES`` of the joint space can be disabled wrongly - give
  the model an SRDF when that matters.

Computed sets are cached on disk per model text (see :mod:`.collision_cache`).
coal runs only on the (sample, pair) cases whose bounding spheres come close, and
stops on a pair once its verdict is known (:mod:`.pair_sampling`); the verdicts
are those of the full count.

Geometries on the same Pinocchio joint (one rigid body) are never paired: their
relative pose cannot change. Pairs are link names in sorted order.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable

import numpy as np
import pinocchio as pin

from .errors import ModelError, suggest
from .pair_sampling import PairChecker, sampled_verdicts

#: Number of random configurations of the "always" / "never" tests (MoveIt's setup assistant: 10000).
SAMPLES = 2000
#: Seed of the random configurations (``numpy.random.default_rng``).
SEED = 0
#: A pair in collision in at least this fraction of the samples is "always" in collision (MoveIt: 95 %).
ALWAYS_FRACTION = 0.95
#: Version of the computation; part of the cache key (2: coal's contact test from a fresh request, see
#: :mod:`.pair_sampling`; version 1 missed some penetrations).
ALGORITHM_VERSION = 2

LinkPair = tuple[str, str]


def link_pair(a: str, b: str) -> LinkPair:
    """The pair ``(a, b)`` in sorted order."""
    return (a, b) if a <= b else (b, a)


def geometry_links(model: pin.Model, geometry: pin.GeometryModel) -> list[str]:
    """The link (frame) name that carries each geometry object, in geometry order."""
    return [model.frames[g.parentFrame].name for g in geometry.geometryObjects]


def srdf_disabled_pairs(srdf: str, link_names: Iterable[str], label: str = "SRDF") -> dict[LinkPair, str]:
    """``{(link1, link2): reason}`` of the ``<disable_collisions>`` elements of SRDF text.

    Raises :class:`ModelError` for malformed XML, a missing attribute, or a link
    name the robot does not have (the message lists close matches). Pairs naming
    links without collision geometry are legal (MoveIt lists them too).
    """
    from lxml import etree

    known = set(link_names)
    try:
        root = etree.fromstring(srdf.encode("utf-8"), etree.XMLParser(resolve_entities=False))
    except etree.XMLSyntaxError as exc:
        raise ModelError(f"{label}: malformed XML: {exc.msg}") from None
    pairs: dict[LinkPair, str] = {}
    for el in root.iter("disable_collisions"):
        a, b = el.get("link1"), el.get("link2")
        if not a or not b:
            raise ModelError(f"{label}, line {el.sourceline}: <disable_collisions> needs link1= and link2= "
                             "attributes")
        for name in (a, b):
            if name not in known:
                raise ModelError(
                    f"{label}, line {el.sourceline}: <disable_collisions> names link {name!r}, which the "
                    "robot "
                    f"does not have.{suggest(name, known)}"
                )
        pairs[link_pair(a, b)] = el.get("reason") or "srdf"
    return pairs


def adjacent_pairs(model: pin.Model, geometry: pin.GeometryModel) -> dict[LinkPair, str]:
    """Link pairs on one rigid body or on two bodies joined by one joint."""
    links = geometry_links(model, geometry)
    joints = [g.parentJoint for g in geometry.geometryObjects]
    parents = list(model.parents)
    out: dict[LinkPair, str] = {}
    for i in range(len(links)):
        for j in range(i + 1, len(links)):
            if links[i] == links[j]:
                continue
            ji, jj = joints[i], joints[j]
            if ji == jj or parents[ji] == jj or parents[jj] == ji:
                out[link_pair(links[i], links[j])] = "Adjacent"
    return out


def candidate_geometry_pairs(model: pin.Model, geometry: pin.GeometryModel,
                             disabled: Iterable[LinkPair] = ()) -> list[tuple[int, int]]:
    """Geometry index pairs ``(i, j)``, ``i < j``, on different joints whose link pair is not disabled."""
    links = geometry_links(model, geometry)
    off = set(disabled)
    objs = geometry.geometryObjects
    out = []
    for i in range(len(objs)):
        for j in range(i + 1, len(objs)):
            if objs[i].parentJoint == objs[j].parentJoint or links[i] == links[j]:
                continue
            if link_pair(links[i], links[j]) in off:
                continue
            out.append((i, j))
    return out


def compute_disabled_pairs(model: pin.Model, geometry: pin.GeometryModel, lower: np.ndarray,
                           upper: np.ndarray, samples: int = SAMPLES, seed: int = SEED,
                           progress: Callable[[int], None] | None = None) -> dict[LinkPair, str]:
    """MoveIt-style disabled link pairs (see the module docstring): adjacent, default, always, never.

    ``geometry`` is left unchanged (a copy is checked). The always / never tests
    are :func:`~.pair_sampling.sampled_verdicts` (coal only where bounding spheres
    of a pair come close; the verdicts of a full count). ``progress(k)`` is
    called as the samples are done (``k`` samples at a time, ``samples`` in all).
    """
    disabled = adjacent_pairs(model, geometry)
    gm = geometry.copy()
    gm.removeAllCollisionPairs()
    pairs = candidate_geometry_pairs(model, gm, disabled)
    if not pairs:
        if progress is not None:
            progress(int(samples))
        return disabled
    for i, j in pairs:
        gm.addCollisionPair(pin.CollisionPair(i, j))
    checker = PairChecker(model, gm)
    links = geometry_links(model, gm)
    pair_links = [link_pair(links[i], links[j]) for i, j in pairs]
    for k in checker.colliding(np.clip(0.5 * (lower + upper), lower, upper), range(len(pairs))):
        disabled[pair_links[k]] = "Default"
    live = [k for k, lp in enumerate(pair_links) if lp not in disabled]
    link_pairs = sorted({pair_links[k] for k in live})
    index = {lp: n for n, lp in enumerate(link_pairs)}
    rng = np.random.default_rng(seed)
    Q = rng.uniform(lower, upper, size=(int(samples), model.nq))
    verdicts = sampled_verdicts(checker, live, [index[pair_links[k]] for k in live], len(link_pairs), Q,
                                ALWAYS_FRACTION, progress)
    for lp, verdict in zip(link_pairs, verdicts):
        if verdict is not None:
            disabled[lp] = verdict
    return dict(sorted(disabled.items()))
