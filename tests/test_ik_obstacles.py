"""kinserve.ik obstacles: closed-form distances, clearances against independent code, gradients against finite
differences of the true distance, every iterate outside every obstacle, start in collision, link radius."""


import numpy as np
import pinocchio as pin
import pytest

from kinserve import ik, robots
from kinserve.ik.constraints.obstacle_distance import box_local
from kinserve.ik.constraints.obstacles import ObstacleAvoidance
from kinserve.ik.constraints.segment_distance import (
    point_segment,
    segment_box,
    segment_box_distance,
    segment_segment,
)
from kinserve.kinematics.errors import InputError

from segment_clearance import rows_and_finite_differences, sampled_clearance


@pytest.fixture(scope="module")
def panda():
    return robots.load("panda", geometry=False)


def _box(center, size, yaw=0.3):
    T = np.eye(4)
    c, s = np.cos(yaw), np.sin(yaw)
    T[:3, :3] = [[c, -s, 0], [s, c, 0], [0, 0, 1]]
    T[:3, 3] = center
    return ik.Box(T, size)


def _cylinder(center, radius, length):
    T = np.eye(4)
    T[:3, :3] = pin.rpy.rpyToMatrix(0.4, -0.2, 0.1)
    T[:3, 3] = center
    return ik.Cylinder(T, radius, length)


OBSTACLES = [
    ik.Sphere((0.35, 0.1, 0.55), 0.06),
    ik.Capsule((0.2, -0.3, 0.4), (0.45, -0.25, 0.7), 0.04),
    _box((0.3, 0.3, 0.3), (0.1, 0.15, 0.08)),
    _cylinder((0.5, 0.0, 0.2), 0.05, 0.2),
]


def test_closed_forms_against_dense_sampling():
    rng = np.random.default_rng(0)
    P = 300
    a, b, c, d = (rng.normal(size=(P, 3)) for _ in range(4))
    b[:20] = a[:20]  # point-like first segment
    d[20:40] = c[20:40]  # point-like second segment
    t = np.linspace(0, 1, 2001)
    s, x = point_segment(a, b, c)
    ref = np.array([np.linalg.norm(a[i] + t[:, None] * (b[i] - a[i]) - c[i], axis=1).min() for i in range(P)])
    assert np.all(np.linalg.norm(x - c, axis=1) <= ref + 1e-12)
    assert np.allclose(np.linalg.norm(x - c, axis=1), ref, atol=2e-6)
    s, u, x, y = segment_segment(a, b, c, d)
    assert np.allclose(x, a + s[:, None] * (b - a)) and np.allclose(y, c + u[:, None] * (d - c))
    for i in range(0, P, 7):
        A = a[i] + t[::10, None] * (b[i] - a[i])
        C = c[i] + t[::10, None] * (d[i] - c[i])
        brute = np.linalg.norm(A[:, None] - C[None], axis=2).min()
        assert np.linalg.norm(x[i] - y[i]) <= brute + 1e-12
        tol = 2e-3 * (1 + np.linalg.norm(b[i] - a[i]))
        assert np.linalg.norm(x[i] - y[i]) == pytest.approx(brute, abs=tol)


@pytest.mark.parametrize("k", range(len(OBSTACLES)))
@pytest.mark.parametrize("link_radius", [0.0, 0.03])
def test_clearance_matches_the_shapes_signed_distance(panda, k, link_radius):
    ob = OBSTACLES[k]
    avoid = ObstacleAvoidance([ob], link_radius=link_radius).bind(panda)
    rng = np.random.default_rng(10 + k)
    for q in panda.random_q(rng, 8):
        pin.forwardKinematics(panda.model, panda.data, q)
        c = avoid.clearances(panda.data, np.inf)
        ref = sampled_clearance(panda, q, panda.tip, ob, link_radius)
        assert c.min() <= ref + 1e-5  # coal (GJK) is exact to about 1e-6 m
        assert c.min() == pytest.approx(ref, abs=1e-3)


@pytest.mark.parametrize("k", range(len(OBSTACLES)))
def test_clearance_rows_match_finite_differences_of_the_true_distance(panda, k):
    avoid = ObstacleAvoidance([OBSTACLES[k]], link_radius=0.02).bind(panda)
    rng = np.random.default_rng(20 + k)
    h = 1e-6 if k < 2 else 1e-5
    checked = 0
    for q in panda.random_q(rng, 6):
        c, G, fd = rows_and_finite_differences(panda, avoid, q, h)
        ok = c > 1e-3  # away from contact (where the distance is not differentiable)
        assert np.allclose(G[ok], fd[ok], atol=2e-4 if k < 2 else 2e-3)
        checked += int(ok.sum())
    assert checked > 10


def test_rows_are_the_velocity_damper(panda):
    ob = OBSTACLES[0]
    avoid = ObstacleAvoidance([ob], gain=0.3, influence=10.0).bind(panda)
    q = panda.random_q(np.random.default_rng(1))
    pin.computeJointJacobians(panda.model, panda.data, q)
    G, lo, hi = avoid.rows(panda, panda.data, q)
    c, G_all = avoid.rows_all(panda, panda.data)
    assert np.allclose(G, G_all) and np.allclose(lo, -0.3 * c) and np.all(np.isinf(hi))


def _all_clear(robot, Q, frame, obstacles, link_radius=0.0, tol=1e-9):
    return all(sampled_clearance(robot, q, frame, ob, link_radius, n=201) >= -tol
               for q in Q for ob in obstacles)


@pytest.mark.parametrize("method", ["auto", "qp"])
def test_every_iterate_is_outside_every_obstacle(panda, method):
    rng = np.random.default_rng(30)
    shoulder = panda.fk(panda.neutral(), "panda_link2")[:3, 3]
    solved = tried = 0
    while tried < 8:
        q = panda.random_q(rng)
        T = panda.fk(q).copy()
        p = T[:3, 3]
        obs = [ik.Sphere(shoulder + f * (p - shoulder), 0.05) for f in (0.3, 0.5)] + [
            _box(shoulder + 0.7 * (p - shoulder), (0.06, 0.06, 0.06))]
        if not _all_clear(panda, [q], panda.tip, obs):
            continue
        tried += 1
        res = ik.solve(panda, T, obstacles=obs, method=method, seed=tried, iteration_budget=2000)
        solved += res.success
        assert _all_clear(panda, res.history.q, panda.tip, obs), res.message
    assert solved >= 7


def test_link_radius_keeps_capsules_clear(panda):
    rng = np.random.default_rng(40)
    q = panda.random_q(rng)
    T = panda.fk(q).copy()
    ob = _box(0.5 * (T[:3, 3] + panda.fk(q, "panda_link4")[:3, 3]) + [0.12, 0.0, 0.0], (0.05, 0.05, 0.05))
    res = ik.solve(panda, T, obstacles=[ob], link_radius=0.04, method="qp", seed=1, iteration_budget=2000)
    assert res.success, res.message
    assert all(sampled_clearance(panda, qi, panda.tip, ob, 0.04) >= -1e-6 for qi in res.history.q)


def test_start_in_collision_is_not_an_error(panda):
    rng = np.random.default_rng(50)
    T = panda.fk(panda.random_q(rng)).copy()
    q0 = panda.random_q(rng)
    elbow = panda.fk(q0, "panda_link4")[:3, 3]
    ob = ik.Sphere(elbow + np.array([0.02, 0.01, 0.0]), 0.05)
    assert sampled_clearance(panda, q0, panda.tip, ob) < 0
    res = ik.solve(panda, T, q0, obstacles=[ob], seed=2, iteration_budget=2000)
    assert res.success and "q0" in res.message, res.message
    assert _all_clear(panda, res.history.q, panda.tip, [ob])
    # a control step from inside demands that the clearance grow
    avoid = ik.ObstacleAvoidance([ob])
    before = sampled_clearance(panda, q0, panda.tip, ob)
    v = ik.step(panda, [ik.PostureTask(q0, priority=1)], [avoid], q0, 0.01)
    after = sampled_clearance(panda, q0 + 0.01 * v, panda.tip, ob)
    assert after > before


def test_obstacle_containing_the_base_is_an_error(panda):
    T = panda.fk(panda.random_q(np.random.default_rng(2))).copy()
    with pytest.raises(InputError, match="base"):
        ik.solve(panda, T, obstacles=[ik.Sphere((0, 0, 0.1), 0.2)])
    with pytest.raises(InputError, match="base"):
        ik.solve(panda, T, obstacles=[_box((0, 0, 0.05), (0.3, 0.3, 0.1))])
    with pytest.raises(InputError, match="link_radius"):
        ik.solve(panda, T, obstacles=[OBSTACLES[0]], link_radius=-0.1)
    with pytest.raises(InputError, match="obstacles"):
        ik.solve(panda, T, obstacles=[{"kind": "cone"}])
    with pytest.raises(InputError):
        ik.solve(panda, T, obstacles=["box"])


def test_obstacles_accept_dicts_and_legacy_pairs(panda):
    T = panda.fk(panda.random_q(np.random.default_rng(3))).copy()
    box = _box((0.6, 0.6, 0.6), (0.1, 0.1, 0.1))
    a = ik.solve(panda, T, obstacles=[box.to_dict(), {"center": (0.6, -0.6, 0.6), "radius": 0.05}], seed=4,
                 iteration_budget=2000)
    b = ik.solve(panda, T, obstacles=[box], spheres=[((0.6, -0.6, 0.6), 0.05)], seed=4, iteration_budget=2000)
    assert a.success and np.array_equal(a.q, b.q)


def test_slider_rows_match_finite_differences():
    # the SCARA's quill (a prismatic joint) gives segments whose ends sit on two bodies
    scara = robots.load("scara", geometry=False)
    shapes = [ik.Sphere((0.6, 0.3, 0.6), 0.05), ik.Capsule((0.2, -0.5, 0.3), (0.8, -0.2, 0.9), 0.03)]
    avoid = ObstacleAvoidance(shapes, tool_frames=("tool",)).bind(scara)
    assert any(n.startswith("slider") for n in avoid.skeleton.names)
    rng = np.random.default_rng(60)
    h = 1e-6
    for q in scara.random_q(rng, 6):
        c, G, fd = rows_and_finite_differences(scara, avoid, q, h)
        ok = c > 1e-3
        assert np.allclose(G[ok], fd[ok], atol=1e-5)


def test_first_violation_agrees_with_the_clearances(panda):
    avoid = ObstacleAvoidance(OBSTACLES, link_radius=0.01).bind(panda)
    rng = np.random.default_rng(70)
    Q = panda.random_q(rng, 40)
    flags = []
    for q in Q:
        pin.forwardKinematics(panda.model, panda.data, q)
        flags.append(avoid.clearances(panda.data, np.inf).min() < 0.0)
    assert any(flags) and not all(flags)
    expected = flags.index(True)
    assert avoid.first_violation(panda, Q) == expected
    clear_rows = Q[[i for i, f in enumerate(flags) if not f]]
    assert avoid.first_violation(panda, clear_rows) is None


def test_no_obstacles_is_a_valid_empty_constraint(panda):
    avoid = ObstacleAvoidance([]).bind(panda)
    q = panda.neutral()
    pin.computeJointJacobians(panda.model, panda.data, q)
    assert avoid.margin(panda, panda.data, q) == np.inf
    G, lo, hi = avoid.rows(panda, panda.data, q)
    assert G.shape == (0, panda.nq)
    T = panda.fk(panda.random_q(np.random.default_rng(8))).copy()
    res = ik.solve(panda, tasks=[ik.FrameTask(None, T)], constraints=[avoid], seed=0, iteration_budget=2000)
    assert res.success, res.message


def test_margin_is_the_smallest_exact_clearance_with_bounded_coal_calls(panda):
    """margin() skips coal pairs whose lower bound exceeds the smallest distance found: same minimum, fewer
    calls."""
    import coal

    avoid = ObstacleAvoidance(OBSTACLES + [_box((0.45, -0.1, 0.45), (0.12, 0.1, 0.2), 1.1)],
                              link_radius=0.01).bind(panda)
    rng = np.random.default_rng(71)
    calls = {"n": 0}
    real = coal.distance

    def counting(*args):
        calls["n"] += 1
        return real(*args)

    fewer = 0
    for q in panda.random_q(rng, 60):
        pin.forwardKinematics(panda.model, panda.data, q)
        coal.distance = counting
        try:
            calls["n"] = 0
            m = avoid.margin(panda, panda.data, q)
            n_min = calls["n"]
            calls["n"] = 0
            full = avoid.clearances(panda.data)  # every coal pair below the 5 cm bound computed
            n_full = calls["n"]
        finally:
            coal.distance = real
        ref = float(full.min())
        if ref < 0.05:  # the exact region: the same smallest clearance
            assert m == pytest.approx(ref, abs=1e-9)  # coal's GJK may differ in the last bits (call order)
        else:  # above it: between the lower bounds and the exact smallest clearance (boxes: exact everywhere)
            exact = float(avoid.clearances(panda.data, np.inf).min())
            assert ref - 1e-9 <= m <= exact + 1e-9
        if 0.0 <= ref < 0.05:  # exact region (outside): also against the dense-sampling reference
            assert m == pytest.approx(min(sampled_clearance(panda, q, panda.tip, ob, 0.01, n=401)
                                          for ob in avoid.obstacles), abs=1e-3)
        assert n_min <= n_full
        fewer += n_min < n_full
    assert fewer > 0


def test_segment_box_against_coal_and_dense_sampling():
    """The closed-form segment-box distance (arrays and floats) against coal's GJK and a dense sampling."""
    import coal

    from kinserve.ik.constraints.obstacle_geometry import segment_transform

    rng = np.random.default_rng(80)
    P = 400
    h = rng.uniform(0.01, 0.3, (P, 3))
    a, b = rng.uniform(-0.6, 0.6, (P, 3)), rng.uniform(-0.6, 0.6, (P, 3))
    b[:20] = a[:20]  # point-like segments
    b[20:40, 1:] = a[20:40, 1:]  # parallel to the box's x axis
    b[40:60, 0] = a[40:60, 0]  # in a plane parallel to a face
    s, d, x, y = segment_box(a, b, h)
    assert np.allclose(x, a + s[:, None] * (b - a)) and np.all(np.abs(y) <= h + 1e-15)
    assert np.allclose(np.linalg.norm(x - y, axis=1), d)
    t = np.linspace(0.0, 1.0, 4001)
    req, res = coal.DistanceRequest(), coal.DistanceResult()
    separated = 0
    for i in range(P):
        X = a[i] + t[:, None] * (b[i] - a[i])
        sampled = np.linalg.norm(np.maximum(np.abs(X) - h[i], 0.0), axis=1).min()
        step = float(np.linalg.norm(b[i] - a[i])) / 4000  # the sampling's spacing bounds its excess
        # a minimum, and the minimum
        assert d[i] <= sampled + 1e-15 and d[i] == pytest.approx(sampled, abs=step + 1e-15)
        si, di = segment_box_distance(a[i].tolist(), b[i].tolist(), h[i].tolist())
        assert di == pytest.approx(d[i], abs=1e-12)
        L = float(np.linalg.norm(b[i] - a[i]))
        if L > 1e-9:
            res.clear()
            dc = coal.distance(coal.Box(*(2 * h[i])), coal.Transform3s(), coal.Capsule(0.0, L),
                               segment_transform(a[i], b[i] - a[i], L), req, res)
            if d[i] > 0.0:
                separated += 1
                assert d[i] == pytest.approx(dc, abs=1e-8)
            else:
                assert dc <= 1e-9  # coal: touching or penetrating
    assert separated > 200


def test_separating_axis_test_implies_the_distance():
    from kinserve.ik.constraints.clearance_kernel import separated

    rng = np.random.default_rng(81)
    h = rng.uniform(0.02, 0.2, (500, 3))
    a, b = rng.uniform(-0.5, 0.5, (500, 3)), rng.uniform(-0.5, 0.5, (500, 3))
    d = segment_box(a, b, h)[1]
    for off in (0.0, 0.03):
        flags = np.array([separated(a[i], b[i], h[i], off) for i in range(500)])
        assert np.all(d[flags] >= off)  # separated from the grown box: at least off away
        assert not flags[d == 0.0].any()  # a segment meeting the box is never separated
        assert flags.any() and not flags.all()


def test_violations_mask_matches_the_clearances(panda):
    avoid = ObstacleAvoidance(OBSTACLES, link_radius=0.01).bind(panda)
    Q = panda.random_q(np.random.default_rng(72), 40)
    flags = []
    for q in Q:
        pin.forwardKinematics(panda.model, panda.data, q)
        flags.append(avoid.clearances(panda.data, np.inf).min() < 0.0)
    assert any(flags) and not all(flags)
    assert avoid.violations(panda, Q).tolist() == flags
    boxes = ObstacleAvoidance([OBSTACLES[2], _box((0.45, -0.1, 0.45), (0.12, 0.1, 0.2), 1.1)]).bind(panda)
    ref = []
    for q in Q:
        pin.forwardKinematics(panda.model, panda.data, q)
        ref.append(min(sampled_clearance(panda, q, panda.tip, ob, n=401) for ob in boxes.obstacles) < -1e-6)
    got = boxes.violations(panda, Q)
    assert all(g or not r for g, r in zip(got, ref))  # every sampled violation found (sampling misses some)


def test_bound_copies_share_one_read_only_tables_object(panda):
    a = ObstacleAvoidance(OBSTACLES, link_radius=0.01).bind(panda)
    b = a.bound_copy(panda, gain=0.2)
    c = ObstacleAvoidance(OBSTACLES, link_radius=0.01).adopt(panda, a.tables)
    assert b.tables is a.tables and c.tables is a.tables  # shared by reference, not copied
    assert b.gain == 0.2 and a.gain != 0.2 and b.influence == a.influence  # own arguments
    t = a.tables
    arrays = [getattr(kind, f) for kind in (t.spheres, t.capsules, t.boxes, t.coal_shapes)
              for f in kind._fields]
    arrays = [a for a in arrays if isinstance(a, np.ndarray)]
    arrays += [t.links.support, t.links.inv_len2, *t.links.point_table, *t.links.tree]
    assert len(arrays) > 30 and not any(x.flags.writeable for x in arrays)
    with pytest.raises(ValueError):
        t.spheres.center[0, 0] = 1.0  # read-only: nobody can change a shared table
    with pytest.raises(AttributeError):
        t.spheres = None  # frozen records
    q = panda.random_q(np.random.default_rng(73))
    pin.computeJointJacobians(panda.model, panda.data, q)
    assert np.array_equal(a.rows(panda, panda.data, q)[1] / 0.5 * 0.2, b.rows(panda, panda.data, q)[1])
    # the same shapes bound again: the tables the skeleton keeps; equal shapes, other objects: equal tables
    assert ObstacleAvoidance(OBSTACLES, link_radius=0.01).bind(panda).tables is a.tables
    equal = [ik.Sphere(o.center, o.radius) if isinstance(o, ik.Sphere) else o for o in OBSTACLES]
    d = ObstacleAvoidance(equal, link_radius=0.01).bind(panda)
    assert d.tables is not a.tables and np.array_equal(d.tables.spheres.center, t.spheres.center)
    assert np.array_equal(d.clearances(panda.data, np.inf), a.clearances(panda.data, np.inf))
    assert d.adopt(panda, a.tables).tables is a.tables  # equal obstacles may adopt them
    e = ObstacleAvoidance(OBSTACLES, link_radius=0.02).bind(panda)  # another link radius: tables of their own
    assert e.tables is not a.tables and e.tables.skeleton is a.tables.skeleton
    assert np.array_equal(e.tables.spheres.center, t.spheres.center) and e.tables.offset == 0.02
    assert np.allclose(a.clearances(panda.data, np.inf), e.clearances(panda.data, np.inf) + 0.01, atol=1e-15)
    with pytest.raises(InputError, match="tables"):
        e.adopt(panda, a.tables)
    with pytest.raises(InputError, match="tables"):
        ObstacleAvoidance(OBSTACLES[:2], link_radius=0.01).adopt(panda, a.tables)


def test_a_skeleton_from_its_owner_is_used_and_checked(panda):
    from kinserve.ik.constraints.robot_skeleton import build_robot_skeleton

    avoid = ObstacleAvoidance(OBSTACLES[:2])
    sk = build_robot_skeleton(panda, *avoid.skeleton_frames(panda))
    assert avoid.bind(panda, skeleton=sk).tables.skeleton is sk
    other = ObstacleAvoidance([ik.Sphere((0.4, 0.2, 0.2), 0.08, ("panda_link4",))])
    with pytest.raises(InputError, match="skeleton"):
        other.bind(panda, skeleton=sk)  # a skeleton without the frame point of panda_link4
    assert other.bind(panda).tables.skeleton.frames == ("panda_link4",)


def test_a_free_answer_reached_through_an_obstacle_is_only_a_start(panda, monkeypatch):
    """The free LM attempts of ik.solve: a converged run whose path enters an obstacle is not returned as it
    is; its clear answer is a start of its own that already meets the target, returned with a history of
    clear configurations only (that answer alone)."""
    import sys

    from kinserve.ik.result import History, Result

    checked = sys.modules["kinserve.ik.strategies.checked"]
    rng = np.random.default_rng(90)
    while True:
        q_goal, q_mid = panda.random_q(rng, 2)
        ob = ik.Sphere(panda.fk(q_mid, "panda_link4")[:3, 3], 0.05)  # contains the elbow at q_mid
        if sampled_clearance(panda, q_goal, panda.tip, ob) > 0.01 and \
                sampled_clearance(panda, panda.neutral(), panda.tip, ob) > 0.01:
            break
    T = panda.fk(q_goal).copy()
    calls = []

    def fake_lm(req, budget, accept=None, admit=None, max_starts=None, screen=None):  # "converges" via q_mid
        qs = np.array([panda.neutral(), q_mid, q_goal])
        calls.append(qs)
        assert accept(qs)  # the answer is clear (its path is not): accepted
        history = History.from_lists(list(qs), [0.1, 0.05, 0.0], [0.1, 0.05, 0.0])
        return Result(q=q_goal.copy(), success=True, position_error=0.0, orientation_error=0.0, iterations=2,
                      message="converged", history=history, method="lm", frame=panda.tip)

    monkeypatch.setattr(checked, "levenberg_marquardt", fake_lm)
    res = ik.solve(panda, T, obstacles=[ob], seed=3, iteration_budget=2000)
    assert len(calls) == 1  # the clear answer ends the free attempts
    assert res.success and "start of its own" in res.message, res.message
    assert np.array_equal(res.q, q_goal) and len(res.history.q) == 1
    assert _all_clear(panda, res.history.q, panda.tip, [ob])
    again = ik.solve(panda, T, obstacles=[ob], seed=3, iteration_budget=2000)
    assert np.array_equal(again.q, res.q)


def test_violations_of_a_list_of_iterates_match_independent_sampling(panda):
    """violations() takes the lazy history's list of iterates as well as a stacked array; sphere and box
    verdicts agree with the shapes' own signed distance sampled along every moving segment."""
    rng = np.random.default_rng(91)
    shapes = [ik.Sphere((0.35, 0.1, 0.55), 0.08), ik.Sphere((0.1, -0.35, 0.5), 0.07),
              _box((0.3, 0.3, 0.3), (0.12, 0.15, 0.1)), _box((0.45, -0.1, 0.45), (0.12, 0.1, 0.2), 1.1)]
    avoid = ObstacleAvoidance(shapes).bind(panda)
    Q = panda.random_q(rng, 60)
    ref = [min(sampled_clearance(panda, q, panda.tip, ob, n=401) for ob in shapes) for q in Q]
    got = avoid.violations(panda, list(Q))
    assert got.tolist() == avoid.violations(panda, Q).tolist()
    assert any(r < -1e-3 for r in ref) and any(r > 1e-3 for r in ref)
    for g, r in zip(got, ref):
        if abs(r) > 1e-3:  # (sampling is exact up to its spacing; skip touching cases)
            assert g == (r < 0.0), (g, r)


def test_points_into_and_box_frames_match_the_plain_forms(panda):
    """LinkSkeleton.points_into == points; the box pairs' ends in the box frames are R^T (x - t) of each
    pair."""
    boxes = [_box((0.3, 0.3, 0.3), (0.1, 0.15, 0.08)), _box((0.4, -0.2, 0.5), (0.1, 0.1, 0.1), 0.7)]
    avoid = ObstacleAvoidance(boxes).bind(panda)
    sk = avoid.skeleton
    Q = panda.random_q(np.random.default_rng(92), 5)
    P = np.empty((len(Q), sk.n_points, 3))
    for k, q in enumerate(Q):
        pin.forwardKinematics(panda.model, panda.data, q)
        sk.points_into(panda.data, P[k])
        assert np.array_equal(P[k], sk.points(panda.data))
    boxes = avoid.tables.boxes
    a, b = box_local(P, boxes)
    for p, (box, ia, ib) in enumerate(zip(boxes.shapes, boxes.ia, boxes.ib)):
        R, t = box.pose[:3, :3], box.pose[:3, 3]
        assert np.allclose(a[:, p], (P[:, ia] - t) @ R, atol=1e-14)
        assert np.allclose(b[:, p], (P[:, ib] - t) @ R, atol=1e-14)


def test_base_check_agrees_with_sampling_of_the_fixed_segments(panda):
    """Every kind of obstacle raises 'contains the robot base' exactly when it comes closer than the link
    radius to a fixed (base) segment (its signed distance to 2001 points of each segment)."""
    from kinserve.ik.constraints import robot_segments

    fixed = [s for s in robot_segments(panda, panda.tip) if s.ja == 0 and s.jb == 0]
    assert fixed
    pts = np.concatenate([s.la + np.linspace(0, 1, 2001)[:, None] * (s.lb - s.la) for s in fixed])
    rng = np.random.default_rng(93)
    outcomes = {kind: set() for kind in ("sphere", "box", "capsule", "cylinder")}
    for _ in range(240):
        c = rng.uniform([-0.2, -0.2, 0.0], [0.2, 0.2, 0.5])
        kind = ("sphere", "box", "capsule", "cylinder")[rng.integers(4)]
        if kind == "sphere":
            ob = ik.Sphere(c, rng.uniform(0.02, 0.1))
        elif kind == "box":
            ob = _box(c, rng.uniform(0.03, 0.2, 3), yaw=rng.uniform(-np.pi, np.pi))
        elif kind == "capsule":
            ob = ik.Capsule(c, c + rng.uniform(-0.15, 0.15, 3), rng.uniform(0.01, 0.06))
        else:
            ob = ik.Cylinder(_box(c, (1, 1, 1), yaw=rng.uniform(-np.pi, np.pi)).pose, rng.uniform(0.02, 0.08),
                             rng.uniform(0.05, 0.2))
        rho = float(rng.choice([0.0, 0.03]))
        d = float(ob.signed_distance(pts).min())
        if abs(d - rho) < 2e-3:
            continue
        try:
            ObstacleAvoidance([ob], link_radius=rho).bind(panda)
            raised = False
        except InputError as exc:
            assert "base" in str(exc)
            raised = True
        assert raised == (d < rho), (ob, rho, d)
        outcomes[kind].add(raised)
    assert all(seen == {True, False} for seen in outcomes.values()), outcomes


def test_skeleton_of_the_right_model_after_binding_another(panda):
    """A constraint bound to one robot and then to another gets the other's skeleton, and back again."""
    ur5 = robots.load("ur5", geometry=False)
    ob = ik.Sphere((0.4, 0.4, 0.6), 0.05)
    names_panda = ObstacleAvoidance([ob]).bind(panda).skeleton.names
    names_ur5 = ObstacleAvoidance([ob]).bind(ur5).skeleton.names
    assert names_panda != names_ur5 and all("panda" in n for n in names_panda[:-1])
    assert ObstacleAvoidance([ob]).bind(panda).skeleton.names == names_panda
    avoid = ObstacleAvoidance([ob]).bind(panda)
    assert avoid.bind(ur5).skeleton.names == names_ur5 and avoid.bind(panda).skeleton.names == names_panda


def test_obstacle_solves_are_deterministic(panda):
    """Same seed, same request (fresh obstacle objects) -> the same bytes (an iteration budget, no clock)."""
    rng = np.random.default_rng(94)
    for _ in range(4):
        T = panda.fk(panda.random_q(rng)).copy()
        q0 = panda.random_q(rng)
        p = T[:3, 3]
        def mk(p=p):
            return [ik.Sphere(0.5 * p + np.array([0, 0, 0.17]), 0.05),
                    _box(0.7 * p + np.array([0, 0, 0.1]), (0.08,) * 3)]
        try:
            a = ik.solve(panda, T, q0, obstacles=mk(), seed=5, iteration_budget=2000)
        except InputError:
            continue
        b = ik.solve(panda, T, q0, obstacles=mk(), seed=5, iteration_budget=2000)
        assert a.q.tobytes() == b.q.tobytes() and a.history.q.tobytes() == b.history.q.tobytes()
        assert a.message == b.message and a.success == b.success


@pytest.mark.parametrize("frames", [None, ("panda_link4", "panda_hand")])
def test_sphere_rows_after_margin_match_fresh_rows_and_the_general_path(panda, frames):
    """Spheres only: rows() reusing margin()'s geometry (same q object) equal rows() computed afresh, and both
    the per-sphere batched product (spheres kept clear of the default segments) and the per-pair product
    (``frames``) equal the general witness-point rows (LinkSkeleton.gradient_rows) of rows_all."""
    rng = np.random.default_rng(5)
    spheres = [ik.Sphere((0.35, 0.1, 0.55), 0.06), ik.Sphere((0.1, -0.3, 0.6), 0.05),
               ik.Sphere((0.4, 0.2, 0.2), 0.08, frames)]
    avoid = ObstacleAvoidance(spheres, link_radius=0.02, margin=0.01, gain=0.4, influence=0.25).bind(panda)
    assert avoid.tables.sphere_only and (avoid.tables.spheres.blocks is None) == (frames is not None)
    n_rows = 0
    for q in panda.random_q(rng, 25):
        pin.computeJointJacobians(panda.model, panda.data, q)
        m = avoid.margin(panda, panda.data, q)
        G, lo, hi = avoid.rows(panda, panda.data, q)  # the geometry kept by margin()
        G2, lo2, _ = avoid.rows(panda, panda.data, q.copy())  # another q object: computed afresh
        assert np.array_equal(G, G2) and np.array_equal(lo, lo2) and np.all(np.isinf(hi))
        c, G_all = avoid.rows_all(panda, panda.data)
        assert abs(m - c.min()) <= 1e-15
        near = c < 0.25
        assert np.allclose(G, G_all[near], rtol=0.0, atol=1e-14)
        assert np.allclose(lo, -0.4 * c[near], rtol=0.0, atol=1e-15)
        n_rows += G.shape[0]
    assert n_rows > 10


class _Tables:
    """A stand-in for bound tables: what :class:`BoundTables` reads of them."""

    def __init__(self, obstacles, link_radius=0.0, margin=0.0):
        self.obstacles, self.link_radius, self.margin = tuple(obstacles), link_radius, margin


def test_bound_tables_find_by_identity_and_evict_in_order():
    """BoundTables finds the tables of the same obstacle objects (not of equal ones), keeps the newest
    ``size`` and forgets the evicted ones - its first-obstacle index stays in step with its entries."""
    from kinserve.ik.constraints.robot_skeleton import BoundTables

    store = BoundTables(size=3)
    sets = [[ik.Sphere((k, 0.0, 1.0), 0.1), ik.Sphere((k, 1.0, 1.0), 0.1)] for k in range(5)]
    tables = [_Tables(s) for s in sets]
    for t in tables[:3]:
        store.add(t)
    assert store.find(sets[1], 0.0, 0.0) is tables[1]
    assert store.find([ik.Sphere((1, 0.0, 1.0), 0.1), sets[1][1]], 0.0, 0.0) is None  # equal, not the same
    assert store.find(sets[1], 0.01, 0.0) is None  # another link radius
    assert store.find(sets[1][:1], 0.0, 0.0) is None  # a prefix of the set
    store.add(tables[3])  # evicts the least recently used: set 0 (set 1 was just found)
    assert store.find(sets[0], 0.0, 0.0) is None
    assert [store.find(s, 0.0, 0.0) for s in sets[1:4]] == tables[1:4]
    shared = _Tables([sets[2][0]], 0.0, 0.0)  # another entry with the same first obstacle
    store.add(shared)  # evicts set 1
    assert store.find([sets[2][0]], 0.0, 0.0) is shared and store.find(sets[2], 0.0, 0.0) is tables[2]
    assert len(store.entries) == 3
    assert sorted(store.first_ids.values()) == [1, 2]  # set 2's first obstacle twice, set 3's once
    empty = _Tables([])
    store.add(empty)
    assert store.find([], 0.0, 0.0) is empty
