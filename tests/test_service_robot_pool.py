"""service.robot_pool: a bounded LRU of robot variants with per-thread copies; built-in names only (any
case), parameters never taken for options."""

from __future__ import annotations

import threading

import numpy as np
import pytest

from kinserve import robots
from kinserve.ik.state import seed_table
from kinserve.kinematics.errors import ModelError, UnknownRobotError
from kinserve.robots.paths import models_dir
from kinserve.service.robot_pool import RobotPool


def rss_mb() -> float:
    with open("/proc/self/status") as status:
        for line in status:
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024
    raise RuntimeError("no VmRSS")


def test_variants_match_the_registry_and_threads_get_their_own_copy():
    pool = RobotPool(max_entries=4)
    a = pool.get("planar4r", {"l1": 1.3})
    ref = robots.load("planar4r", l1=1.3, geometry=False)
    q = ref.random_q(0)
    assert np.allclose(a.fk(q), ref.fk(q), atol=1e-14)
    assert pool.get("planar4r", {"l1": 1.3}) is a  # same thread: same copy
    other = []
    t = threading.Thread(target=lambda: other.append(pool.get("planar4r", {"l1": 1.3})))
    t.start()
    t.join()
    assert other[0] is not a and other[0].data is not a.data and other[0].model is a.model
    assert a.model is not ref.model  # a private model: its seed tables die with the pool entry


def test_lru_by_count_keeps_the_recently_used():
    pool = RobotPool(max_entries=3)
    for l1 in (1.0, 1.1, 1.2):
        pool.get("planar4r", {"l1": l1})
    pool.get("planar4r", {"l1": 1.0})  # touch: now the most recent
    pool.get("planar4r", {"l1": 1.3})  # evicts 1.1, the least recently used
    assert len(pool) == 3
    assert pool.cached("planar4r", {"l1": 1.0}) is not None
    assert pool.cached("planar4r", {"l1": 1.1}) is None
    assert pool.evictions == 1


def test_lru_by_bytes_counts_seed_tables():
    pool = RobotPool(max_entries=100, max_bytes=2 << 20)
    r = pool.get("planar4r", {"l1": 1.0})
    before = pool.nbytes()
    table = seed_table(r, r.tip)
    assert pool.nbytes() - before == table.nbytes > 300_000  # the estimate includes the table
    for i in range(1, 8):
        r = pool.get("planar4r", {"l1": 1.0 + 0.1 * i})
        seed_table(r, r.tip)
    pool.get("planar4r", {"l1": 9.0})  # a miss re-checks the byte bound
    assert pool.nbytes() <= 2 << 20 + table.nbytes  # at most one table grown since the last check
    assert len(pool) < 8


def test_unknown_robot_and_bad_params_raise_library_errors():
    pool = RobotPool()
    with pytest.raises(UnknownRobotError, match="pandaa.*panda"):
        pool.get("pandaa")
    with pytest.raises(Exception, match="l1"):
        pool.get("planar4r", {"l1": "1e308"})
    assert len(pool) == 0


def test_distinct_params_leave_the_rss_bounded():
    """The issue's leak: variants of a parametric robot, each with its IK seed table (the issue used 1,000;
    a pool of 16 and 140 variants keep the bound as sharp in a third of the time: unbounded, the 100 variants
    after the first 40 would hold ~63 MB).

    The planar PR robot (two joints, a xacro model like planar4r's) keeps the test fast.
    """
    pool = RobotPool(max_entries=16)

    def use(i):
        r = pool.get("pr", {"d2": 1.0 + 1e-4 * i})
        seed_table(r, r.tip)  # what /ik builds on first use (~0.4 MB)

    for i in range(40):  # the pool full and evicting: its steady state
        use(i)
    rss40 = rss_mb()
    for i in range(40, 140):
        use(i)
    growth = rss_mb() - rss40
    assert len(pool) == 16 and pool.evictions == 140 - 16
    assert pool.nbytes() < 16 << 20
    # unbounded, the 100 further variants would hold ~63 MB (measured: 0.63 MB each)
    assert growth < 20, f"RSS grew {growth:.0f} MB over 100 further variants"


def test_names_ignore_case_and_share_one_model():
    pool = RobotPool()
    a, b = pool.get("PANDA"), pool.get("panda")
    assert a is b and a.name == "panda" and a.visual_model is None


@pytest.mark.parametrize("name", ["/etc/passwd", str(models_dir() / "planar4r.urdf.xacro"),
                                  "../robots/models/pr.urdf.xacro",
                                  '<robot name="x"><link name="a"/></robot>'])
def test_paths_and_xml_from_the_network_are_unknown_robots(name):
    with pytest.raises(UnknownRobotError, match="Known robots: planar4r") as err:
        RobotPool().get(name)
    assert "path" not in str(err.value)  # no hint the service would read files


@pytest.mark.parametrize("params", [{"geometry": True}, {"package_dirs": "/"}, {"allow_outside": True},
                                    {"srdf": "/etc/passwd"}])
def test_request_parameters_are_model_parameters_never_loader_options(params):
    with pytest.raises(ModelError, match="unknown parameter"):
        RobotPool().get("panda", params)
    with pytest.raises(ModelError, match="unknown xacro arg"):
        RobotPool().get("planar4r", params)
