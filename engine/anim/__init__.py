"""Animations: the generalized asset, its file format and goal evaluation.

    import engine
    creature = engine.load_creature("creatures/humanoid.yaml")
    anim = engine.load_animation("animations/wave.yaml")
    goals = engine.anim.evaluate_goals(anim, creature, t=0.5)
"""

from engine.anim.animation import (
                                   BRANCH_PREDICATES,
                                   FORMAT_VERSION,
                                   SIDE_CONSTRAINTS,
                                   Animation,
                                   AnimationError,
                                   ChannelDef,
                                   Curves,
                                   Event,
                                   Key,
)
from engine.anim.evaluate import Goals, SimpleBinding, bind_all, default_target, evaluate_goals
from engine.anim.fileio import animation_from_text, animation_to_text, load_animation, write_animation
from engine.anim.remap import remap_channel

__all__ = ["BRANCH_PREDICATES", "FORMAT_VERSION", "SIDE_CONSTRAINTS", "Animation", "AnimationError", "ChannelDef",
           "Curves", "Event", "Goals", "Key", "SimpleBinding", "animation_from_text", "animation_to_text",
           "bind_all", "default_target", "evaluate_goals", "load_animation", "remap_channel", "write_animation"]
