"""ik: inverse kinematics - an open model of tasks and constraints, QP-based with strict priorities.

    from kinserve import ik, robots
    panda = robots.load("panda")
    res = ik.solve(panda, T_target)                               # method "auto"
    res = ik.solve(panda, T, relax=("roll", "pitch", "yaw"))      # position only
    res = ik.solve(panda, T, obstacles=[ik.Box(T_box, (0.1, 0.2, 0.3))], link_radius=0.04)
    res = ik.solve(scara, T, relax=("z",), centring=1.0,
                   spheres=[ik.Sphere((0.4, -0.7, 0.5), 0.2)])    # S9
    res = ik.solve(baxter, tasks=[ik.FrameTask("left_gripper", T_left),
                                  ik.FrameTask("right_gripper", T_right),
                                  ik.PostureTask(q_rest, priority=2)],
                   constraints=[ik.Sphere((0.7, 0.0, 0.3), 0.1)])
    v = ik.step(panda, tasks, constraints, q, dt=0.01)            # one control-loop velocity
    branches = ik.solve_all(youbot, T)                            # every closed-form branch
    results = ik.solve_many(panda, poses)                         # all cores

One concept per module: :mod:`ik.tasks` (the :class:`Task` protocol,
:class:`FrameTask`, :class:`PostureTask`, :class:`CentringTask`),
:mod:`ik.constraints` (the :class:`Constraint` protocol, :class:`JointLimits`,
:class:`VelocityLimits`, :class:`ObstacleAvoidance` against any shape of
:mod:`kinserve.kinematics.shapes`), :mod:`ik.problem` (tasks and constraints
bound to a robot), :mod:`ik.hierarchy` (one prioritised step),
:mod:`ik.dense_qp`, :mod:`ik.task_solver` (iterations, back-off, restarts),
:mod:`ik.multistart`, :mod:`ik.step`, :mod:`ik.targets`, :mod:`ik.centring`,
:mod:`ik.qp_solver`, :mod:`ik.lm_solver`, :mod:`ik.classical`,
:mod:`ik.analytic`, :mod:`ik.chooser`, :mod:`ik.seeds`, :mod:`ik.qp_backends`,
:mod:`ik.solve`, :mod:`ik.options`, :mod:`ik.result`, :mod:`ik.batch` (with
:mod:`ik.batch_worker`, :mod:`ik.batch_runners`, :mod:`ik.batch_pool`).
"""

from kinserve.kinematics.shapes import Box, Capsule, Cylinder, Mesh, Sphere

from .batch import solve_many
from .chooser import CRITERIA, choose
from .constraints import CollisionConstraint, Constraint, SceneCollision, SelfCollision
from .constraints.joint_limits import JointLimits
from .constraints.obstacles import ObstacleAvoidance
from .constraints.velocity_limits import VelocityLimits
from .qp_backends import available_backends
from .result import History, Result
from .solve import METHODS, solve, solve_all
from .step import step
from .targets import RELAX_NAMES, Target
from .tasks import Task
from .tasks.centring_task import CentringTask
from .tasks.frame_task import FrameTask
from .tasks.posture_task import PostureTask

__all__ = [
    "solve", "solve_all", "solve_many", "step", "Result", "History",
    "Task", "FrameTask", "PostureTask", "CentringTask",
    "Constraint", "JointLimits", "VelocityLimits", "ObstacleAvoidance",
    "SelfCollision", "SceneCollision", "CollisionConstraint",
    "Sphere", "Box", "Capsule", "Cylinder", "Mesh",
    "Target", "choose", "METHODS", "CRITERIA", "RELAX_NAMES", "available_backends",
]
