"""The HTTP service on loopback: FK/IK round trips, validation, concurrency, fuzzing."""

from __future__ import annotations

import json
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor

import httpx
import numpy as np
import pytest

from kinserve import robots

from service_server import ROOT, client_of, running


@pytest.fixture(scope="module")
def server():
    yield from running(max_time_cap=0.2)


@pytest.fixture(scope="module")
def client(server):
    yield from client_of(server, timeout=30)


@pytest.fixture(scope="module")
def panda():
    return robots.load("panda")


def post(client, path, body):
    return client.post(path, content=body if isinstance(body, (str, bytes)) else json.dumps(body),
                       headers={"content-type": "application/json"})


def test_health_and_catalogue(client):
    assert client.get("/health").json()["status"] == "ok"
    names = client.get("/robots").json()
    assert {"panda", "ur5", "scara", "youbot", "planar4r", "pr"} <= set(names)
    info = client.get("/robots/panda").json()
    assert info["nq"] == 7 and len(info["lower"]) == 7 and "panda_link8" in info["frames"]


def test_unknown_robot_is_404_listing_names(client):
    r = client.get("/robots/pandaa")
    assert r.status_code == 404
    msg = r.json()["detail"][0]["msg"]
    assert "pandaa" in msg and "panda" in msg


def test_fk_and_jacobian_match_the_library(client, panda):
    q = panda.random_q(3)
    r = post(client, "/fk", {"robot": "panda", "q": q.tolist(), "frame": "panda_link8"})
    assert r.status_code == 200, r.text
    assert np.allclose(r.json()["pose"], panda.fk(q, "panda_link8"), atol=1e-12)
    r = post(client, "/jacobian", {"robot": "panda", "q": q.tolist()})
    assert np.allclose(r.json()["jacobian"], panda.jacobian(q), atol=1e-12)
    assert r.json()["frame"] == panda.tip


def test_ik_round_trip(client, panda):
    rng = np.random.default_rng(5)
    for _ in range(5):
        q = panda.random_q(rng)
        T = panda.fk(q, "panda_link8")
        r = post(client, "/ik",
                 {"robot": "panda", "target": T.tolist(), "frame": "panda_link8", "seed": 1, "max_time": 0.2})
        body = r.json()
        assert r.status_code == 200 and body["success"], body
        assert np.allclose(panda.fk(np.array(body["q"]), "panda_link8"), T, atol=1e-3)
        assert body["position_error"] < 1e-4


def test_ik_batch(client, panda):
    Q = panda.random_q(9, n=6)
    targets = [panda.fk(q, "panda_link8").tolist() for q in Q]
    r = post(client, "/ik/batch", {"robot": "panda", "targets": targets, "frame": "panda_link8", "seed": 0})
    body = r.json()
    assert r.status_code == 200 and len(body["results"]) == 6 and body["success_rate"] == 1.0


def test_scara_relaxed_ik_over_http(client):
    scara = robots.load("scara")
    q = np.array([0.3, 0.8, 0.5, 0.2])
    T = scara.fk(q)
    r = post(client, "/ik", {"robot": "scara", "target": T.tolist(), "relax": ["phi"], "centring": 1.0})
    body = r.json()
    assert body["success"], body
    assert np.allclose(scara.fk(np.array(body["q"]))[:3, 3], T[:3, 3], atol=1e-4)


@pytest.mark.parametrize(
    "path, body, status, field",
    [
        ("/fk", {"robot": "panda", "q": [0.0] * 6}, 422, "q"),
        ("/fk", {"robot": "panda", "q": [0.0] * 7, "frame": "nope"}, 422, "frame"),
        ("/fk", {"robot": "nope", "q": [0.0] * 7}, 404, "robot"),
        ("/fk", {"robot": "panda", "q": [1e300] + [0.0] * 6}, 422, "q"),
        ("/fk", '{"robot": "panda", "q": [NaN, 0, 0, 0, 0, 0, 0]}', 422, "q"),
        ("/fk", '{"robot": "panda", "q": [Infinity, 0, 0, 0, 0, 0, 0]}', 422, "q"),
        ("/fk", '{"robot": "panda", "q": [0, 0', 422, None),
        ("/fk", {"robot": "panda"}, 422, "q"),
        ("/ik", {"robot": "panda", "target": [[2, 0, 0, 0.3], [0, 1, 0, 0], [0, 0, 1, 0.5], [0, 0, 0, 1]]},
         422, "target"),
        ("/ik", {"robot": "panda", "target": [[1, 0, 0], [0, 1, 0], [0, 0, 1]]}, 422, "target"),
        ("/ik", {"robot": "panda", "target": np.eye(4).tolist(), "relax": ["w"]}, 422, "relax"),
        ("/ik", {"robot": "panda", "target": np.eye(4).tolist(),
                 "spheres": [{"center": [0, 0, 0], "radius": -1}]}, 422, "spheres"),
        ("/ik", {"robot": "panda", "target": np.eye(4).tolist(), "q0": [0.0] * 3}, 422, "q0"),
        ("/jacobian", {"robot": "panda", "q": [0.0] * 7, "reference": "globe"}, 422, "reference"),
    ],
)
def test_bad_requests_are_4xx_json_naming_the_field(client, path, body, status, field):
    r = post(client, path, body)
    assert r.status_code == status, r.text
    detail = r.json()["detail"]
    assert detail and detail[0]["msg"]
    if field is not None:
        assert any(field in [str(x) for x in d["loc"]] or field in str(d["loc"]) for d in detail), detail


def test_unreachable_target_is_a_result_not_an_error(client):
    T = np.eye(4)
    T[:3, 3] = [3.0, 0.0, 0.5]  # 3 m away: beyond the Panda's reach
    r = post(client, "/ik", {"robot": "panda", "target": T.tolist(), "max_time": 0.05})
    assert r.status_code == 200
    assert r.json()["success"] is False and r.json()["message"]


def test_400_concurrent_ik_requests(server, panda):
    rng = np.random.default_rng(11)
    Q = panda.random_q(rng, n=400)
    bodies = [json.dumps({"robot": "panda", "target": panda.fk(q, "panda_link8").tolist(),
                          "frame": "panda_link8", "seed": i, "max_time": 0.2}) for i, q in enumerate(Q)]

    def call(body):
        with httpx.Client(base_url=server.url, timeout=60) as c:
            r = c.post("/ik", content=body, headers={"content-type": "application/json"})
            return r.status_code, r.json()

    with ThreadPoolExecutor(max_workers=32) as pool:
        results = list(pool.map(call, bodies))
    assert all(code == 200 for code, _ in results)
    ok = sum(body["success"] for _, body in results)
    assert ok >= 396, f"{ok}/400 solved"
    for (code, body), q in zip(results[:20], Q[:20]):
        if body["success"]:
            assert np.allclose(panda.fk(np.array(body["q"]), "panda_link8"),
                               panda.fk(q, "panda_link8"), atol=1e-3)
    assert server.alive()


def test_fuzz_openapi_no_server_errors(server):
    """schemathesis generates requests from the OpenAPI document; none may answer 5xx."""
    cmd = [sys.executable, "-m", "schemathesis.cli", "run", f"{server.url}/openapi.json", "--checks",
           "not_a_server_error", "--max-examples", "25", "--seed", "7", "--request-timeout", "30",
           "--generation-deterministic"]
    proc = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stdout[-4000:] + proc.stderr[-2000:]
    assert httpx.get(server.url + "/health", timeout=5).status_code == 200
    assert server.alive()
