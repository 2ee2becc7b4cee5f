"""Rigid-body physics for Menagerie characters: a substepped soft-step sequential-impulse
integrator in numba (``_kernels.py``), ball-and-socket and locked joints, PD servos and
proportional velocity controllers, penalty-style feet, contacts between characters and
with a terrain height function (Zordan et al. 2005 section 5; Wilke & Semwal).

    model = model_from_creatures(creature)     # immutable, like mjModel
    state = PhysicsState(model)                # preallocated, like mjData
    step(model, state, 0.0005)
"""

from engine.physics.model import (
    DEFAULT_FOOT,
    DEFAULT_GROUND,
    DEFAULT_PAIR,
    BodySpec,
    ContactSettings,
    CreatureBodyOptions,
    PhysicsError,
    PhysicsModel,
    SimulationDiverged,
    Terrain,
    WorldSettings,
    build_model,
    model_from_creatures,
    shape_mass_inertia,
)
from engine.physics.world import (
    PhysicsState,
    energy,
    joint_separation,
    rotvec_between,
    servo_targets_from_pose,
    state_from_kinematic,
    step,
)

__all__ = [
    "BodySpec", "ContactSettings", "CreatureBodyOptions", "DEFAULT_FOOT", "DEFAULT_GROUND", "DEFAULT_PAIR",
    "PhysicsError", "PhysicsModel", "PhysicsState", "SimulationDiverged", "Terrain", "WorldSettings",
    "build_model", "energy", "joint_separation", "model_from_creatures", "rotvec_between",
    "servo_targets_from_pose", "shape_mass_inertia", "state_from_kinematic", "step",
]
