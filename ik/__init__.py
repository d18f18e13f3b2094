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
bound to a robot), :mod:`ik.qp.hierarchy` (one prioritised step),
:mod:`ik.qp.dense_qp`, :mod:`ik.qp.task_solver` (iterations, back-off, restarts),
:mod:`ik.starts.multistart`, :mod:`ik.step`, :mod:`ik.targets`, :mod:`ik.tasks.centring_weights`,
:mod:`ik.qp.target_solver`, :mod:`ik.lm.solver`, :mod:`ik.classical.methods`,
:mod:`ik.closed_form`, :mod:`ik.closed_form.chooser`, :mod:`ik.starts.seed_table`, :mod:`ik.qp.backends`,
:mod:`ik.solve`, :mod:`ik.options`, :mod:`ik.result`, :mod:`ik.batch.solve_many` (with
:mod:`ik.batch.worker`, :mod:`ik.batch.runners`, :mod:`ik.batch.pool`).
"""

from kinserve.ik.batch.solve_many import solve_many
from kinserve.ik.closed_form.chooser import CRITERIA, choose
from kinserve.ik.constraints import CollisionConstraint, Constraint, SceneCollision, SelfCollision
from kinserve.ik.constraints.joint_limits import JointLimits
from kinserve.ik.constraints.obstacles import ObstacleAvoidance
from kinserve.ik.constraints.velocity_limits import VelocityLimits
from kinserve.ik.options import METHODS
from kinserve.ik.qp.backends import available_backends
from kinserve.ik.result import History, Result
from kinserve.ik.solve import solve, solve_all
from kinserve.ik.state import warm
from kinserve.ik.step import step
from kinserve.ik.targets import RELAX_NAMES, Target
from kinserve.ik.tasks import Task
from kinserve.ik.tasks.centring_task import CentringTask
from kinserve.ik.tasks.frame_task import FrameTask
from kinserve.ik.tasks.posture_task import PostureTask
from kinserve.kinematics.shapes import Box, Capsule, Cylinder, Mesh, Sphere

__all__ = [
    "solve", "solve_all", "solve_many", "step", "warm", "Result", "History",
    "Task", "FrameTask", "PostureTask", "CentringTask",
    "Constraint", "JointLimits", "VelocityLimits", "ObstacleAvoidance",
    "SelfCollision", "SceneCollision", "CollisionConstraint",
    "Sphere", "Box", "Capsule", "Cylinder", "Mesh",
    "Target", "choose", "METHODS", "CRITERIA", "RELAX_NAMES", "available_backends",
]
