"""The compiled motion certificates (kinserve.kinematics.motion_kernels) against sampled motions and coal.

* ``motion_hard_pairs``: on densely sampled Panda motions near obstacles, every pair it certifies keeps its
  sphere lower bound above the tolerance, and coal finds the samples free;
* the rates they advance with (``motion_rates``) against sampled sphere-centre displacements, the centres'
  distances from the joint axes and the self pairs' bound changes; ``geometry_pair_rates`` against coal's
  distances of the shapes themselves.
"""

import numpy as np

from kinserve import robots
from kinserve.kinematics import motion_kernels as mk
from kinserve.kinematics import precheck_kernels as pk
from kinserve.kinematics.serial_chain import REVOLUTE

from collision_scenes import SCENE, coal_hits, scenes_near_the_arm


def test_motion_hard_pairs_keeps_every_other_bound_above_the_tolerance_over_the_whole_motion(tmp_path):
    """Straight motions of the Panda near obstacles: every pair ``motion_hard_pairs`` does not hand over
    keeps its sphere lower bound (``pair_lower_bounds``) above the tolerance at 400 samples of the whole
    motion, the hard ones on the samples of ``[0, lo)`` and ``(hi, 1]``, and coal finds the samples of a
    motion with no hard pair free; motions with no hard pair, with some and with too many (``-1``) all
    occur."""
    robot = robots.load("panda")
    rng = np.random.default_rng(22)
    kinds = {"none": 0, "some": 0, "too many": 0}
    for q_s, scene, pre in scenes_near_the_arm(robot, rng, tmp_path):
        P = len(scene.pairs)
        for _ in range(30):
            qa = np.clip(q_s + rng.normal(scale=0.4, size=robot.nq), robot.lower, robot.upper)
            qb = np.clip(qa + rng.normal(scale=0.1, size=robot.nq), robot.lower, robot.upper)
            out = mk.motion_hard_pairs(pre.floats, pre.ints, pre.sphere_reach, pre.pair_reach, qa, qb,
                                       pre.tolerance, 1e-3, 1024, 4)
            assert len(out) == 8 and out[1] >= 1
            if out[0] < 0:
                kinds["too many"] += 1
                continue
            h, lo, hi = int(out[0]), out[2], out[3]
            hard = out[4:4 + h].astype(int)
            assert np.all(out[4 + h:] == -1) and len(set(hard.tolist())) == len(hard)
            samples = np.linspace(0.0, 1.0, 400)
            bounds = np.array([pk.pair_lower_bounds(pre.floats, pre.ints, qa + s * (qb - qa))
                               for s in samples]).reshape(len(samples), P)
            keep = np.ones(P, dtype=bool)
            keep[hard] = False
            assert np.all(bounds[:, keep] > pre.tolerance)
            ends = (samples < lo) | (samples > hi)
            assert np.all(bounds[np.ix_(ends, hard)] > pre.tolerance)
            if not len(hard):
                assert lo >= hi
                kinds["none"] += 1
                assert not coal_hits(scene, qa + samples[:, None] * (qb - qa)).any()
            else:
                kinds["some"] += 1
                assert 0.0 <= lo < hi <= 1.0
    assert kinds["none"] > 5 and kinds["some"] > 3 and kinds["too many"] > 0, kinds


def test_motion_hard_pairs_fits_its_arguments_and_counts_its_hard_pairs():
    """Arguments of the wrong size: ``[-1, 0, 0, 1, -1, ...]``; a motion with no hard pair has none whatever
    ``max_hard`` allows (and ``lo >= hi``); one with hard pairs is ``-1`` when ``max_hard = 0``; both kinds
    occur on random Panda motions."""
    robot = robots.load("panda")
    scene = robot.collision_scene(SCENE)
    pre = scene.precheck()
    P = len(scene.pairs)
    args = (pre.floats, pre.ints, pre.sphere_reach, pre.pair_reach)
    rng = np.random.default_rng(4)
    qa, qb = robot.neutral(), robot.random_q(rng)
    assert list(mk.motion_hard_pairs(*args, qa[:-1], qb, 1e-5, 1e-3, 64, 2)) == [-1, 0, 0, 1, -1, -1]
    short_rows = np.ascontiguousarray(pre.sphere_reach[:-1])
    assert mk.motion_hard_pairs(pre.floats, pre.ints, short_rows, pre.pair_reach, qa, qb, 1e-5, 1e-3, 64,
                                2)[0] == -1
    whole = handed = 0
    for _ in range(200):
        qa = robot.random_q(rng)
        qb = np.clip(qa + rng.normal(scale=0.3, size=robot.nq), robot.lower, robot.upper)
        out = mk.motion_hard_pairs(*args, qa, qb, 1e-5, 1e-3, 1024, P)
        none_allowed = mk.motion_hard_pairs(*args, qa, qb, 1e-5, 1e-3, 1024, 0)
        if out[0] == 0:
            whole += 1
            assert none_allowed[0] == 0 and out[2] >= out[3]
        elif out[0] > 0:
            handed += 1
            assert none_allowed[0] == -1
    assert whole > 10 and handed > 10, (whole, handed)


def test_self_pair_bounds_change_no_faster_than_their_motion_reach():
    """For the self pairs of the Panda, the sphere lower bound of the pair (``pair_lower_bounds``) changes
    between two configurations by at most ``pair_reach[p] . |dq|`` (the global rate the motion certificates
    start from), for steps from a micro-radian to the whole range; and the rate is not vacuous (within a
    factor ~10 of the largest change seen on some pair)."""
    robot = robots.load("panda")
    scene = robot.collision_scene(())
    pre = scene.precheck()
    table = scene.layout.precheck().pairs
    own = table[:, 2] == pk.SELF_PAIR
    assert own.any()
    idx = robot.collision.spheres.joints[:, 1]
    rng = np.random.default_rng(5)
    tight = 0.0
    for _ in range(300):
        q = robot.random_q(rng)
        q2 = np.clip(q + 10.0 ** rng.uniform(-6, 0) * rng.normal(size=robot.nq), robot.lower, robot.upper)
        change = np.abs(pk.pair_lower_bounds(pre.floats, pre.ints, q2) - pk.pair_lower_bounds(pre.floats,
                                                                                               pre.ints, q))
        rates = pre.pair_reach @ np.abs(q2[idx] - q[idx])
        scene_index = table[own, 3]
        assert np.all(change[scene_index] <= rates[own] * (1 + 1e-9) + 1e-12)
        moving = rates[own] > 0
        if moving.any():
            tight = max(tight, float(np.max(change[scene_index][moving] / rates[own][moving])))
    assert tight > 0.1, tight


def _placements(spheres, q: np.ndarray) -> np.ndarray:
    """Every joint's world placement ``(J + 1, 12)`` at ``q`` (the tree's forward kinematics)."""
    X = np.empty((len(spheres.joints) + 1, 12))
    pk.tree_placements(spheres.tree, spheres.joints, q, X)
    return X


def _centres_at(spheres, X: np.ndarray) -> np.ndarray:
    """World centres ``(G + S, 3)`` of every sphere row of the robot's sphere model at the placements ``X``:
    ``t + R c`` for each row's joint."""
    rows = np.empty((len(spheres.spheres), 3))
    for g, (joint, first, end) in enumerate(spheres.geoms):
        own = [g, *range(first, end)]
        R, t = X[joint, :9].reshape(3, 3), X[joint, 9:]
        rows[own] = t + spheres.spheres[own, :3] @ R.T
    return rows


def _centres(spheres, q: np.ndarray) -> np.ndarray:
    """World centres ``(G + S, 3)`` of every sphere row of the robot's sphere model at ``q``."""
    return _centres_at(spheres, _placements(spheres, q))


def _axis_rate_sum(spheres, qs: np.ndarray, du: np.ndarray) -> np.ndarray:
    """Per sphere row, ``sum_k du[k] max_s rho_k(s)`` over the samples ``qs``: ``rho_k`` the centre's distance
    from revolute joint ``k``'s axis (1 for a prismatic joint), over the joints carrying the row. A rate
    whose every per-joint term bounds that joint's part of the speed is at least this."""
    J = len(spheres.joints)
    peak = np.zeros((len(spheres.spheres), J))
    X = np.array([_placements(spheres, q) for q in qs])  # (N, J + 1, 12)
    C = np.array([_centres_at(spheres, Xn) for Xn in X])  # (N, G + S, 3)
    for g, (joint, first, end) in enumerate(spheres.geoms):
        rows = [g, *range(first, end)]
        j = int(joint)
        while j > 0:
            k = j - 1
            if spheres.joints[k, 0] == REVOLUTE:
                axis = X[:, j, :9].reshape(-1, 3, 3) @ spheres.tree[k, 12:15]  # (N, 3), every sample
                rho = np.linalg.norm(np.cross(axis[:, None, :], C[:, rows] - X[:, j, None, 9:]), axis=-1)
                peak[rows, k] = np.maximum(peak[rows, k], rho.max(axis=0))
            else:
                peak[rows, k] = np.maximum(peak[rows, k], 1.0)
            j = int(spheres.joints[k, 2])
    return peak @ du


def _motions(robot, rng, count):
    """Straight motions of every length: short steps to moves across the joint ranges."""
    for _ in range(count):
        qa = robot.random_q(rng)
        scale = 10.0 ** rng.uniform(-2, 0.5)
        yield qa, np.clip(qa + scale * rng.normal(size=robot.nq), robot.lower, robot.upper)


def test_motion_rates_bound_every_sphere_centre_and_self_pair_on_the_motion():
    """``motion_rates`` (the rates the sphere advancement uses) on straight Panda motions of every length:
    between any two of 40 samples ``s, s'`` of the motion, every sphere centre moves by at most
    ``v[c] |s - s'|`` and every self pair's sphere lower bound changes by at most ``w[p] |s - s'|`` (centres
    from the tree's placements), and each rate is at least ``sum_k |u_k| max_s rho_k(s)`` (the centre's
    distance from each joint's axis at its largest on 200 samples: each joint's term bounds its part); the
    rates are never above the global ones (``sphere_reach . |u|``,
    ``pair_reach . |u|``), below them on most motions, and not vacuous (the largest centre displacement seen
    is more than half the bound on some motion)."""
    robot = robots.load("panda")
    scene = robot.collision_scene(())
    pre = scene.precheck()
    spheres = robot.collision.spheres
    table = scene.layout.precheck().pairs
    own = np.flatnonzero(table[:, 2] == pk.SELF_PAIR)
    S = len(spheres.spheres)  # the model's sphere rows (the packed rows go on with its inner balls: rate 0)
    idx = spheres.joints[:, 1]
    rng = np.random.default_rng(31)
    s = np.linspace(0.0, 1.0, 40)
    ds = np.abs(s[:, None] - s[None, :])
    lower_than_global, tightest = 0, 0.0
    for qa, qb in _motions(robot, rng, 60):
        rates = mk.motion_rates(pre.floats, pre.ints, pre.sphere_reach, pre.pair_reach, qa, qb)
        v, w = rates[:S], rates[len(rates) - len(table):]
        assert not rates[S:len(rates) - len(table)].any()
        du = np.abs(qb[idx] - qa[idx])
        v_global, w_global = spheres.sphere_reach @ du, pre.pair_reach @ du
        assert np.all(v <= v_global * (1 + 1e-9) + 1e-15) and np.all(w <= w_global * (1 + 1e-9) + 1e-15)
        lower_than_global += bool(np.median(v / np.maximum(v_global, 1e-300)) < 0.9)
        qs = qa + s[:, None] * (qb - qa)
        C = np.array([_centres(spheres, q) for q in qs])  # (40, S, 3)
        moved = np.linalg.norm(C[:, None] - C[None, :], axis=-1)  # (40, 40, S)
        assert np.all(moved <= v[None, None, :] * ds[:, :, None] * (1 + 1e-9) + 1e-12)
        assert np.all(v >= _axis_rate_sum(spheres, np.linspace(qa, qb, 200), du) * (1 - 1e-9))
        moving = v > 0
        seen = moved[..., moving] / (v[moving] * np.maximum(ds, 1e-300)[..., None])
        tightest = max(tightest, float(np.max(seen)))
        bounds = np.array([pk.pair_lower_bounds(pre.floats, pre.ints, q) for q in qs])[:, table[own, 3]]
        change = np.abs(bounds[:, None] - bounds[None, :])
        assert np.all(change <= w[own][None, None, :] * ds[:, :, None] * (1 + 1e-9) + 1e-12)
    assert lower_than_global > 40 and tightest > 0.5, (lower_than_global, tightest)


def test_geometry_pair_rates_bound_coal_distances_on_the_stretch():
    """``geometry_pair_rates`` on stretches ``[lo, hi]`` of straight Panda motions in a scene with obstacles:
    between any two of 25 samples of the stretch, every pair's coal distance (the shapes, not their spheres)
    changes by at most the pair's rate times ``|s - s'|`` (plus coal's distance error); the rates are below
    the planner's global ones (``EdgeCertifier.reach . |u|``) on most pairs; a pair the scene lacks and
    arguments of the wrong size get ``inf``."""
    from kinserve.planners.motion.clearance import ClearanceOracle
    from kinserve.planners.motion.edges import EdgeCertifier
    from kinserve.planners.motion.reach import pair_reach

    robot = robots.load("panda")
    scene = robot.collision_scene(SCENE)
    pre = scene.precheck()
    P = len(scene.pairs)
    reach = pair_reach(robot.model, scene)
    certifier = EdgeCertifier(ClearanceOracle(scene), reach)
    everything = np.arange(P, dtype=np.int64)
    rng = np.random.default_rng(32)
    tighter = total = 0
    for qa, qb in _motions(robot, rng, 25):
        lo, hi = np.sort(rng.uniform(0.0, 1.0, 2))
        rates = mk.geometry_pair_rates(pre.floats, pre.ints, pre.sphere_reach, qa, qb, lo, hi, everything)
        glob = reach @ np.abs(qb - qa)
        assert np.allclose(certifier.stretch_rates(qa, qb - qa, everything, lo, hi), np.minimum(rates, glob))
        tighter += int(np.sum(rates < glob * 0.95))
        total += P
        s = np.linspace(lo, hi, 25)
        d = np.array([scene.distance_arrays(qa + t * (qb - qa)).distance for t in s])
        change = np.abs(d[:, None] - d[None, :])
        ds = np.abs(s[:, None] - s[None, :])
        assert np.all(change <= rates[None, None, :] * ds[:, :, None] + 2e-6)
    assert tighter > total / 2, (tighter, total)
    qa, qb = robot.neutral(), robot.random_q(rng)
    missing = np.array([P + 5], dtype=np.int64)
    assert np.isinf(mk.geometry_pair_rates(pre.floats, pre.ints, pre.sphere_reach, qa, qb, 0.0, 1.0, missing))
    assert np.all(np.isinf(mk.geometry_pair_rates(pre.floats, pre.ints, pre.sphere_reach, qa[:-1], qb, 0.0,
                                                  1.0, everything)))
