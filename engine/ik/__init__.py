"""Two-phase Particle IK (Hecker et al. 2008, section 4.3): ``plan_for`` builds and caches
the plan for a creature and a set of goal bodies; ``solve_ik`` (one character) and
``solve_ik_batch`` (a crowd sharing a plan) write the IK sub-tree's world poses."""

from engine.ik.plan import (
    DEFAULT_PARAMS,
    IKError,
    IKParams,
    IKPlan,
    default_params,
    fit_quintic,
    ik_defaults,
    params_from_strings,
    params_to_strings,
    plan_for,
)
from engine.ik.solver import IKGoals, IKSolver, pose_free_rigid, rest_pose_world, solve_ik, solve_ik_batch

__all__ = ["DEFAULT_PARAMS", "IKError", "IKGoals", "IKParams", "IKPlan", "IKSolver", "default_params", "fit_quintic",
           "ik_defaults", "params_from_strings", "params_to_strings", "plan_for", "pose_free_rigid",
           "rest_pose_world", "solve_ik", "solve_ik_batch"]
