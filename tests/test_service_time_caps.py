"""Every request bounded in time; /health unaffected by heavy load (issue 13 items 1 and 5), real server."""

from __future__ import annotations

import json
import threading
import time

import httpx
import numpy as np
import pytest

from kinserve import robots

from service_server import KeepAliveClient, Server

REQUEST_CAP = 2.0
IK_CAP = 0.3
SLACK = 0.3  # s: loopback, scheduling and JSON on a shared 2-core machine, beyond the 10 % allowed


@pytest.fixture(scope="module")
def server():
    srv = Server("--request-time-cap", str(REQUEST_CAP), max_time_cap=IK_CAP)
    yield srv
    srv.stop()


@pytest.fixture(scope="module")
def panda():
    return robots.load("panda", geometry=False)


def far_pose(x: float = 3.0) -> list:
    T = np.eye(4)
    T[:3, 3] = (x, 0.0, 0.5)  # metres from the Panda's base: out of reach
    return T.tolist()


def post(url, path, body, timeout=60):
    t0 = time.perf_counter()
    r = httpx.post(url + path, content=json.dumps(body), headers={"content-type": "application/json"},
                   timeout=timeout)
    return r, time.perf_counter() - t0


def test_45_unreachable_ik_leave_health_fast_and_every_request_bounded(server):
    body = json.dumps({"robot": "panda", "target": far_pose(), "max_time": IK_CAP}).encode()
    post(server.url, "/ik", json.loads(body))  # model and seed table loaded
    results, health = [], []
    lock = threading.Lock()
    done = threading.Event()
    clients = [KeepAliveClient(server.port) for _ in range(45)]  # connected before the load starts

    def one(c):
        t0 = time.perf_counter()
        status, headers, out = c.request("POST", "/ik", body)
        with lock:
            results.append((status, headers, json.loads(out), time.perf_counter() - t0))

    def sample():
        with KeepAliveClient(server.port) as c:
            while not done.is_set():
                t0 = time.perf_counter()
                assert c.request("GET", "/health")[0] == 200
                health.append(time.perf_counter() - t0)
                time.sleep(0.02)

    sampler = threading.Thread(target=sample)
    sampler.start()
    time.sleep(0.2)
    threads = [threading.Thread(target=one, args=(c,)) for c in clients]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    done.set()
    sampler.join()
    for c in clients:
        c.close()

    p95 = sorted(health)[int(0.95 * (len(health) - 1))]
    assert len(health) > 20 and p95 < 0.05, f"/health p95 {1e3 * p95:.1f} ms over {len(health)} samples"
    codes = [r[0] for r in results]
    assert set(codes) <= {200, 503} and codes.count(200) >= 2 * int(REQUEST_CAP / IK_CAP) - 2
    for code, headers, out, dt in results:
        assert dt < REQUEST_CAP * 1.1 + SLACK, f"{code} after {dt:.2f} s"
        if code == 200:
            # + scheduling delay on a busy shared machine
            assert out["success"] is False and out["elapsed"] < IK_CAP * 1.1 + 0.1
        else:
            assert int(headers["retry-after"]) >= 1 and out["detail"][0]["type"] == "ServiceBusy"
    assert httpx.get(server.url + "/health", timeout=5).json()["solver_jobs"] == 0


def test_batch_stops_at_the_request_cap_with_every_target_answered(server, panda):
    targets = [far_pose(3.0 + 0.01 * i) for i in range(30)]  # 30 x 0.3 s of work against a 2 s cap
    r, dt = post(server.url, "/ik/batch", {"robot": "panda", "targets": targets, "max_time": IK_CAP})
    assert r.status_code == 200, r.text
    out = r.json()
    assert dt < REQUEST_CAP * 1.1 + SLACK, f"batch took {dt:.2f} s"
    assert out["stop_reason"] == "time_cap" and 3 <= out["attempted"] < 30
    assert len(out["results"]) == 30 and out["success_rate"] == 0.0
    skipped = out["results"][out["attempted"]:]
    assert all(s["message"].startswith("not attempted") and s["iterations"] == 0 for s in skipped)
    # a skipped target's error is the distance from where the arm stands (neutral) to the target
    p = panda.fk(panda.neutral())[:3, 3]
    assert (skipped[0]["position_error"]
            == pytest.approx(np.linalg.norm(p - np.array(targets[out["attempted"]])[:3, 3])))


def test_cartesian_plan_stops_at_the_first_failure_by_default(server, panda):
    T0 = panda.fk(panda.neutral())
    T1 = np.array(far_pose())
    r, dt = post(server.url, "/plan/cartesian",
                 {"robot": "panda", "poses": [T0.tolist(), T1.tolist()], "steps": 20})
    assert r.status_code == 200, r.text
    out = r.json()
    assert out["stop_reason"] == "ik_failed" and out["success"] is False and out["total_poses"] == 22
    failed = [e["index"] for e in out["events"] if e["kind"] == "ik_failed"]
    assert failed == [out["poses_attempted"] - 1]
    assert len(out["trajectory"]["positions"]) == out["poses_attempted"] < 22
    assert dt < out["poses_attempted"] * IK_CAP * 1.1 + SLACK


def test_cartesian_plan_without_stopping_honours_its_total_cap(server, panda):
    T0 = panda.fk(panda.neutral())
    poses = [T0.tolist(), far_pose(3.0), far_pose(3.5)]  # 2 unreachable poses x 20 steps: 11 s before the cap
    for cap, body in ((REQUEST_CAP, {}), (1.0, {"max_time": 1.0})):
        r, dt = post(server.url, "/plan/cartesian", {"robot": "panda", "poses": poses, "steps": 20,
                                                     "stop_on_failure": False, **body})
        assert r.status_code == 200, r.text
        out = r.json()
        assert dt < cap * 1.1 + SLACK, f"plan took {dt:.2f} s against a {cap} s cap"
        assert out["stop_reason"] == "time_cap" and out["poses_attempted"] < out["total_poses"] == 43
        assert any(e["kind"] == "time_cap" for e in out["events"]) and "time cap" in out["message"]
