"""kinserve.ik.qp.target_solver: convergence on random targets for every backend; S9 relaxed tasks with
centring and the sphere."""

import numpy as np
import pytest

from kinserve import ik, robots
from kinserve.ik.constraints import ObstacleAvoidance
from kinserve.ik.qp.target_solver import solve_qp
from kinserve.ik.targets import Target
from kinserve.kinematics import se3

from segment_clearance import sampled_clearance

SPHERE = ik.Sphere((0.4, -0.7, 0.5), 0.2)
#: Iterations of every start together: no time limit decides a solve here (none is given).
BUDGET = dict(iteration_budget=2000)


@pytest.fixture(scope="module")
def scara():
    return robots.load("scara", geometry=False)


@pytest.mark.parametrize("backend", ik.available_backends()[:4])
@pytest.mark.parametrize("name,n", [("panda", 12), ("ur5", 10), ("youbot", 8), ("planar4r", 8)])
def test_random_reachable_targets_every_backend(backend, name, n):
    robot = robots.load(name, geometry=False)
    rng = np.random.default_rng(77)
    for q in robot.random_q(rng, n):
        T = robot.fk(q).copy()
        res = solve_qp(robot, Target(robot, T), robot.random_q(rng), backend=backend, **BUDGET)
        assert res.success, (backend, name, res.message)
        assert robot.within_limits(res.q)
        pe, re = se3.pose_error(robot.fk(res.q), T)
        assert pe < 1e-4 and re < 1e-3
        assert all(robot.within_limits(qi) for qi in res.history.q)


def _tool_distances(robot, history, sphere):
    c = np.asarray(sphere.center)
    return np.array([np.linalg.norm(robot.fk(q)[:3, 3] - c) for q in history.q])


def test_s9_relax_phi_centres_theta4(scara):
    q_goal = np.array([0.3, 0.9, 0.5, 2.0])
    T = scara.fk(q_goal).copy()
    res = ik.solve(scara, T, np.array([0.0, 0.5, 0.4, 1.0]), relax=("phi",), centring=1.0, **BUDGET)
    assert res.method == "qp" and res.success
    assert res.position_error < 1e-4 and res.orientation_error < 1e-3
    p = scara.fk(res.q)[:3, 3]
    assert np.linalg.norm(p - T[:3, 3]) < 1e-4  # x, y, z kept
    assert res.q[3] == pytest.approx(0.0, abs=1e-4)  # theta4 at the middle of [-2 pi, 2 pi]
    # yaw was free: the tool angle phi = theta1 + theta2 - theta4 differs from the target's
    assert abs((res.q[0] + res.q[1] - res.q[3]) - (q_goal[0] + q_goal[1] - q_goal[3])) > 1.0


def test_s9_relax_z_centres_d3_where_the_sphere_does_not_bind(scara):
    T = scara.fk(np.array([1.0, 0.8, 0.3, 0.4])).copy()
    res = ik.solve(scara, T, np.array([0.5, 0.5, 0.3, 0.0]), relax=("z",), centring=1.0, spheres=[SPHERE],
                   **BUDGET)
    assert res.success
    assert res.q[2] == pytest.approx(0.625, abs=1e-4)  # d3 mid-range
    T_res = scara.fk(res.q)
    assert np.linalg.norm(T_res[:2, 3] - T[:2, 3]) < 1e-4  # x, y kept
    assert se3.rotation_angle(T_res[:3, :3], T[:3, :3]) < 1e-3  # phi kept
    assert _tool_distances(scara, res.history, SPHERE).min() >= SPHERE.radius


@pytest.mark.parametrize("backend", ["osqp", "daqp"])
def test_s9_relax_z_with_the_sphere_binding(scara, backend):
    # tool above the sphere: centring pulls d3 to 0.625 (tool z 0.375, inside the sphere), the sphere stops it
    x, y = 0.42, -0.68
    c2 = (x * x + y * y - 0.5) / 0.5
    t2 = np.arccos(c2)
    t1 = np.arctan2(y, x) - np.arctan2(0.5 * np.sin(t2), 0.5 + 0.5 * np.cos(t2))
    q0 = np.array([t1, t2, 0.25, 0.0])
    T = scara.fk(q0).copy()
    res = ik.solve(scara, T, q0, relax=("z",), centring=1.0, spheres=[SPHERE], backend=backend, **BUDGET)
    assert res.success, res.message
    d = _tool_distances(scara, res.history, SPHERE)
    assert d.min() >= SPHERE.radius  # on every iterate, not only at the end
    assert len(res.history) > 3
    # every link / quill segment stays outside too
    assert min(sampled_clearance(scara, q, "tool", SPHERE) for q in res.history.q) >= 0.0
    # the sphere binds: d3 moved towards 0.625 but stopped at the sphere's top (tool z ~ 0.698)
    z_top = SPHERE.center[2] + np.sqrt(SPHERE.radius**2 - (x - 0.4) ** 2 - (y + 0.7) ** 2)
    assert 0.25 < res.q[2] < 0.625
    assert scara.fk(res.q)[2, 3] == pytest.approx(z_top, abs=5e-3)


def test_centring_never_degrades_the_task_on_a_redundant_arm():
    # start *at* a solution: centring may only slide along the self-motion manifold
    robot = robots.load("panda", geometry=False)
    rng = np.random.default_rng(3)
    mid = robot.middle()
    rngs = robot.upper - robot.lower

    def h(q):
        return float(np.sum(((q - mid) / rngs) ** 2))

    for _ in range(5):
        q_sol = robot.random_q(rng)
        T = robot.fk(q_sol).copy()
        centred = ik.solve(robot, T, q_sol, centring=1.0, prefer_q0=True, seed_table=False, **BUDGET)
        assert centred.success
        assert centred.position_error < 1e-4 and centred.orientation_error < 1e-3
        assert h(centred.q) < h(q_sol)
        # every recorded iterate that the solver accepted kept the task within tolerance
        assert np.all(centred.history.position_error < 1e-4)
        assert np.all(centred.history.orientation_error < 1e-3)


def test_infeasible_target_reports_failure(scara):
    T = scara.fk(np.array([0.0, 0.0, 0.5, 0.0])).copy()
    T[:3, 3] = (3.0, 0.0, 0.5)  # beyond a1 + a2 = 1 m
    res = ik.solve(scara, T, np.array([0.1, 0.2, 0.5, 0.0]), method="qp", iteration_budget=300)
    assert not res.success
    assert "best residual" in res.message
    assert scara.within_limits(res.q)
    assert res.position_error == pytest.approx(2.0, abs=1e-2)  # stretched towards it: 3 - (a1 + a2)


def test_shortcut_is_exact():
    # a feasible unconstrained minimiser is the QP's solution: same iterates with and without the shortcut
    robot = robots.load("panda", geometry=False)
    rng = np.random.default_rng(12)
    for _ in range(4):
        T = robot.fk(robot.random_q(rng)).copy()
        q0 = robot.random_q(rng)
        kw = dict(prefer_q0=True, seed_table_enabled=False, max_starts=1, backend="daqp", **BUDGET)
        a = solve_qp(robot, Target(robot, T), q0, shortcut=True, **kw)
        b = solve_qp(robot, Target(robot, T), q0, shortcut=False, **kw)
        assert len(a.history) == len(b.history)
        assert np.allclose(a.history.q, b.history.q, atol=1e-8)
        assert b.info["qp_calls"] == b.iterations >= a.info["qp_calls"]


def test_box_active_set_matches_a_qp_solver():
    import qpsolvers

    from kinserve.ik.qp.target_solver import box_active_set

    rng = np.random.default_rng(0)
    exact = 0
    for _ in range(200):
        J = rng.normal(size=(6, 7))
        P = J.T @ J + 1e-3 * np.eye(7)
        c = -J.T @ (rng.normal(size=6) * 0.3)  # an IK step: c = -J^T e
        lb, ub = -rng.random(7) * 0.3, rng.random(7) * 0.3
        x0 = np.linalg.solve(P, -c)
        x = box_active_set(P, c, lb, ub, x0)
        ref = qpsolvers.solve_qp(P, c, lb=lb, ub=ub, solver="quadprog")
        if x is not None:  # when it answers, it is the QP's solution
            exact += 1
            assert np.allclose(x, ref, atol=1e-8)
    assert exact > 20


def test_no_start_outside_the_spheres_reports_finite_errors():
    """Used to answer NaN errors (null over HTTP); now the residual at the returned q."""
    panda = robots.load("panda", geometry=False)
    T = panda.fk(panda.neutral(), "panda_link8")
    target = Target(panda, T, "panda_link8")
    spheres = ObstacleAvoidance([ik.Sphere(T[:3, 3], 1.5, frames=["panda_link8"])], tool_frames="panda_link8")
    res = solve_qp(panda, target, spheres=spheres, iteration_budget=300)
    assert not res.success and "no start configuration" in res.message
    pe, re = target.errors_at(panda, res.q)
    assert np.isfinite(res.position_error) and res.position_error == pytest.approx(pe)
    assert res.orientation_error == pytest.approx(re)
