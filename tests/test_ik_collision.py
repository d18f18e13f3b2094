"""Collision-aware IK: damper rows against finite differences of coal distances, collision-free answers and
iterates (checked with an independent coal model), infeasible targets, the constraint protocol, solve_many."""

import itertools

import coal
import numpy as np
import pinocchio as pin
import pytest

from kinserve import ik, robots
from kinserve.ik.constraints.collision import CollisionConstraint
from kinserve.kinematics import errors


def _pose(xyz):
    T = np.eye(4)
    T[:3, 3] = xyz
    return T


SCENE = [ik.Box(_pose((0.65, 0.0, -0.05)), (0.7, 1.2, 0.1)),
         ik.Box(_pose((0.0, -0.6, 0.5)), (1.5, 0.05, 1.0))]


@pytest.fixture(scope="module")
def panda():
    return robots.load("panda")


def _independent_min_distance(robot, q, obstacles):
    """Smallest signed distance over the robot's SRDF pairs and scene pairs, pair by pair with
    coal.distance."""
    cm = robot.collision
    data = robot.model.createData()
    pin.forwardKinematics(robot.model, data, q)
    objs = cm.geometry.geometryObjects

    def world(g):
        M = data.oMi[g.parentJoint] * g.placement
        return coal.Transform3s(M.rotation, M.translation)

    best = np.inf
    req, res = coal.DistanceRequest(), coal.DistanceResult()
    for i, j in cm.self_pairs:
        res.clear()
        best = min(best, coal.distance(objs[i].geometry, world(objs[i]), objs[j].geometry,
                                       world(objs[j]), req, res))
    for ob in obstacles:
        T = coal.Transform3s(ob.pose[:3, :3], ob.pose[:3, 3])
        for g in objs:
            if g.parentJoint:
                res.clear()
                best = min(best, coal.distance(g.geometry, world(g), ob.geometry(), T, req, res))
    return best


def test_damper_rows_match_finite_differences_of_the_distance(panda):
    rng = np.random.default_rng(4)
    c = CollisionConstraint(SCENE, self_collision=True, influence=0.3).bind(panda)
    checked = 0
    data = panda.model.createData()
    for _ in range(40):
        q = panda.random_q(rng)
        pin.computeJointJacobians(panda.model, data, q)
        d, G, pairs = c.pair_rows(panda, data, q)
        for r, k in enumerate(pairs):
            if d[r] < 0.005:  # penetration depth / near-contact witness points are not smooth enough for FD
                continue
            h = 1e-4
            dq = rng.normal(size=panda.nq)
            dq *= h / np.linalg.norm(dq)

            def dist(qq):
                data2 = panda.model.createData()
                pin.forwardKinematics(panda.model, data2, qq)
                c.scene.near(c._threshold, data=data2)
                return c.scene.near_distance(c._threshold, k)[0]

            fd = (dist(q + dq) - dist(q - dq)) / 2.0
            # near-pair distances use GJK to 1e-9 m: an absolute bound well below |G dq| ~ h |g|
            assert abs(G[r] @ dq - fd) <= 1e-3 * h + 1e-8, (c.scene.pair_names[k], G[r] @ dq, fd)
            checked += abs(fd) > 1e-5
    assert checked > 30


def test_answers_and_every_iterate_are_collision_free(panda, monkeypatch):
    """Open scene: every answer and iterate clear; every other solve without unconstrained attempts
    (straight to the constrained path), the others with the default attempts."""
    from kinserve.ik.strategies import checked as collision_solve

    default_attempts = collision_solve.CHECKED_ATTEMPTS
    rng = np.random.default_rng(11)
    targets = []
    while len(targets) < 25:
        q = panda.random_q(rng)
        if not panda.in_collision(q, SCENE):
            targets.append(panda.fk(q))
    paths = set()
    for i, T in enumerate(targets):
        monkeypatch.setattr(collision_solve, "CHECKED_ATTEMPTS", 0 if i % 2 else default_attempts)
        q0 = panda.random_q(rng)  # some starts are in collision: not an error
        res = ik.solve(panda, T, q0, self_collision=True, obstacles=SCENE, seed=3, iteration_budget=2000)
        assert res.success, res.summary()
        assert _independent_min_distance(panda, res.q, SCENE) >= 0.0
        for q in res.history.q:
            assert _independent_min_distance(panda, q, SCENE) >= 0.0
        paths.add(res.info["collision"])
    assert paths == {"unconstrained, checked", "constrained"}  # both paths are exercised


@pytest.mark.parametrize("attempts", [0, None])
def test_obstacle_in_the_way_is_avoided(panda, attempts, monkeypatch):
    """A 10 cm box at the elbow of the unconstrained answer, cleared by the generating configuration.

    ``attempts=0`` (no unconstrained solve) forces the constrained path; the default
    may find another branch with its unconstrained attempts.
    """
    from kinserve.ik.strategies import checked as collision_solve

    if attempts is not None:
        monkeypatch.setattr(collision_solve, "CHECKED_ATTEMPTS", attempts)
    rng = np.random.default_rng(8)
    cases = 0
    for _ in range(40):
        q_gen = panda.random_q(rng)
        if panda.in_collision(q_gen):
            continue
        T = panda.fk(q_gen)
        free = ik.solve(panda, T, panda.random_q(rng), seed=0, iteration_budget=2000)
        elbow = panda.fk(free.q, "panda_link4")[:3, 3]
        block = ik.Box(_pose(elbow), (0.1, 0.1, 0.1))
        if not free.success or panda.min_distance(q_gen, [block], self_collision=False) < 0.02:
            continue
        res = ik.solve(panda, T, self_collision=True, obstacles=[block], seed=0, iteration_budget=2000,
                       collision_margin=0.01)
        assert res.success, res.summary()
        if attempts == 0:
            assert res.info["collision"] == "constrained"
        assert panda.min_distance(res.q, [block]) >= 0.01 - 1e-6
        assert all(panda.min_distance(q, [block]) >= 0.01 - 1e-6 for q in res.history.q[1:])
        cases += 1
        if cases == 3:
            break
    assert cases == 3

def test_target_inside_an_obstacle_is_a_failed_result_not_a_hang(panda):
    T = panda.fk(panda.neutral())
    wall = ik.Box(_pose(T[:3, 3]), (0.3, 0.3, 0.3))
    # the one-time model, layout and pre-check builds: not the budget's
    panda.collision_scene([wall]).precheck()
    # no clock: the target is refused after the unconstrained attempts (each converges into the wall and is
    # rejected), before the constrained search (which would spend the whole budget)
    res = ik.solve(panda, T, self_collision=True, obstacles=[wall], iteration_budget=500)
    assert not res.success and 0 < res.iterations < 500 and res.info["strategy"] == "infeasible"
    assert "inside obstacle[0]:box" in res.message


def test_margin_grows_from_a_start_in_collision_and_protocol_methods(panda):
    c = ik.SelfCollision(margin=0.0).bind(panda)
    rng = np.random.default_rng(2)
    q = next(q for q in panda.random_q(rng, 200) if panda.in_collision(q))
    assert c.margin(panda, None, q) < 0
    assert "self-collision:" in c.describe(panda, None, q)
    data = panda.model.createData()
    pin.computeJointJacobians(panda.model, data, q)
    G, lo, hi = c.rows(panda, data, q)
    d = c.pair_rows(panda, data, q)[0]
    assert G.shape == (len(d), panda.nq) and np.all(np.isinf(hi))
    assert np.any(d < 0) and np.all(lo[d < 0] > 0)  # a negative clearance must grow
    assert np.allclose(lo, -ik.constraints.DAMPER_GAIN * d)


def test_bad_input_is_named(panda):
    with pytest.raises(errors.InputError, match="collision margin must be >= 0"):
        ik.SelfCollision(margin=-0.1)
    base = ik.Box(_pose((0.0, 0.0, 0.05)), (0.2, 0.2, 0.2))
    with pytest.raises(errors.InputError, match="overlaps the robot's fixed base"):
        ik.solve(panda, panda.fk(panda.neutral()), self_collision=True, obstacles=[base])
    bare = robots.load("""<robot name="bare"><link name="b"/><link name="l"/>
      <joint name="j" type="revolute"><parent link="b"/><child link="l"/><axis xyz="0 0 1"/>
      <origin xyz="0 0 0"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint></robot>""")
    with pytest.raises(errors.ModelError, match="no <collision> elements"):
        ik.solve(bare, np.eye(4), self_collision=True, relax=("x", "y", "z", "roll", "pitch"))


def test_solve_many_forwards_the_collision_options(panda):
    rng = np.random.default_rng(5)
    qs = [q for q in panda.random_q(rng, 50) if not panda.in_collision(q, SCENE)][:6]
    poses = np.array([panda.fk(q) for q in qs])
    results = ik.solve_many(panda, poses, processes=1, self_collision=True, obstacles=SCENE, seed=0,
                            iteration_budget=2000)
    assert all(r.success and "collision" in r.info for r in results)
    assert not any(panda.in_collision(r.q, SCENE) for r in results)


def test_reach_map_counts_collision_free_solutions_only(panda):
    from kinserve.ik.batch.reachability import reachability_map

    block = ik.Box(_pose((0.5, 0.0, 0.6)), (0.6, 1.6, 0.4))
    rmap = reachability_map(panda, 60, processes=1, max_time=0.05, seed=1, self_collision=True,
                            obstacles=[block])
    inside = block.contains(rmap.positions)
    assert inside.any() and not rmap.reached[inside].any()  # the hand's origin cannot be inside the block
    assert rmap.reached[~inside].any()


def test_control_loop_with_collision_constraints_stays_clear(panda):
    """ik.step with a frame task pulling the hand through the wall: SelfCollision + SceneCollision hold on
    every step."""
    q = np.array([-0.5, 0.3, 0.0, -1.8, 0.0, 2.1, 0.8])
    assert not panda.in_collision(q, SCENE)
    goal = panda.fk(q)
    goal[:3, 3] = (0.1, -0.9, 0.5)  # behind the wall (y = -0.6)
    task = ik.FrameTask(panda.tip, goal)
    # velocity limits bound a step (1 rad/s x 20 ms): links move less than the rows' influence distance (5 cm)
    cons = [ik.SelfCollision(), ik.SceneCollision(SCENE, margin=0.005), ik.VelocityLimits(1.0)]
    closest = np.inf
    for _ in range(150):
        v = ik.step(panda, [task], cons, q, dt=0.02)
        q = np.clip(q + 0.02 * v, panda.lower, panda.upper)
        assert not panda.in_collision(q)
        closest = min(closest, panda.min_distance(q, SCENE, self_collision=False))
    assert 0.0 < closest  # pushed against the wall, never through it
    assert closest < 0.05


def test_attempt_starts_follow_the_ordinary_order_minus_the_ones_in_collision(panda):
    """The checked QP's attempts start from the ordinary solve's starts (``q0`` and the target's ranked table
    samples, then random configurations) in its order - ranked lazily, the same order - minus the ones its
    checker does not admit (a ``q0`` in collision included)."""
    from kinserve.ik.request import target_request
    from kinserve.ik.starts.multistart import frame_starts
    from kinserve.ik.strategies import checked

    rng = np.random.default_rng(4)
    q0_placed = 0
    for case in range(6):
        q_gen = panda.random_q(rng)
        while panda.in_collision(q_gen, SCENE):
            q_gen = panda.random_q(rng)
        T = panda.fk(q_gen)
        # q0: in collision, near the target (among the ranked table samples), far from it
        q0 = (q_gen + rng.normal(0.0, 0.05 if case % 3 == 1 else 2.0, 7)).clip(panda.lower, panda.upper)
        while (case % 3 == 0) != panda.in_collision(q0, SCENE):
            q0 = panda.random_q(rng)
        req = target_request(panda, T, q0, seed=5 + case, self_collision=True, obstacles=SCENE)
        tgt = req.target
        ordinary = list(itertools.islice(frame_starts(panda, tgt.frame, tgt.frame_id, tgt.T[:3, :3],
                                                      tgt.T[:3, 3], True, q0, 5 + case), 40))
        q0_placed += any(np.array_equal(q, q0) for q in ordinary[1:9])
        admit = lambda q: not panda.in_collision(q, SCENE)  # noqa: E731 - the order alone
        starts = list(itertools.islice(checked._admissible_starts(req, admit), 30))
        assert len(starts) == 30
        assert all(not panda.in_collision(q, SCENE) for q in starts)
        if case % 3 == 0:
            assert not any(np.array_equal(q, q0) for q in starts)
        expected = [q for q in ordinary if not panda.in_collision(q, SCENE)]
        assert len(expected) >= 20
        np.testing.assert_array_equal(np.array(starts[:20]), np.array(expected[:20]))
    assert q0_placed >= 1  # q0 ranked among the table samples, not first: its place is checked too

def test_base_overlap_is_caught_next_to_obstacles_remembered_clear(panda, monkeypatch):
    """Obstacles found clear of the fixed base are remembered (by value) by the robot's IK state - per
    collision model, no module-level memory; a new one overlapping the base still raises; a remembered one
    is not checked again (coal is not asked), an equal new one neither."""
    from kinserve.ik.constraints import base_overlap
    from kinserve.ik.state import ik_state

    # this test's own obstacles (no other test binds their layout: a scene of a layout bound before is a moved
    # copy, whose obstacles are checked but, by design, not remembered)
    own = [ik.Box(_pose((0.65, 0.0, -0.05)), (0.7, 1.2, 0.101)),
           ik.Box(_pose((0.0, -0.6, 0.5)), (1.5, 0.051, 1.0))]
    ik.solve(panda, panda.fk(panda.neutral()), self_collision=True, obstacles=own)
    clear = ik_state(panda).base_clearance
    assert clear.model is panda.collision and all(clear.holds(panda.collision, ob) for ob in own)
    assert not any(isinstance(v, (dict, set)) or type(v).__name__ in ("WeakKeyDictionary", "local")
                   for k, v in vars(base_overlap).items() if not k.startswith("__"))
    base = ik.Box(_pose((0.0, 0.0, 0.05)), (0.2, 0.2, 0.2))
    with pytest.raises(errors.InputError, match=r"obstacle\[2\]:box overlaps the robot's fixed base"):
        ik.solve(panda, panda.fk(panda.neutral()), self_collision=True, obstacles=[*own, base])
    assert not clear.holds(panda.collision, base)
    scene = panda.collision_scene([*own, base])
    asked = []
    distance = base_overlap._BaseDistance

    class Counting(distance):
        def __call__(self, i, slot):
            asked.append(slot)
            return super().__call__(i, slot)

    monkeypatch.setattr(base_overlap, "_BaseDistance", Counting)
    with pytest.raises(errors.InputError, match="overlaps the robot's fixed base"):
        base_overlap.check_base_overlap(panda, scene, clear=clear)
    assert set(asked) == {2}  # the remembered obstacles were not asked about
    asked.clear()
    twins = panda.collision_scene([ik.Box(ob.pose, ob.size) for ob in own])  # equal, new objects
    base_overlap.check_base_overlap(panda, twins, clear=clear)
    assert asked == []
    base_overlap.check_base_overlap(panda, twins, clear=base_overlap.BaseClearance())  # no memory
    assert asked  # the same obstacles asked about again


def test_base_overlap_is_caught_for_a_moved_obstacle_of_a_known_layout(panda):
    """A 20 cm box far from the base, then the same box moved onto it: the second scene shares the first's
    layout (geometry objects) but the base check uses its own pose - and agrees with coal on that pose."""
    T = panda.fk(panda.neutral())
    far = ik.Box(_pose((0.5, 0.5, 0.9)), (0.2, 0.2, 0.2))
    ik.solve(panda, T, self_collision=True, obstacles=[*SCENE, far], max_time=0.2)
    for z, overlaps in ((0.05, True), (0.45, False)):  # base link mesh: up to ~0.2 m high
        moved = ik.Box(_pose((0.0, 0.0, z)), (0.2, 0.2, 0.2))
        assert panda.collision_scene([*SCENE, moved]).layout is panda.collision_scene([*SCENE, far]).layout
        base = panda.collision.geometry.geometryObjects[0]
        assert base.parentJoint == 0
        depth = coal.distance(base.geometry,
                              coal.Transform3s(base.placement.rotation, base.placement.translation),
                              coal.Box(0.2, 0.2, 0.2), coal.Transform3s(np.eye(3), np.array([0.0, 0.0, z])),
                              coal.DistanceRequest(), coal.DistanceResult())
        assert (depth < -1e-3) == overlaps  # an independent coal query on this pose
        if overlaps:
            with pytest.raises(errors.InputError, match=r"obstacle\[2\]:box overlaps the robot's fixed base"):
                ik.solve(panda, T, self_collision=True, obstacles=[*SCENE, moved], max_time=0.2)
        else:
            ik.solve(panda, T, self_collision=True, obstacles=[*SCENE, moved], max_time=0.2)


def test_max_starts_caps_the_unconstrained_runs(panda, monkeypatch):
    """``max_starts=1``: one unconstrained run, then the constrained solve; without it, one unconstrained
    solve whose starts are capped at 1 + CHECKED_ATTEMPTS, a run that meets the block followed by the next
    start."""
    from kinserve.ik.collision import collision_checker as checkers
    from kinserve.ik.lm import solver as lm_solver
    from kinserve.ik.strategies import checked as collision_solve
    from kinserve.ik.strategies import direct

    runs = []
    real = lm_solver.solve_lm

    def counting(*args, **kwargs):
        runs.append(kwargs.get("max_starts"))
        return real(*args, **kwargs)

    monkeypatch.setattr(direct, "solve_lm", counting)
    monkeypatch.setattr(checkers, "UNCERTIFIED_SKIPS", 0)  # the run from the start next to the block
    rng = np.random.default_rng(8)
    while True:
        # a witness-feasible target: its generating configuration clears the box on the answer's elbow
        q_gen = panda.random_q(rng)
        T = panda.fk(q_gen)
        free = ik.solve(panda, T, seed=0, iteration_budget=2000)
        block = ik.Box(_pose(panda.fk(free.q, "panda_link4")[:3, 3]), (0.1, 0.1, 0.1))
        if not panda.in_collision(q_gen, [block]):
            break
    assert panda.in_collision(free.q, [block])
    runs.clear()
    res = ik.solve(panda, T, self_collision=True, obstacles=[block], seed=0, iteration_budget=2000,
                   max_starts=1)
    assert runs == [1] and res.info["collision"] == "constrained"  # the one run met the block
    runs.clear()
    res = ik.solve(panda, T, self_collision=True, obstacles=[block], seed=0, iteration_budget=2000)
    # one solve, its starts capped; the first converged run met the block, a later start's run is the answer
    assert (runs == [1 + collision_solve.CHECKED_ATTEMPTS]
            and res.info["collision"] == "unconstrained, checked")
    assert (1 <= res.restarts <= collision_solve.CHECKED_ATTEMPTS
            and res.info["collision_attempts"] == res.restarts + 1)
    assert res.success and not panda.in_collision(res.q, [block])


def test_uncertified_starts_are_skipped_without_coal_then_coal_decides(panda):
    """The checked LM's admission: a start the sphere pre-check certifies runs; the first UNCERTIFIED_SKIPS
    uncertified ones are refused without coal, later ones (and the caller's q0 with prefer_q0) go to coal."""
    from kinserve.ik.collision import collision_checker as checkers
    from kinserve.ik.state import ik_state
    from kinserve.kinematics.scene_precheck import certify

    wall = ik.Box(_pose((0.45, 0.0, 0.5)), (0.05, 1.0, 1.0))
    con = ik_state(panda).collision_checker((wall,), True, 0.0).constraint
    pre = con.scene.precheck()
    rng = np.random.default_rng(4)
    Q = panda.random_q(rng, 3000)
    ok = certify(pre, Q)
    hit = np.array([con.scene.in_collision(q) for q in Q])
    near = Q[~ok & ~hit][:4]  # free, but not certified: within centimetres of the wall or of the arm itself
    inside = Q[~ok & hit][:4]
    clear = Q[ok][:2]
    assert len(near) == 4 and len(inside) == 4 and not hit[ok].any()  # certified means free (coal agrees)
    coal_calls = []
    real = con.in_collision
    con.in_collision = lambda q: coal_calls.append(q) or real(q)
    try:
        admit = checkers.CollisionChecker(panda, con).admission()
        assert admit(clear[0]) and not coal_calls  # certified: no coal
        skips = checkers.UNCERTIFIED_SKIPS
        assert skips >= 1
        assert [admit(q) for q in near[:skips]] == [False] * skips and not coal_calls  # skipped unasked
        assert admit(near[skips]) and len(coal_calls) == 1  # then coal decides: free, admitted
        assert not admit(inside[0]) and len(coal_calls) == 2  # ... and in collision, refused
        chosen = checkers.CollisionChecker(panda, con).admission(near[3])
        assert chosen(near[3].copy()) and len(coal_calls) == 3  # the caller's q0 is never skipped unasked
    finally:
        con.in_collision = real


def test_moved_constraint_answers_like_one_bound_from_scratch(panda):
    """A new pose of known obstacle shapes binds by moving a constraint of the same layout (no scene caches);
    its checks, distances and damper rows equal those of a constraint bound from nothing for the same
    obstacles, and ik.solve takes that path for the second scene."""
    from kinserve.ik.state import ik_state

    rng = np.random.default_rng(12)
    state = ik_state(panda)
    first = [*SCENE, ik.Box(_pose((0.5, 0.3, 0.6)), (0.1, 0.1, 0.1))]
    template = state.collision_checker(tuple(first), True, 0.0).constraint
    moved_obs = (*SCENE, ik.Box(_pose((0.4, -0.2, 0.5)), (0.1, 0.1, 0.1)))
    moved = state.collision_checker(moved_obs, True, 0.0).constraint
    assert moved.scene.layout is template.scene.layout and moved.scene is not template.scene
    assert panda.collision.cached_scene(moved_obs) is None  # built without the model's scene caches
    fresh = CollisionConstraint(moved_obs, self_collision=True).bind(panda)
    Q = panda.random_q(rng, 300)
    assert [moved.in_collision(q) for q in Q] == [fresh.in_collision(q) for q in Q]
    assert 10 < sum(fresh.in_collision(q) for q in Q) < 290
    for lo in range(0, 300, 10):
        assert moved.first_collision(Q[lo:lo + 10]) == fresh.first_collision(Q[lo:lo + 10])
    data = panda.model.createData()
    for q in Q[:40]:
        pin.forwardKinematics(panda.model, data, q)
        a, b = moved.near_pairs(q), fresh.near_pairs(q)
        assert [p[0] for p in a] == [p[0] for p in b]
        assert np.allclose([p[1] for p in a], [p[1] for p in b], atol=1e-9)
    # a moved copy onto the fixed base is still refused
    onto_base = (*SCENE, ik.Box(_pose((0.0, 0.0, 0.05)), (0.1, 0.1, 0.1)))
    with pytest.raises(errors.InputError, match="fixed base"):
        state.collision_checker(onto_base, True, 0.0).constraint


