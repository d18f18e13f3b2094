"""The hulls' verdict on the pairs the sphere pre-check leaves to coal, against coal itself.

:func:`kinserve.kinematics.hull_verdict.hull_verdict` may call a configuration free only when coal finds
none of its pairs in collision, in collision only when coal finds one, and the pairs it leaves open must
hold every pair coal finds colliding.
Both are checked with coal on every pair (``computeCollisions`` on the scene's own ``GeometryModel``), on
configurations the spheres leave undecided around a box, a capsule, a cylinder and a ball.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from kinserve import robots
from kinserve.kinematics.precheck_verdicts import COLLIDING, FREE, UNDECIDED, carried_pairs

from collision_scenes import coal_hits, fresh_requests, tilted_clutter


def _coal_colliding(scene, q: np.ndarray) -> set[int]:
    """Every pair coal finds in collision at ``q``, on a fresh copy of the scene's geometry (fresh requests,
    as :func:`collision_scenes.coal_hits`)."""
    model, geometry = scene.model, scene.geometry
    data, gd = model.createData(), fresh_requests(pin.GeometryData(geometry))
    pin.computeCollisions(model, data, geometry, gd, q, False)
    return {k for k, r in enumerate(gd.collisionResults) if r.isCollision()}


@pytest.fixture(scope="module")
def panda():
    return robots.load("panda")


def test_a_free_verdict_is_coals_and_the_open_pairs_hold_every_collision(panda):
    scene = panda.collision_scene(tilted_clutter())
    pre = scene.precheck()
    h = pre.hulls
    rng = np.random.default_rng(3)
    seen = {"free": 0, "colliding": 0, "open": 0, "narrowed": 0}
    for _ in range(1500):
        q = panda.random_q(rng)
        verdict = pre.classify(pre.floats, pre.ints, q, pre.tolerance)
        if verdict <= UNDECIDED:
            continue
        out = pre.hull_verdict(pre.floats, pre.ints, h.points, h.geoms, h.radius, pre.table_rows, q, verdict,
                               pre.tolerance)
        hits = _coal_colliding(scene, q)
        if out == FREE:
            assert not hits, (q, sorted(hits))
            seen["free"] += 1
            continue
        if out == COLLIDING:
            assert hits, q
            seen["colliding"] += 1
            continue
        assert out > UNDECIDED
        left, carried = carried_pairs(out), carried_pairs(verdict)
        assert left == [p for p in carried if p in set(left)]  # a subset, in the same order
        assert hits <= set(left), (sorted(hits), left)  # (the spheres certify every other pair)
        seen["open"] += 1
        seen["narrowed"] += len(left) < len(carried)
        assert scene.in_collision(q) == bool(hits)
    assert seen["free"] >= 20 and seen["colliding"] >= 20 and seen["open"] >= 1, seen


def test_the_check_through_the_hulls_agrees_with_coal_on_every_configuration(panda):
    scene = panda.collision_scene(tilted_clutter())
    rng = np.random.default_rng(11)
    qs = [panda.random_q(rng) for _ in range(600)]
    got = [scene.in_collision(q) for q in qs]
    assert got == coal_hits(scene, qs).tolist()
    assert 0 < sum(got) < len(got)


def test_other_verdicts_and_bad_arguments_pass_through_unchanged(panda):
    scene = panda.collision_scene(tilted_clutter())
    pre = scene.precheck()
    h = pre.hulls
    q = panda.random_q(np.random.default_rng(0))
    args = (pre.floats, pre.ints, h.points, h.geoms, h.radius, pre.table_rows)
    for verdict in (FREE, COLLIDING, UNDECIDED):
        assert pre.hull_verdict(*args, q, verdict, pre.tolerance) == verdict
    carrying = UNDECIDED | (1 << 2)  # scene pair 0
    assert pre.hull_verdict(*args, q[:-1], carrying, pre.tolerance) == carrying  # not one entry per joint
    outside = UNDECIDED | ((len(scene.pairs) + 1) << 2)
    assert pre.hull_verdict(*args, q, outside, pre.tolerance) == outside
    assert pre.hull_verdict(pre.floats, pre.ints, h.points, h.geoms[:-1], h.radius[:-1], pre.table_rows, q,
                            carrying, pre.tolerance) == carrying
