"""The one chain encoding (:func:`kinserve.kinematics.serial_chain.joint_table`): the tree, every frame's
serial chain and the batch FK derive from it.

* the tree's rows are Pinocchio's joints (placement, axis, kind, q index, parent) read independently here;
* every frame's serial chain is the tree's rows on the frame's path (walked here through ``model.parents``),
  plus the frame's placement, for serial and branched robots (baxter);
* :class:`ChainFK` built from a table agrees with Pinocchio's frame placement;
* a joint the kernels do not model is marked OTHER: the tree is refused, a chain avoiding it is not.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from kinserve import robots
from kinserve.kinematics.batch_fk import ChainFK
from kinserve.kinematics.errors import ModelError
from kinserve.kinematics.serial_chain import (
    OTHER,
    PRISMATIC,
    REVOLUTE,
    joint_table,
    kinematic_tree,
    serial_chain,
)

NAMES = ["panda", "ur5", "scara", "baxter", "finger_edu"]


@pytest.mark.parametrize("name", NAMES)
def test_tree_rows_are_the_models_joints(name):
    model = robots.load(name, geometry=False).model
    geometry, joints = kinematic_tree(model)
    data = model.createData()
    pin.computeJointJacobians(model, data, pin.neutral(model))
    assert geometry.shape == (model.njoints - 1, 15) and joints.shape == (model.njoints - 1, 3)
    for j in range(1, model.njoints):
        M = model.jointPlacements[j]
        assert np.array_equal(geometry[j - 1, :9].reshape(3, 3), M.rotation)
        assert np.array_equal(geometry[j - 1, 9:12], M.translation)
        # the axis: the joint's motion subspace, its own column of the joint Jacobian in the joint frame
        S = pin.getJointJacobian(model, data, j, pin.LOCAL)[:, model.joints[j].idx_v]
        kind, iq, parent = joints[j - 1]
        assert iq == model.joints[j].idx_q and parent == model.parents[j]
        assert kind in (REVOLUTE, PRISMATIC)
        want = S[3:] if kind == REVOLUTE else S[:3]
        other = S[:3] if kind == REVOLUTE else S[3:]
        assert np.allclose(geometry[j - 1, 12:], want, atol=1e-15) and not other.any()


@pytest.mark.parametrize("name", NAMES)
def test_every_serial_chain_is_the_trees_rows_on_the_path(name):
    model = robots.load(name, geometry=False).model
    table = joint_table(model)
    tree_g, tree_j = table.tree()
    branched = len(set(model.parents[1:])) < model.njoints - 1
    assert branched == (name == "baxter")
    for fid, frame in enumerate(model.frames):
        path, j = [], frame.parentJoint
        while j > 0:
            path.append(j)
            j = model.parents[j]
        rows = [p - 1 for p in reversed(path)]
        assert table.path_to(fid) == rows
        # each row's parent column names the previous row's joint
        assert [int(tree_j[r, 2]) for r in rows] == ([0] + [r + 1 for r in rows])[:len(rows)]
        geometry, joints = serial_chain(model, fid)
        assert np.array_equal(geometry[:-1], tree_g[rows]) and np.array_equal(joints, tree_j[rows, :2])
        assert np.array_equal(geometry[-1, :9].reshape(3, 3), frame.placement.rotation)
        assert np.array_equal(geometry[-1, 9:12], frame.placement.translation)
        assert not geometry[-1, 12:].any()
        assert joints.dtype == np.int64 and joints.flags.c_contiguous


@pytest.mark.parametrize("name", ["baxter", "scara"])
def test_chain_fk_from_a_table_matches_pinocchio(name):
    model = robots.load(name, geometry=False).model
    table = joint_table(model)
    data = model.createData()
    Q = np.random.default_rng(3).uniform(-1.5, 1.5, (7, model.nq))
    for fid in range(0, model.nframes, 5):
        T = ChainFK(model, fid, table)(Q)
        assert np.array_equal(T, ChainFK(model, fid)(Q))
        for s in range(len(Q)):
            pin.framesForwardKinematics(model, data, Q[s])
            assert np.allclose(T[s], data.oMf[fid].homogeneous, atol=1e-12)


def test_a_joint_the_kernels_do_not_model_is_other():
    model = pin.Model()
    a = model.addJoint(0, pin.JointModelRZ(), pin.SE3.Identity(), "a")
    b = model.addJoint(a, pin.JointModelTranslation(), pin.SE3(np.eye(3), np.array([0.0, 0.3, 0.0])), "b")
    fa, fb = model.addJointFrame(a), model.addJointFrame(b)
    table = joint_table(model)
    assert table.joints[:, 0].tolist() == [REVOLUTE, OTHER] and table.joints[1, 2] == a
    assert table.tree() is None and kinematic_tree(model) is None
    assert serial_chain(model, fb) is None and serial_chain(model, fa) is not None
    with pytest.raises(ModelError, match="Translation"):
        ChainFK(model, fb)
    q = np.array([[0.4, 0.2, -0.1, 0.3]])
    data = model.createData()
    pin.framesForwardKinematics(model, data, q[0])
    assert np.allclose(ChainFK(model, fa)(q)[0], data.oMf[fa].homogeneous, atol=1e-14)
