"""POST /collision and the collision options of /ik, /ik/batch on a real server; `kinserve collide` end to
end."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import httpx
import numpy as np
import pytest

from kinserve import ik, robots

from service_server import ROOT, Server

TABLE = {"kind": "box", "pose": [[1, 0, 0, 0.65], [0, 1, 0, 0], [0, 0, 1, -0.05], [0, 0, 0, 1]],
         "size": [0.7, 1.2, 0.1]}
WALL = {"kind": "box", "pose": [[1, 0, 0, 0], [0, 1, 0, -0.6], [0, 0, 1, 0.5], [0, 0, 0, 1]],
        "size": [1.5, 0.05, 1.0]}
Q_DOWN = [0.0, 1.5, 0.0, -0.5, 0.0, 1.0, 0.0]  # the hand reaches into the table


@pytest.fixture(scope="module")
def client():
    srv = Server(max_time_cap=1.0)
    with httpx.Client(base_url=srv.url, timeout=60) as c:
        yield c
    srv.stop()


@pytest.fixture(scope="module")
def panda():
    return robots.load("panda")


def test_collision_endpoint_matches_the_library(client, panda):
    scene = [ik.Box(np.array(o["pose"]), o["size"]) for o in (TABLE, WALL)]
    for q in (panda.neutral().tolist(), Q_DOWN):
        r = client.post("/collision",
                        json={"robot": "panda", "q": q, "obstacles": [TABLE, WALL], "distances": True})
        assert r.status_code == 200, r.text
        body = r.json()
        assert body["in_collision"] == panda.in_collision(q, scene)
        assert [tuple(p) for p in body["pairs"]] == panda.collisions(q, scene)
        assert body["min_distance"] == pytest.approx(panda.min_distance(q, scene), abs=1e-9)
        assert len(body["distances"]) == len(panda.distances(q, scene))
    assert ["panda_hand", "obstacle[0]:box"] in body["pairs"]
    r = client.post("/collision",
                    json={"robot": "panda", "q": Q_DOWN, "obstacles": [TABLE], "self_collision": False})
    assert all(p[1].startswith("obstacle") for p in r.json()["pairs"])


@pytest.mark.parametrize("body, status, field", [
    ({"robot": "panda", "q": [0.0] * 6}, 422, "q"),
    ({"robot": "panda", "q": [0.0] * 7, "obstacles": [dict(TABLE, size=[0.7, 0.0, 0.1])]}, 422, "obstacles"),
    ({"robot": "panda", "q": [0.0] * 7, "obstacles": [{"kind": "box", "size": [1, 1, 1]}]}, 422, "pose"),
    ({"robot": "panda", "q": [0.0] * 7, "obstacles": [{"kind": "mesh", "path": "/etc/passwd"}]},
     422, "obstacles"),
    ({"robot": "pandaa", "q": [0.0] * 7}, 404, "robot"),
])
def test_bad_collision_requests_name_the_field(client, body, status, field):
    r = client.post("/collision", json=body)
    assert r.status_code == status, r.text
    assert field in json.dumps(r.json()["detail"][0]["loc"])


def test_ik_and_batch_accept_collision_options(client, panda):
    scene = [ik.Box(np.array(o["pose"]), o["size"]) for o in (TABLE, WALL)]
    rng = np.random.default_rng(1)
    qs = [q for q in panda.random_q(rng, 40) if not panda.in_collision(q, scene)][:3]
    targets = [panda.fk(q).tolist() for q in qs]
    r = client.post("/ik", json={"robot": "panda", "target": targets[0], "self_collision": True,
                                 "obstacles": [TABLE, WALL], "seed": 0})
    assert r.status_code == 200, r.text
    assert r.json()["success"] and not panda.in_collision(r.json()["q"], scene)
    r = client.post("/ik/batch", json={"robot": "panda", "targets": targets, "self_collision": True,
                                       "obstacles": [TABLE, WALL], "collision_margin": 0.005})
    assert r.status_code == 200, r.text
    for res in r.json()["results"]:
        assert res["success"] and panda.min_distance(res["q"], scene) >= 0.005 - 1e-6
    r = client.post("/ik", json={"robot": "panda", "target": targets[0], "collision_margin": -1,
                                 "obstacles": [TABLE]})
    assert r.status_code == 422 and "collision_margin" in json.dumps(r.json())


def kinserve(*args: str) -> subprocess.CompletedProcess:
    env = dict(os.environ, MPLBACKEND="Agg")
    return subprocess.run([sys.executable, "-m", "kinserve.service.cli", *args], cwd=ROOT, env=env,
                          capture_output=True, text=True, timeout=120)


def test_cli_collide_end_to_end(panda):
    q = " ".join(map(str, Q_DOWN))
    out = kinserve("collide", "panda", "--q", *q.split(), "--box", "0.65", "0", "-0.05", "0.7", "1.2",
                   "0.1", "--json")
    assert out.returncode == 0, out.stderr
    body = json.loads(out.stdout)
    table = ik.Box(np.array(TABLE["pose"]), TABLE["size"])
    assert body["in_collision"] is True
    assert [tuple(p) for p in body["pairs"]] == panda.collisions(Q_DOWN, [table])
    assert body["min_distance"] == pytest.approx(panda.min_distance(Q_DOWN, [table]), abs=1e-9)
    text = kinserve("collide", "panda", "--sphere", "3", "3", "3", "0.1", "--fail-on-collision")
    assert text.returncode == 0 and "collision free" in text.stdout
    hit = kinserve("collide", "panda", "--q", *q.split(), "--box", "0.65", "0", "-0.05", "0.7", "1.2", "0.1",
                   "--fail-on-collision")
    assert hit.returncode == 1 and "IN COLLISION" in hit.stdout
    bad = kinserve("collide", "panda", "--sphere", "0", "0", "1", "-0.1")
    assert bad.returncode == 2 and bad.stderr.strip() == "error: sphere radius must be positive (m), got -0.1"


def test_cli_reach_with_collision_options(tmp_path):
    out = kinserve("reach", "panda", "--samples", "20", "--processes", "1", "--self-collision",
                   "--box", "0.65", "0", "-0.05", "0.7", "1.2", "0.1", "--out", str(tmp_path / "r"))
    assert out.returncode == 0, out.stderr
    assert "collision-free solutions only (1 obstacle(s), self-collision)" in out.stdout
    assert (tmp_path / "r.npz").is_file() and (tmp_path / "r.png").is_file()


def test_cli_view_collision_html(tmp_path):
    page = tmp_path / "c.html"
    q = " ".join(map(str, Q_DOWN)).split()
    out = kinserve("view", "panda", "--q", *q, "--collision", "--box", "0.65", "0", "-0.05", "0.7", "1.2",
                   "0.1", "--html", str(page))
    assert out.returncode == 0, out.stderr
    plain = tmp_path / "p.html"
    assert kinserve("view", "panda", "--q", *q, "--html", str(plain)).returncode == 0
    # the page is compressed: the hull meshes and the obstacle make it clearly larger
    assert page.stat().st_size > plain.stat().st_size + 5000


def test_ik_several_targets_with_self_collision(client):
    baxter = robots.load("baxter")
    rng = np.random.default_rng(3)
    q = next(q for q in baxter.random_q(rng, 200) if not baxter.in_collision(q))
    body = {"robot": "baxter", "self_collision": True, "seed": 0, "max_time": 1.0,
            "targets": [{"frame": "left_gripper", "pose": baxter.fk(q, "left_gripper").tolist()},
                        {"frame": "right_gripper", "pose": baxter.fk(q, "right_gripper").tolist()}]}
    r = client.post("/ik", json=body)
    assert r.status_code == 200, r.text
    assert r.json()["success"], r.json()["message"]
    assert not baxter.in_collision(r.json()["q"])
