"""The fast path of ik.solve keeps every answer and check: lazy starts and history, pose/vector
validation shortcuts, the scene cache by value and the per-iterate collision check."""

import itertools
import pickle

import numpy as np
import pytest

from kinserve import ik, robots
from kinserve.ik.result import History
from kinserve.ik.starts.multistart import frame_starts
from kinserve.ik.starts.seed_table import seed_table, start_sequence
from kinserve.kinematics import errors
from kinserve.kinematics.validation import ROTATION_TOL, as_pose, as_vector, is_pose_fast

FRAME = "panda_link8"


@pytest.fixture(scope="module")
def panda():
    return robots.load("panda", tip=FRAME)


def test_prefer_q0_starts_are_the_eager_sequence(panda):
    """prefer_q0 ranks the table only after q0: the sequence is exactly start_sequence's."""
    rng = np.random.default_rng(3)
    T = panda.fk(panda.random_q(rng), FRAME).copy()
    q0 = panda.random_q(rng)
    table = seed_table(panda, FRAME)
    eager = start_sequence(panda, table, table.features(T[:3, :3], T[:3, 3]), q0, 5, q0_distance=1e9, prefer_q0=True)
    lazy = frame_starts(panda, FRAME, panda.frame_id(FRAME), T[:3, :3], T[:3, 3], True, q0, 5, prefer_q0=True)
    a, b = list(itertools.islice(eager, 25)), list(itertools.islice(lazy, 25))
    assert np.array_equal(a[0], q0) and a[0] is not q0
    assert all(np.array_equal(x, y) for x, y in zip(a, b))


def test_lazy_history_equals_the_recorded_iterates(panda):
    qs = [np.arange(7.0) + k for k in range(4)]
    pos2, rot2 = [4.0, 1.0, 0.25, 0.01, 99.0], [9.0, 4.0, 1.0, 0.04, 99.0]
    h = History.from_squared(qs, pos2, rot2, 3, components=("x", "y"))
    assert len(h) == 3
    assert np.array_equal(h.q, np.array(qs[:3]))
    assert np.allclose(h.position_error, [2.0, 1.0, 0.5]) and np.allclose(h.orientation_error, [3.0, 2.0, 1.0])
    h2 = pickle.loads(pickle.dumps(History.from_squared(qs, pos2, rot2, 2)))
    assert h2.q.shape == (2, 7) and np.allclose(h2.position_error, [2.0, 1.0])
    empty = History.from_squared([], [], [], 0)
    assert len(empty) == 0 and empty.q.shape == (0, 0)


def test_lm_history_errors_match_fk(panda):
    """The history the solver returns (built lazily) holds the true errors of every iterate."""
    rng = np.random.default_rng(4)
    T = panda.fk(panda.random_q(rng), FRAME).copy()
    res = ik.solve(panda, T, panda.random_q(rng), frame=FRAME, prefer_q0=True)
    assert res.success and len(res.history) >= 2
    assert np.array_equal(res.history.q[-1], res.q)
    for q, pe, re in zip(res.history.q, res.history.position_error, res.history.orientation_error):
        F = panda.fk(q, FRAME)
        assert abs(pe - np.linalg.norm(F[:3, 3] - T[:3, 3])) < 1e-9
        c = np.clip((np.trace(F[:3, :3].T @ T[:3, :3]) - 1) / 2, -1, 1)
        assert abs(re - np.arccos(c)) < 1e-6


def _rot(axis, angle):
    axis = np.asarray(axis, float) / np.linalg.norm(axis)
    K = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return np.eye(3) + np.sin(angle) * K + (1 - np.cos(angle)) * K @ K


def test_pose_fast_check_agrees_with_the_precise_check():
    """is_pose_fast accepts only what the NumPy path accepts (and every clean pose)."""
    rng = np.random.default_rng(5)
    for k in range(400):
        T = np.eye(4)
        T[:3, :3] = _rot(rng.normal(size=3), rng.uniform(-3, 3))
        T[:3, 3] = rng.normal(size=3)
        kind = k % 5
        if kind == 1:
            T[:3, :3] += rng.normal(size=(3, 3)) * 10 ** rng.uniform(-9, -4)  # near the tolerance
        elif kind == 2:
            T[:3, :3] = -T[:3, :3]  # det -1
        elif kind == 3:
            T[rng.integers(4), rng.integers(4)] = rng.choice([np.nan, np.inf, 1e300])
        elif kind == 4:
            T[3, rng.integers(3)] = 1e-12  # only the precise path accepts a bottom row within 1e-9
        precise_ok = True
        try:
            as_pose(T.tolist(), "pose")  # a list: always the precise path
        except errors.InputError:
            precise_ok = False
        if is_pose_fast(T):
            assert precise_ok
        if kind == 0:  # a clean pose takes the fast path
            assert is_pose_fast(T) and np.abs(T[:3, :3].T @ T[:3, :3] - np.eye(3)).max() < ROTATION_TOL
        if precise_ok:
            assert np.array_equal(as_pose(T), T, equal_nan=True)
        else:
            with pytest.raises(errors.InputError):
                as_pose(T)


def test_vector_shortcut_rejects_what_the_precise_check_rejects():
    assert np.array_equal(as_vector((0.5, 1.0, 2.0), 3), [0.5, 1.0, 2.0])
    for bad in ((0.0, np.nan, 1.0), (0.0, 1e300, 1.0), [np.inf, 0, 0], (2e6, 0, 0)):
        with pytest.raises(errors.NonFiniteError):
            as_vector(bad, 3, "size")
    with pytest.raises(errors.NonFiniteError, match="box size"):
        ik.Box(np.eye(4), (0.1, np.nan, 0.1))


def test_equal_obstacles_built_anew_share_one_scene(panda):
    def scene_objects():
        T = np.eye(4)
        T[:3, 3] = (0.65, 0.0, -0.05)
        return [ik.Box(T, (0.7, 1.2, 0.1)), ik.Sphere((0.3, 0.3, 0.6), 0.05)]

    a = panda.collision_scene(scene_objects())
    assert panda.collision_scene(scene_objects()) is a
    assert panda.collision_scene(scene_objects(), self_collision=False) is not a
    T = np.eye(4)
    T[:3, 3] = (0.65, 0.0, -0.06)  # a different table: a different scene
    other = panda.collision_scene([ik.Box(T, (0.7, 1.2, 0.1)), ik.Sphere((0.3, 0.3, 0.6), 0.05)])
    assert other is not a and other.obstacles[0].pose[2, 3] == -0.06


def test_every_iterate_is_still_checked(panda, monkeypatch):
    """The cheap path checks the answer and every other iterate of the returned run (the sphere pre-check or
    coal: whatever the scene's checks decide; the start by the admission before its run), the answer once."""
    from kinserve.ik.collision import solve as collision_solve
    from kinserve.kinematics import collision_scene

    checked = []
    real_admission = collision_solve._start_admission

    def admission(*args, **kwargs):
        admit = real_admission(*args, **kwargs)

        def spied(q):
            ok = admit(q)
            if ok:
                checked.append(np.array(q))
            return ok

        return spied

    monkeypatch.setattr(collision_solve, "_start_admission", admission)
    real_parts = collision_solve._check_parts

    def parts(constraint):  # the pre-check the accept test calls directly: the rows it certifies
        got = real_parts(constraint)
        if len(got) == 1:
            return got
        first = got[2]

        def spied_first(floats, ints, qs, start, tol):
            k = first(floats, ints, qs, start, tol)
            checked.extend(np.array(q) for q in qs[start:k])
            return k

        return got[:2] + (spied_first,) + got[3:]

    monkeypatch.setattr(collision_solve, "_check_parts", parts)
    scene_cls = collision_scene.CollisionScene
    real_first, real_one = scene_cls.first_collision, scene_cls.in_collision

    def first_collision(self, qs, uncertified=None):  # the rows before ``uncertified``: the caller certified them
        checked.extend(np.array(q) for q in qs[uncertified or 0:])
        return real_first(self, qs, uncertified)

    def in_collision(self, q):
        checked.append(np.array(q))
        return real_one(self, q)

    monkeypatch.setattr(scene_cls, "first_collision", first_collision)
    monkeypatch.setattr(scene_cls, "in_collision", in_collision)
    rng = np.random.default_rng(6)
    T = panda.fk(panda.random_q(rng), FRAME).copy()
    res = ik.solve(panda, T, panda.random_q(rng), frame=FRAME, self_collision=True, seed=1, max_time=2.0)
    assert res.success and res.info["collision"] == "unconstrained, checked"
    hist = res.history.q
    assert len(hist) >= 3
    for q in hist:
        assert any(np.array_equal(q, c) for c in checked)
    assert sum(np.array_equal(res.q, c) for c in checked) == 1
    monkeypatch.undo()
    assert not any(panda.in_collision(q) for q in hist)


def test_collision_options_are_remembered_by_the_shapes_identities(panda):
    """The same shape objects give the same validated options (one lookup); other objects - equal or not - are
    validated anew, and so is anything that is not a list or tuple of shapes (a dict can change between calls:
    a bad size raises every time)."""
    from kinserve.ik.collision.solve import _request_constraint, collision_options

    T = np.eye(4)
    T[:3, 3] = (0.65, 0.0, -0.05)
    table = ik.Box(T, (0.7, 1.2, 0.1))
    a = collision_options(True, [table], 0.0, ())
    assert collision_options(True, [table], 0.0, ()) is a and collision_options(True, (table,), 0.0, ()) is a
    assert a["obstacles"] == (table,) and a["self_collision"] is True
    assert collision_options(False, [table], 0.0, ()) is not a
    assert collision_options(True, [ik.Box(T, (0.7, 1.2, 0.1))], 0.0, ()) is not a
    spec = {"kind": "box", "pose": T.tolist(), "size": [0.7, 1.2, 0.1]}
    assert collision_options(True, [spec], 0.0, ()) is not collision_options(True, [spec], 0.0, ())
    spec["size"] = [0.7, -1.2, 0.1]
    for _ in range(2):
        with pytest.raises(errors.InputError):
            collision_options(True, [spec], 0.0, ())
    # the bound constraint of one options dictionary is found by identity, and is that scene's
    bound = _request_constraint(panda, a)
    assert _request_constraint(panda, a) is bound and bound.obstacles == (table,)
    T2 = T.copy()
    T2[2, 3] = 0.3  # the table raised into the arm's way: a different scene, a different answer
    other = _request_constraint(panda, collision_options(True, [ik.Box(T2, (0.7, 1.2, 0.1))], 0.0, ()))
    assert other is not bound and other.obstacles[0].pose[2, 3] == 0.3
    rng = np.random.default_rng(4)
    raised = other.obstacles[0]
    q = next(q for q in panda.random_q(rng, 500)
             if panda.in_collision(q, [raised]) and not panda.in_collision(q, [table]))
    assert other.in_collision(q) and not bound.in_collision(q)
