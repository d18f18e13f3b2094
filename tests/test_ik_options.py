"""kinserve.ik.options: method options are checked by name and value without solving, and agree with
ik.solve."""

import numpy as np
import pytest

from kinserve import ik, robots
from kinserve.ik.options import OPTIONS, check_options
from kinserve.kinematics.errors import InputError, NonFiniteError


@pytest.mark.parametrize("method, options", [
    ("lm", {"max_iter": 5, "damping": 1e-4, "max_starts": None, "prefer_q0": True, "seed_table": False}),
    ("qp", {"max_step": 0.2, "shortcut": False, "max_starts": 3}),
    ("analytic", {"samples": 12, "choose": ("displacement", "joint_limit_distance")}),
    ("auto", {"choose": "manipulability", "max_iter": 10}),
    ("dls", {"gain": 0.5, "damping": 0.1, "max_iter": 100}),
    ("qp", {"iteration_budget": 1}),
    ("lm", {"iteration_budget": 250, "max_iter": 20}),
    ("auto", {"iteration_budget": np.int64(40)}),
    ("jacobian_transpose", {"iteration_budget": 7}),
])
def test_accepted_options(method, options):
    check_options(method, options)


@pytest.mark.parametrize("method, options, error, words", [
    ("lm", {"frobnicate": 1}, InputError, "unknown option(s) ['frobnicate'] for method 'lm'"),
    ("lm", {"max_step": 0.1}, InputError, "unknown option"),  # a QP option
    ("qp", {"max_iter": 0}, InputError, "max_iter must be an integer >= 1"),
    ("qp", {"max_iter": 2.5}, InputError, "max_iter"),
    ("qp", {"max_iter": True}, InputError, "max_iter"),
    ("lm", {"damping": float("nan")}, NonFiniteError, "damping must be finite"),
    ("lm", {"damping": -1.0}, InputError, "damping must be positive"),
    ("lm", {"max_starts": 0}, InputError, "max_starts must be an integer >= 1 or None"),
    ("lm", {"prefer_q0": 1}, InputError, "prefer_q0 must be True or False"),
    ("analytic", {"samples": 1}, InputError, "samples must be an integer >= 2"),
    ("analytic", {"choose": ["nearest"]}, InputError, "choose must name criteria"),
    ("analytic", {"choose": []}, InputError, "choose must name criteria"),
    ("frob", {}, InputError, "method must be one of"),
    ("qp", {"iteration_budget": 0}, InputError, "option iteration_budget must be an integer >= 1, got 0"),
    ("lm", {"iteration_budget": -3}, InputError, "option iteration_budget must be an integer >= 1"),
    ("auto", {"iteration_budget": 2.0}, InputError, "option iteration_budget must be an integer >= 1"),
    ("dls", {"iteration_budget": True}, InputError, "option iteration_budget must be an integer >= 1"),
    ("qp", {"iteration_budget": None}, InputError, "option iteration_budget must be an integer >= 1"),
    ("analytic", {"iteration_budget": 5}, InputError, "unknown option(s) ['iteration_budget']"),
])
def test_rejected_options_name_the_option(method, options, error, words):
    with pytest.raises(error) as info:
        check_options(method, options)
    assert words in str(info.value)


def test_names_agree_with_what_ik_solve_accepts():
    """Every name OPTIONS lists for a method is accepted by ik.solve with that method, and nothing else is."""
    ur5 = robots.load("ur5", geometry=False)
    planar = robots.load("scara", geometry=False)
    values = {"max_iter": 5, "damping": 1e-3, "max_starts": 1, "prefer_q0": False, "seed_table": True,
              "max_step": 0.3, "shortcut": True, "lazy": True, "gain": 0.5, "samples": 4,
              "choose": "joint_limit_distance", "iteration_budget": 3}
    for method, names in OPTIONS.items():
        robot = planar if method == "analytic" else ur5
        T = robot.fk(robot.random_q(np.random.default_rng(0)))
        for name in names:
            ik.solve(robot, T, method=method, max_time=0.01, **{name: values[name]})
        for name in set(values) - set(names):
            with pytest.raises(InputError, match="unknown option"):
                ik.solve(robot, T, method=method, max_time=0.01, **{name: values[name]})


@pytest.mark.parametrize("method", ["auto", "lm", "qp"])
@pytest.mark.parametrize("options, error, words", [
    ({"prefer_q0": "yes"}, InputError, "prefer_q0 must be True or False"),
    ({"max_iter": 0}, InputError, "max_iter must be an integer >= 1"),
    ({"damping": -1.0}, InputError, "damping must be positive"),
    ({"damping": float("inf")}, NonFiniteError, "damping must be finite"),
    ({"max_starts": 0}, InputError, "max_starts must be an integer >= 1 or None"),
    ({"seed_table": None}, InputError, "seed_table must be True or False"),
    ({"iteration_budget": 0}, InputError, "iteration_budget must be an integer >= 1"),
])
def test_ik_solve_checks_option_values_on_every_path(method, options, error, words):
    """The values, not only the names: ik.solve's short LM path, "auto" and "qp" (with and without obstacles)
    refuse a bad value before solving, with the option's name in the message."""
    panda = robots.load("panda", geometry=False)
    T = panda.fk(panda.random_q(np.random.default_rng(1)))
    # lm: refused
    with_obstacles = () if method == "lm" else ({"obstacles": [ik.Sphere((0.5, 0.5, 0.9), 0.05)]},)
    for extra in ({}, *with_obstacles):
        with pytest.raises(error) as info:
            ik.solve(panda, T, method=method, **extra, **options)
        assert words in str(info.value)
    with pytest.raises(InputError, match="lazy must be True or False"):
        ik.solve(panda, T, method="qp", lazy="x")
