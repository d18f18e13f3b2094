"""Reachability maps: sampled targets, per-cell statistics, saved arrays."""

import numpy as np
import pytest

from kinserve import robots
from kinserve.ik.batch.reachability import reachability_map, workspace_box
from kinserve.kinematics import InputError, RotationError


def test_planar_arm_reachability_matches_the_annulus():
    """Planar 4R (links 1.0/0.8/0.6/0.4, joints +-pi), position only: reachable iff |p| <= 2.8 m."""
    arm = robots.load("planar4r", geometry=False)
    rmap = reachability_map(arm, 300, resolution=6, backend="serial", seed=1, max_time=0.05)
    assert rmap.positions.shape == (300, 3) and rmap.reached.shape == (300,)
    # a planar arm cannot leave its plane: every sample sits at the arm's constant z
    assert np.ptp(rmap.positions[:, 2]) == 0.0
    r = np.linalg.norm(rmap.positions[:, :2], axis=1)
    reach = 1.0 + 0.8 + 0.6 + 0.4
    # position-only with joint limits of +-pi: everything inside the disc of radius `reach` is reachable
    assert np.all(rmap.reached[r < reach - 1e-3])
    assert not np.any(rmap.reached[r > reach + 1e-6])
    assert rmap.counts.sum() == 300 and rmap.hits.sum() == rmap.reached.sum()
    assert rmap.counts.shape == (6, 6, 1)
    f = rmap.fraction
    assert np.all((f[rmap.counts > 0] >= 0) & (f[rmap.counts > 0] <= 1))
    assert np.isnan(f[rmap.counts == 0]).all()


def test_save_round_trip(tmp_path):
    arm = robots.load("scara", geometry=False)
    rmap = reachability_map(arm, 60, resolution=3, backend="serial", orientation=np.diag([1.0, -1.0, -1.0]))
    path = rmap.save(tmp_path / "scara.npz")
    data = np.load(path)
    assert np.array_equal(data["reached"], rmap.reached) and np.array_equal(data["counts"], rmap.counts)
    assert str(data["orientation"]) == "fixed"


def test_workspace_box_contains_fk_samples():
    panda = robots.load("panda", geometry=False)
    box = workspace_box(panda, n=2000)
    P = panda.fk_batch(panda.random_q(99, n=500))[:, :3, 3]
    assert np.all(P >= box[0]) and np.all(P <= box[1])


def test_bad_arguments():
    arm = robots.load("planar4r", geometry=False)
    with pytest.raises(InputError, match="samples"):
        reachability_map(arm, 0)
    with pytest.raises(InputError, match="resolution"):
        reachability_map(arm, 10, resolution=0)
    with pytest.raises(InputError, match="orientation"):
        reachability_map(arm, 10, orientation="sideways")
    with pytest.raises(RotationError):
        reachability_map(arm, 10, orientation=np.ones((3, 3)))
