"""POST /ik with the IK model: obstacles of every kind, several frame targets, errors that name the field
(a real server on loopback)."""

from __future__ import annotations

import json

import httpx
import numpy as np
import pytest

from kinserve import ik, robots

from service_server import Server


@pytest.fixture(scope="module")
def client():
    srv = Server(max_time_cap=2.0)
    try:
        with httpx.Client(base_url=srv.url, timeout=60) as c:
            yield c
    finally:
        srv.stop()


def post(client, body):
    return client.post("/ik", content=json.dumps(body), headers={"content-type": "application/json"})


def test_obstacles_of_every_kind_are_kept_clear(client):
    panda = robots.load("panda", geometry=False)
    q = panda.random_q(np.random.default_rng(3))
    T = panda.fk(q).copy()
    elbow = panda.fk(q, "panda_link4")[:3, 3]
    B = np.eye(4)
    B[:3, 3] = elbow + [0.0, 0.0, 0.15]
    C = np.eye(4)
    C[:3, 3] = [0.6, -0.5, 0.3]
    obstacles = [{"kind": "box", "pose": B.tolist(), "size": [0.05, 0.05, 0.05]},
                 {"kind": "sphere", "center": [0.4, 0.5, 0.2], "radius": 0.05},
                 {"kind": "capsule", "a": [0.7, 0.3, 0.0], "b": [0.7, 0.3, 0.4], "radius": 0.03},
                 {"kind": "cylinder", "pose": C.tolist(), "radius": 0.05, "length": 0.2}]
    r = post(client, {"robot": "panda", "target": T.tolist(), "obstacles": obstacles,
                      "link_radius": 0.02, "seed": 1})
    assert r.status_code == 200, r.text
    body = r.json()
    assert body["success"], body["message"]
    avoid = ik.ObstacleAvoidance([ik.Box(B, (0.05, 0.05, 0.05)), ik.Sphere((0.4, 0.5, 0.2), 0.05),
                                  ik.Capsule((0.7, 0.3, 0.0), (0.7, 0.3, 0.4), 0.03),
                                  ik.Cylinder(C, 0.05, 0.2)],
                                 link_radius=0.02).bind(panda)
    panda.fk(np.array(body["q"]))
    assert avoid.clearances(panda.data, np.inf).min() >= -1e-9


def test_two_hands_at_once(client):
    baxter = robots.load("baxter", geometry=False)
    q = baxter.random_q(np.random.default_rng(4))
    targets = [{"frame": f, "pose": baxter.fk(q, f).tolist()} for f in ("left_gripper", "right_gripper")]
    r = post(client, {"robot": "baxter", "targets": targets, "seed": 2})
    assert r.status_code == 200, r.text
    body = r.json()
    assert body["success"], body["message"]
    assert [t["name"] for t in body["task_errors"]] == ["frame left_gripper", "frame right_gripper"]
    for t in targets:
        assert np.linalg.norm(baxter.fk(np.array(body["q"]), t["frame"])[:3, 3]
                              - np.array(t["pose"])[:3, 3]) < 1e-4


def test_errors_name_the_field(client):
    T = np.eye(4).tolist()
    cases = [
        ({"robot": "panda", "target": T, "obstacles": [{"kind": "box", "pose": T, "size": [0.1, -0.1, 0.1]}]},
         ["body", "obstacles", 0, "box", "size", 1]),
        ({"robot": "panda", "target": T, "obstacles": [{"kind": "cone", "radius": 1}]},
         ["body", "obstacles", 0]),
        ({"robot": "panda", "target": T,
          "obstacles": [{"kind": "sphere", "center": [0, 0, 0.1], "radius": 0.2}]},
         ["body", "obstacles"]),
        ({"robot": "baxter", "targets": [{"frame": "left_grip", "pose": T}]}, ["body", "targets[0].frame"]),
        ({"robot": "panda"}, ["body", "target"]),
        ({"robot": "panda", "target": T, "targets": [{"frame": "panda_hand", "pose": T}]},
         ["body", "target"]),
        ({"robot": "panda", "targets": [{"frame": "panda_hand", "pose": T}], "method": "lm"},
         ["body", "method"]),
        ({"robot": "panda", "target": T, "link_radius": -1}, ["body", "link_radius"]),
    ]
    for body, loc in cases:
        r = post(client, body)
        assert r.status_code == 422, (body, r.text)
        got = r.json()["detail"][0]["loc"]
        assert got[: len(loc)] == loc, (loc, got)


def test_batch_mixes_poses_and_several_frame_targets(client):
    """/ik/batch: an item is a pose of `frame` or a list of frame targets solved together; each answer is
    checked by FK here, and a bad frame in the third item names that item."""
    baxter = robots.load("baxter", geometry=False)
    rng = np.random.default_rng(11)
    q1, q2 = baxter.random_q(rng), baxter.random_q(rng)
    hands = ("left_gripper", "right_gripper")
    both = [{"frame": f, "pose": baxter.fk(q2, f).tolist()} for f in hands]
    body = {"robot": "baxter", "frame": "left_gripper", "seed": 3,
            "targets": [baxter.fk(q1, "left_gripper").tolist(), both]}
    r = client.post("/ik/batch", json=body)
    assert r.status_code == 200, r.text
    single, pair = r.json()["results"]
    assert single["success"] and pair["success"], (single["message"], pair["message"])
    assert single["task_errors"] == []
    assert [t["name"] for t in pair["task_errors"]] == ["frame left_gripper", "frame right_gripper"]
    T1 = baxter.fk(np.array(single["q"]), "left_gripper")
    assert np.linalg.norm(T1[:3, 3] - baxter.fk(q1, "left_gripper")[:3, 3]) < 1e-4
    for t in both:
        p = baxter.fk(np.array(pair["q"]), t["frame"])[:3, 3]
        assert np.linalg.norm(p - np.array(t["pose"])[:3, 3]) < 1e-4

    body["targets"].append([{"frame": "left_grip", "pose": np.eye(4).tolist()}])
    r = client.post("/ik/batch", json=body)
    assert (r.status_code == 422
            and r.json()["detail"][0]["loc"][:2] == ["body", "targets[2][0].frame"]), r.text
    body["targets"][2] = [[1, 0, 0], [0, 1, 0]]  # neither a 4x4 pose nor a list of frame targets
    r = client.post("/ik/batch", json=body)
    assert r.status_code == 422 and r.json()["detail"][0]["loc"][:3] == ["body", "targets", 2], r.text


def test_not_attempted_frame_targets_report_the_largest_error_at_the_start():
    """A batch item the time cap skipped reports the start and its residual: for several frame targets the
    largest position / orientation error among them, computed here from FK."""
    from kinserve.service import jobs, schemas

    baxter = robots.load("baxter", geometry=False)
    q0 = baxter.random_q(np.random.default_rng(12))
    q = baxter.random_q(np.random.default_rng(13))
    problem = [schemas.FrameTarget(frame=f, pose=baxter.fk(q, f).tolist())
               for f in ("left_gripper", "right_gripper")]
    out = jobs.not_attempted(baxter, problem, {"q0": q0, "frame": None, "relax": ()}, "skipped")
    pos, rot = [], []
    for t in problem:
        A, B = baxter.fk(q0, t.frame), np.array(t.pose)
        pos.append(np.linalg.norm(A[:3, 3] - B[:3, 3]))
        rot.append(np.arccos(np.clip((np.trace(A[:3, :3].T @ B[:3, :3]) - 1) / 2, -1, 1)))
    assert out["success"] is False and out["message"] == "skipped" and out["q"] == q0.tolist()
    assert out["position_error"] == pytest.approx(max(pos), abs=1e-12)
    assert out["orientation_error"] == pytest.approx(max(rot), abs=1e-9)


@pytest.mark.parametrize("q", [["0.1"] * 7, [True] * 7, [0, "1", 0, 0, 0, 0, 0]])
def test_text_and_booleans_are_not_numbers(client, q):
    """A joint value written as text or true / false is a 422 naming the field (pydantic's lax float would
    read "0.1" as 0.1 and true as 1.0); integers are JSON numbers and pass."""
    r = client.post("/fk", content=json.dumps({"robot": "panda", "q": q}),
                    headers={"content-type": "application/json"})
    assert r.status_code == 422, r.text
    assert "q" in r.text and "valid number" in r.text
    ok = client.post("/fk", content=json.dumps({"robot": "panda", "q": [0, 0, 0, -1, 0, 1, 0]}),
                     headers={"content-type": "application/json"})
    assert ok.status_code == 200, ok.text
