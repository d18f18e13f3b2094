"""``POST /plan/motion`` on a real server on loopback: plans checked on an independent collision model,
failures with their reason, validation, the time cap, carried objects, ``/health`` under planning load."""

from __future__ import annotations

import json
import threading

import httpx
import numpy as np
import pytest

from kinserve import ik, robots
from kinserve.service.motion_schemas import EXAMPLE_REQUEST, MotionPlanRequest, MotionPlanResponse

from motion_scenes import IndependentCheck, dense
from service_scenes import ASIDE, READY, box, cage
from service_server import KeepAliveClient, client_of, running

CAP = 1.0  # --max-time-cap (s)


@pytest.fixture(scope="module")
def server():
    # one solver process: consecutive requests run in the same process (a carried object that leaked into
    # the pooled robot would show in the next request)
    yield from running("--solver-threads", "1", max_time_cap=CAP)


@pytest.fixture(scope="module")
def client(server):
    yield from client_of(server, timeout=120)


@pytest.fixture(scope="module")
def panda():
    return robots.load("panda")


def plan(client, body) -> httpx.Response:
    return client.post("/plan/motion", content=json.dumps(body), headers={"content-type": "application/json"})


def as_boxes(specs: list[dict]) -> list:
    return [ik.Box(size=s["size"], pose=np.asarray(s["pose"])) for s in specs]


def test_plan_around_a_box_is_free_on_an_independent_check(client, panda):
    body = {**EXAMPLE_REQUEST, "attached": []}
    r = plan(client, body)
    assert r.status_code == 200, r.text
    out = MotionPlanResponse(**r.json())
    assert out.success, out.message
    path = np.array(out.path)
    start, goal = np.array(body["start"]), np.array(body["goal"])
    assert np.allclose(path[0], start) and np.allclose(path[-1], goal) and out.goal_index == 0
    obstacles = as_boxes(body["obstacles"])
    # the straight motion hits the box: the obstacle shaped the answer
    assert any(panda.in_collision(start + s * (goal - start), obstacles) for s in np.linspace(0, 1, 50))
    check = IndependentCheck(panda, obstacles)
    assert check.first_collision(dense(path, 2e-3)) == -1
    traj = out.trajectory
    times, positions = np.array(traj.times), np.array(traj.positions)
    assert np.all(np.diff(times) > 0)
    assert np.allclose(positions[0], start) and np.allclose(positions[-1], goal)
    assert np.allclose(traj.velocities[0], 0) and np.allclose(traj.velocities[-1], 0)
    assert check.first_collision(positions) == -1
    v_max = np.array(panda.model.velocityLimit)
    assert np.all(np.abs(np.array(traj.velocities)) <= v_max * (1 + 1e-6))


def test_openapi_examples_validate_and_the_example_request_plans(client):
    doc = client.get("/openapi.json").json()
    schemas = doc["components"]["schemas"]
    request_example = schemas["MotionPlanRequest"]["examples"][0]
    MotionPlanRequest(**request_example)
    MotionPlanResponse(**schemas["MotionPlanResponse"]["examples"][0])
    r = plan(client, request_example)
    assert r.status_code == 200 and r.json()["success"], r.text
    MotionPlanResponse(**r.json())


def test_start_in_collision_is_a_failure_naming_the_pair(client):
    blocker = box((0.2, -0.15, 0.40), (0.42, 0.15, 0.55))  # through the hand at READY
    r = plan(client, {"robot": "panda", "start": READY, "goal": ASIDE, "obstacles": [blocker], "seed": 0,
                      "max_iterations": 1000})
    assert r.status_code == 200, r.text
    out = r.json()
    assert not out["success"] and out["trajectory"] is None and out["path"] == [] and out["goal_index"] == -1
    assert "start is in collision" in out["message"] and "obstacle[0]:box" in out["message"]


NAN_START = '{"robot": "panda", "start": [NaN, 0, 0, -2, 0, 2, 0.8], "goal": [0, 0, 0, -2, 0, 2, 0.8]}'


@pytest.mark.parametrize("body, status, field", [
    (NAN_START, 422, "start"),
    ({"robot": "panda", "start": READY[:6], "goal": ASIDE}, 422, "start"),
    ({"robot": "panda", "start": READY, "goal": ASIDE + [0.0]}, 422, "goal"),
    ({"robot": "panda", "start": READY, "goal": [ASIDE, ASIDE[:5]]}, 422, "goal"),
    ({"robot": "pandaa", "start": READY, "goal": ASIDE}, 404, "robot"),
    ({"robot": "panda", "start": READY, "goal": ASIDE, "obstacles": [box((1, 1, 1), (2, 2, 2))] * 33}, 422,
     "obstacles"),
    ({"robot": "panda", "start": READY, "goal": [ASIDE] * 65}, 422, "goal"),
    ({"robot": "panda", "start": READY, "goal": ASIDE, "acceleration_limits": [1.0, 2.0]}, 422,
     "acceleration_limits"),
    ({"robot": "panda", "start": READY, "goal": ASIDE, "max_iterations": 0}, 422, "max_iterations"),
    ({"robot": "panda", "start": READY, "goal": ASIDE, "colour": "red"}, 422, "colour"),
    ({"robot": "panda", "start": READY, "goal": ASIDE, "attached": [
        {"name": "a", "shape": {"kind": "sphere", "center": [0, 0, 0], "radius": 0.05}, "frame": "nowhere"}]},
     422, "attached[0].frame"),
    ({"robot": "panda", "start": READY, "goal": ASIDE, "attached": [
        {"name": "a", "shape": {"kind": "sphere", "center": [0, 0, 0], "radius": 0.05}, "frame": "panda_hand",
         "touch_links": ["no_such_link"]}]}, 422, "attached[0]"),
])
def test_invalid_requests_name_the_field(client, body, status, field):
    r = client.post("/plan/motion", content=body if isinstance(body, str) else json.dumps(body),
                    headers={"content-type": "application/json"})
    assert r.status_code == status, r.text
    locs = [d["loc"] for d in r.json()["detail"]]
    assert any(field in [str(x) for x in loc] for loc in locs), locs


def test_the_time_cap_bounds_a_search_that_cannot_succeed(client, panda):
    walls = cage()
    assert not panda.in_collision(READY, as_boxes(walls))  # the hand is free, and locked in
    r = plan(client, {"robot": "panda", "start": READY, "goal": ASIDE, "obstacles": walls, "max_time": 30.0})
    assert r.status_code == 200, r.text
    out = r.json()
    assert not out["success"] and "no path found within the budget" in out["message"], out["message"]
    # asked for 30 s, the server's cap is 1 s (generous outer bound for a loaded machine)
    assert out["stats"]["plan_time"] <= CAP + 1.0


def carrying_body(attached: list) -> dict:
    floor = box((0.1, -0.3, 0.40), (0.5, 0.3, 0.43))  # 4.8 cm below the fingertips at READY
    return {"robot": "panda", "start": READY, "goal": ASIDE, "obstacles": [floor], "seed": 7,
            "max_iterations": 3000, "attached": attached}


def test_a_carried_object_changes_the_answer_and_does_not_stay(client):
    before = plan(client, carrying_body([])).json()
    assert before["success"], before["message"]
    ball = {"name": "ball", "shape": {"kind": "sphere", "center": [0, 0, 0], "radius": 0.08},
            "frame": "panda_hand_tcp", "touch_links": ["panda_hand", "panda_leftfinger", "panda_rightfinger"]}
    carried = plan(client, carrying_body([ball])).json()
    assert not carried["success"]
    assert "start is in collision" in carried["message"] and "attached:ball" in carried["message"]
    after = plan(client, carrying_body([])).json()  # same solver process: the pooled robot carries nothing
    assert after["success"] and after["path"] == before["path"]


def test_a_pose_goal_is_reached(client, panda):
    T = panda.fk(np.array(ASIDE))
    import pinocchio as pin

    quat = pin.Quaternion(T[:3, :3]).coeffs().tolist()  # [qx, qy, qz, qw]
    r = plan(client, {"robot": "panda", "start": READY, "goal": {"position": T[:3, 3].tolist(),
                                                                 "quaternion": quat},
                      "seed": 3, "max_iterations": 3000, "goal_count": 2})
    assert r.status_code == 200, r.text
    out = r.json()
    assert out["success"], out["message"]
    end = np.array(out["path"][-1])
    assert np.allclose(end, out["goals"][out["goal_index"]])
    assert np.allclose(panda.fk(end)[:3, 3], T[:3, 3], atol=1e-3)


def test_health_answers_throughout_twenty_concurrent_plans(server):
    body = json.dumps({"robot": "panda", "start": READY, "goal": ASIDE, "obstacles": cage(),
                       "max_time": 0.2}).encode()
    statuses: list[int] = []

    def one():
        with KeepAliveClient(server.port) as c:
            statuses.append(c.request("POST", "/plan/motion", body)[0])

    threads = [threading.Thread(target=one) for _ in range(20)]
    for t in threads:
        t.start()
    health = []
    with KeepAliveClient(server.port) as c:
        while any(t.is_alive() for t in threads):
            health.append(c.request("GET", "/health")[0])
    for t in threads:
        t.join()
    assert statuses == [200] * 20
    assert len(health) >= 5 and set(health) == {200}
