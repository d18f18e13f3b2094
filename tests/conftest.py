"""Shared fixtures: models built straight from Pinocchio so kinematics tests do not depend on robots/."""

import os
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]

os.environ.setdefault("MPLBACKEND", "Agg")
# computed collision pairs are cached on disk: keep the tests' cache out of the user's ~/.cache
if "KINSERVE_CACHE_DIR" not in os.environ:
    import atexit
    import shutil
    import tempfile

    os.environ["KINSERVE_CACHE_DIR"] = tempfile.mkdtemp(prefix="kinserve-test-cache-")
    atexit.register(shutil.rmtree, os.environ["KINSERVE_CACHE_DIR"], True)


def erd_share_dir() -> Path:
    """The `share` dir of example-robot-data inside this interpreter's site-packages."""
    for entry in sys.path:
        cand = Path(entry) / "cmeel.prefix" / "share"
        if (cand / "example-robot-data" / "robots").is_dir():
            return cand
    pytest.skip("example-robot-data not installed")


@pytest.fixture(scope="session")
def panda_model():
    import pinocchio as pin

    share = erd_share_dir()
    path = share / "example-robot-data/robots/panda_description/urdf/panda.urdf"
    model = pin.buildModelFromUrdf(str(path))
    lock = [model.getJointId("panda_finger_joint1"), model.getJointId("panda_finger_joint2")]
    return pin.buildReducedModel(model, lock, pin.neutral(model))


@pytest.fixture
def panda(panda_model):
    from kinserve.kinematics import Robot

    return Robot(panda_model, tip="panda_link8", name="panda")


@pytest.fixture
def rng():
    return np.random.default_rng(12345)

