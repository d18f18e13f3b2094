"""Poses over HTTP in every form (issue 24), on a real server: a 4x4 matrix, ``{"position", "quaternion"}``
(``[qx, qy, qz, qw]``, scalar last) and ``{"position", "rpy"}`` give the same answers wherever a pose is read;
a quaternion that is not unit is a 422 naming the field; the OpenAPI document describes the forms.

The quaternions and angles here come from scipy (its ``as_quat`` is scalar last too), not from kinserve.
"""

from __future__ import annotations

import jsonschema
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from kinserve import robots

from service_server import client_of, running


@pytest.fixture(scope="module")
def server():
    yield from running(max_time_cap=2.0)


@pytest.fixture(scope="module")
def client(server):
    yield from client_of(server, timeout=60)


@pytest.fixture(scope="module")
def panda():
    return robots.load("panda", geometry=False)


def forms(T: np.ndarray) -> dict:
    """The three spellings of the pose ``T``."""
    rot = Rotation.from_matrix(T[:3, :3])
    p = T[:3, 3].tolist()
    return {"matrix": T.tolist(), "quaternion": {"position": p, "quaternion": rot.as_quat().tolist()},
            "rpy": {"position": p, "rpy": rot.as_euler("xyz").tolist()}}  # fixed x, y, z: Rz Ry Rx


def ok(client, path: str, body: dict) -> dict:
    r = client.post(path, json=body)
    assert r.status_code == 200, r.text
    return r.json()


def test_fk_pose_given_back_to_ik_in_every_form_gives_the_same_answer(client, panda):
    rng = np.random.default_rng(24)
    for _ in range(2):
        q = panda.random_q(rng)
        T = np.array(ok(client, "/fk", {"robot": "panda", "q": q.tolist()})["pose"])
        np.testing.assert_allclose(T, panda.fk(q), atol=1e-12)
        # a start a little off the answer: a few iterations, far inside any time budget
        q0 = (q + 0.02 * rng.standard_normal(panda.nq)).tolist()
        answers = {}
        for name, pose in forms(T).items():
            body = ok(client, "/ik", {"robot": "panda", "target": pose, "q0": q0, "seed": 7, "max_time": 2.0})
            assert body["success"], (name, body["message"])
            reached = panda.fk(np.array(body["q"]))
            assert np.linalg.norm(reached[:3, 3] - T[:3, 3]) < 1e-4
            answers[name] = np.array(body["q"])
        np.testing.assert_allclose(answers["quaternion"], answers["matrix"], atol=1e-8)
        np.testing.assert_allclose(answers["rpy"], answers["matrix"], atol=1e-8)


def test_frame_targets_batches_and_cartesian_plans_read_the_forms_alike(client, panda):
    rng = np.random.default_rng(5)
    q = panda.random_q(rng)
    T = panda.fk(q, "panda_hand")
    q0 = (q + 0.02 * rng.standard_normal(panda.nq)).tolist()
    many = {name: ok(client, "/ik", {"robot": "panda", "targets": [{"frame": "panda_hand", "pose": pose}],
                                     "q0": q0, "seed": 1, "max_time": 2.0})
            for name, pose in forms(T).items()}
    assert all(b["success"] for b in many.values()), many
    np.testing.assert_allclose(many["quaternion"]["q"], many["matrix"]["q"], atol=1e-8)

    batch = ok(client, "/ik/batch", {"robot": "panda", "frame": "panda_hand", "q0": q0, "seed": 1,
                                     "max_time": 2.0, "targets": list(forms(T).values())})
    qs = [np.array(r["q"]) for r in batch["results"]]
    assert batch["attempted"] == 3 and all(r["success"] for r in batch["results"]), batch
    np.testing.assert_allclose(qs[1], qs[0], atol=1e-8)
    np.testing.assert_allclose(qs[2], qs[0], atol=1e-8)

    U = T.copy()
    U[:3, 3] += [0.0, 0.0, 0.03]  # 3 cm up, same orientation
    plans = {name: ok(client, "/plan/cartesian", {"robot": "panda", "frame": "panda_hand", "q0": q.tolist(),
                                                  "steps": 2, "poses": [forms(T)[name], forms(U)[name]]})
             for name in ("matrix", "quaternion")}
    a, b = (np.array(plans[k]["trajectory"]["positions"]) for k in ("matrix", "quaternion"))
    assert plans["matrix"]["success"] and plans["quaternion"]["success"], plans
    assert a.shape == b.shape == (4, panda.nq)
    np.testing.assert_allclose(b, a, atol=1e-8)


def test_obstacle_poses_take_the_forms_too(client, panda):
    q = panda.neutral()
    T = np.eye(4)
    T[:3, :3] = Rotation.from_euler("z", 0.6).as_matrix()
    T[:3, 3] = panda.fk(q, "panda_link4")[:3, 3] + [0.0, 0.0, 0.05]
    boxes = [{"kind": "box", "pose": pose, "size": [0.3, 0.02, 0.02]} for pose in forms(T).values()]
    answers = [ok(client, "/collision", {"robot": "panda", "q": q.tolist(), "self_collision": False,
                                         "obstacles": [box]}) for box in boxes]
    assert answers[0]["in_collision"] and answers[0]["pairs"], answers[0]
    assert answers[1]["pairs"] == answers[2]["pairs"] == answers[0]["pairs"]
    for other in answers[1:]:
        assert other["min_distance"] == pytest.approx(answers[0]["min_distance"], abs=1e-9)


def test_a_quaternion_that_is_not_unit_is_a_422_on_that_field(client):
    p = [0.4, 0.0, 0.5]
    cases = [
        ({"robot": "panda", "target": {"position": p, "quaternion": [1, 0, 0, 1]}},
         ["body", "target", "position_quaternion", "quaternion"]),
        ({"robot": "panda", "targets": [{"frame": "panda_hand", "pose": {"position": p,
                                                                         "quaternion": [0, 0, 0, 0]}}]},
         ["body", "targets", 0, "pose", "position_quaternion", "quaternion"]),
        ({"robot": "panda", "target": {"position": p}},
         ["body", "target", "position_quaternion", "quaternion"]),
        ({"robot": "panda", "target": {"position": p, "quaternion": [0, 0, 0, 1], "rpy": [0, 0, 0]}},
         ["body", "target", "position_rpy", "quaternion"]),
    ]
    for body, loc in cases:
        r = client.post("/ik", json=body)
        assert r.status_code == 422, r.text
        assert any(d["loc"] == loc for d in r.json()["detail"]), (loc, r.json())
    r = client.post("/ik", json=cases[0][0])
    (detail,) = r.json()["detail"]
    assert "unit quaternion [qx, qy, qz, qw]" in detail["msg"] and "scalar last" in detail["msg"], detail
    r = client.post("/ik/batch", json={"robot": "panda",
                                       "targets": [{"position": p, "quaternion": [0, 0, 2, 0]}]})
    assert r.status_code == 422 and any(d["loc"][:3] == ["body", "targets", 0]
                                        and d["loc"][-1] == "quaternion" for d in r.json()["detail"]), r.text


def test_openapi_documents_the_pose_forms(client):
    doc = client.get("/openapi.json").json()
    schemas = doc["components"]["schemas"]
    target = schemas["IKRequest"]["properties"]["target"]["anyOf"][0]
    assert len(target["oneOf"]) == 3 and "[qx, qy, qz, qw]" in target["description"]
    assert "scalar last" in target["description"] and "Rz(yaw) Ry(pitch) Rx(roll)" in target["description"]
    pq = schemas["PositionQuaternion"]
    assert pq["required"] == ["position", "quaternion"] and pq["additionalProperties"] is False
    assert "[qx, qy, qz, qw]" in pq["properties"]["quaternion"]["description"]
    for name in ("FrameTarget", "BoxObstacle", "CylinderObstacle", "CartesianPlanRequest", "IKBatchRequest"):
        assert "PositionQuaternion" in str(schemas[name]), name
    # every schema is a valid JSON Schema (OpenAPI 3.1's dialect) and every reference resolves
    for name, schema in schemas.items():
        jsonschema.Draft202012Validator.check_schema(schema)
    refs = [s.split("/")[-1] for s in _refs(doc)]
    assert refs and set(refs) <= set(schemas)


def _refs(node):
    if isinstance(node, dict):
        for k, v in node.items():
            if k == "$ref":
                yield v
            else:
                yield from _refs(v)
    elif isinstance(node, list):
        for v in node:
            yield from _refs(v)
