"""``POST /plan/cartesian`` in line mode (``planners.plan_cartesian``: jump_threshold, obstacles) on a real
server on loopback; the interpolated mode keeps its fields and answers."""

from __future__ import annotations

import json

import httpx
import numpy as np
import pytest

from kinserve import ik, robots
from kinserve.service.schemas import CartesianPlanRequest, CartesianPlanResponse

from motion_scenes import IndependentCheck
from service_scenes import READY, box
from service_server import client_of, running

TCP = "panda_hand_tcp"


@pytest.fixture(scope="module")
def server():
    yield from running("--solver-threads", "1", max_time_cap=1.0)


@pytest.fixture(scope="module")
def client(server):
    yield from client_of(server, timeout=120)


@pytest.fixture(scope="module")
def panda():
    return robots.load("panda")


def post(client, body) -> httpx.Response:
    return client.post("/plan/cartesian", content=json.dumps(body),
                       headers={"content-type": "application/json"})


def moved(panda, dx: float) -> list:
    T = panda.fk(np.array(READY), TCP)
    T[0, 3] += dx
    return T.tolist()


def test_the_openapi_example_follows_its_lines(client):
    schemas = client.get("/openapi.json").json()["components"]["schemas"]
    example = schemas["CartesianPlanRequest"]["examples"][0]
    CartesianPlanRequest(**example)
    r = post(client, example)
    assert r.status_code == 200, r.text
    out = CartesianPlanResponse(**r.json())
    assert out.success and out.stop_reason == "completed" and out.poses_attempted == out.total_poses


def test_a_box_on_the_line_stops_the_move_before_it(client, panda):
    wall = box((0.44, -0.2, 0.35), (0.46, 0.2, 0.65))
    body = {"robot": "panda", "q0": READY, "frame": TCP, "poses": [moved(panda, 0.2)], "obstacles": [wall],
            "max_step": 0.01}
    r = post(client, body)
    assert r.status_code == 200, r.text
    out = r.json()
    assert not out["success"] and out["stop_reason"] == "collision", out["message"]
    assert 0 < out["poses_attempted"] < out["total_poses"]
    Q = np.array(out["trajectory"]["positions"])
    assert len(Q) > 1 and np.allclose(Q[0], READY)
    x = [panda.fk(q, TCP)[0, 3] for q in Q]
    assert max(x) < 0.44 - 0.03  # the hand (3 cm ahead of its centre) stopped before the wall
    check = IndependentCheck(panda, [ik.Box(size=wall["size"], pose=np.asarray(wall["pose"]))])
    assert check.first_collision(Q) == -1
    # without the wall the same line is followed to its end
    free = post(client, {**body, "obstacles": []}).json()
    assert free["success"] and free["stop_reason"] == "completed"
    assert np.allclose(panda.fk(np.array(free["trajectory"]["positions"][-1]), TCP), moved(panda, 0.2),
                       atol=1e-3)


def test_jump_threshold_stops_a_step_that_moves_a_joint_too_far(client, panda):
    body = {"robot": "panda", "q0": READY, "frame": TCP, "poses": [moved(panda, 0.2)], "max_step": 0.02,
            "jump_threshold": 1e-3}
    out = post(client, body).json()
    assert out["stop_reason"] == "joint_jump" and not out["success"], out["message"]
    relaxed = post(client, {**body, "jump_threshold": 0.5}).json()
    assert relaxed["success"], relaxed["message"]


@pytest.mark.parametrize("extra, field", [({"steps": 5}, "steps"), ({"q0": None}, "q0")])
def test_line_mode_refuses_interpolated_fields_and_needs_q0(client, panda, extra, field):
    body = {"robot": "panda", "q0": READY, "frame": TCP, "poses": [moved(panda, 0.1)], "jump_threshold": 0.3,
            **extra}
    r = post(client, {k: v for k, v in body.items() if v is not None})
    assert r.status_code == 422, r.text
    assert any(field in d["loc"] for d in r.json()["detail"]), r.text


def test_the_interpolated_mode_is_unchanged(client, panda):
    body = {"robot": "panda", "q0": READY, "frame": TCP, "poses": [moved(panda, 0.0), moved(panda, 0.1)],
            "steps": 4}
    out = post(client, body).json()
    from kinserve.planners import cartesian_to_joint

    plan = cartesian_to_joint(panda, [np.asarray(T) for T in body["poses"]], q0=np.array(READY), frame=TCP,
                              steps=4, dt=0.1)
    assert out["success"] and plan.success and out["total_poses"] == plan.total_poses
    assert np.allclose(out["trajectory"]["times"], plan.trajectory.times)
    assert np.allclose(out["trajectory"]["positions"], plan.trajectory.positions, atol=1e-3)
    one = post(client, {**body, "poses": body["poses"][:1]})
    assert one.status_code == 422 and one.json()["detail"][0]["loc"] == ["body", "poses"], one.text
