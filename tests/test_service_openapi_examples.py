"""The OpenAPI document is a user's manual that holds (issue 24): every endpoint has a human summary, a
description, a request example (POST) and an answer example; every request example, posted to a real server
on loopback, is answered 200 with a body valid against the documented answer schema; every answer example is
valid against that schema too, and where the endpoint is deterministic it is the answer the server gives to
the request example (numbers to 1e-3). ``GET /`` redirects to ``/docs``.

The time budgets: the defaults the docs state for Python, the CLI and HTTP are the ones in force - read
from the code, the CLI's parser and the OpenAPI schema, and run on a fake clock (:mod:`fake_clock`), so no
machine load sways the verdicts.
"""

from __future__ import annotations

import argparse
import contextlib
import inspect
import io
import json
import re

import jsonschema
import numpy as np
import pytest
from fake_clock import stepping_clock

from kinserve import ik, planners, robots
from kinserve.ik.options import MAX_TIME_LM, MAX_TIME_QP
from kinserve.service import cli, cli_plan, jobs, motion_jobs
from kinserve.service import schemas as S
from kinserve.service.executor import Deadline
from kinserve.service.settings import ServiceSettings

from service_server import ROOT, client_of, running

METHODS = ("get", "post", "put", "patch", "delete")
#: Answers whose example is the server's own answer to the first request example (to TOL), but for these
#: keys; the others (health counters, a random-tree plan) only follow the schema.
DETERMINISTIC = {"/robots/{name}", "/fk", "/jacobian", "/ik", "/ik/batch", "/collision", "/plan/cartesian"}
UNTIMED = {"elapsed"}
TOL = 1e-3
STEP = 1e-3  # s per reading of the fake clock
OVERRUN = 10 * STEP  # readings a solve may take after its last check of the clock


@pytest.fixture(scope="module")
def server():
    yield from running("--solver-threads", "1", max_time_cap=1.0)


@pytest.fixture(scope="module")
def client(server):
    yield from client_of(server, timeout=120)


@pytest.fixture(scope="module")
def doc(client) -> dict:
    return client.get("/openapi.json").json()


def operations(doc: dict):
    """``(path, method, operation)`` of every documented operation."""
    for path, item in doc["paths"].items():
        for method in METHODS:
            if method in item:
                yield path, method, item[method]


def resolve(doc: dict, schema: dict) -> dict:
    """``schema`` itself, or the component it refers to."""
    ref = schema.get("$ref", "")
    return doc["components"]["schemas"][ref.rsplit("/", 1)[1]] if ref else schema


def request_examples(doc: dict, op: dict) -> list:
    """The JSON request body examples of ``op`` (on the body or on its schema)."""
    media = op["requestBody"]["content"]["application/json"]
    found = [e["value"] for e in media.get("examples", {}).values()]
    return found + ([media["example"]] if "example" in media else []) + resolve(doc, media["schema"]).get(
        "examples", [])


def answer_schema(doc: dict, op: dict) -> dict:
    """The 200 answer's JSON schema, with the document's components so that its references resolve."""
    schema = op["responses"]["200"]["content"]["application/json"]["schema"]
    return {**schema, "components": doc["components"]}


def answer_examples(doc: dict, op: dict) -> list:
    """The 200 answer examples of ``op`` (on the response or on its schema)."""
    media = op["responses"]["200"]["content"]["application/json"]
    found = [e["value"] for e in media.get("examples", {}).values()]
    return found + ([media["example"]] if "example" in media else []) + resolve(doc, media["schema"]).get(
        "examples", [])


def validate(doc: dict, op: dict, body) -> None:
    jsonschema.Draft202012Validator(answer_schema(doc, op)).validate(body)


def close(example, actual, where: str = "") -> None:
    """``example`` is ``actual``: numbers to :data:`TOL`, the rest equal, keys in :data:`UNTIMED` skipped
    (FastAPI leaves null values out of the OpenAPI document: a key missing from the example is null)."""
    if isinstance(example, dict):
        assert isinstance(actual, dict), (where, example, actual)
        actual = {k: v for k, v in actual.items() if k in example or v is not None}
        assert set(example) == set(actual), (where, example, actual)
        for k in example.keys() - UNTIMED:
            close(example[k], actual[k], f"{where}.{k}")
    elif isinstance(example, list):
        assert isinstance(actual, list) and len(example) == len(actual), (where, example, actual)
        for i, (e, a) in enumerate(zip(example, actual)):
            close(e, a, f"{where}[{i}]")
    elif isinstance(example, float) or isinstance(actual, float):
        assert abs(example - actual) <= TOL, (where, example, actual)
    else:
        assert example == actual, (where, example, actual)


def path_examples(op: dict) -> list[dict]:
    """Every combination-free filling of ``op``'s path parameters: one dict per documented example."""
    params = [p for p in op.get("parameters", []) if p["in"] == "path"]
    if not params:
        return [{}]
    (param,) = params
    return [{param["name"]: e["value"]} for e in param["examples"].values()]


# ------------------------------------------------------------------ the document


def test_every_operation_has_a_summary_a_description_and_examples(doc):
    ops = list(operations(doc))
    assert {p for p, _, _ in ops} >= {"/health", "/robots", "/robots/{name}", "/fk", "/jacobian", "/ik",
                                      "/ik/batch", "/plan/cartesian", "/plan/motion", "/collision"}
    for path, method, op in ops:
        summary, description = op.get("summary", ""), op.get("description", "")
        assert len(summary.split()) >= 3, (path, summary)  # not FastAPI's own from the name: "Fk", "Solve Ik"
        assert len(description) >= 150 and "``" not in description, (path, description)
        if method == "post":
            assert request_examples(doc, op), path
        assert answer_examples(doc, op), path
        for example in answer_examples(doc, op):
            validate(doc, op, example)


def test_descriptions_state_the_conventions(doc):
    ops = {path: op for path, _, op in operations(doc)}
    assert "[qx, qy, qz, qw]" in ops["/ik"]["description"] and "scalar last" in ops["/ik"]["description"]
    jac = ops["/jacobian"]["description"]
    assert "[v; w]" in jac and "world axes" in jac and "LOCAL_WORLD_ALIGNED" in jac
    for path in ("/ik", "/ik/batch", "/plan/cartesian", "/plan/motion"):  # the time cap, the failure
        text = ops[path]["description"]
        assert "max_time" in text and "`success: false`" in text, path
    assert "`in_collision: true`" in ops["/collision"]["description"]


# ------------------------------------------------------------------ the examples, posted


def test_every_request_example_is_answered_200_as_documented(client, doc):
    posted = 0
    for path, method, op in operations(doc):
        if method != "post":
            continue
        first = None
        for body in request_examples(doc, op):
            r = client.post(path, content=json.dumps(body), headers={"content-type": "application/json"})
            assert r.status_code == 200, (path, body, r.text)
            validate(doc, op, r.json())
            first = r.json() if first is None else first
            posted += 1
        if path in DETERMINISTIC:
            close(answer_examples(doc, op)[0], first, path)
        else:
            assert answer_examples(doc, op)[0]["success"] == first["success"], path
    assert posted >= 9  # fk, jacobian, ik (2), ik/batch, plan/cartesian (2), plan/motion, collision


def test_get_operations_answer_their_examples(client, doc):
    for path, method, op in operations(doc):
        if method != "get":
            continue
        for params in path_examples(op):
            r = client.get(path.format(**params))
            assert r.status_code == 200, (path, params, r.text)
            validate(doc, op, r.json())
            example = answer_examples(doc, op)[0]
            if path == "/robots/{name}" and params["name"] == example["name"]:
                close(example, r.json(), path)
            if path == "/robots":  # the example shows two entries of the real catalogue
                assert example.items() <= r.json().items()


def test_the_ik_example_answer_places_the_frame_at_the_target(doc):
    """The documented q (rounded) puts panda_hand_tcp on the example target: FK of the model here."""
    panda = robots.load("panda", geometry=False)
    ops = {path: op for path, _, op in operations(doc)}
    request, answer = request_examples(doc, ops["/ik"])[0], answer_examples(doc, ops["/ik"])[0]
    T = panda.fk(np.array(answer["q"]), request["frame"])
    assert np.allclose(T[:3, 3], request["target"]["position"], atol=1e-4)
    assert np.allclose(T[:3, :3], np.diag([1.0, -1.0, -1.0]), atol=1e-4)  # [1, 0, 0, 0]: a half turn about x


def test_root_redirects_to_the_docs_page(client):
    r = client.get("/", follow_redirects=False)
    assert r.status_code in (307, 308) and r.headers["location"] == "/docs"
    page = client.get("/", follow_redirects=True)
    assert page.status_code == 200 and page.url.path == "/docs" and "swagger-ui" in page.text.lower()


# ------------------------------------------------------------------ the time budgets


def far_target() -> np.ndarray:
    T = np.eye(4)
    T[:3, 3] = (3.0, 0.0, 0.5)  # 3 m from the Panda's base: out of reach, so the solve runs its budget out
    return T


def seconds_in(text: str) -> set[str]:
    return set(re.findall(r"(\d+(?:\.\d+)?) s\b", text))


def paragraph(path: str, start: str) -> str:
    text = (ROOT / path).read_text(encoding="utf-8")
    at = text.index(start)
    end = re.search(r"\n(- \*\*|\n)", text[at + len(start):])
    return text[at: at + len(start) + (end.start() if end else len(text))]


def test_the_documented_defaults_are_the_ones_declared():
    python_default = inspect.signature(ik.solve).parameters["max_time"].default
    assert python_default is None  # the solver's own: MAX_TIME_LM or MAX_TIME_QP
    assert jobs.DEFAULT_MAX_TIME == MAX_TIME_QP  # over HTTP: the larger one, whichever solver runs
    assert jobs.capped_by(ServiceSettings(), None) == jobs.DEFAULT_MAX_TIME
    commands = next(a for a in cli.build_parser()._actions if isinstance(a, argparse._SubParsersAction))
    ik_help = next(a for a in commands.choices["ik"]._actions if "--max-time" in a.option_strings)
    assert ik_help.default is None and {f"{MAX_TIME_LM:g}", f"{MAX_TIME_QP:g}"} <= seconds_in(ik_help.help)
    field = S.IKRequest.model_json_schema()["properties"]["max_time"]["description"]
    assert f"{jobs.DEFAULT_MAX_TIME:g} s" in field
    pose_budget = inspect.signature(planners.cartesian_to_joint).parameters["max_time"].default
    plan_default = inspect.signature(planners.plan_motion).parameters["max_time"].default
    assert plan_default == motion_jobs.DEFAULT_PLAN_TIME == cli_plan.DEFAULT_MAX_TIME
    defaults = (MAX_TIME_LM, MAX_TIME_QP, jobs.DEFAULT_MAX_TIME, pose_budget, plan_default)
    in_force = {f"{v:g}" for v in defaults}
    service = paragraph("docs/service.md", "- **Time budgets**")
    assert seconds_in(service) == in_force, service  # every number stated is one in force, and all are
    assert f"{jobs.DEFAULT_MAX_TIME:g} s whichever solver runs" in service
    cli_text = paragraph("docs/cli.md", "**Time budgets.**")
    assert seconds_in(cli_text) == in_force - {f"{pose_budget:g}"}, cli_text


@pytest.fixture(scope="module")
def panda():
    return robots.load("panda", geometry=False)


@pytest.fixture(scope="module")
def warm(panda):
    """Models, seed tables and compiled kernels loaded here, before any fake clock."""
    req = S.IKRequest(robot="panda", target=far_target().tolist(), max_time=0.01)
    jobs.solve_ik(Deadline(60.0), req, 0.01)
    ik.solve(panda, far_target(), max_time=0.01)
    ik.solve(panda, far_target(), max_time=0.01, centring=0.1)


def test_the_defaults_in_force_python_cli_http(panda, warm):
    far = far_target()
    with stepping_clock(STEP):
        lm = ik.solve(panda, far)
        qp = ik.solve(panda, far, centring=0.1)
        out = io.StringIO()
        with contextlib.redirect_stdout(out):
            code = cli.main(["ik", "panda", "--xyz", "3", "0", "0.5", "--json"])
        req = S.IKRequest(robot="panda", target=far.tolist())
        http = jobs.solve_ik(Deadline(60.0), req, jobs.capped_by(ServiceSettings(), req.max_time))
    assert lm.method == "lm" and MAX_TIME_LM <= lm.elapsed <= MAX_TIME_LM + OVERRUN, (lm.method, lm.elapsed)
    assert qp.method == "qp" and MAX_TIME_QP <= qp.elapsed <= MAX_TIME_QP + OVERRUN, (qp.method, qp.elapsed)
    answer = json.loads(out.getvalue())
    assert code == 1 and answer["method"] == "lm"
    assert MAX_TIME_LM <= answer["elapsed"] <= MAX_TIME_LM + OVERRUN, answer["elapsed"]
    assert not http["success"]
    assert jobs.DEFAULT_MAX_TIME <= http["elapsed"] <= jobs.DEFAULT_MAX_TIME + OVERRUN, http["elapsed"]


def test_a_target_reached_within_the_budget_gets_the_same_answer_everywhere(panda, warm):
    """The budget only cuts a solve short: Python's default and the service's give the same q (same seed)."""
    T = panda.fk(np.array(S.PANDA_READY) + 0.2, panda.tip)
    with stepping_clock(STEP):
        here = ik.solve(panda, T, seed=3)
        req = S.IKRequest(robot="panda", target=T.tolist(), seed=3)
        http = jobs.solve_ik(Deadline(60.0), req, jobs.capped_by(ServiceSettings(), req.max_time))
    assert here.success and http["success"]
    assert np.array_equal(np.asarray(here.q), np.asarray(http["q"]))
