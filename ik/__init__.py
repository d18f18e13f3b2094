"""ik: inverse kinematics - QP-based with task relaxation, joint-limit centring and sphere avoidance.

    from kinserve import ik, robots
    panda = robots.load("panda")
    res = ik.solve(panda, T_target)                               # method "auto"
    res = ik.solve(panda, T, relax=("roll", "pitch", "yaw"))      # position only
    res = ik.solve(scara, T, relax=("z",), centring=1.0,
                   spheres=[ik.Sphere((0.4, -0.7, 0.5), 0.2)])    # S9
    branches = ik.solve_all(youbot, T)                            # every closed-form branch
    results = ik.solve_many(panda, poses)                         # all cores

One concept per module: :mod:`ik.targets` (target, relaxation, task error and
Jacobian rows), :mod:`ik.constraints` (limits, spheres), :mod:`ik.centring`
(secondary objective), :mod:`ik.qp_solver`, :mod:`ik.lm_solver`,
:mod:`ik.classical`, :mod:`ik.analytic`, :mod:`ik.chooser`, :mod:`ik.seeds`
(start configurations), :mod:`ik.qp_backends`, :mod:`ik.solve`,
:mod:`ik.batch` (with :mod:`ik.batch_worker`, :mod:`ik.batch_runners`, :mod:`ik.batch_pool`),
:mod:`ik.options`, :mod:`ik.result`.
"""

from .batch import solve_many
from .chooser import CRITERIA, choose
from .constraints import Sphere
from .qp_backends import available_backends
from .result import History, Result
from .solve import METHODS, solve, solve_all
from .targets import RELAX_NAMES, Target

__all__ = [
    "solve", "solve_all", "solve_many", "Result", "History", "Sphere", "Target", "choose",
    "METHODS", "CRITERIA", "RELAX_NAMES", "available_backends",
]
