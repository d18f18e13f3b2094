"""Bad input to the service settings, the CLI's frames and seeds, scene YAML, viz animations and the
top-level helpers: each is a kinserve error (or a one-line CLI error) naming what was wrong; and over HTTP
(a real server on loopback), numbers of every request field that are not JSON numbers: a 422 naming the
field."""

from __future__ import annotations

import json
from typing import Annotated

import numpy as np
import pytest
from pydantic import BaseModel, Field

import kinserve
from kinserve import robots, viz
from kinserve.ik.batch.reachability import reachability_map
from kinserve.kinematics.errors import InputError, NonFiniteError, ShapeError
from kinserve.planners.motion.scene_yaml import read_planning_scene
from kinserve.service import cli, collision_schemas, motion_schemas, schemas
from kinserve.service.schemas import Number, integer, real
from kinserve.service.settings import ServiceSettings

from cli_runs import assert_one_line_error, run_main
from service_server import client_of, running

SCENE = """world:
  collision_objects:
  - id: a
    primitives: [{{type: {kind}, dimensions: {dims}}}]
    primitive_poses: [{{position: {pos}}}]
"""


@pytest.fixture(scope="module")
def planar():
    return robots.load("planar4r")


def one_line_error(argv, capsys, needle):
    """``kinserve <argv>`` in-process fails in one line holding ``needle`` (:mod:`cli_runs`)."""
    assert_one_line_error(*run_main(argv, capsys), needle)


# ---------------------------------------------------------------- service settings
@pytest.mark.parametrize("field, value, needle", [
    ("robot_cache_bytes", 10**300, "robot_cache_bytes must be at most"),
    ("max_body", 10**30, "max_body must be at most"),
    ("request_time_cap", 1e300, "request_time_cap must be at most 86400 s"),
    ("keep_alive", 1e300, "keep_alive must be at most"),
    ("keep_alive", float("inf"), "finite number"),
    ("queue", True, "finite number"),
])
def test_settings_refuse_absurd_values(field, value, needle):
    with pytest.raises(ValueError, match=needle):
        ServiceSettings(**{field: value})
    ServiceSettings(**{field: 2 if field != "queue" else 0})  # a sane value still works


def test_serve_accepts_sane_options_when_parsing():
    args = cli.build_parser().parse_args(["serve", "--max-body", "2M", "--robot-cache-mb", "512",
                                          "--keep-alive", "30"])
    from kinserve.service.cli_serve import settings_of

    settings = settings_of(args)
    assert settings.max_body == 2 << 20 and settings.robot_cache_bytes == 512 << 20


# ---------------------------------------------------------------- CLI frames, seed, numbers
@pytest.mark.parametrize("argv, needle", [
    (["collide", "planar4r", "--frame", "nope"], "unknown frame 'nope'"),
    (["fk", "planar4r", "--frame", ""], "unknown frame ''"),
    (["jacobian", "planar4r", "--frame", ""], "unknown frame ''"),
    (["reach", "pr", "--seed", "-1"], "argument --seed"),
    (["collide", "planar4r", "--box", "0.5", "0", "0.3", "0.1", "0.1", "0.1", "1e300", "0", "0"],
     "argument --box: expected numbers"),
    (["collide", "planar4r", "--cylinder", "0.5", "0", "0.3", "0.1", "0.2", "0", "1e7", "0"],
     "argument --cylinder"),
])
def test_cli_bad_frame_seed_or_angle_is_one_line_error(argv, needle, capsys):
    one_line_error(argv, capsys, needle)


def test_view_html_with_unknown_frame_is_one_line_error(tmp_path, capsys):
    out = tmp_path / "f.html"
    one_line_error(["view", "planar4r", "--html", str(out), "--frame", "nope"], capsys,
                   "unknown frame 'nope'")
    assert not out.exists()


def test_cli_known_frame_and_bounded_angle_still_work(capsys):
    code, out, _ = run_main(["fk", "planar4r", "--frame", "tool"], capsys)
    assert code == 0 and "frame tool" in out
    code, _, err = run_main(["collide", "planar4r", "--frame", "tool", "--box", "5", "5", "5", "0.1", "0.1",
                             "0.1", "0.1", "0", "3"], capsys)
    assert code == 0, err


def test_reachability_map_refuses_a_negative_seed_before_any_work(planar):
    with pytest.raises(InputError, match="seed must be an integer from 0"):
        reachability_map(planar, 4, resolution=2, seed=-1)
    with pytest.raises(InputError, match="seed must be an integer"):
        reachability_map(planar, 4, resolution=2, seed=1.5)


# ---------------------------------------------------------------- scene YAML
def test_scene_yaml_not_utf8_is_input_error(tmp_path, capsys):
    path = tmp_path / "bin.yaml"
    path.write_bytes(b"\xff\xfe\x00world: 1")
    with pytest.raises(InputError, match="is not UTF-8 text"):
        read_planning_scene(path)
    one_line_error(["collide", "planar4r", "--scene", str(path)], capsys, "is not UTF-8 text")


def test_scene_yaml_directory_is_named(tmp_path):
    with pytest.raises(InputError, match="is a directory, expected a YAML file"):
        read_planning_scene(str(tmp_path))


@pytest.mark.parametrize("kind, dims, pos, needle", [
    (1, "[0.1, 0.1, 0.1]", "[0.4, no, yes]", "position must hold numbers"),
    (2, "[yes]", "[0, 0, 0]", "dimensions \\(sphere\\) must hold numbers"),
    (2, '["0.1"]', "[0, 0, 0]", "dimensions \\(sphere\\) must hold numbers"),
    (2, "[0.1]", "[0, 0, 1e7]", "position must hold finite numbers with"),
])
def test_scene_yaml_refuses_booleans_text_and_huge_numbers(kind, dims, pos, needle):
    with pytest.raises(InputError, match=needle):
        read_planning_scene(SCENE.format(kind=kind, dims=dims, pos=pos))
    shapes = read_planning_scene(SCENE.format(kind=2, dims="[0.1]", pos="[0.4, 0, 1]"))
    assert shapes[0].radius == pytest.approx(0.1)


# ---------------------------------------------------------------- viz
def test_motion_plan_scene_bounds_frames_and_fps(planar):
    a, b = np.zeros(4), np.full(4, 0.1)
    with pytest.raises(InputError, match="more than the 100,000 allowed"):
        viz.motion_plan_scene(planar, ([0.0, 1e6], np.vstack([a, b])), fps=30)
    with pytest.raises(InputError, match="fps"):
        viz.motion_plan_scene(planar, ([0.0, 1.0], np.vstack([a, b])), fps=1e6)
    scene = viz.motion_plan_scene(planar, ([0.0, 1.0], np.vstack([a, b])), fps=10)
    assert "planar4r" in scene.robots


def test_animation_refuses_huge_fps_and_empty_trajectory(planar):
    scene = viz.Scene()
    scene.add_robot(planar)
    with pytest.raises(InputError, match="fps"):
        viz.Animation(scene, fps=1e300)
    anim = viz.Animation(scene, fps=240)
    with pytest.raises(InputError, match="at least one sample"):
        anim.robot("planar4r", np.zeros((0, 4)))
    assert list(anim.robot("planar4r", np.zeros((2, 4)))) == [0, 1]


def test_add_robot_with_bad_q_leaves_the_scene_unchanged(planar):
    scene = viz.Scene()
    with pytest.raises(NonFiniteError):
        scene.add_robot(planar, [np.nan] * 4)
    assert "planar4r" not in scene.robots
    assert scene.add_robot(planar, np.zeros(4)).name == "planar4r"


# ---------------------------------------------------------------- top-level helpers
@pytest.mark.parametrize("xyz, error, needle", [
    ([10**400, 0, 0], NonFiniteError, "xyz must hold finite numbers .* an integer too large for a float"),
    (["1", "2", "3"], ShapeError, "xyz must be a sequence of 3 numbers, got \\['1'"),
    ([True, False, True], ShapeError, "xyz must be a sequence of 3 numbers, got \\[True"),
    (np.array([True, False, True]), ShapeError, "xyz must be a sequence of 3 numbers"),
])
def test_pose_refuses_text_bools_and_huge_integers(xyz, error, needle):
    with pytest.raises(error, match=needle):
        kinserve.pose(xyz)
    assert kinserve.pose([1, 2, 3], rpy=[0, 0, 1])[:3, 3].tolist() == [1.0, 2.0, 3.0]


@pytest.mark.parametrize("arg", ["panda", None])
def test_clear_caches_refuses_what_is_not_a_robot(arg, planar):
    with pytest.raises(InputError, match="clear_caches: argument 1 must be a kinserve Robot"):
        kinserve.clear_caches(arg)
    kinserve.clear_caches(planar)


def test_attach_refuses_touch_links_that_are_not_names():
    panda = robots.load("panda")
    sphere = {"kind": "sphere", "center": [0, 0, 0], "radius": 0.03}
    with pytest.raises(InputError, match="touch_links must be a link name or a list"):
        panda.attach("ball", sphere, panda.tip, touch_links=5)
    panda.attach("ball", sphere, panda.tip)
    assert "ball" in panda.attached


# ---------------------------------------------------------------- HTTP: request numbers are JSON numbers
Q = [0.3, 0.6, -0.4, 0.2]  # planar4r; P0 is (about) the tool's pose there, P1 a nearby one
P0 = {"position": [2.2851, 1.4675, 0.0], "rpy": [0.0, 0.0, 0.7]}
P1 = {"position": [2.1922, 1.6418, 0.0], "rpy": [0.0, 0.0, 0.8]}
FAR = [50.0, 50.0, 50.0]
SPHERE = {"kind": "sphere", "center": FAR, "radius": 0.1}
BOX = {"kind": "box", "pose": {"position": FAR, "rpy": [0.0, 0.0, 0.0]}, "size": [0.1, 0.1, 0.1]}
CYLINDER = {"kind": "cylinder", "pose": {"position": FAR, "rpy": [0.0, 0.0, 0.0]}, "radius": 0.1,
            "length": 0.1}
BODIES = {
    "/fk": {"robot": "planar4r", "q": Q, "params": {"l1": 1.2}},
    "/ik": {"robot": "planar4r", "target": P0, "q0": Q, "seed": 0, "max_time": 0.2,
            "spheres": [{"center": FAR, "radius": 0.1}], "obstacles": [SPHERE, BOX, CYLINDER]},
    "/ik/batch": {"robot": "planar4r", "targets": [P0, P1], "q0": Q, "seed": 0, "max_time": 0.2},
    "/plan/cartesian": {"robot": "planar4r", "q0": Q, "poses": [P0, P1], "steps": 2, "dt": 0.1,
                        "max_time": 5.0},
    "line": {"robot": "planar4r", "q0": Q, "poses": [P1], "jump_threshold": 0.5, "max_step": 0.05,
             "max_rotation_step": 0.05, "self_collision": False},
    "/plan/motion": {"robot": "planar4r", "start": [0.0, 0.0, 0.0, 0.0], "goal": [0.5, 0.5, 0.5, 0.5],
                     "seed": 1, "max_iterations": 2000, "max_time": 1.0, "goal_count": 2,
                     "acceleration_limits": [2.0, 2.0, 2.0, 2.0],
                     "attached": [{"name": "ball", "shape": {"kind": "sphere", "center": [0.0, 0.0, 0.0],
                                                             "radius": 0.01}, "frame": "tool"}]},
    "/collision": {"robot": "planar4r", "q": Q, "obstacles": [SPHERE, BOX, CYLINDER]},
}
#: (body, path of the field in it, kind, a valid JSON integer for it): every scalar number field of the
#: request models, by route (the shared models once), and a centre (a list of numbers, as q and the poses).
FIELDS = [
    ("/fk", ("params", "l1"), "param", 1),
    ("/ik", ("centring",), "float", 1),
    ("/ik", ("max_time",), "float", 1),
    ("/ik", ("collision_margin",), "float", 0),
    ("/ik", ("tol_pos",), "float", 1),
    ("/ik", ("tol_rot",), "float", 1),
    ("/ik", ("link_radius",), "float", 0),
    ("/ik", ("seed",), "int", 2),
    ("/ik", ("spheres", 0, "radius"), "float", 1),
    ("/ik", ("spheres", 0, "center", 0), "float", 50),
    ("/ik", ("obstacles", 0, "radius"), "float", 1),
    ("/ik", ("obstacles", 1, "size", 0), "float", 1),
    ("/ik", ("obstacles", 2, "radius"), "float", 1),
    ("/ik", ("obstacles", 2, "length"), "float", 1),
    ("/ik/batch", ("max_time",), "float", 1),
    ("/ik/batch", ("seed",), "int", 2),
    ("/plan/cartesian", ("steps",), "int", 2),
    ("/plan/cartesian", ("dt",), "float", 1),
    ("/plan/cartesian", ("max_time",), "float", 5),
    ("line", ("jump_threshold",), "float", 1),
    ("line", ("max_step",), "float", 1),
    ("line", ("max_rotation_step",), "float", 1),
    ("/plan/motion", ("goal_count",), "int", 2),
    ("/plan/motion", ("seed",), "int", 2),
    ("/plan/motion", ("max_iterations",), "int", 2000),
    ("/plan/motion", ("max_time",), "float", 1),
    ("/plan/motion", ("acceleration_limits",), "float", 2),
    ("/plan/motion", ("acceleration_limits", 0), "float", 2),
    ("/plan/motion", ("attached", 0, "shape", "radius"), "float", 1),
    ("/collision", ("obstacles", 0, "radius"), "float", 1),
    ("/ik", ("self_collision",), "bool", False),
    ("/plan/cartesian", ("stop_on_failure",), "bool", True),
    ("line", ("self_collision",), "bool", False),
    ("/plan/motion", ("self_collision",), "bool", True),
    ("/plan/motion", ("simplify",), "bool", False),
    ("/collision", ("self_collision",), "bool", False),
    ("/collision", ("distances",), "bool", True),
]
#: Values pydantic's lax mode would read as numbers (each within the field's bounds once read): text, true,
#: and for an integer field a float, with or without a fraction part. A model parameter may be text (a xacro
#: argument: "0.1" is a string parameter), not true.
BAD = {"float": ["0.1", True], "int": ["2", True, 2.5, 2.0], "param": [True], "bool": ["true", "yes", 1, 0]}
EXPECTED = {"float": "Input should be a valid number", "int": "Input should be a valid integer",
            "param": "Input should be a valid number", "bool": "Input should be a valid boolean"}


@pytest.fixture(scope="module")
def server():
    yield from running(max_time_cap=1.0)


@pytest.fixture(scope="module")
def client(server):
    yield from client_of(server, timeout=60)


def with_value(body: dict, path: tuple, value) -> dict:
    """A copy of ``body`` with ``value`` at ``path`` (keys and indices); the copy shares no list."""
    body = json.loads(json.dumps(body))
    node = body
    for key in path[:-1]:
        node = node[key]
    node[path[-1]] = value
    return body


def post(client, name: str, body: dict):
    route = "/plan/cartesian" if name == "line" else name
    return client.post(route, content=json.dumps(body), headers={"content-type": "application/json"})


def names_the_field(loc: list, path: tuple) -> bool:
    """``loc`` is ``["body", *path]``, with the tags of unions / tagged unions (e.g. ``"sphere"``) between."""
    keys = iter(loc[1:])
    return loc[0] == "body" and all(any(k == key for k in keys) for key in path)


def assert_names_the_field(detail: list, path: tuple) -> None:
    """Every error of ``detail`` is on the field ``path[0]`` and one names the whole ``path`` (the other
    branches of a union, e.g. a number or a list of numbers, may stop higher)."""
    assert detail and all(d["loc"][:2] == ["body", path[0]] for d in detail), detail
    assert any(names_the_field(d["loc"], path) for d in detail), detail


@pytest.mark.parametrize("name, path, kind, value", [
    (name, path, kind, value) for name, path, kind, _ in FIELDS for value in BAD[kind]],
    ids=lambda v: v if isinstance(v, str) else None)
def test_request_numbers_refuse_text_bools_and_fractions(client, name, path, kind, value):
    """Text, true and (for an integer field) 2.5 or 2.0 are a 422 naming the field and saying a number (an
    integer) was expected: pydantic's lax mode would have read each as a number within the field's
    bounds."""
    r = post(client, name, with_value(BODIES[name], path, value))
    assert r.status_code == 422, r.text
    detail = r.json()["detail"]
    assert_names_the_field(detail, path)
    assert any(EXPECTED[kind] in d["msg"] for d in detail), detail


@pytest.mark.parametrize("name, path, kind, value", FIELDS, ids=lambda v: v if isinstance(v, str) else None)
def test_request_numbers_take_json_numbers(client, name, path, kind, value):
    """The neighbouring valid request still works: a JSON integer in a float field is a float."""
    r = post(client, name, with_value(BODIES[name], path, value))
    assert r.status_code == 200, r.text


@pytest.mark.parametrize("dt", [1e-300, 1e-5, 0.0, -0.1])
def test_cartesian_dt_below_its_least_names_dt(client, dt):
    """A dt too short for finite-difference velocities (1e-300 gave a 422 on `poses`: the velocities overflow
    inside the planner) is a 422 on `dt` saying its least value."""
    r = post(client, "/plan/cartesian", with_value(BODIES["/plan/cartesian"], ("dt",), dt))
    assert r.status_code == 422, r.text
    detail = r.json()["detail"]
    assert [d["loc"] for d in detail] == [["body", "dt"]], detail
    assert "greater than or equal to 0.0001" in detail[0]["msg"], detail
    ok = post(client, "/plan/cartesian", with_value(BODIES["/plan/cartesian"], ("dt",), 1e-4))
    assert ok.status_code == 200 and ok.json()["trajectory"]["times"][1] == pytest.approx(1e-4), ok.text


def test_cartesian_dt_whose_last_time_passes_the_bound_names_dt(client):
    """200 poses, 200 steps per segment and dt = 60 s (each within its field's bounds) make 40,000 points, the
    last at 2.4e6 s, beyond the 1e6 s a time may take: a 422 on `dt` giving its largest value for this path,
    before any pose is solved (it was a 422 on `poses` after the solves); that dt is answered."""
    poses = [P0 if k % 2 == 0 else P1 for k in range(200)]
    body = dict(BODIES["/plan/cartesian"], poses=poses, steps=200, dt=60.0, stop_on_failure=False)
    r = post(client, "/plan/cartesian", body)
    assert r.status_code == 422, r.text
    detail = r.json()["detail"]
    assert [d["loc"] for d in detail] == [["body", "dt"]], detail
    assert "dt = 60 s over 40000 points ends at 2.39994e+06 s" in detail[0]["msg"], detail
    assert "dt must be at most 25 s" in detail[0]["msg"], detail
    ok = post(client, "/plan/cartesian", dict(body, poses=poses[:3], steps=2, dt=25.0))
    assert ok.status_code == 200 and ok.json()["trajectory"]["times"][-1] == pytest.approx(150.0), ok.text


# ---------------------------------------------------------------- request models: every number is strict
NUMBER_TYPES = ("float", "int", "decimal", "complex", "bool")


def lax_numbers(node, where: str = "") -> list[str]:
    """Where a pydantic core schema holds a number or a bool that is not strict (lax mode reads "5" and true
    as 5 and 1, and "yes" and 1 as true)."""
    found = []
    if isinstance(node, dict):
        if node.get("type") in NUMBER_TYPES and not node.get("strict"):
            found.append(where)
        for key, value in node.items():
            found += lax_numbers(value, f"{where}/{key}")
    elif isinstance(node, list):
        for i, value in enumerate(node):
            found += lax_numbers(value, f"{where}/{i}")
    return found


def request_models() -> list[type]:
    """Every request model of the service: the subclasses of ``schemas.Strict`` at any depth, and the models
    of the schema modules that refuse unknown fields as requests do."""
    found, todo = [], [schemas.Strict]
    while todo:
        model = todo.pop()
        found.append(model)
        todo += model.__subclasses__()
    found += [m for module in (schemas, motion_schemas, collision_schemas) for m in vars(module).values()
              if isinstance(m, type) and issubclass(m, BaseModel) and m.model_config.get("extra") == "forbid"]
    return list(dict.fromkeys(found))


def test_every_numeric_field_of_every_request_model_is_strict():
    models = {m.__name__: m for m in request_models()}
    assert {"IKRequest", "IKBatchRequest", "CartesianPlanRequest", "MotionPlanRequest", "CollisionRequest",
            "FKRequest", "JacobianRequest"} <= set(models)
    lax = {name: where for name, m in models.items() if (where := lax_numbers(m.__pydantic_core_schema__))}
    assert not lax, lax


def test_every_request_body_is_a_request_model(client):
    """The models walked above are the served ones: every route's body is one of them."""
    bodies = [op["requestBody"]["content"]["application/json"]["schema"]["$ref"].rsplit("/", 1)[1]
              for path in client.get("/openapi.json").json()["paths"].values()
              for op in path.values() if "requestBody" in op]
    assert len(bodies) >= 7 and set(bodies) <= {m.__name__ for m in request_models()}, bodies


def test_the_strictness_check_finds_a_lax_field():
    class Lax(BaseModel):
        fine: Number
        also: integer(0, 3) | None = None
        lax: list[Annotated[float, Field(allow_inf_nan=False, ge=0)]] | None = None
        count: Annotated[int, Field(ge=1)] = 1
        flag: bool = True

    class Strictish(BaseModel):
        x: real(gt=0, le=1)
        n: integer(0, 3)

    assert [w.rsplit("/fields/", 1)[1].split("/")[0] for w in lax_numbers(Lax.__pydantic_core_schema__)] == [
        "lax", "count", "flag"]
    assert lax_numbers(Strictish.__pydantic_core_schema__) == []
