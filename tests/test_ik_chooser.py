"""kinserve.ik.closed_form.chooser: named criteria pick the expected branch; the self-overlap filter detects
crossing links."""

import math

import numpy as np
import pytest

from kinserve import ik, robots
from kinserve.ik.closed_form.chooser import choose, joint_limit_distance, scores, self_overlap
from kinserve.kinematics.errors import InputError


@pytest.fixture(scope="module")
def arm():
    return robots.load("planar4r", geometry=False)


def test_joint_limit_distance_values(arm):
    assert joint_limit_distance(arm, arm.middle()) == pytest.approx(0.5)
    q = arm.middle().copy()
    q[2] = arm.upper[2]
    assert joint_limit_distance(arm, q) == pytest.approx(0.0)


def test_criteria_pick_the_expected_candidate(arm):
    a = np.array([0.1, 0.2, 0.3, 0.4])
    b = np.array([3.0, 0.2, 0.3, 0.4])  # q1 close to its limit (pi)
    c = np.array([0.1, 0.0, 0.0, 0.0])  # stretched: singular for (x, y, yaw)
    cands = [a, b, c]
    assert choose(arm, cands, "joint_limit_distance") == 2  # all joints near the middle
    assert choose(arm, cands, "displacement", q_current=b + 0.01) == 1
    assert choose(arm, cands, "manipulability") == 0
    m = scores(arm, cands, "manipulability")
    assert m[2] == pytest.approx(0.0, abs=1e-12)  # stretched arm: rank-deficient task Jacobian
    with pytest.raises(InputError, match="q_current"):
        choose(arm, cands, "displacement")
    with pytest.raises(InputError, match="unknown criterion"):
        choose(arm, cands, "beauty")
    assert choose(arm, [], "manipulability") is None


def test_self_overlap_filter(arm):
    straight = np.zeros(4)
    folded = np.array([0.0, math.pi * 0.9, math.pi * 0.9, 0.0])  # link 3 crosses back over link 1
    assert not self_overlap(arm, straight)
    assert self_overlap(arm, folded)
    assert choose(arm, [folded, straight], ("no_self_overlap", "joint_limit_distance")) == 1
    assert choose(arm, [folded], ("no_self_overlap",)) is None


def test_solve_with_choose_on_the_4r_family(arm):
    T = arm.fk(np.array([0.4, 0.5, -0.3, 0.6])).copy()
    fam = ik.solve_all(arm, T)
    q_now = fam[3].q + 0.01
    res = ik.solve(arm, T, q_now, method="analytic")  # default criterion with q0: displacement
    assert np.allclose(res.q, fam[3].q, atol=1e-9)
    res = ik.solve(arm, T, method="analytic", choose=("no_self_overlap", "manipulability"))
    best = max(arm.manipulability(r.q) for r in fam if not self_overlap(arm, r.q))
    assert arm.manipulability(res.q) == pytest.approx(best, rel=1e-9)  # mirror branches tie
    assert not self_overlap(arm, res.q)
    assert res.success and res.info["branches"] == len(fam)
