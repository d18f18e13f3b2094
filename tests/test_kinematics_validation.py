"""Every bad input to the kinematics entry points gets a named, useful error."""

import numpy as np
import pinocchio as pin
import pytest

from kinserve.kinematics import (
    FrameError,
    InputError,
    JointLimitError,
    NonFiniteError,
    RotationError,
    ShapeError,
    as_pose,
    as_vector,
    se3,
)


def test_good_inputs_in_any_numeric_form(panda):
    q = [0.0, -0.3, 0.0, -2.0, 0.0, 1.5, 0.7]
    T = panda.fk(np.array(q)).copy()
    assert np.allclose(panda.fk(q), T)  # list
    assert np.allclose(panda.fk(tuple(q)), T)  # tuple
    assert np.allclose(panda.fk(np.array(q, dtype=np.float32)), T, atol=1e-6)  # float32
    assert np.allclose(panda.fk(np.array(q).reshape(7, 1)), T)  # column vector
    assert np.allclose(panda.jacobian(q), panda.jacobian(np.array(q)))


@pytest.mark.parametrize(
    "q, error, pattern",
    [
        (np.zeros(6), ShapeError, r"q must have shape \(7,\), got shape \(6,\)"),
        (np.zeros(9), ShapeError, r"shape \(7,\)"),
        (np.zeros((2, 7)), ShapeError, r"shape \(7,\)"),
        ("abc", ShapeError, "q must be a sequence of 7 numbers"),
        ([0, 0, 0, "x", 0, 0, 0], ShapeError, "sequence of 7 numbers"),
        (None, ShapeError, "sequence of 7 numbers"),
        ([0, 0, np.nan, 0, 0, 0, 0], NonFiniteError, r"\[2\]=nan"),
        ([0, 0, 0, 0, 0, np.inf, 0], NonFiniteError, r"\[5\]=inf"),
        ([0, 0, 0, 0, 0, 0, 1e300], NonFiniteError, "magnitude"),
    ],
)
def test_bad_joint_vectors(panda, q, error, pattern):
    for call in (panda.fk, panda.jacobian, panda.fk_all, panda.manipulability):
        with pytest.raises(error, match=pattern):
            call(q)


def test_errors_are_value_errors_for_callers_that_catch_those(panda):
    with pytest.raises(ValueError):
        panda.fk([1.0])
    assert issubclass(NonFiniteError, InputError)


def test_unknown_frame_suggests_close_names(panda):
    with pytest.raises(FrameError, match=r"unknown frame 'panda_link88'.*Did you mean: panda_link8"):
        panda.fk(np.zeros(7), "panda_link88")
    with pytest.raises(FrameError):
        panda.jacobian(np.zeros(7), frame=3)


def test_limit_checking_on_request(panda):
    q = panda.middle()
    q[3] = 0.5  # panda_joint4 upper limit is about -0.07
    panda.fk(q)  # FK itself is defined everywhere
    with pytest.raises(JointLimitError, match=r"panda_joint4=0.5 not in \["):
        panda.fk(q, check_limits=True)
    with pytest.raises(JointLimitError):
        panda.jacobian(q, check_limits=True)


def test_bad_reference_name(panda):
    with pytest.raises(ShapeError, match="reference must be one of"):
        panda.jacobian(np.zeros(7), reference="globe")


def test_as_pose_checks_rotation_and_shape():
    T = se3.pose(se3.rot_z(0.3), [1, 2, 3])
    assert np.array_equal(as_pose(T), T)
    assert np.allclose(as_pose(pin.SE3(T[:3, :3], T[:3, 3])), T)
    scaled = T.copy()
    scaled[:3, :3] *= 1.1
    with pytest.raises(RotationError, match="not a rotation matrix"):
        as_pose(scaled)
    mirror = T.copy()
    mirror[:3, 0] *= -1  # orthonormal but det = -1
    with pytest.raises(RotationError, match="det R = -1"):
        as_pose(mirror)
    with pytest.raises(ShapeError, match=r"shape \(4, 4\)"):
        as_pose(np.eye(3))
    bottom = T.copy()
    bottom[3, 0] = 1
    with pytest.raises(ShapeError, match="bottom row"):
        as_pose(bottom)
    nan = T.copy()
    nan[0, 3] = np.nan
    with pytest.raises(NonFiniteError, match="target"):
        as_pose(nan)


def test_as_vector_names_the_argument():
    with pytest.raises(ShapeError, match=r"^velocity must have shape \(2,\)"):
        as_vector([1, 2, 3], 2, "velocity")


def test_every_float64_array_is_checked_whatever_its_dtype_object():
    """The fast path takes arrays holding NumPy's own float64 dtype; float64 arrays with another dtype object
    (metadata, the other byte order) and other dtypes take the general path: the same answer, the same
    errors."""
    plain = np.array([0.1, -0.2, 0.3])
    tagged = plain.astype(np.dtype(np.float64, metadata={"unit": "rad"}))
    assert tagged.dtype is not plain.dtype and tagged.dtype == np.float64
    for value in (plain, tagged, plain.astype(">f8"), plain.astype(np.float32).astype(np.float64)):
        out = as_vector(value, 3)
        assert out.dtype == np.float64 and np.allclose(out, plain, atol=1e-7)
    for bad in (np.array([0.1, np.nan, 0.3], dtype=tagged.dtype), np.array([0.1, np.inf, 0.3], dtype=">f8")):
        with pytest.raises(NonFiniteError, match=r"^q must hold finite numbers.*bad entries: \[1\]="):
            as_vector(bad, 3)
    with pytest.raises(ShapeError, match=r"shape \(3,\)"):
        as_vector(tagged[:2], 3)


def test_one_per_entry_bound_whatever_the_container(panda):
    """|q_i| <= MAX_ABS for every entry: a list and an array of the same numbers are treated alike."""
    q = [5e5] * 7  # every entry within the bound, the norm beyond it
    T = panda.fk(np.full(7, 5e5))
    assert np.allclose(panda.fk(q), T) and np.allclose(panda.fk(tuple(q)), T)
    assert np.allclose(panda.jacobian(q), panda.jacobian(np.full(7, 5e5)))
    assert np.array_equal(as_vector(q, 7), np.full(7, 5e5))
    for bad in ([5e5] * 6 + [1.5e6], np.array([5e5] * 6 + [1.5e6])):
        with pytest.raises(NonFiniteError, match=r"\[6\]=1500000.0"):
            panda.fk(bad)


def test_the_scalar_checks_bound_every_number():
    """``as_positive`` / ``as_nonnegative`` / ``as_real`` take finite reals within 1e6 only (bools, text,
    complex, NaN, inf and 1e300 named), ``as_count`` an integer in its range, ``as_numbers`` any numeric
    array of bounded entries; each returns plain floats / ints / a float64 array."""
    from kinserve.kinematics.validation import as_count, as_nonnegative, as_numbers, as_positive, as_real

    assert as_positive(2, "t") == 2.0 and type(as_positive(2, "t")) is float
    assert as_positive(1e6, "t") == 1e6 and as_positive(0.5, "t", maximum=1.0) == 0.5
    assert as_nonnegative(0, "x") == 0.0 and as_real(-3, "x") == -3.0
    for bad, error, words in [(1e300, NonFiniteError, "t must be finite with magnitude <= 1e\\+06"),
                              (float("nan"), NonFiniteError, "t must be finite"),
                              (True, InputError, "t must be a number, got True"),
                              ("1", InputError, "t must be a number, got '1'"),
                              (1j, InputError, "t must be a number"),
                              (-1, InputError, "t must be positive, got -1"),
                              (0.0, InputError, "t must be positive, got 0.0"),
                              (2e6, NonFiniteError, "t must be finite with magnitude")]:
        with pytest.raises(error, match=words):
            as_positive(bad, "t")
    with pytest.raises(InputError, match="t must be at most 1, got 1.5"):
        as_positive(1.5, "t", maximum=1.0)
    with pytest.raises(InputError, match="x must be zero or positive, got -0.1"):
        as_nonnegative(-0.1, "x")
    assert as_count(3, "n") == 3 and as_count(3.0, "n") == 3 and as_count(np.int64(0), "n", minimum=0) == 0
    for bad, words in [(1.5, "n must be an integer, got 1.5"), (True, "n must be an integer, got True"),
                       (float("inf"), "n must be an integer, got inf"), (None, "n must be an integer"),
                       (0, "n must be an integer from 1 to 10,000,000, got 0"),
                       (10**12, "from 1 to 10,000,000, got 1000000000000")]:
        with pytest.raises(InputError, match=words):
            as_count(bad, "n")
    np.testing.assert_array_equal(as_numbers([[1, 2], [3, 4]], "a"), [[1.0, 2.0], [3.0, 4.0]])
    assert as_numbers(2, "a").shape == ()
    for bad, error, words in [(None, ShapeError, "a must be a number or an array of numbers, got None"),
                              ("ab", ShapeError, "got 'ab'"), (True, ShapeError, "got True"),
                              ([1, [2, 3]], ShapeError, "a must be a number or an array"),
                              ([1.0, np.nan], NonFiniteError, r"bad entries: \[1\]=nan")]:
        with pytest.raises(error, match=words):
            as_numbers(bad, "a")


@pytest.mark.parametrize("value, error, words", [
    (["1", "2", "3"], ShapeError, r"q must be a sequence of 3 numbers, got \['1', '2', '3'\]"),
    ([True, False, True], ShapeError, "q must be a sequence of 3 numbers, got \\[True, False, True\\]"),
    (np.array([True, False, True]), ShapeError, "q must be a sequence of 3 numbers"),
    ([10**400, 0, 0], NonFiniteError, "an integer too large for a float"),
    ((10**400, 0, 0), NonFiniteError, "an integer too large for a float"),
])
def test_text_bools_and_huge_integers_are_not_read_as_numbers(value, error, words):
    """NumPy reads ``"1"`` and ``True`` as 1.0 and overflows on 10**400: the checks refuse them by name, on
    the list fast path and on the general one; plain integers still pass."""
    with pytest.raises(error, match=words):
        as_vector(value, 3)
    np.testing.assert_array_equal(as_vector([1, 2, 3], 3), [1.0, 2.0, 3.0])
    np.testing.assert_array_equal(as_vector((1, 2, 3), 3), [1.0, 2.0, 3.0])


@pytest.mark.parametrize("value", [np.zeros(0), np.array(["a"]), [], ["a"], {"a": 1}, np.str_("a"), 1, True,
                                   None, "A", "ab"])
def test_as_choice_matches_by_type_and_value_only(value):
    """No ``==`` on arrays (NumPy's "truth value ... is ambiguous"), no hashing of lists ("unhashable
    type"), no ``1 == True``: anything else is an InputError naming the argument and the choices."""
    from kinserve.kinematics.validation import as_choice

    with pytest.raises(InputError, match=r"^method must be one of 'a', 'b', False, got "):
        as_choice(value, "method", ("a", "b", False))
    assert as_choice("b", "method", ("a", "b")) == "b" and as_choice(None, "x", ("a", None)) is None


def test_as_robot_names_what_it_got_and_how_to_load_it():
    from kinserve import robots
    from kinserve.kinematics.robot import as_robot

    arm = robots.load("planar4r", geometry=False)
    assert as_robot(arm) is arm
    with pytest.raises(InputError, match=r"^robot must be a kinserve Robot .*\(robots.load\('panda'\) loads"):
        as_robot("panda")
    with pytest.raises(InputError, match=r"^arm must be a kinserve Robot .*got None$"):
        as_robot(None, "arm")


@pytest.mark.parametrize("value", [3, None, np.zeros(0), b"x", ["a"]])
def test_as_text_takes_a_str_only(value):
    from kinserve.kinematics.validation import as_text

    with pytest.raises(InputError, match=r"^title must be a str, got "):
        as_text(value, "title")
    assert as_text("", "title") == "" and as_text(None, "title", optional=True) is None


@pytest.mark.parametrize("value", [3, None, b"/tmp/x", ["a"]])
def test_as_path_takes_a_str_or_a_path_like(value, tmp_path):
    from kinserve.kinematics.validation import as_path

    with pytest.raises(InputError, match=r"^out must be a file path \(str or os.PathLike\), got "):
        as_path(value, "out")
    assert as_path(str(tmp_path), "out") == tmp_path and as_path(tmp_path / "a.json") == tmp_path / "a.json"
