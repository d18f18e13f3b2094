"""The strategy table of ik.solve (ik/plan.py): it covers every request, agrees with its docstring, and the
answers it leads to are right - including a target inside an obstacle, refused at once with the reason."""

from __future__ import annotations

import itertools
import re
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

import kinserve
from kinserve import ik, robots
from kinserve.ik import plan
from kinserve.ik.options import CHECKED_ATTEMPTS, MAX_ITER_QP
from kinserve.ik.request import pose_request, target_request, task_request


@pytest.fixture(scope="module")
def panda():
    return robots.load("panda")


def test_every_feature_combination_has_a_strategy():
    methods = ("auto", "qp", "lm", "analytic", "classical")
    flags = (False, True)
    for row in itertools.product(("target",), methods, flags, flags, flags, flags):
        strategy = next(s for want, s in plan.TABLE
                        if all(w is plan.ANY or w == g for w, g in zip(want, row)))
        assert strategy.name
    assert plan.TABLE[0][1] is plan.TASK_QP


def test_the_docstring_table_is_the_table():
    """Each data row of the module docstring's table equals the row of TABLE at the same place."""
    lines = [ln.split() for ln in plan.__doc__.splitlines() if re.match(r"^(tasks|target)\s", ln)]
    assert len(lines) == len(plan.TABLE)
    spell = {None: "*", True: "yes", False: "no"}
    for words, (row, strategy) in zip(lines, plan.TABLE):
        cols = [w if isinstance(w, str) else spell[w] for w in row]
        assert words[:6] == cols
        assert " ".join(words[6:]) == strategy.name


@pytest.mark.parametrize("page", ["README.md", "docs/ik.md"])
def test_the_pages_strategy_table_is_the_table(page):
    """The Markdown strategy table of the README and of the IK guide equals TABLE, row for row (an empty cell
    is ANY)."""
    text = (Path(kinserve.__file__).parent / page).read_text(encoding="utf-8")
    start = text.index("| door | method | closed form |")
    lines = text[start:].split("\n\n", 1)[0].splitlines()[2:]
    cells = [[c.strip() for c in ln.strip().strip("|").split("|")] for ln in lines]
    assert len(cells) == len(plan.TABLE), page
    spell = {None: "", True: "yes", False: "no"}
    for got, (row, strategy) in zip(cells, plan.TABLE):
        assert got == [w if isinstance(w, str) else spell[w] for w in row] + [strategy.name], (page, got)


def test_requests_pick_the_documented_strategy(panda):
    T = panda.fk(panda.random_q(0), "panda_link8")
    sphere = ik.Sphere((0.5, 0.4, 0.4), 0.05)
    cases = [
        (pose_request(panda, T, frame="panda_link8"), plan.LM),
        (pose_request(panda, T, frame="panda_link8", method="dls"), plan.CLASSICAL),
        (target_request(panda, T, frame="panda_link8", spheres=[sphere]), plan.CHECKED_LM),
        (target_request(panda, T, frame="panda_link8", centring=1.0), plan.QP),
        (target_request(panda, T, frame="panda_link8", method="qp", spheres=[sphere]), plan.QP),
        (target_request(panda, T, frame="panda_link8", self_collision=True), plan.CHECKED_LM),
        (target_request(panda, T, frame="panda_link8", self_collision=True, centring=1.0), plan.CHECKED_QP),
        (task_request(panda, [ik.FrameTask("panda_link8", T)]), plan.TASK_QP),
    ]
    for req, expected in cases:
        assert plan.choose_strategy(req) is expected, (plan.features(req), expected.name)
    youbot = robots.load("youbot")
    Ty = youbot.fk(youbot.random_q(1))
    assert plan.choose_strategy(pose_request(youbot, Ty)) is plan.CLOSED_FORM_OR_LM


def test_the_request_is_immutable(panda):
    req = pose_request(panda, panda.fk(panda.neutral()))
    with pytest.raises(AttributeError):
        req.method = "qp"  # a NamedTuple
    with pytest.raises(TypeError):
        req.options["max_iter"] = 3  # a read-only mapping


def _inside_target(panda, frame):
    """A pose whose position lies 3 cm inside a 20 cm cube."""
    T = panda.fk(panda.random_q(5), frame)
    box_pose = np.eye(4)
    box_pose[:3, 3] = T[:3, 3] + np.array([0.03, 0.0, 0.0])
    return T, ik.Box(box_pose, (0.2, 0.2, 0.2))


@pytest.mark.parametrize("door", ["obstacles", "spheres", "self_collision"])
def test_a_target_inside_an_obstacle_is_refused_with_the_reason(panda, door):
    """Every door says why, without spending its budget: only the unconstrained attempts run (each converges
    and is rejected), never the constrained solve."""
    frame = "panda_link8"
    T, box = _inside_target(panda, frame)
    if door == "obstacles":
        res = ik.solve(panda, T, frame=frame, obstacles=[box], max_time=30.0)
    elif door == "spheres":
        sphere = ik.Sphere(box.pose[:3, 3], 0.1)
        res = ik.solve(panda, T, frame=frame, spheres=[sphere], max_time=30.0)
    else:
        res = ik.solve(panda, T, frame="panda_hand", self_collision=True, obstacles=[box], max_time=30.0)
    assert not res.success
    assert "lies inside obstacle[0]" in res.message, res.message
    assert res.info["strategy"] == "infeasible"
    assert 0 < res.iterations <= (1 + CHECKED_ATTEMPTS) * MAX_ITER_QP


def test_clear_caches_drops_the_ik_state(panda):
    ik.warm(panda, "panda_link8")
    state = panda.extensions.ik
    assert "panda_link8" in state.seed_tables
    kinserve.clear_caches(panda)
    assert panda.extensions.ik is None
    ik.solve(panda, panda.fk(panda.neutral(), "panda_link8"), frame="panda_link8")
    assert panda.extensions.ik is not state and "panda_link8" in panda.extensions.ik.seed_tables


def test_a_checked_solve_reports_the_whole_iteration_budget(panda):
    """With obstacles in the way of every attempt, the constrained stage's result counts the attempts'
    iterations too, and an exhausted budget is reported as the one the caller gave."""
    frame = "panda_link8"
    rng = np.random.default_rng(3)
    T = panda.fk(panda.random_q(rng), frame)
    free = ik.solve(panda, T, frame=frame, seed=0, iteration_budget=2000)  # (the wall's place: no clock)
    wall = ik.Sphere(panda.fk(free.q, "panda_link4")[:3, 3], 0.12)
    res = ik.solve(panda, T, frame=frame, spheres=[wall], seed=0, iteration_budget=40, max_starts=3)
    assert res.iterations <= 40 + 1
    if not res.success and "iteration budget" in res.message:
        assert "iteration budget exhausted (40 iterations)" in res.message


def test_the_message_says_when_q0_is_inside_an_obstacle(panda):
    """A q0 whose links cross an obstacle is told in the message; a q0 clear of it is not (whether or not the
    run started there)."""
    frame = "panda_link8"
    rng = np.random.default_rng(11)
    told = clear = 0
    for _ in range(20):
        q_goal, q0 = panda.random_q(rng), panda.random_q(rng)
        T = panda.fk(q_goal, frame)
        data = panda.model.createData()
        pin.forwardKinematics(panda.model, data, q0)
        centre = data.oMi[panda.model.getJointId("panda_joint4")].translation.copy()  # on q0's elbow
        sphere = ik.Sphere(centre, 0.04)
        if ik.ObstacleAvoidance([sphere]).bind(panda).violations(panda, q_goal[None])[0]:
            continue  # the goal itself crosses the sphere
        res = ik.solve(panda, T, q0, frame=frame, spheres=[sphere], iteration_budget=4000)
        if res.success and res.info["strategy"] == "unconstrained, checked":
            assert "q0 is inside an obstacle" in res.message, res.message
            told += 1
        far = ik.Sphere(centre + np.array([0.0, 0.0, 5.0]), 0.04)
        res = ik.solve(panda, T, q0, frame=frame, spheres=[far], iteration_budget=4000, prefer_q0=True)
        assert res.success and "q0 is inside" not in res.message, res.message
        clear += 1
    assert told >= 5 and clear >= 5
