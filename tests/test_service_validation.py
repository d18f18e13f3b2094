"""Bounded inputs and finite outputs over HTTP (issue 13 items 3 and 7), on a real server."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from kinserve import robots
from kinserve.service.responses import json_response

from service_server import client_of, running


@pytest.fixture(scope="module")
def server():
    yield from running(max_time_cap=0.3)


@pytest.fixture(scope="module")
def client(server):
    yield from client_of(server, timeout=30)


@pytest.fixture(scope="module")
def panda():
    return robots.load("panda", geometry=False)


def numbers(value):
    """Every number in a decoded JSON document."""
    if isinstance(value, bool) or value is None or isinstance(value, str):
        return
    if isinstance(value, (int, float)):
        yield value
    elif isinstance(value, dict):
        for v in value.values():
            yield from numbers(v)
    elif isinstance(value, list):
        for v in value:
            yield from numbers(v)


def post(client, path, body):
    r = client.post(path, content=json.dumps(body), headers={"content-type": "application/json"})
    assert r.status_code < 500, r.text
    assert "NaN" not in r.text and "Infinity" not in r.text
    if r.status_code == 200:
        doc = r.json()
        assert all(math.isfinite(x) for x in numbers(doc)), r.text
        assert "null" not in r.text.replace('"accelerations":null', ""), r.text
    return r


def loc(r):
    return r.json()["detail"][0]["loc"]


@pytest.mark.parametrize("path,robot,params,extra", [
    ("/jacobian", "planar4r", {"l1": "1e308"}, {"q": [0, 0, 0, 0]}),
    ("/fk", "planar4r", {"l1": "1e308"}, {"q": [0, 0, 0, 0]}),
    ("/fk", "planar4r", {"l1": 1e6 + 1}, {"q": [0, 0, 0, 0]}),  # schema bound, same number
    ("/ik", "scara", {"d3_min": "-1e308"}, {"target": np.eye(4).tolist()}),
    ("/ik", "scara", {"d3_min": "-1e7"}, {"target": np.eye(4).tolist()}),
])
def test_string_params_cannot_bypass_the_numeric_bound(client, path, robot, params, extra):
    r = post(client, path, {"robot": robot, "params": params, **extra})
    assert r.status_code == 422, r.text
    assert loc(r)[:2] == ["body", "params"]
    assert "1e+06" in r.json()["detail"][0]["msg"] or "less than or equal" in r.json()["detail"][0]["msg"]


def test_large_but_bounded_params_answer_finite_numbers(client):
    r = post(client, "/jacobian", {"robot": "planar4r", "params": {"l1": "1e5"}, "q": [0.3, 0, 0, 0]})
    assert r.status_code == 200
    J = np.array(r.json()["jacobian"])
    assert J[0, 0] == pytest.approx(-(1e5 + 0.8 + 0.6 + 0.4) * math.sin(0.3), rel=1e-12)


def test_frame_only_sphere_containing_the_target_answers_finite_errors(client, panda):
    T = panda.fk(panda.neutral(), "panda_link8")
    r = post(client, "/ik", {"robot": "panda", "target": T.tolist(), "frame": "panda_link8",
                             "spheres": [{"center": T[:3, 3].tolist(), "radius": 1.5,
                                          "frames": ["panda_link8"]}]})
    assert r.status_code == 200
    out = r.json()
    assert out["success"] is False
    # the errors are those of the returned q, recomputed independently
    Tq = panda.fk(np.array(out["q"]), "panda_link8")
    assert out["position_error"] == pytest.approx(np.linalg.norm(Tq[:3, 3] - T[:3, 3]), abs=1e-9)


def test_q_with_large_entries_is_accepted_as_the_library_does(client, panda):
    q = [5e5] * 7  # each entry within the bound, |q| beyond it
    r = post(client, "/fk", {"robot": "panda", "q": q})
    assert r.status_code == 200, r.text
    assert np.allclose(r.json()["pose"], panda.fk(np.array(q)), atol=1e-9)
    assert np.allclose(panda.fk(np.full(7, 5e5)), panda.fk(q))
    r = post(client, "/fk", {"robot": "panda", "q": [5e5] * 6 + [2e6]})
    assert r.status_code == 422 and loc(r)[:2] == ["body", "q"]


def test_sphere_errors_point_at_spheres(client, panda):
    T = panda.fk(panda.neutral(), "panda_link8")
    base = {"robot": "panda", "target": T.tolist()}
    r = post(client, "/ik",
             {**base, "spheres": [{"center": [0, 0, 0], "radius": 0.1, "frames": ["no_such_frame"]}]})
    assert r.status_code == 422 and loc(r) == ["body", "spheres"] and "no_such_frame" in r.text
    r = post(client, "/ik", {**base, "spheres": [{"center": [0, 0, 0], "radius": 0.2}]})  # around the base
    assert r.status_code == 422 and loc(r) == ["body", "spheres"] and "base" in r.text


def test_the_response_guard_turns_non_finite_results_into_an_error_answer():
    ok = json_response({"pose": np.eye(4), "x": [1.0, 2.0], "note": "null is a word"})
    assert ok.status_code == 200 and json.loads(ok.body)["pose"][0] == [1.0, 0.0, 0.0, 0.0]
    for bad in ({"x": [1.0, float("nan")]}, {"pose": np.full((2, 2), np.inf)}, {"a": {"b": -float("inf")}}):
        r = json_response(bad)
        assert r.status_code == 422 and json.loads(r.body)["detail"][0]["type"] == "NonFiniteResult"
    assert json_response({"accelerations": None}).status_code == 200
