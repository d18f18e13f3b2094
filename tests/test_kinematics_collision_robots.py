"""Every URDF that example-robot-data ships: it loads (or the loader refuses it with a ModelError: skipped,
named), its collision model is built from nothing (computed pairs in a fresh cache directory) or refused with
a ModelError that names what is missing, and ``in_collision`` answers a bool on random configurations.

centauro's pelvis mesh is the case coal's qhull cannot hold ("Too many neighbors": a 564-triangle fan):
its hull comes from scipy's qhull and the model says so in ``hull_fallbacks``.
"""

from pathlib import Path

import numpy as np
import pytest

from kinserve import robots
from kinserve.kinematics import collision_cache, errors
from kinserve.robots.paths import example_robot_data_package_dir


def _share() -> Path | None:
    try:
        return example_robot_data_package_dir()
    except errors.ModelError:
        return None


def _urdfs() -> list[str]:
    share = _share()
    if share is None:
        return []
    root = share / "example-robot-data" / "robots"
    return sorted(p.relative_to(root).as_posix() for p in root.rglob("*.urdf"))


URDFS = _urdfs()


@pytest.fixture
def fresh_cache(tmp_path, monkeypatch) -> Path:
    """A cache directory of this test's own: every computed pair set is computed here, none read; the
    registry's models are dropped afterwards (64 robots with their collision models would stay loaded)."""
    monkeypatch.setenv(collision_cache.CACHE_ENV, str(tmp_path / "cache"))
    yield tmp_path / "cache"
    robots.clear_cache()


def _load(relative: str):
    """The robot of an ERD file, kinematics only (the collision model then reads only the collision meshes);
    a ModelError of the loader skips the test, naming it (the loader's own test covers those files)."""
    share = _share()
    if share is None:
        pytest.skip("example-robot-data is not installed")
    try:
        path = share / "example-robot-data" / "robots" / relative
        return robots.load(path, package_dirs=[share], geometry=False)
    except errors.ModelError as exc:
        pytest.skip(f"the loader refuses {relative}: {exc}")


def test_every_shipped_urdf_is_walked():
    if _share() is None:
        pytest.skip("example-robot-data is not installed")
    assert len(URDFS) == 69  # a broken glob must not pass silently


@pytest.mark.filterwarnings("ignore::kinserve.robots.srdf.SrdfWarning")
@pytest.mark.filterwarnings("ignore::kinserve.robots.mesh_resolver.MissingMeshWarning")
@pytest.mark.parametrize("relative", URDFS)
def test_collision_model_is_built_or_refused_by_name(relative, fresh_cache):
    robot = _load(relative)
    try:
        cmodel = robot.collision
    except errors.ModelError as exc:  # refused: the message says what is missing
        message = str(exc)
        assert "no <collision> elements" in message or "mesh file" in message, message
        return
    assert cmodel.pair_source in ("srdf", "computed")  # never a cache hit: this test's cache starts empty
    if cmodel.pair_source == "computed":
        assert list(fresh_cache.glob("collision-pairs-*.json"))  # and the computed pairs are stored
    for fallback in cmodel.hull_fallbacks:
        assert fallback.geometry in cmodel.geometry_names and fallback.mesh_file and fallback.cause
    rng = np.random.default_rng(7)
    answers = [robot.in_collision(q) for q in robot.random_q(rng, 3)]
    assert all(type(a) is bool for a in answers)
    assert type(robot.in_collision(robot.neutral())) is bool


@pytest.mark.filterwarnings("ignore::kinserve.robots.srdf.SrdfWarning")
def test_centauro_pelvis_hull_comes_from_scipy(fresh_cache):
    robot = _load("centauro_description/urdf/centauro.urdf")
    cmodel = robot.collision
    names = {f.geometry: f for f in cmodel.hull_fallbacks}
    assert "pelvis_0" in names, cmodel.hull_fallbacks
    fallback = names["pelvis_0"]
    assert fallback.mesh_file.endswith("pelvis_reduced.stl") and fallback.link == "pelvis"
    assert "Too many neighbors" in fallback.cause
    # the hull holds the mesh: volume(hull) >= volume(mesh), and this mesh is nearly convex
    assert 1.0 - 1e-9 <= cmodel.hull_volume_ratio["pelvis_0"] < 1.01
    assert type(robot.in_collision(robot.random_q(3))) is bool
