"""The fast path of ik.solve keeps every answer and check: lazy starts and history, pose/vector
validation shortcuts, the scene layouts shared by equal obstacles and the per-iterate collision check."""

import itertools
import pickle

import numpy as np
import pytest

from kinserve import ik, robots
from kinserve.ik.result import History
from kinserve.ik.starts.multistart import frame_starts
from kinserve.ik.starts.seed_table import start_sequence
from kinserve.ik.state import seed_table
from kinserve.kinematics import errors
from kinserve.kinematics.errors import InputError
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
    eager = start_sequence(panda, table, table.features(T[:3, :3], T[:3, 3]), q0, 5, q0_distance=1e9,
                           prefer_q0=True)
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
    assert (np.allclose(h.position_error, [2.0, 1.0, 0.5])
            and np.allclose(h.orientation_error, [3.0, 2.0, 1.0]))
    h2 = pickle.loads(pickle.dumps(History.from_squared(qs, pos2, rot2, 2)))
    assert h2.q.shape == (2, 7) and np.allclose(h2.position_error, [2.0, 1.0])
    empty = History.from_squared([], [], [], 0)
    assert len(empty) == 0 and empty.q.shape == (0, 0)


def test_lm_history_errors_match_fk(panda):
    """The history the solver returns (built lazily) holds the true errors of every iterate."""
    rng = np.random.default_rng(4)
    T = panda.fk(panda.random_q(rng), FRAME).copy()
    res = ik.solve(panda, T, panda.random_q(rng), frame=FRAME, prefer_q0=True, iteration_budget=2000)
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


def test_equal_obstacles_built_anew_share_one_layout(panda):
    """New objects of equal values: a scene of their own (a few microseconds) on the same layout, with the
    same pre-check arrays; the same objects: the same scene."""
    def scene_objects():
        T = np.eye(4)
        T[:3, 3] = (0.65, 0.0, -0.05)
        return [ik.Box(T, (0.7, 1.2, 0.1)), ik.Sphere((0.3, 0.3, 0.6), 0.05)]

    objects = scene_objects()
    a = panda.collision_scene(objects)
    assert panda.collision_scene(objects) is a
    again = panda.collision_scene(scene_objects())
    assert again.layout is a.layout and np.array_equal(again.precheck().floats, a.precheck().floats)
    assert panda.collision_scene(scene_objects(), self_collision=False).layout is not a.layout
    T = np.eye(4)
    T[:3, 3] = (0.65, 0.0, -0.06)  # a different table: a different scene
    other = panda.collision_scene([ik.Box(T, (0.7, 1.2, 0.1)), ik.Sphere((0.3, 0.3, 0.6), 0.05)])
    assert other is not a and other.obstacles[0].pose[2, 3] == -0.06


def test_every_iterate_is_still_checked(panda, monkeypatch):
    """The checked LM checks the answer and every other iterate of the returned run, and its start: in the
    screen's compiled call (the sphere pre-check, after the run) when it certifies them, else by the
    admission and the checker's ``first_violation`` (the pre-check, then coal); the answer once."""
    from kinserve.ik.collision import collision_checker as checkers
    from kinserve.ik.lm.screen import LMScreen
    from kinserve.ik.lm.status import ROWS_CERTIFIED
    from kinserve.ik.state import ik_state

    checked = []
    checker = ik_state(panda).collision_checker((), True, 0.0)  # the one the solve below uses
    screen = checker.screen
    assert screen is not None

    calls = []

    def screened(*args):
        calls.append(1)
        status, it, k, flag, row = screen.run(*args)
        q0, qs, admit_start = args[2], args[16], args[-1]
        if admit_start and flag == ROWS_CERTIFIED:  # the start certified by the screen
            checked.append(np.array(q0))
        if flag == ROWS_CERTIFIED and status == 0:
            checked.extend(np.array(q) for q in qs[1:k])
        return status, it, k, flag, row

    real_admission = checkers._admission

    def admission(*args):
        admit = real_admission(*args)

        def spied(q):
            ok = admit(q)
            if ok:
                checked.append(np.array(q))
            return ok

        return spied

    real_first = checkers.CollisionChecker.first_violation

    def first_violation(self, rows, uncertified=None):  # rows before uncertified: certified by the screen
        k = real_first(self, rows, uncertified)
        checked.extend(np.array(q) for q in (rows if k < 0 else rows[:k + 1]))
        return k

    monkeypatch.setattr(checker, "screen", LMScreen(screened, *screen[1:]))
    monkeypatch.setattr(checkers, "_admission", admission)
    monkeypatch.setattr(checkers.CollisionChecker, "first_violation", first_violation)
    rng = np.random.default_rng(6)
    T = panda.fk(panda.random_q(rng), FRAME).copy()
    res = ik.solve(panda, T, panda.random_q(rng), frame=FRAME, self_collision=True, seed=1,
                   iteration_budget=2000)
    assert res.success and res.info["collision"] == "unconstrained, checked"
    assert calls  # the starts ran through the screen
    hist = res.history.q
    assert len(hist) >= 3
    for q in hist:
        assert any(np.array_equal(q, c) for c in checked)
    assert sum(np.array_equal(res.q, c) for c in checked) == 1
    monkeypatch.undo()
    assert not any(panda.in_collision(q) for q in hist)


def test_the_last_scene_is_reused_only_for_the_very_same_shapes(panda):
    """A collision-aware request whose obstacles are the very shape objects of the thread's last one (and the
    same options) skips re-validating them and reuses that binding; one other object, another order, other
    options or bad input go through validation and binding (equal new shapes find the same binding by
    value)."""
    from kinserve.ik.request import pose_request

    def box(x):
        T = np.eye(4)
        T[:3, 3] = (x, 0.0, -0.05)
        return ik.Box(T, (0.7, 1.2, 0.1))

    table, wall, other = box(0.65), box(-0.9), box(-1.2)
    T = panda.fk(panda.neutral(), FRAME)

    def request(obstacles, self_collision=True, margin=0.0):
        return pose_request(panda, T, None, FRAME, (), "world", "auto", 1e-4, 1e-3, None, None, {},
                            (self_collision, obstacles, margin, ()))

    first = request([table, wall])
    again = request([table, wall])
    assert again.collision_checker is first.collision_checker and again.collision == first.collision
    assert request((table, wall)).collision is again.collision  # the last binding's validated options
    swapped = request([table, other])
    assert swapped.collision_checker is not first.collision_checker
    assert swapped.collision_checker.constraint.obstacles[1] is other
    assert request([wall, table]).collision_checker.constraint.obstacles[0] is wall
    assert request([table, wall], margin=0.01).collision.margin == 0.01
    assert request([table, wall], self_collision=False).collision.self_collision is False
    with pytest.raises(InputError, match="collision margin"):
        request([table, wall], margin=-1.0)
    with pytest.raises(InputError, match="self_collision"):
        request([table, wall], self_collision=1)
    equal = request([box(0.65), box(-0.9)])  # equal new objects: validated, then the same binding by value
    assert equal.collision_checker is first.collision_checker


def test_bound_constraints_are_found_by_the_shapes_values(panda):
    """The robot's IK state keeps one bound constraint per obstacle set: the same shapes, or equal new ones,
    find it; other flags, other sizes or a dict spec with a bad size are another scene or an error."""
    from kinserve.ik.collision.request import collision_request
    from kinserve.ik.state import ik_state

    T = np.eye(4)
    T[:3, 3] = (0.65, 0.0, -0.05)
    table = ik.Box(T, (0.7, 1.2, 0.1))
    state = ik_state(panda)
    a = state.collision_checker((table,), True, 0.0).constraint
    assert state.collision_checker((table,), True, 0.0).constraint is a
    assert state.collision_checker((ik.Box(T, (0.7, 1.2, 0.1)),), True, 0.0).constraint is a  # equal shapes
    assert state.collision_checker((table,), False, 0.0).constraint is not a
    assert a.obstacles == (table,)
    spec = {"kind": "box", "pose": T.tolist(), "size": [0.7, -1.2, 0.1]}
    for _ in range(2):
        with pytest.raises(errors.InputError):
            collision_request(True, [spec], 0.0)
    T2 = T.copy()
    T2[2, 3] = 0.3  # the table raised into the arm's way: another pose of the same layout, moved
    b = state.collision_checker((ik.Box(T2, (0.7, 1.2, 0.1)),), True, 0.0).constraint
    assert b is not a and b.scene.layout is a.scene.layout
    q = panda.neutral()
    assert b.in_collision(q) == panda.in_collision(q, [ik.Box(T2, (0.7, 1.2, 0.1))])

