"""kinserve.ik.classical.methods on S9 (seed 004): Jacobian inverse vs transpose vs DLS, with their
convergence histories."""

import numpy as np
import pytest

from kinserve import ik, robots
from kinserve.kinematics.errors import InputError

#: S9 task (x, y, z, phi): the SCARA's roll / pitch rows are identically zero, so they are relaxed
RELAX = ("roll", "pitch")


@pytest.fixture(scope="module")
def scara():
    return robots.load("scara", geometry=False)


@pytest.fixture(scope="module")
def task(scara):
    q_goal = np.array([0.6, 1.1, 0.55, 0.4])
    q0 = np.array([0.2, 0.6, 0.4, 0.0])
    return scara.fk(q_goal).copy(), q0, q_goal


def run(scara, task, method, **kw):
    T, q0, _ = task
    return ik.solve(scara, T, q0, method=method, relax=RELAX, **kw)


def test_s9_analytic_jacobian_row_of_phi(scara):
    # the geometric Jacobian's yaw row is [1, 1, 0, -1] (seed 004 wrote +1 for theta4: a mistake)
    J = scara.jacobian(np.array([0.3, -0.4, 0.5, 0.2]))
    assert np.allclose(J[5], [1.0, 1.0, 0.0, -1.0])
    assert np.allclose(J[2], [0.0, 0.0, -1.0, 0.0])


def test_inverse_transpose_dls_all_converge_with_their_characteristic_rates(scara, task):
    inv = run(scara, task, "jacobian_inverse")
    tra = run(scara, task, "jacobian_transpose")
    dls = run(scara, task, "dls", damping=0.05)
    pin_ = run(scara, task, "pseudo_inverse")
    for r in (inv, tra, dls, pin_):
        assert r.success, (r.method, r.message)
        assert scara.within_limits(r.q)
        h = r.history
        assert h.components == ("x", "y", "z", "yaw")
        assert h.task_error.shape == (len(h), 4)
        assert np.allclose(h.q[0], task[1])
        assert len(h) == r.iterations + 1
    # Newton (inverse / pseudo-inverse): quadratic convergence, a handful of steps
    assert inv.iterations <= 8 and pin_.iterations <= 8
    e = np.linalg.norm(inv.history.task_error, axis=1)
    assert e[-1] < 1e-3 * e[-3] or e[-2] < 1e-3 * e[-4]  # superlinear tail
    # transpose: linear convergence, many more iterations
    assert tra.iterations > 3 * inv.iterations
    # DLS: between the two; the damping slows the last steps
    assert inv.iterations <= dls.iterations < tra.iterations


def test_transpose_error_decreases_monotonically_with_the_optimal_step(scara, task):
    r = run(scara, task, "jacobian_transpose")
    e = np.linalg.norm(r.history.task_error, axis=1)
    assert np.all(np.diff(e) <= 1e-12)


def test_fixed_gain_and_iteration_cap(scara, task):
    r = run(scara, task, "jacobian_transpose", gain=0.05, max_iter=20)
    assert not r.success and "iteration limit" in r.message and r.iterations == 20
    e = np.linalg.norm(r.history.task_error, axis=1)
    assert e[-1] < e[0]


def test_jacobian_inverse_needs_a_square_task(scara, task):
    T, q0, _ = task
    with pytest.raises(InputError, match="square"):
        ik.solve(scara, T, q0, method="jacobian_inverse")  # 6 rows for 4 joints
    with pytest.raises(InputError, match="centring"):
        ik.solve(scara, T, q0, method="jacobian_transpose", relax=RELAX, centring=1.0)


def test_jacobian_inverse_stops_at_a_singularity(scara):
    # stretched arm (theta2 = 0) is singular for (x, y): the inverse method refuses to divide by zero
    q0 = np.array([0.0, 0.0, 0.5, 0.0])
    T = scara.fk(np.array([0.3, 0.8, 0.5, 0.0])).copy()
    r = ik.solve(scara, T, q0, method="jacobian_inverse", relax=RELAX)
    assert not r.success and "singular" in r.message
    assert r.iterations == 0


def test_pseudo_inverse_with_centring_relax_phi(scara, task):
    T, q0, _ = task
    r = ik.solve(scara, T, q0, method="pseudo_inverse", relax=RELAX + ("yaw",), centring=1.0)
    assert r.success
    assert r.q[3] == pytest.approx(0.0, abs=1e-3)  # theta4 centred through the null space
