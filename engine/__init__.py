"""Menagerie: a game-runtime animation engine for creatures whose shape nobody knew in advance.

The public surface (see the README and ../shared/DESIGN.md)::

    import engine
    creature = engine.load_creature("creatures/humanoid.yaml")   # Creature
    anim = engine.load_animation("animations/wave.yaml")        # Animation
    char = engine.Character(creature)
    char.play(anim, variant=None, weight=1.0, fade=0.2, loop=True)
    char.set_target("fruit", (0.5, 0.2, 0.8))
    char.tick(1 / 60)
    char.world_positions, char.world_rotations                  # (nbody, 3), (nbody, 4)
    crowd = engine.Crowd([char, ...]); crowd.tick(1 / 60)

The animation and runtime names load on first use, so tools that only read creature
files do not pay for numba.
"""

from engine._cache import refresh_stale_kernel_cache

refresh_stale_kernel_cache()   # numba's cache does not see changes in called modules

from engine.errors import CreatureError, DataError, MenagerieError  # noqa: E402
from engine.model import Creature, CreatureDef, build_creature, load_creature  # noqa: E402

_LAZY = {
    "Animation": ("engine.anim", "Animation"),
    "load_animation": ("engine.anim", "load_animation"),
    "bind": ("engine.anim.binding", "bind"),
    "Character": ("engine.runtime", "Character"),
    "Crowd": ("engine.runtime", "Crowd"),
    "load_async": ("engine.loading", "load_async"),
}


def __getattr__(name: str):
    if name in _LAZY:
        import importlib

        module, attr = _LAZY[name]
        value = getattr(importlib.import_module(module), attr)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'engine' has no attribute '{name}'")


__all__ = ["Animation", "Character", "Creature", "CreatureDef", "CreatureError", "Crowd", "DataError",
           "MenagerieError", "bind", "build_creature", "load_animation", "load_async", "load_creature"]
