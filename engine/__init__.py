"""Menagerie: a game-runtime animation engine for creatures whose shape nobody knew in advance.

The public surface (see the README and DESIGN.md)::

    import engine
    creature = engine.load_creature("creatures/humanoid.yaml")
"""

from engine.errors import CreatureError, DataError, MenagerieError
from engine.model import Creature, CreatureDef, build_creature, load_creature

__all__ = ["Creature", "CreatureDef", "CreatureError", "DataError", "MenagerieError",
           "build_creature", "load_creature"]
