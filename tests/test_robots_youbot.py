"""kinserve.robots.youbot: the shipped youbot.urdf is exactly what the DH builder generates."""

import math

import numpy as np

from kinserve.robots import dh_fk, load_urdf
from kinserve.robots.paths import models_dir
from kinserve.robots.youbot import YOUBOT_DH, YOUBOT_LOWER, YOUBOT_UPPER, youbot_urdf


def test_shipped_file_equals_fresh_generation():
    assert (models_dir() / "youbot.urdf").read_text() == youbot_urdf()


def test_table_is_the_seed_table():
    a, alpha, d, theta = np.array(YOUBOT_DH).T
    np.testing.assert_array_equal(a, [-0.033, 0.155, 0.135, 0.002, 0.0])
    np.testing.assert_array_equal(alpha, [math.pi / 2, 0, 0, math.pi / 2, math.pi])
    np.testing.assert_array_equal(d, [0.145, 0, 0, 0, -0.185])
    np.testing.assert_array_equal(theta, 0.0)


def test_model_is_the_dh_chain_with_first_axis_plus_z():
    robot = load_urdf(models_dir() / "youbot.urdf", tip="tool", geometry=False)
    np.testing.assert_allclose(robot.lower, YOUBOT_LOWER)
    np.testing.assert_allclose(robot.upper, YOUBOT_UPPER)
    J = robot.jacobian(np.zeros(5))
    np.testing.assert_allclose(J[3:, 0], [0, 0, 1], atol=1e-15)  # joint 1 turns about +z of the base
    for q in robot.random_q(np.random.default_rng(0), n=20):
        np.testing.assert_allclose(robot.fk(q), dh_fk(YOUBOT_DH, "RRRRR", q), atol=1e-12)
