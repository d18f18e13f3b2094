"""planners: time scaling, via-point and SE(3) trajectories, checkpoint ordering, joint trajectories,
resolved-rate control, joint-space motion planning (``planners.motion``) and mobile-base planning
(``planners.mobile``).

Imports ``kinematics`` (and may import ``ik``); never ``scenarios``, ``service`` or ``viz``.
"""

from . import mobile
from .cartesian import CartesianPlan, cartesian_to_joint
from .cartesian_move import CartesianMove, plan_cartesian
from .checkpoint_order import OrderResult, euclidean_cost_matrix, held_karp, path_cost, shortest_order
from .errors import BlockedPointError, NoPathError, PlanningError
from .joint_trajectory import JointTrajectory, finite_difference_velocities
from .motion import (
    MotionPlan,
    MotionProblem,
    MotionRequest,
    plan_many,
    plan_motion,
    read_motion_request,
    read_planning_scene,
    write_planning_scene,
)
from .polynomials import cubic_coefficients, quintic_coefficients
from .resolved_rate import (
    ResolvedRateResult,
    SingularityEvent,
    damped_pseudo_inverse,
    follow_circle,
    resolved_rate,
    task_coordinates,
    track_reference,
)
from .se3_interpolation import (
    SE3PolynomialTrajectory,
    decoupled_interpolation,
    intermediate_poses,
    interpolate,
    interpolate_checkpoints,
    poses_along,
    screw_interpolation,
    se3_polynomial_trajectory,
)
from .time_scaling import (
    PolynomialTimeScaling,
    TimeScaling,
    TrapezoidalTimeScaling,
    cubic_time_scaling,
    minimum_time,
    quintic_time_scaling,
    time_scaling,
    trapezoidal_time_scaling,
)
from .via_points import ViaPointTrajectory, via_point_trajectory

__all__ = [
    "mobile",
    # time scaling
    "TimeScaling", "PolynomialTimeScaling", "TrapezoidalTimeScaling", "cubic_time_scaling",
    "quintic_time_scaling", "trapezoidal_time_scaling", "minimum_time", "time_scaling", "cubic_coefficients",
    "quintic_coefficients",
    # trajectories
    "ViaPointTrajectory", "via_point_trajectory", "JointTrajectory", "finite_difference_velocities",
    # SE(3)
    "decoupled_interpolation", "screw_interpolation", "interpolate", "intermediate_poses",
    "interpolate_checkpoints", "se3_polynomial_trajectory", "SE3PolynomialTrajectory", "poses_along",
    # ordering
    "shortest_order", "OrderResult", "held_karp", "path_cost", "euclidean_cost_matrix",
    # Cartesian path -> joint trajectory
    "cartesian_to_joint", "CartesianPlan", "plan_cartesian", "CartesianMove",
    # motion planning in joint space
    "plan_motion", "MotionPlan", "plan_many", "MotionProblem", "read_planning_scene", "write_planning_scene",
    "read_motion_request", "MotionRequest",
    # resolved rate
    "resolved_rate", "track_reference", "follow_circle", "ResolvedRateResult", "SingularityEvent",
    "damped_pseudo_inverse", "task_coordinates",
    # errors
    "PlanningError", "NoPathError", "BlockedPointError",
]
