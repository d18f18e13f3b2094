"""MoveIt-style disabled-pair computation: adjacency, determinism with the stated seed, the on-disk cache,
SRDF parsing."""

import io
import json
import sys

import numpy as np
import pinocchio as pin
import pytest

from kinserve import robots
from kinserve.kinematics import build_progress, collision_cache, collision_pairs, errors
from kinserve.kinematics.collision_model import CollisionModel
from kinserve.robots import paths


@pytest.fixture
def cache(tmp_path, monkeypatch):
    monkeypatch.setenv(collision_cache.CACHE_ENV, str(tmp_path / "cache"))
    return tmp_path / "cache"


def _fresh(robot, **kw):
    return CollisionModel(robot.model, robot.collision_model, robot.lower, robot.upper, name=robot.name, **kw)


def test_adjacent_links_are_disabled_and_never_checked(cache):
    robot = robots.load("youbot")
    cm = _fresh(robot, model_text=robot.source)
    assert cm.pair_source == "computed"
    # every pair of links whose bodies are joined by one joint (or are one body) is disabled as adjacent
    parents = list(robot.model.parents)
    objs = cm.geometry.geometryObjects
    for i, a in enumerate(objs):
        for j, b in enumerate(objs[i + 1:], i + 1):
            adjacent = a.parentJoint == b.parentJoint or parents[a.parentJoint] == b.parentJoint \
                or parents[b.parentJoint] == a.parentJoint
            if adjacent:
                assert cm.disabled[collision_pairs.link_pair(cm.links[i], cm.links[j])] == "Adjacent"
                assert (i, j) not in cm.self_pairs
    assert set(cm.disabled.values()) <= {"Adjacent", "Default", "Always", "Never"}


def test_never_and_always_pairs_follow_the_samples(cache):
    robot = robots.load("planar4r")
    cm = _fresh(robot, model_text=robot.source)
    # link1/link3 and link1/link4 collide when the arm folds back: they stay checked
    assert ("link1", "link3") not in cm.disabled and ("link1", "link4") not in cm.disabled
    # a sample set that never folds the arm marks them "Never"
    narrow = collision_pairs.compute_disabled_pairs(robot.model, robot.collision_model, -0.1 * np.ones(4),
                                                    0.1 * np.ones(4), samples=200)
    assert narrow[("link1", "link3")] == "Never"
    # always-colliding pairs: joint limits that keep link3 folded onto link1
    folded = collision_pairs.compute_disabled_pairs(robot.model, robot.collision_model,
                                                    np.array([0.0, 3.0, 3.0, 0.0]) - 0.01,
                                                    np.array([0.0, 3.0, 3.0, 0.0]) + 0.01, samples=100)
    assert folded[("link1", "link3")] in ("Default", "Always")


def test_computation_is_deterministic_with_the_stated_seed():
    robot = robots.load("panda", geometry=True)
    args = (robot.model, robot.collision_model, robot.lower, robot.upper)
    a = collision_pairs.compute_disabled_pairs(*args, samples=300, seed=collision_pairs.SEED)
    b = collision_pairs.compute_disabled_pairs(*args, samples=300, seed=collision_pairs.SEED)
    assert a == b
    # the SRDF's adjacent pairs are among the computed ones (fixed-joint links merged into one body)
    srdf = (paths.example_robot_data_dir() / "panda_description/srdf/panda.srdf").read_text()
    from_srdf = collision_pairs.srdf_disabled_pairs(srdf, [f.name for f in robot.model.frames])
    for pair, reason in from_srdf.items():
        if reason == "Adjacent" and "finger" not in pair[0] + pair[1]:
            assert a[pair] == "Adjacent"


def test_cache_hit_and_bad_cache_file(cache):
    robot = robots.load("youbot")
    first = _fresh(robot, model_text=robot.source)
    files = list(cache.glob("collision-pairs-*.json"))
    assert first.pair_source == "computed" and len(files) == 1
    second = _fresh(robot, model_text=robot.source)
    assert second.pair_source == "cache" and second.disabled == first.disabled
    assert second.self_pairs == first.self_pairs
    # another model text -> another key; a corrupt file is recomputed, not an error
    assert collision_cache.cache_key(robot.source
                                     + " ", 1, 0, 1) != collision_cache.cache_key(robot.source, 1, 0, 1)
    files[0].write_text("{not json")
    third = _fresh(robot, model_text=robot.source)
    assert third.pair_source == "computed" and third.disabled == first.disabled
    assert json.loads(files[0].read_text())["disabled"]


def test_srdf_parsing_errors_are_named():
    links = ["a", "b", "c"]
    assert collision_pairs.srdf_disabled_pairs(
        '<robot name="r"><disable_collisions link1="b" link2="a" '
        'reason="Never"/></robot>', links) == {("a", "b"): "Never"}
    with pytest.raises(errors.ModelError, match="line 1.*'d'"):
        collision_pairs.srdf_disabled_pairs('<robot name="r"><disable_collisions link1="a" '
                                            'link2="d"/></robot>', links)
    with pytest.raises(errors.ModelError, match="needs link1= and link2="):
        collision_pairs.srdf_disabled_pairs('<robot name="r"><disable_collisions link1="a"/></robot>', links)
    with pytest.raises(errors.ModelError, match="malformed XML"):
        collision_pairs.srdf_disabled_pairs('<robot name="r"><disable_collisions', links)


def test_loader_finds_the_srdf_by_convention():
    erd = paths.example_robot_data_dir()
    from kinserve.robots.srdf import find_srdf

    assert find_srdf(erd / "panda_description/urdf/panda.urdf") == erd / "panda_description/srdf/panda.srdf"
    assert find_srdf(erd / "ur_description/urdf/ur5_robot.urdf") == erd / "ur_description/srdf/ur5.srdf"
    assert robots.load("panda").srdf is not None and robots.load("planar4r").srdf is None
    assert isinstance(robots.load("planar4r").collision.geometry, pin.GeometryModel)


class Terminal(io.StringIO):
    """A stderr that says it is a terminal."""

    def isatty(self) -> bool:
        return True


@pytest.mark.parametrize("delay, terminal, shown",
                         [(0.0, True, True), (0.0, False, False), (1e9, True, False)])
def test_build_progress_only_on_a_terminal_and_after_the_delay(cache, monkeypatch, delay, terminal, shown):
    robot = robots.load("youbot")
    monkeypatch.setattr(build_progress, "DELAY", delay)
    stream = Terminal() if terminal else io.StringIO()
    monkeypatch.setattr(sys, "stderr", stream)
    cm = _fresh(robot, model_text=robot.source)
    assert cm.pair_source == "computed"
    text = stream.getvalue()
    if shown:
        total = len(cm.geometry_names) + collision_pairs.SAMPLES  # one step per geometry and per sample
        assert "collision model of 'youbot'" in text and f"/{total}" in text
    else:
        assert text == ""
