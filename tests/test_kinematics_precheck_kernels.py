"""The compiled pre-check kernels (kinserve.kinematics.precheck_kernels) against Pinocchio and the shapes.

* the tree's forward kinematics against Pinocchio's ``oMi`` (serial arms, a two-arm tree, prismatic and
  unaligned joints);
* obstacle bounds against the closed-form signed distances of kinematics.shapes, and the squared test and
  slack of the certification against them;
* the packed arrays' row views (``rows_view``, and ``float_rows_view`` of float64 values stored in int64
  words) against NumPy's ``reshape`` and ``view``, sharing memory;
* ``first_uncertified`` on converging paths against row-by-row certification and coal; rows near a certified
  one skipped without forward kinematics.
"""

import coal
import numba
import numpy as np
import pinocchio as pin
import pytest

from kinserve import robots
from kinserve.kinematics import precheck_kernels as pk
from kinserve.kinematics.kernel_primitives import float_rows_view, rows_view
from kinserve.kinematics.obstacle_table import obstacle_row
from kinserve.kinematics.precheck_verdicts import carried_pairs
from kinserve.kinematics.serial_chain import kinematic_tree
from kinserve.kinematics.shapes import Box, Capsule, Cylinder, Mesh, Sphere

from collision_scenes import SCENE, coal_hits, pose, rotation, scenes_near_the_arm, tetrahedron_file


@pytest.mark.parametrize("name", ["panda", "ur5", "baxter", "scara", "finger_edu", "pr"])
def test_tree_placements_match_pinocchio_omi(name):
    robot = robots.load(name, geometry=False)
    model, data = robot.model, robot.model.createData()
    tree, joints = kinematic_tree(model)
    assert len(joints) == model.njoints - 1 and joints[:, 2].tolist() == list(model.parents)[1:]
    X = np.empty((model.njoints, 12))
    for q in robot.random_q(np.random.default_rng(3), 30):
        pk.tree_placements(tree, joints, q, X)
        pin.forwardKinematics(model, data, q)
        for j in range(model.njoints):
            M = data.oMi[j]
            assert np.abs(X[j, :9].reshape(3, 3) - M.rotation).max() < 1e-12
            assert np.abs(X[j, 9:] - M.translation).max() < 1e-12


@numba.njit
def _rows_of(flat, start, rows, cols):
    return rows_view(flat[start:], rows, cols)


@pytest.mark.parametrize("dtype", [np.float64, np.int64])
def test_rows_view_is_reshape_of_the_slice_and_shares_its_memory(dtype):
    """Every (start, rows, cols) that fits a flat array: the view equals NumPy's reshape of the slice, is
    C-ordered (its compiled type too), writes through to the flat array, and is read-only when it is."""
    flat = np.arange(30).astype(dtype)
    for start in (0, 1, 7):
        for rows, cols in ((0, 4), (1, 1), (3, 5), (2, 11), ((30 - start) // 4, 4)):
            view = _rows_of(flat, start, rows, cols)
            assert view.shape == (rows, cols) and view.flags.c_contiguous
            assert np.array_equal(view, flat[start:start + rows * cols].reshape(rows, cols))
            if rows:
                view[rows - 1, cols - 1] = -5
                assert flat[start + rows * cols - 1] == -5
                flat[:] = np.arange(30)
    item = numba.from_dtype(flat.dtype)
    (signature,) = [s for s in _rows_of.nopython_signatures if s.args[0].dtype == item]
    assert signature.return_type.layout == "C" and signature.return_type.ndim == 2
    frozen = flat.copy()
    frozen.setflags(write=False)
    assert not _rows_of(frozen, 2, 3, 4).flags.writeable
    with pytest.raises(numba.TypingError):
        _rows_of(np.zeros((3, 4), dtype=dtype), 0, 2, 2)  # not 1-D: no implementation


@numba.njit
def _float_rows_of(words, start, rows, cols):
    return float_rows_view(words[start:], rows, cols)


def test_float_rows_view_reads_the_words_bits_as_float64_rows_and_shares_their_memory():
    """Float64 values stored as int64 words (as the pre-check's integer array holds the robot's floats):
    every (start, rows, cols) that fits reads them back exactly - signed zeros, tiny and huge values - as
    NumPy's ``view(float64)`` of the slice, reshaped, C-ordered; a write through the view lands in the words'
    bits; a read-only array gives a read-only view; float64 or 2-D words have no implementation."""
    rng = np.random.default_rng(40)
    values = np.concatenate([rng.normal(size=24), [-0.0, 5e-324, 1.7e308, -np.pi, 1e-300, 0.1]])
    words = values.view(np.int64).copy()
    for start in (0, 1, 7):
        for rows, cols in ((0, 4), (1, 1), (3, 5), (2, 11), ((30 - start) // 4, 4)):
            view = _float_rows_of(words, start, rows, cols)
            expected = words[start:start + rows * cols].view(np.float64).reshape(rows, cols)
            assert view.dtype == np.float64 and view.shape == (rows, cols) and view.flags.c_contiguous
            assert np.array_equal(view.view(np.int64), expected.view(np.int64))  # bit for bit (-0.0 too)
            if rows:
                view[rows - 1, cols - 1] = 2.5
                assert words[start + rows * cols - 1] == np.float64(2.5).view(np.int64)
                words[:] = values.view(np.int64)
    frozen = words.copy()
    frozen.setflags(write=False)
    assert not _float_rows_of(frozen, 2, 3, 4).flags.writeable
    with pytest.raises(numba.TypingError):
        _float_rows_of(values.copy(), 0, 2, 2)  # float64 already: no implementation
    with pytest.raises(numba.TypingError):
        _float_rows_of(words.reshape(5, 6), 0, 2, 2)  # not 1-D


def test_obstacle_bounds_are_the_shapes_signed_distances(tmp_path):
    """For sphere centres around every obstacle kind: the bound is the shape's closed-form signed distance
    minus the radius (a mesh: its bounding sphere, a lower bound), and the squared test of the certification
    says "clear" exactly when that bound exceeds the tolerance, with the bound minus the tolerance as its
    slack (capped by the margin so far)."""
    rng = np.random.default_rng(6)
    shapes = [Sphere((0.1, 0.2, 0.3), 0.15), Box(pose((0.3, -0.1, 0.4), rotation(rng)), (0.2, 0.5, 0.1)),
              Capsule((0.1, 0.1, 0.1), (0.4, -0.2, 0.5), 0.06),
              Cylinder(pose((0.0, 0.3, 0.2), rotation(rng)), 0.1, 0.4),
              Mesh(tetrahedron_file(tmp_path), pose((0.2, 0.2, 0.2), rotation(rng)), scale=0.3)]
    obstacles = np.array([obstacle_row(s.geometry(), s.placement()) for s in shapes])
    assert obstacles[:, pk.KIND].tolist() == [pk.BALL, pk.BOX, pk.CAPSULE, pk.CYLINDER, pk.BALL]
    W = np.zeros((1, 4))
    tol = pk.TOLERANCE
    for o, shape in enumerate(shapes):
        centre = shape.pose[:3, 3]
        for c in centre + rng.normal(scale=0.25, size=(400, 3)):
            W[0, :3], W[0, 3] = c, rng.uniform(0.001, 0.05)
            gap = pk.obstacle_gap(W, 0, obstacles, o)
            if shape.kind == "mesh":  # coal's distance from the ball to the hull (signed_distance is a bound)
                M = shape.placement()
                d = coal.distance(coal.Sphere(W[0, 3]), coal.Transform3s(np.eye(3), c), shape.geometry(),
                                  coal.Transform3s(M.rotation, M.translation), coal.DistanceRequest(),
                                  coal.DistanceResult())
                assert gap <= d + 1e-9
            else:
                assert gap == pytest.approx(float(shape.signed_distance(c)[0]) - W[0, 3], abs=1e-12)
            if abs(gap - tol) > 1e-9:  # the squared test, and the slack it reports when it passes
                slack = pk._obstacle_slack(W, 0, obstacles, o, tol, pk.MARGIN_CAP)
                assert (slack >= 0.0) == (gap > tol)
                if slack >= 0.0:
                    assert slack == pytest.approx(min(gap - tol, pk.MARGIN_CAP), abs=1e-9)
                    assert pk._obstacle_slack(W, 0, obstacles, o, tol, 0.5 * slack) == 0.5 * slack


def test_first_uncertified_on_converging_paths_matches_every_row_certified(tmp_path):
    """IK-like paths (rows closing in geometrically on an answer near the arm's obstacles, the answer first,
    as the IK checks them): the index ``first_uncertified`` returns - skipping rows close to one it
    certified - is the first row that certification row by row (``certify_configurations``) does not certify,
    and coal finds every row before it free."""
    robot = robots.load("panda")
    rng = np.random.default_rng(12)
    checked = stopped = 0
    for q_s, scene, pre in scenes_near_the_arm(robot, rng, tmp_path):
        floats, ints, tol = pre.floats, pre.ints, pre.tolerance
        for _ in range(40):
            answer = np.clip(q_s + rng.normal(scale=0.3, size=robot.nq), robot.lower, robot.upper)
            start = robot.random_q(rng)
            rows = np.array([answer + (start - answer) * 0.5 ** (12 - k) for k in range(13)])
            rows = np.clip(rows, robot.lower, robot.upper)
            k = pk.first_uncertified(floats, ints, rows, 0, tol)
            each = pk.certify_configurations(floats, ints, rows, tol)
            assert k == (len(rows) if each.all() else int(np.argmin(each)))
            assert not coal_hits(scene, rows[:k]).any()
            checked += k
            stopped += int(k < len(rows))
    assert checked > 300 and stopped > 10, (checked, stopped)  # rows certified, and paths stopped short


def test_first_uncertified_skips_rows_near_a_certified_one(monkeypatch):
    """A path of 3000 rows within a micro-radian of each other: every row is certified, and the rows after
    the first are certified by their displacement, without forward kinematics: the kernel's loop
    (``first_uncertified_in``), run as Python (``py_func``) with a counting spy on the per-configuration
    certificate, asks for it once; rows a large step apart are each certified in full."""
    robot = robots.load("panda")
    scene = robot.collision_scene(SCENE)
    pre = scene.precheck()
    floats, ints, tol = pre.floats, pre.ints, pre.tolerance
    rng = np.random.default_rng(13)
    q = next(q for q in robot.random_q(rng, 50) if pk.certify_configuration(floats, ints, q, tol))
    rows = q + 1e-9 * np.arange(3000)[:, None]
    assert pk.first_uncertified(floats, ints, rows, 0, tol) == 3000 and pk.certify_configurations(
        floats, ints, rows, tol).all()
    calls = []
    real = pk._configuration_margin
    monkeypatch.setattr(pk, "_configuration_margin", lambda *a: calls.append(1) or real(*a))
    def first_as_python(qs):  # first_uncertified's loop, run as Python in a workspace of its own
        X, W, placed = pk.packed_workspace.py_func(ints)
        return pk.first_uncertified_in.py_func(floats, ints, qs, 0, tol, X, W, placed, 0)

    assert first_as_python(rows) == 3000
    assert len(calls) == 1
    apart = q + 0.05 * (np.arange(4) % 2)[:, None]  # each row 5 cm-ish from the one before: no skipping
    calls.clear()
    k = first_as_python(apart)
    assert k == pk.first_uncertified(floats, ints, apart, 0, tol)
    assert len(calls) == min(k + 1, len(apart))


def test_the_group_sphere_contains_the_moving_geometries_and_nan_spheres_pass_no_test():
    """``place_group_sphere`` contains every bounding sphere of the first block's geometries (random spheres,
    the farthest one touching it from inside), and a NaN or infinite sphere makes its radius NaN."""
    rng = np.random.default_rng(21)
    pairs = np.array([[g, 0, pk.OBSTACLE_PAIR, g] for g in range(6)] + [[0, 1, pk.SELF_PAIR, 6]])
    assert pk.obstacle_block(pairs) == 6 and pk.obstacle_block(pairs[6:]) == 0
    W = np.empty((8, 4))
    for _ in range(200):
        W[:6, :3] = rng.normal(scale=0.5, size=(6, 3))
        W[:6, 3] = rng.uniform(0.0, 0.2, 6)
        pk.place_group_sphere(W, pairs, 6, 7)
        reach = np.linalg.norm(W[:6, :3] - W[7, :3], axis=1) + W[:6, 3]
        assert np.all(reach <= W[7, 3]) and reach.max() == pytest.approx(W[7, 3], rel=1e-9)
    for bad in (np.nan, np.inf):
        W[2, 1] = bad
        pk.place_group_sphere(W, pairs, 6, 7)
        assert np.isnan(W[7, 3])


def test_certification_with_obstacles_far_and_near_equals_every_pair_bound_above_the_tolerance():
    """Scenes of obstacles away from the arm (the group sphere certifies whole obstacle blocks) and near it:
    a configuration is certified exactly when every pair's lower bound (``pair_lower_bounds``, computed pair
    by pair without the group sphere) exceeds the tolerance, with and without self pairs, and the pairs left
    to coal (``uncertified_pairs``, and those an undecided verdict carries) are exactly those whose bound
    does not; coal finds every certified one free; a NaN configuration is never certified, even without self
    pairs."""
    robot = robots.load("panda")
    rng = np.random.default_rng(22)
    far = [Box(pose(rng.uniform(-1, 1, 3) * [1.6, 1.6, 0.5] + [0, 0, 1.9], rotation(rng)), (0.3, 0.2, 0.1))
           for _ in range(4)]
    far += [Sphere((1.5, 0.2, 0.4), 0.2), Cylinder(pose((-1.4, -0.6, 0.5), rotation(rng)), 0.1, 0.6),
            Capsule((0.2, 1.5, 0.1), (0.3, 1.6, 0.9), 0.05)]
    near = [Box(pose((0.55, 0.0, 0.3)), (0.2, 0.3, 0.05)), Sphere((0.0, 0.45, 0.5), 0.1)]
    ring = [Sphere((r * np.cos(a), r * np.sin(a), z), 0.05)  # at the edge of the arm's reach
            for r, a, z in zip(rng.uniform(0.8, 1.1, 8), np.linspace(0, 2 * np.pi, 8, endpoint=False),
                               rng.uniform(0.1, 1.0, 8))]
    culled = certified = 0
    for obstacles in (far, far + near, ring):
        for self_collision in (True, False):
            scene = robot.collision_scene(obstacles, self_collision)
            pre = scene.precheck()
            for q in robot.random_q(rng, 150):
                bounds = pk.pair_lower_bounds(pre.floats, pre.ints, q)
                cert = pk.certify_configuration(pre.floats, pre.ints, q, pre.tolerance)
                left = pk.uncertified_pairs(pre.floats, pre.ints, q, pre.tolerance)
                verdict = pk.classify_configuration(pre.floats, pre.ints, q, pre.tolerance)
                if verdict > pk.UNDECIDED:  # the pairs it carries: the list, in the table's order
                    assert carried_pairs(verdict) == left.tolist()
                if np.abs(bounds - pre.tolerance).min() > 1e-9:
                    assert cert == bool(np.all(bounds > pre.tolerance))
                    assert sorted(left.tolist()) == np.flatnonzero(bounds <= pre.tolerance).tolist()
                if cert:
                    certified += 1
                    assert not coal_hits(scene, q[None, :]).any()
                culled += int(np.all(bounds[scene.n_robot <= scene.pairs[:, 1]] > 0.3))
            nan_q = robot.neutral().copy()
            nan_q[3] = np.nan
            assert not pk.certify_configuration(pre.floats, pre.ints, nan_q, pre.tolerance)
            assert pk.first_uncertified(pre.floats, pre.ints, nan_q[None, :], 0, pre.tolerance) == 0
    assert certified > 200 and culled > 50, (certified, culled)
